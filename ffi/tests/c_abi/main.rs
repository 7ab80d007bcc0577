//! The C header compiled into a C program (`tests/c/frame.c`) linked with
//! the static library: its pipeline frames' raw words equal `ercube render
//! --raw-npy`'s for the same frames (a volume file with a configuration
//! from TOML text, and a u16 buffer), and its error paths return a status
//! and a one-line message. Needs a C compiler (`cc`); skips with one line
//! without it unless `ERCUBE_REQUIRE_TOOLS=1`.
//!
//! And `tests/c/datapath.c`: one datapath sample per line of input words,
//! for the whole sample and its units in both orders, equal to the
//! model's `pipeline::datapath::Datapath` step by step (`datapath.rs`);
//! `tests/c/chip.c`: a frame stepped one clock at a time, ending with
//! `ercube_render`'s raw words and cycles;
//! and the DPI-C package's scoreboard testbenches in Verilator (`dpi.rs`:
//! the cuts; `dpi_sample.rs`: the whole datapath; `dpi_pe.rs`: one PE's
//! sample stage).

mod datapath;
mod dpi;
mod dpi_pe;
mod dpi_sample;

#[path = "../../../tests/support/round_robin.rs"]
mod round_robin;
#[path = "../../../tests/support/tools.rs"]
mod tools;
#[path = "../../../tests/support/window.rs"]
mod window;

use std::path::{Path, PathBuf};
use std::process::{Command, ExitCode};

const BRAIN: &str = "data/brainsmall.den";

/// The workspace root (the `ercube` package).
fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

/// The folder the static library was built into (beside `deps/`, which
/// holds this test).
fn lib_dir() -> PathBuf {
    // `cargo test` builds the library's static archive beside this test
    // binary, in `deps/`; only `cargo build` copies it up a level.
    let exe = std::env::current_exe().unwrap();
    let deps = exe.parent().unwrap();
    if deps.join("libercube_ffi.a").is_file() {
        deps.to_path_buf()
    } else {
        deps.parent().unwrap().to_path_buf()
    }
}

/// `ercube render ARGS --raw-npy` through the command line's own entry,
/// returning the int64 words after the `.npy` header.
fn cli_raw(dir: &Path, name: &str, args: &[&str]) -> Vec<i64> {
    let npy = dir.join(format!("{name}.npy"));
    let png = dir.join(format!("{name}.png"));
    let mut argv = vec!["ercube", "render"];
    argv.extend(args);
    argv.extend([
        "--raw-npy",
        npy.to_str().unwrap(),
        "--out",
        png.to_str().unwrap(),
    ]);
    assert_eq!(ercube::cli::run_with(argv), ExitCode::SUCCESS);
    let bytes = std::fs::read(&npy).unwrap();
    let header = 10 + u16::from_le_bytes([bytes[8], bytes[9]]) as usize;
    words(&bytes[header..])
}

/// Builds a DPI-C testbench in `dir` with Verilator: the package, the
/// design files `sources` (name, text; a `.vlt` waiver among them is
/// read first), the testbench `tb` (top module `tb`) and the C++ main,
/// linked with the crate's static library; `flags` are further Verilator
/// options. Returns the executable.
fn verilate_dpi(dir: &Path, tb: &str, sources: &[(&str, &str)], flags: &[&str]) -> PathBuf {
    use ercube_ffi::testbench::{MAIN, PACKAGE};
    std::fs::create_dir_all(dir).unwrap();
    let mut files = vec![("ercube_pkg.sv", PACKAGE)];
    files.extend_from_slice(sources);
    files.extend([("tb.sv", tb), ("sim_main.cpp", MAIN)]);
    for (name, text) in &files {
        std::fs::write(dir.join(name), text).unwrap();
    }
    // Verilator reads a configuration file before the sources it waives.
    files.sort_by_key(|(name, _)| !name.ends_with(".vlt"));
    let lib = lib_dir().join("libercube_ffi.a");
    let build = std::process::Command::new("verilator")
        .current_dir(dir)
        .args(["--cc", "--exe", "--build", "-j", "2", "--top-module", "tb"])
        .args(["-Mdir", "obj", "-o", "Vtb"])
        .args(files.iter().map(|(name, _)| *name))
        .args(flags)
        .arg("-LDFLAGS")
        .arg(format!("{} -lpthread -ldl -lm", lib.display()))
        .output()
        .unwrap();
    assert!(
        build.status.success(),
        "verilator failed:\n{}",
        String::from_utf8_lossy(&build.stderr)
    );
    dir.join("obj/Vtb")
}

/// Verilator's options for a testbench built unoptimised (its runs are
/// short; the C++ compile dominates).
const UNOPTIMISED: [&str; 2] = ["-MAKEFLAGS", "OPT_FAST=-O0 OPT_SLOW=-O0 OPT_GLOBAL=-O0"];

fn words(bytes: &[u8]) -> Vec<i64> {
    bytes
        .chunks_exact(8)
        .map(|c| i64::from_le_bytes(c.try_into().unwrap()))
        .collect()
}

/// Compiles `ffi/tests/c/NAME.c` with the header and the static library
/// into `dir/NAME`.
fn compile(dir: &Path, name: &str) -> PathBuf {
    let root = root();
    let prog = dir.join(name);
    let lib = lib_dir().join("libercube_ffi.a");
    assert!(lib.is_file(), "{} was not built", lib.display());
    let cc = Command::new("cc")
        .args(["-std=c11", "-Wall", "-Wextra", "-Werror", "-I"])
        .arg(root.join("ffi/include"))
        .arg(root.join(format!("ffi/tests/c/{name}.c")))
        .arg(&lib)
        .args(["-lpthread", "-ldl", "-lm", "-o"])
        .arg(&prog)
        .output()
        .unwrap();
    assert!(
        cc.status.success(),
        "cc failed:\n{}",
        String::from_utf8_lossy(&cc.stderr)
    );
    prog
}

#[test]
fn a_c_program_renders_the_command_lines_raw_words_and_reports_errors() {
    if !tools::have("cc", "gcc", "the C ABI test") {
        return;
    }
    let root = root();
    let brain = root.join(BRAIN);
    assert!(brain.is_file(), "{} is missing", brain.display());
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let prog = compile(d, "frame");
    let toml = d.join("cfg.toml");
    std::fs::write(&toml, "pes = 8\n").unwrap();
    let (file_raw, buf_raw) = (d.join("file.raw"), d.join("buffer.raw"));
    let out = Command::new(&prog)
        .args([&brain, &toml, &file_raw, &buf_raw])
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "the C program failed:\n{text}\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    // Each error path printed a one-line message naming the problem.
    for (line, says) in [
        ("bad size:", "size"),
        ("bad flag:", "--no-such-flag"),
        ("missing file:", "nonexistent"),
        ("zero dims:", "dimension x is zero"),
        ("bad config:", "pes"),
        ("golden raw:", "golden"),
        ("null volume:", "null"),
    ] {
        let l = text.lines().find(|l| l.starts_with(line)).unwrap();
        assert!(l.contains(says), "{l}");
    }

    let c_file = words(&std::fs::read(&file_raw).unwrap());
    let cli_file = cli_raw(
        d,
        "file",
        &[
            "--volume",
            brain.to_str().unwrap(),
            "--method",
            "pipeline",
            "--size",
            "64x64",
            "--config",
            toml.to_str().unwrap(),
        ],
    );
    assert!(
        c_file.iter().any(|&w| w != 0),
        "an empty frame proves nothing"
    );
    assert_eq!(c_file, cli_file, "file volume: raw words differ");

    // The same ramp the C program builds, as a raw file for the command line.
    let mut vox = Vec::new();
    for z in 0..16u16 {
        for y in 0..20u16 {
            for x in 0..24u16 {
                vox.extend((97 * x + 31 * y + 7 * z + 40).to_le_bytes());
            }
        }
    }
    let ramp = d.join("ramp.raw");
    std::fs::write(&ramp, vox).unwrap();
    let cli_buf = cli_raw(
        d,
        "buffer",
        &[
            "--volume",
            ramp.to_str().unwrap(),
            "--raw-dims",
            "24,20,16",
            "--raw-type",
            "u16le",
            "--method",
            "pipeline",
            "--size",
            "32x32",
        ],
    );
    let c_buf = words(&std::fs::read(&buf_raw).unwrap());
    assert!(
        c_buf.iter().any(|&w| w != 0),
        "an empty frame proves nothing"
    );
    assert_eq!(c_buf, cli_buf, "buffer volume: raw words differ");
}

/// `tests/c/chip.c` steps a frame one clock at a time through the C ABI:
/// to the end (the cycles stepped equal the statistics' `cycles`, the raw
/// words `ercube_render`'s), finished after 100 cycles (the same raw
/// words), freed mid-frame (returns); its error paths report a status and
/// a message; the header's structs have the library's sizes.
#[test]
fn a_c_program_steps_a_frame_to_the_renders_raw_words() {
    if !tools::have("cc", "gcc", "the C ABI test") {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let prog = compile(dir.path(), "chip");
    let out = Command::new(&prog).output().unwrap();
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "the C program failed:\n{text}\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    for (line, says) in [
        ("step before begin:", "ercube_chip_begin"),
        ("golden begin:", "golden method"),
        ("ports past the end:", "outside"),
        ("stepped frame:", "equal ercube_render's"),
        ("finished after 100 cycles:", "equal"),
        ("freed mid-frame", ""),
    ] {
        let l = text
            .lines()
            .find(|l| l.starts_with(line))
            .unwrap_or_else(|| panic!("no line {line:?} in\n{text}"));
        assert!(l.contains(says), "{l}");
    }
    eprintln!(
        "{}",
        text.lines().find(|l| l.starts_with("stepped ")).unwrap()
    );
}
