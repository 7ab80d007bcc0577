//! `ercube`: render volumes with ER-Perspective and its baselines, compare
//! them against a supersampled reference, run the bit- and cycle-accurate
//! model of the PE array (raw words, cycle counts, waveforms), estimate
//! its FPGA cost, and benchmark all of it. Run `ercube --help` for the
//! commands.

// The doc comments on clap's argument structs are the program's --help
// text, written for a terminal (`checker[:N]`), not rustdoc links.
#![allow(rustdoc::broken_intra_doc_links)]

mod cli;

fn main() -> std::process::ExitCode {
    cli::run()
}
