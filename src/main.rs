//! `ercube`: render volumes with ER-Perspective and its baselines, compare
//! them against a supersampled reference, run the bit- and cycle-accurate
//! model of the PE array (raw words, cycle counts, waveforms), estimate
//! its FPGA cost, and benchmark all of it. Run `ercube --help` for the
//! commands.

fn main() -> std::process::ExitCode {
    ercube::cli::run()
}
