//! The round-robin mappings' frames the PE's sample stage is verified on
//! (`ercube vectors --stage pe` replayed in Icarus, `tests/it/pe_vectors.rs`;
//! the DPI-C scoreboard, `ffi/tests/c_abi/dpi_pe.rs`; the cocotb testbench,
//! `python/tests/wheel/cocotb_pe.rs`): three PEs under the interleave with
//! the overlapped migration and two lanes, and under the cyclic mapping of
//! width 2 with empty passes skipped, each PE holding several blocks, so
//! the column map (`cm_mx`, `cm_sl`) and the column decoder (`loc`) carry
//! every issue and tap. Included by the three crates' tests (`#[path]`),
//! so the frames are written once.
#![allow(dead_code)]

use std::path::{Path, PathBuf};

/// (mapping, configuration TOML, frame flags), one a mapping; the
/// transfer function named (the scene's, which the command line picks and
/// `ercube.pe_vectors` of the scene's voxels does not).
pub const FRAMES: [(&str, &str, &str); 2] = [
    (
        "interleave",
        "pes = 3\nmapping = \"interleave\"\nmigration = \"overlapped\"\nlink_lanes = 2\n",
        "--scene sphere:16 --tf sphere --size 12x12 --eye 40,30,-50",
    ),
    (
        "cyclic",
        "pes = 3\nmapping = \"cyclic\"\ncyclic_width = 2\npass_skip_empty = true\n",
        "--scene ml:16 --tf ml --size 12x12 --eye -20,10,-40 --no-skip-empty",
    ),
];

/// The volume columns of both frames' scenes (the column decoder's entries).
pub const COLUMNS: usize = 16;

/// Writes mapping `name`'s configuration into `dir`; its path.
pub fn config(dir: &Path, name: &str, toml: &str) -> PathBuf {
    let p = dir.join(format!("{name}.toml"));
    std::fs::write(&p, toml).unwrap();
    p
}

/// The `ercube vectors --stage pe` arguments of PE 1 of mapping frame
/// `frame` with configuration `cfg`, into `out`.
pub fn vectors_args(frame: &str, cfg: &Path, out: &Path) -> Vec<String> {
    let mut a: Vec<String> = ["vectors", "--stage", "pe", "--pe", "1"]
        .iter()
        .map(|s| s.to_string())
        .collect();
    a.extend(frame.split_whitespace().map(String::from));
    a.extend([
        "--config".to_owned(),
        cfg.to_str().unwrap().to_owned(),
        "--out-dir".to_owned(),
        out.to_str().unwrap().to_owned(),
    ]);
    a
}

/// The emitted PE's right tap column read at the left one's index in the
/// column decoder (a deliberately broken copy: every tap of a ray whose
/// two columns differ misreads); `None` when the text has no decoder.
pub fn break_decoder(verilog: &str) -> Option<String> {
    let right = "wire [31:0] l1 = {1'b0, loc[c1]};";
    verilog
        .contains(right)
        .then(|| verilog.replace(right, "wire [31:0] l1 = {1'b0, loc[c0]};"))
}
