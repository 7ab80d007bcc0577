//! The `ercube` command line as a library: [`cli`] is the program, and
//! [`frame`] renders one frame exactly as `ercube render` does, in memory,
//! for the C ABI (`ercube-ffi`) and the Python module (`python/`).

// The doc comments on clap's argument structs are the program's --help
// text, written for a terminal (`checker[:N]`), not rustdoc links.
#![allow(rustdoc::broken_intra_doc_links)]

pub mod cli;
pub mod frame;
