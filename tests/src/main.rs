//! `ercube`: render volumes with ER-Perspective and its baselines, compare
//! them against a supersampled reference, and (later) drive the
//! bit-accurate pipeline model. Run `ercube --help` for the commands.

mod cli;

fn main() -> std::process::ExitCode {
    cli::run()
}
