//! Integration tests of the `ercube` command line: the real binary, run in
//! temporary directories, against the contract of `render`, `compare` and
//! `demo` (outputs, file formats, loaders, the one-line error rule, atomic
//! writes and thread-count independence).
//!
//! Scenes and images are kept small (the reference renderer is the slow
//! part) so the whole file runs in a few seconds in release.

mod compare;
mod errors;
mod loaders;
mod range;
mod render;
mod rtl;
mod traces;
mod vocabulary;
mod writes;

use std::path::Path;
use std::process::Output;

use serde_json::Value;

/// One finished run of the binary.
struct Run {
    args: Vec<String>,
    out: Output,
}

impl Run {
    fn stdout(&self) -> String {
        String::from_utf8_lossy(&self.out.stdout).into_owned()
    }

    fn stderr(&self) -> String {
        String::from_utf8_lossy(&self.out.stderr).into_owned()
    }

    /// Describes the run for assertion messages.
    fn describe(&self) -> String {
        crate::bin::describe(&self.args, &self.out)
    }

    /// Asserts the run succeeded and returns it.
    #[track_caller]
    fn ok(self) -> Run {
        assert!(
            self.out.status.success(),
            "expected success:\n{}",
            self.describe()
        );
        self
    }
}

/// Runs `ercube` with whitespace-separated `args` in `dir`. Arguments are
/// relative file names, so the temporary directory's path never needs
/// quoting.
fn ercube(dir: &Path, args: &str) -> Run {
    ercube_args(dir, args.split_whitespace().map(String::from).collect())
}

/// Runs `ercube` with exactly `args` (for paths that may hold spaces).
fn ercube_args(dir: &Path, args: Vec<String>) -> Run {
    let out = crate::bin::ercube(dir, &args);
    Run { args, out }
}

fn tempdir() -> tempfile::TempDir {
    tempfile::tempdir().expect("temporary directory")
}

/// Names of the entries of `dir`, sorted.
fn entries(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .expect("readable directory")
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    v.sort();
    v
}

/// A parsed `.npy` file: its shape and float32 values.
struct Npy {
    shape: Vec<usize>,
    values: Vec<f32>,
}

/// Reads a float32 `.npy` file, checking the header byte by byte against the
/// NumPy format specification (version 1.0).
#[track_caller]
fn read_npy(path: &Path) -> Npy {
    let bytes = std::fs::read(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    assert!(bytes.len() >= 10, "{}: too short for .npy", path.display());
    assert_eq!(&bytes[..6], b"\x93NUMPY", "magic string");
    assert_eq!((bytes[6], bytes[7]), (1, 0), "format version 1.0");
    let hlen = u16::from_le_bytes([bytes[8], bytes[9]]) as usize;
    let start = 10 + hlen;
    assert!(
        bytes.len() >= start,
        "header length {hlen} runs past the file"
    );
    // The spec pads the header so the data starts 64-byte aligned.
    assert_eq!(start % 64, 0, "data offset {start} is not 64-byte aligned");
    let header = std::str::from_utf8(&bytes[10..start]).expect("ASCII header");
    assert!(
        header.ends_with('\n'),
        "header ends with a newline: {header:?}"
    );
    assert!(
        header.contains("'descr': '<f4'"),
        "little-endian float32: {header}"
    );
    assert!(
        header.contains("'fortran_order': False"),
        "C order: {header}"
    );
    let shape_text = header
        .split("'shape': (")
        .nth(1)
        .and_then(|s| s.split(')').next())
        .unwrap_or_else(|| panic!("no shape in {header}"));
    let shape: Vec<usize> = shape_text
        .split(',')
        .map(str::trim)
        .filter(|s| !s.is_empty())
        .map(|s| s.parse().expect("shape entries are integers"))
        .collect();
    let count: usize = shape.iter().product();
    assert_eq!(
        bytes.len() - start,
        count * 4,
        "data length for shape {shape:?}"
    );
    let values = bytes[start..]
        .chunks_exact(4)
        .map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]]))
        .collect();
    Npy { shape, values }
}

/// Checks that an `.npy` is an `h x w x 4` RGBA image of finite values in
/// [0, 1] and returns its values. One float32 ulp of slack above 1 is
/// allowed here so that tests about other things are not masked by the
/// rounding defect that `npy_values_lie_in_the_unit_interval` pins down.
#[track_caller]
fn read_rgba_npy(path: &Path, h: usize, w: usize) -> Vec<f32> {
    let npy = read_npy(path);
    assert_eq!(npy.shape, vec![h, w, 4], "{}: shape", path.display());
    for (k, v) in npy.values.iter().enumerate() {
        assert!(
            v.is_finite() && (0.0..=1.0 + 1e-6).contains(v),
            "{}: value {v} at {k} outside [0, 1]",
            path.display()
        );
    }
    npy.values
}

#[track_caller]
fn read_json(path: &Path) -> Value {
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    serde_json::from_str(&text).unwrap_or_else(|e| panic!("{}: {e}\n{text}", path.display()))
}

#[track_caller]
fn num(v: &Value, key: &str) -> f64 {
    v[key]
        .as_f64()
        .unwrap_or_else(|| panic!("'{key}' is not a number in {v}"))
}

#[track_caller]
fn u64s(v: &Value, key: &str) -> Vec<u64> {
    v[key]
        .as_array()
        .unwrap_or_else(|| panic!("'{key}' is not an array in {v}"))
        .iter()
        .map(|x| {
            x.as_u64()
                .unwrap_or_else(|| panic!("'{key}' holds {x}, not a count"))
        })
        .collect()
}

#[track_caller]
fn f64s(v: &Value, key: &str) -> Vec<f64> {
    v[key]
        .as_array()
        .unwrap_or_else(|| panic!("'{key}' is not an array in {v}"))
        .iter()
        .map(|x| x.as_f64().unwrap_or_else(|| panic!("'{key}' holds {x}")))
        .collect()
}

/// The stats `volume` field as dimensions.
#[track_caller]
fn volume_dims(stats: &Value) -> Vec<u64> {
    u64s(stats, "volume")
}

/// Decodes a PNG written by the CLI.
#[track_caller]
fn read_png(path: &Path) -> image::RgbImage {
    image::open(path)
        .unwrap_or_else(|e| panic!("{}: {e}", path.display()))
        .to_rgb8()
}

/// Checks the one-line error contract for a failed run and returns the
/// message; `keyword` (case-blind) must occur in it. Returns a description
/// of every broken rule rather than panicking, so a table of cases reports
/// all failures at once.
fn error_problems(run: &Run, keyword: &str) -> Vec<String> {
    let mut problems = Vec::new();
    let err = run.stderr();
    match run.out.status.code() {
        None => problems.push("killed by a signal".to_string()),
        Some(0) => problems.push("exit code 0".to_string()),
        Some(_) => {}
    }
    let msg = err.strip_suffix('\n').unwrap_or(&err);
    if msg.trim().is_empty() {
        problems.push("empty stderr".into());
    }
    if msg.contains('\n') {
        problems.push(format!("{} lines on stderr", msg.lines().count()));
    }
    if err.contains("panicked") || err.contains("RUST_BACKTRACE") {
        problems.push("panic text on stderr".into());
    }
    if !msg.to_lowercase().contains(&keyword.to_lowercase()) {
        problems.push(format!("message does not mention '{keyword}'"));
    }
    problems
}

/// Asserts the one-line error contract for a single run.
#[track_caller]
fn assert_one_line_error(run: &Run, keyword: &str) {
    let p = error_problems(run, keyword);
    assert!(p.is_empty(), "{}:\n{}", p.join("; "), run.describe());
}

// ---------------------------------------------------------------------------
// Help
// ---------------------------------------------------------------------------

/// `--help` is a request, not an error: exit 0 with usage on stdout, for the
/// program and each command.
#[test]
fn help_exits_zero() {
    let dir = tempdir();
    for args in ["--help", "render --help", "compare --help", "demo --help"] {
        let run = ercube(dir.path(), args).ok();
        assert!(run.stdout().contains("Usage"), "{}", run.describe());
    }
    // Help must not render anything.
    assert!(entries(dir.path()).is_empty());
}
