//! `ercube`: render volumes with ER-Perspective and its baselines, compare
//! them against a supersampled reference, run the bit- and cycle-accurate
//! model of the PE array (raw words, cycle counts, waveforms), estimate
//! its FPGA cost, and benchmark all of it. Run `ercube --help` for the
//! commands.

fn main() -> std::process::ExitCode {
    // A file grown past the process's size limit (`ulimit -f`) should fail
    // its write with EFBIG, reported in one line with the run's outputs
    // removed, instead of the signal killing the process mid-run.
    // SAFETY: setting a signal's disposition to SIG_IGN before any other
    // thread exists races with nothing.
    #[cfg(unix)]
    unsafe {
        libc::signal(libc::SIGXFSZ, libc::SIG_IGN);
    }
    ercube::cli::run()
}
