//! A window of a real frame captured by `ercube vectors`, the stimulus the
//! whole-datapath testbenches replay (the DPI-C one in
//! `ffi/tests/c_abi/dpi_sample.rs`, the cocotb one in
//! `python/tests/wheel/cocotb.rs`): a 64x64 brainsmall frame on 4 PEs, in
//! the model's defaults otherwise, whose cycles from [`FIRST`] keep every
//! PE's datapath busy. Included by both crates' tests (`#[path]` from
//! `tests/support/`), so the frame is written once.
#![allow(dead_code)]

use std::path::Path;
use std::process::ExitCode;

/// The window's first cycle (the frame's cycles count from 1).
pub const FIRST: u64 = 300_001;

/// The frame's 4 PEs.
pub const PES: usize = 4;

/// Writes the `ercube vectors` files of cycles `FIRST..=last` of the frame
/// of `volume` (brainsmall) into `out`, through the command line's own
/// entry.
pub fn capture(volume: &Path, last: u64, out: &Path) {
    let status = ercube::cli::run_with([
        "ercube",
        "vectors",
        "--volume",
        volume.to_str().unwrap(),
        "--pes",
        &PES.to_string(),
        "--size",
        "64x64",
        "--cycles",
        &format!("{FIRST}-{last}"),
        "--out-dir",
        out.to_str().unwrap(),
    ]);
    assert_eq!(status, ExitCode::SUCCESS, "ercube vectors into {out:?}");
}

/// The samples PE `pe` issued in the window of `dir`: the ones of its
/// `in_valid` file.
pub fn issued(dir: &Path, pe: usize) -> usize {
    let file = dir.join(format!("pe{pe}_in_valid.hex"));
    std::fs::read_to_string(&file)
        .unwrap_or_else(|e| panic!("{}: {e}", file.display()))
        .lines()
        .filter(|l| l.trim() == "1")
        .count()
}
