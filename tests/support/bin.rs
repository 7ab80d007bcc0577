//! Running the `ercube` binary from the program's integration tests.
#![allow(dead_code)]

use std::path::Path;
use std::process::{Command, Output};

/// The binary Cargo built for these tests.
pub const BIN: &str = env!("CARGO_BIN_EXE_ercube");

/// Runs `ercube` in `dir` with exactly `args`. A backtrace request in the
/// caller's environment must not change what a user sees on bad input.
pub fn ercube<S: AsRef<std::ffi::OsStr>>(dir: &Path, args: &[S]) -> Output {
    Command::new(BIN)
        .args(args)
        .current_dir(dir)
        .env_remove("RUST_BACKTRACE")
        .output()
        .expect("the ercube binary runs")
}

/// A run's command line, status and output, for assertion messages.
pub fn describe<S: AsRef<str>>(args: &[S], out: &Output) -> String {
    let args: Vec<&str> = args.iter().map(AsRef::as_ref).collect();
    format!(
        "ercube {}\n  status: {:?}\n  stdout: {}\n  stderr: {}",
        args.join(" "),
        out.status,
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    )
}

/// Asserts the one-line error contract: status 2 and exactly one stderr
/// line, `ercube: error: ...`, that contains `needle`.
#[track_caller]
pub fn assert_refused<S: AsRef<str>>(args: &[S], out: &Output, needle: &str) {
    let err = String::from_utf8_lossy(&out.stderr);
    let lines: Vec<&str> = err.lines().collect();
    assert_eq!(out.status.code(), Some(2), "{}", describe(args, out));
    assert_eq!(lines.len(), 1, "{}", describe(args, out));
    assert!(
        lines[0].starts_with("ercube: error: ") && lines[0].contains(needle),
        "stderr does not name {needle:?}:\n{}",
        describe(args, out)
    );
}

/// An `H x W x 4` float32 `.npy` as ercube (`--npy`) and the peer
/// script write it: height, width and the values.
pub fn read_npy(path: &Path) -> (usize, usize, Vec<f32>) {
    let b = std::fs::read(path).unwrap();
    assert_eq!(&b[..6], b"\x93NUMPY");
    let hlen = u16::from_le_bytes([b[8], b[9]]) as usize;
    let header = std::str::from_utf8(&b[10..10 + hlen]).unwrap();
    assert!(header.contains("'<f4'"), "{header}");
    let shape = header.split("'shape': (").nth(1).unwrap();
    let dims: Vec<usize> = shape
        .split(')')
        .next()
        .unwrap()
        .split(',')
        .filter_map(|t| t.trim().parse().ok())
        .collect();
    assert_eq!(dims.len(), 3);
    assert_eq!(dims[2], 4);
    let v = b[10 + hlen..]
        .chunks_exact(4)
        .map(|c| f32::from_le_bytes(c.try_into().unwrap()))
        .collect();
    (dims[0], dims[1], v)
}
