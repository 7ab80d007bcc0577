//! `pip install ./python` into a virtual environment under `target/`, then
//! `tests/check_render.py`: `ercube.render` gives the command line's
//! `--npy` image bit for bit and its `--stats` (apart from wall-clock
//! fields), on brainsmall (er and pipeline, the pipeline again after the
//! scene's on another PE count, through the last frame's kept memories)
//! and on a scene with every method. Needs Python with `venv`, and maturin and numpy in the
//! environment (`.ci/run` installs them into `target/pyvenv`; so does this
//! test when PyPI is reachable); skips with one line without them unless
//! `ERCUBE_REQUIRE_TOOLS=1`.
//!
//! The same environment runs `tests/check_datapath.py` (`ercube.Datapath`
//! gives the description's words, `datapath.rs`) and the cocotb testbench
//! (`python/cocotb`) in Icarus on the emitted units and a broken copy
//! (`cocotb.rs`), in Verilator (`cocotb_verilator.rs`), on one PE's sample
//! stage in both (`cocotb_pe.rs`); and `tests/check_pe_vectors.py`
//! (`ercube.pe_vectors` gives the words of `ercube vectors --stage pe`'s
//! files, `pe_vectors.rs`).

mod chip;
mod cocotb;
mod cocotb_pe;
mod cocotb_verilator;
mod datapath;
mod pe_vectors;

#[path = "../../../tests/support/round_robin.rs"]
mod round_robin;
#[path = "../../../tests/support/tools.rs"]
mod tools;
#[path = "../../../tests/support/window.rs"]
mod window;

use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::{Command, ExitCode};
use std::sync::OnceLock;

use serde_json::json;

const BRAIN: &str = "data/brainsmall.den";

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

/// Skips (one line) or, under `ERCUBE_REQUIRE_TOOLS=1`, fails.
fn skip(why: &str) {
    if std::env::var("ERCUBE_REQUIRE_TOOLS").as_deref() == Ok("1") {
        panic!("{why} and ERCUBE_REQUIRE_TOOLS=1 (.ci/run makes target/pyvenv)");
    }
    let line = format!("skipped the Python module test: {why} (.ci/run makes target/pyvenv)\n");
    let _ = std::io::stderr().lock().write_all(line.as_bytes());
}

fn ok(cmd: &mut Command) -> bool {
    cmd.output().map(|o| o.status.success()).unwrap_or(false)
}

/// The environment's Python with maturin and numpy, made if it can be.
fn venv(root: &Path) -> Option<PathBuf> {
    let dir = root.join("target/pyvenv");
    let py = dir.join("bin/python");
    let ready = |py: &Path| ok(Command::new(py).args(["-c", "import maturin, numpy"]));
    if !py.is_file() {
        if tools::on_path("python3").is_none() {
            skip("python3 is not on PATH");
            return None;
        }
        if !ok(Command::new("python3").args(["-m", "venv"]).arg(&dir)) {
            skip("python3 -m venv failed");
            return None;
        }
    }
    if !ready(&py) {
        let pip = dir.join("bin/pip");
        if !ok(Command::new(pip).args(["install", "-q", "maturin>=1.16,<2", "numpy"])) {
            skip("maturin and numpy cannot be installed into target/pyvenv");
            return None;
        }
    }
    Some(py)
}

/// Runs `ercube render ARGS` through the command line's own entry,
/// writing `--npy` and `--stats` into `dir` under `name`.
fn cli(dir: &Path, name: &str, args: &[&str]) -> serde_json::Value {
    let (npy, stats, png) = (
        dir.join(format!("{name}.npy")),
        dir.join(format!("{name}.json")),
        dir.join(format!("{name}.png")),
    );
    let mut argv = vec!["ercube", "render"];
    argv.extend(args);
    for (flag, p) in [("--npy", &npy), ("--stats", &stats), ("--out", &png)] {
        argv.extend([flag, p.to_str().unwrap()]);
    }
    assert_eq!(ercube::cli::run_with(argv), ExitCode::SUCCESS, "{args:?}");
    json!({"npy": npy, "stats": stats})
}

/// `pip install ./python` into the environment, once for every test of
/// this binary: the environment's Python, or `None` when skipped.
fn installed() -> Option<PathBuf> {
    static ONCE: OnceLock<Option<PathBuf>> = OnceLock::new();
    ONCE.get_or_init(|| {
        let root = root();
        let py = venv(&root)?;
        let bin = py.parent().unwrap();
        // The environment's maturin builds the wheel: its bin/ leads PATH,
        // as when it is activated.
        let install = Command::new(bin.join("pip"))
            .env("PATH", with_bin(bin))
            .args([
                "install",
                "-q",
                "--no-build-isolation",
                "--force-reinstall",
                "--no-deps",
            ])
            .arg(root.join("python"))
            .output()
            .unwrap();
        assert!(
            install.status.success(),
            "pip install ./python failed:\n{}",
            String::from_utf8_lossy(&install.stderr)
        );
        Some(py)
    })
    .clone()
}

/// `ercube vectors --stage pe` of PE 1 of the round-robin mapping frame
/// `frame` with configuration `toml` into `out` (the configuration's file
/// beside it); the file.
fn round_robin_pe1_vectors(out: &Path, name: &str, toml: &str, frame: &str) -> PathBuf {
    let parent = out.parent().unwrap();
    std::fs::create_dir_all(parent).unwrap();
    let cfg = round_robin::config(parent, name, toml);
    let args = round_robin::vectors_args(frame, &cfg, out);
    let argv = std::iter::once("ercube").chain(args.iter().map(String::as_str));
    assert_eq!(ercube::cli::run_with(argv), ExitCode::SUCCESS, "{name}");
    cfg
}

/// `ercube vectors --stage pe` of PE 1 of a 3-PE, 12x12 front-to-back
/// frame of `ml:16` into `out`, with `extra` options.
fn ml16_pe1_vectors(out: &Path, extra: &[&str]) {
    let mut argv = vec![
        "ercube", "vectors", "--stage", "pe", "--pe", "1", "--scene", "ml:16", "--pes", "3",
        "--size", "12x12", "--order", "ftb",
    ];
    argv.extend_from_slice(extra);
    argv.extend(["--out-dir", out.to_str().unwrap()]);
    assert_eq!(ercube::cli::run_with(argv), std::process::ExitCode::SUCCESS);
}

/// `PATH` with `bin` first.
fn with_bin(bin: &Path) -> std::ffi::OsString {
    std::env::join_paths(
        std::iter::once(bin.to_path_buf()).chain(std::env::split_paths(
            &std::env::var_os("PATH").unwrap_or_default(),
        )),
    )
    .unwrap()
}

#[test]
fn the_python_module_renders_the_command_lines_images() {
    let root = root();
    let Some(py) = installed() else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let brain = root.join(BRAIN);
    let brain = brain.to_str().unwrap();
    let mut cases = Vec::new();
    // brainsmall with the command line's defaults, golden and pipeline.
    for method in ["er", "pipeline"] {
        let mut c = cli(
            d,
            &format!("brain-{method}"),
            &["--volume", brain, "--method", method],
        );
        c["source"] = json!("brain");
        c["kwargs"] = json!({"method": method});
        cases.push(c);
    }
    // A scene with every method, a camera and options given.
    for method in [
        "reference",
        "er",
        "er-ftb",
        "under",
        "over",
        "box",
        "mipmap",
        "shear-warp",
        "pipeline",
        "pipeline-ftb",
    ] {
        let mut c = cli(
            d,
            &format!("scene-{method}"),
            &[
                "--scene",
                "ml:40",
                "--tf",
                "ml",
                "--method",
                method,
                "--size",
                "48x40",
                "--eye",
                "-30,25,-70",
                "--fov",
                "45",
            ],
        );
        c["source"] = json!("scene");
        c["kwargs"] = json!({
            "method": method, "tf": "ml", "size": [48, 40], "eye": [-30.0, 25.0, -70.0], "fov": 45.0,
        });
        cases.push(c);
    }
    // brainsmall's pipeline again after the scene's, on 4 PEs and then the
    // default 16: each frame loads its memories into the last pipeline
    // frame's buffers (another volume, another PE count) and takes its
    // datapath only when the configuration and table are the same.
    for (name, extra, kw) in [
        (
            "brain-pipeline-4",
            &["--pes", "4"][..],
            json!({"method": "pipeline", "pes": 4}),
        ),
        (
            "brain-pipeline-again",
            &[][..],
            json!({"method": "pipeline"}),
        ),
    ] {
        let mut args = vec!["--volume", brain, "--method", "pipeline"];
        args.extend(extra);
        let mut c = cli(d, name, &args);
        c["source"] = json!("brain");
        c["kwargs"] = kw;
        cases.push(c);
    }
    cases[0]["brain"] = json!(brain);
    cases[0]["scene"] = json!("ml:40");
    let file = d.join("cases.json");
    std::fs::write(&file, serde_json::to_string(&cases).unwrap()).unwrap();
    let out = Command::new(&py)
        .arg(root.join("python/tests/check_render.py"))
        .arg(&file)
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "check_render.py failed:\n{text}\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert_eq!(
        text.matches("image same, stats same").count(),
        cases.len(),
        "{text}"
    );
}
