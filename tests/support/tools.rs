//! External tools the tests drive (yosys, GTKWave's `vcd2fst`). A test
//! that needs one runs it when it is on `PATH`; otherwise it prints one
//! line saying what it skipped and how to install the tool, and passes, so
//! the README's test command is green on a machine that has only Rust.
//! `.ci/run` installs the tools and sets `ERCUBE_REQUIRE_TOOLS=1`, under
//! which a missing tool fails the test: CI never skips silently.
//!
//! Included by every crate's integration tests that need a tool (`#[path]`
//! from `tests/support/`), so there is one copy.
#![allow(dead_code)]

use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::Command;

/// Where `tool` is on `PATH`, if anywhere.
pub fn on_path(tool: &str) -> Option<PathBuf> {
    let path = std::env::var_os("PATH")?;
    std::env::split_paths(&path)
        .map(|dir| dir.join(tool))
        .find(|p| p.is_file())
}

/// Whether `tool` (Debian package `package`) can be used for `what`. When
/// it cannot, says so on the terminal (past the test harness's capture, so
/// the line shows in a normal run) or, under `ERCUBE_REQUIRE_TOOLS=1`,
/// fails.
pub fn have(tool: &str, package: &str, what: &str) -> bool {
    if on_path(tool).is_some() {
        return true;
    }
    if std::env::var("ERCUBE_REQUIRE_TOOLS").as_deref() == Ok("1") {
        panic!(
            "{tool} is not on PATH and ERCUBE_REQUIRE_TOOLS=1: install it \
             (Debian: apt-get install {package}; .ci/run does)"
        );
    }
    // Written to the process's stderr directly: libtest captures only the
    // print macros, and a skip nobody sees is a silent one.
    // One write of the whole line, so that tests skipping in parallel do
    // not interleave their words.
    let line = format!(
        "skipped {what}: {tool} is not on PATH (Debian: apt-get install {package}; \
         .ci/run installs it and sets ERCUBE_REQUIRE_TOOLS=1)\n"
    );
    let _ = std::io::stderr().lock().write_all(line.as_bytes());
    false
}

/// Converts `vcd` with GTKWave's `vcd2fst`, which rejects or warns about
/// malformed VCD, and checks it did so silently and wrote a non-empty FST.
/// Returns the FST's path, or `None` when `vcd2fst` is missing (skipped).
pub fn vcd2fst(vcd: &Path) -> Option<PathBuf> {
    if !have("vcd2fst", "gtkwave", "the vcd2fst check") {
        return None;
    }
    let fst = vcd.with_extension("fst");
    let out = Command::new("vcd2fst")
        .arg(vcd)
        .arg(&fst)
        .output()
        .unwrap_or_else(|e| panic!("cannot run vcd2fst: {e}"));
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        out.status.success(),
        "vcd2fst failed on {}: {stderr}",
        vcd.display()
    );
    assert!(stderr.trim().is_empty(), "vcd2fst complained: {stderr}");
    let len = std::fs::metadata(&fst).map(|m| m.len()).unwrap_or(0);
    assert!(len > 0, "vcd2fst wrote no {}", fst.display());
    Some(fst)
}

/// Runs `prog args files` and asserts it succeeds and prints nothing (a
/// lint or a compile that must be clean); `what` names the design.
pub fn assert_quiet(prog: &str, args: &[&str], files: &[&Path], what: &str) {
    let out = Command::new(prog)
        .args(args)
        .args(files)
        .output()
        .unwrap_or_else(|e| panic!("{prog}: {e}"));
    let text = format!(
        "{}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(
        out.status.success() && text.trim().is_empty(),
        "{prog} {what}: {text}"
    );
}
