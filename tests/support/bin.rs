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
