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
    // The pipeline model builds and drops its per-frame buffers (ray
    // columns, line buffers, row tables) at every frame and region: with
    // glibc's defaults, freeing them hands the pages back to the kernel
    // (heap trimming, or unmapping blocks above the mmap threshold) and
    // the next frame takes a page fault and a zeroed page for each again,
    // a tenth of the model's time on brainsmall. Keeping up to 256 MiB of
    // freed heap and serving blocks below 32 MiB from it leaves the pages
    // mapped between frames; nothing a frame computes depends on it.
    // SAFETY: `mallopt` only tunes the allocator, called before any
    // other thread exists.
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    unsafe {
        libc::mallopt(libc::M_TRIM_THRESHOLD, 256 << 20);
        libc::mallopt(libc::M_MMAP_THRESHOLD, 32 << 20);
    }
    ercube::cli::run()
}
