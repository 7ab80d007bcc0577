//! `ercube cosim` and `ercube vectors`: frames run in the model and,
//! replayed from its capture, in the emitted Verilog of every PE's
//! datapath, every output of every cycle compared; in Verilator (one build
//! shared by the architectures) and in Icarus (both orders, a property test
//! over scene, eye, PEs and order); a mutated operator is caught with its
//! cycle and signal; the vector files replay in Icarus with no mismatch and
//! a broken copy fails; the sample composed with the shading unit and the
//! volume-of-interest stage in both simulators, and a mutated shading
//! operator caught. The plain configurations set `datapath_latency` to the
//! emitted module's depth (35 back to front, 36 front to back), which a
//! cycle-for-cycle comparison needs. Without the simulators the tests
//! print one line and skip (`ERCUBE_REQUIRE_TOOLS=1` makes that a failure).
//!
//! `cargo test --release --test it -- cosim::` (about 5 minutes on the
//! loaded shared machine, most of it the two Verilator builds; the property test's many cases: `-- --ignored
//! cosim::many`).

use std::path::{Path, PathBuf};
use std::process::Output;

use proptest::prelude::*;
use serde_json::Value;

use crate::bin::{assert_refused, describe, ercube};
use crate::pe_vectors::{assert_rows_fit, passed_checks, replay};
use crate::tools::have;

/// The builds' cache, shared by the tests (and kept between runs).
pub(crate) fn cache() -> PathBuf {
    PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("cosim-cache")
}

/// A configuration whose model writes back after `depth` clocks, as the
/// emitted module does, plus `extra` TOML lines.
fn config(dir: &Path, name: &str, depth: u32, extra: &str) -> String {
    let file = format!("{name}.toml");
    std::fs::write(
        dir.join(&file),
        format!("datapath_latency = {depth}\n{extra}"),
    )
    .unwrap();
    file
}

/// Runs `ercube` with whitespace-separated `args` in `dir`.
pub(crate) fn run(dir: &Path, args: &str) -> (Vec<String>, Output) {
    let args: Vec<String> = args.split_whitespace().map(String::from).collect();
    let out = ercube(dir, &args);
    (args, out)
}

/// Runs a cosim that must pass: 0 mismatches, every sample written back and
/// compared, as many as the stats say; returns the stats.
#[track_caller]
pub(crate) fn passes(dir: &Path, args: &str) -> Value {
    let stats = dir.join("cosim.json");
    let _ = std::fs::remove_file(&stats);
    let full = format!(
        "cosim {args} --stats cosim.json --cache-dir {}",
        cache().display()
    );
    let (a, out) = run(dir, &full);
    let text = describe(&a, &out);
    assert!(out.status.success(), "{text}");
    let s: Value = serde_json::from_str(&std::fs::read_to_string(&stats).unwrap()).unwrap();
    assert_eq!(s["mismatches"], 0, "{text}");
    let samples = s["samples"].as_u64().unwrap();
    assert!(samples > 0, "no sample issued: {text}");
    assert_eq!(s["write_backs_compared"].as_u64(), Some(samples), "{text}");
    assert!(s["problems"].as_array().unwrap().is_empty(), "{text}");
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(stdout.contains(", 0 mismatches"), "{text}");
    s
}

/// One Verilator build (back to front, 3 PEs) serves frames of three
/// scenes and eyes under four architectures: the column mappings, the
/// overlapped migration with lanes, the external ray buffer, and skipping
/// off; each frame's cycles and samples are the ones `ercube render`
/// reports for it.
#[test]
fn cosim_matches_the_model_in_verilator() {
    if !have("verilator", "verilator", "the cosim in Verilator") {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let cases = [
        ("blocks", "", "--scene ml:24 --size 24x24"),
        (
            "interleave",
            "mapping = \"interleave\"\nmigration = \"overlapped\"\nlink_lanes = 2\n",
            "--scene sphere:24 --size 20x20 --eye 40,30,-50",
        ),
        (
            "cyclic",
            "mapping = \"cyclic\"\ncyclic_width = 2\npass_skip_empty = true\n",
            "--scene ml:24 --size 24x24 --eye -20,10,-40 --no-skip-empty",
        ),
        (
            "external",
            "ray_buffer = \"external\"\n",
            "--scene checker:24 --size 16x16",
        ),
    ];
    for (name, extra, frame) in cases {
        let cfg = config(d, name, 35, &format!("pes = 3\n{extra}"));
        let s = passes(d, &format!("{frame} --config {cfg}"));
        let (a, out) = run(
            d,
            &format!("render {frame} --config {cfg} --method pipeline --out r.png --stats r.json"),
        );
        assert!(out.status.success(), "{}", describe(&a, &out));
        let r: Value =
            serde_json::from_str(&std::fs::read_to_string(d.join("r.json")).unwrap()).unwrap();
        assert_eq!(s["frame_cycles"], r["cycles"], "{name}");
        assert_eq!(s["cycles"], r["cycles"], "{name}: every cycle simulated");
        assert_eq!(s["samples"], r["samples_total"], "{name}");
    }
}

/// Icarus, both orders: front to back with termination on 2 PEs, back to
/// front on one; and a window of the first cycles (`--max-cycles`).
#[test]
fn cosim_matches_the_model_in_icarus() {
    if !have("iverilog", "iverilog", "the cosim in Icarus") {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let ftb = config(d, "ftb", 36, "");
    let s = passes(
        d,
        &format!("--scene ml:16 --size 16x16 --pes 2 --order ftb --terminate 0.9 --config {ftb} --simulator iverilog"),
    );
    assert_eq!(s["order"], "front-to-back");
    let btf = config(d, "btf", 35, "");
    let s = passes(
        d,
        &format!("--scene sphere:16 --size 12x12 --pes 1 --config {btf} --simulator iverilog --max-cycles 300"),
    );
    assert!(s["cycles"].as_u64().unwrap() < s["frame_cycles"].as_u64().unwrap());
    assert!(s["cycles"].as_u64().unwrap() >= 300);
}

/// The red compositing sum (or the first sum of the datapath) turned from
/// `+` into `-` in the emitted text: cosim exits 1 naming the first
/// differing cycle, PE and signal with both words.
#[test]
fn a_mutated_operator_is_caught() {
    if !have("iverilog", "iverilog", "the cosim mutation test") {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let (a, out) = run(d, "rtl --out-dir rtl");
    assert!(out.status.success(), "{}", describe(&a, &out));
    let v = std::fs::read_to_string(d.join("rtl/ercube_sample.v")).unwrap();
    let (broken, line) = crate::mutate::break_one_sum(&v).expect("a sum to break");
    std::fs::write(d.join("broken.v"), broken).unwrap();
    let cfg = config(d, "btf", 35, "");
    let args = format!(
        "cosim --scene ml:16 --size 12x12 --pes 2 --config {cfg} --simulator iverilog \
         --verilog broken.v --max-cycles 400 --cache-dir {}",
        cache().display()
    );
    let (a, out) = run(d, &args);
    let text = describe(&a, &out);
    assert_eq!(out.status.code(), Some(1), "{text}");
    let err = String::from_utf8_lossy(&out.stderr);
    let first = err.trim();
    assert!(
        first.starts_with("ercube: ") && first.contains("mismatches; the first: cycle "),
        "{text}"
    );
    // `cycle C, PE K, SIGNAL: model M, RTL R`, the words differing.
    let tail = first.split("the first: ").nth(1).unwrap();
    let parts: Vec<&str> = tail.split(", ").collect();
    assert_eq!(parts.len(), 4, "{text}");
    let cycle: u64 = parts[0].trim_start_matches("cycle ").parse().unwrap();
    assert!(cycle > 0, "{text}");
    let (signal, model) = parts[2].split_once(": model ").unwrap();
    assert!(
        [
            "acc_out_r",
            "acc_out_g",
            "acc_out_b",
            "acc_out_a",
            "x0",
            "out_valid"
        ]
        .contains(&signal),
        "{text} (broken line: {line})"
    );
    assert_ne!(model, parts[3].trim_start_matches("RTL "), "{text}");
    assert!(!String::from_utf8_lossy(&out.stdout).contains(", 0 mismatches"));
}

/// A model writing back after another latency than the module's depth is a
/// mismatch class of its own (exit 1), the words still compared at the
/// module's depth.
#[test]
fn a_latency_other_than_the_depth_is_reported() {
    if !have("iverilog", "iverilog", "the cosim latency check") {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let cfg = config(d, "lat", 20, "");
    let args = format!(
        "cosim --scene ml:16 --size 12x12 --pes 1 --config {cfg} --simulator iverilog \
         --max-cycles 200 --cache-dir {}",
        cache().display()
    );
    let (a, out) = run(d, &args);
    let text = describe(&a, &out);
    assert_eq!(out.status.code(), Some(1), "{text}");
    assert!(
        String::from_utf8_lossy(&out.stderr).contains(
            "mismatch class latency: the model writes back 20 clocks after issue, the RTL 35"
        ),
        "{text}"
    );
    assert!(
        String::from_utf8_lossy(&out.stdout).contains(", 0 mismatches"),
        "{text}"
    );
}

/// The shading unit and the volume-of-interest stage composed into the
/// sample (`hw::compose`), in Verilator: one build of the sample with both
/// units (back to front, 3 PEs, one light) serves a sphere VOI with a ramp
/// and an outside box; every sample compared, 0 mismatches, the model's
/// latency the composed module's depth, and the frame's cycles and
/// samples those of `ercube render`.
#[test]
fn cosim_covers_shading_and_the_voi_in_verilator() {
    if !have(
        "verilator",
        "verilator",
        "the shading and VOI cosim in Verilator",
    ) {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    for frame in [
        "--scene ml:16 --size 16x16 --pes 3 --shade --voi sphere:8,8,8,5 --voi-ramp 2 --voi-scale 3",
        "--scene sphere:16 --size 12x12 --pes 3 --eye 30,20,-40 --shade --voi box:2,2,2,10,10,10 --voi-outside --voi-scale 0.3",
    ] {
        let s = passes(d, frame);
        assert_eq!(s["model_latency"], s["rtl_depth"], "{frame}");
        assert_eq!(s["cycles"], s["frame_cycles"], "{frame}: every cycle simulated");
        let (a, out) = run(
            d,
            &format!("render {frame} --method pipeline --out r.png --stats r.json"),
        );
        assert!(out.status.success(), "{}", describe(&a, &out));
        let r: Value =
            serde_json::from_str(&std::fs::read_to_string(d.join("r.json")).unwrap()).unwrap();
        assert_eq!(s["frame_cycles"], r["cycles"], "{frame}");
        assert_eq!(s["samples"], r["samples_total"], "{frame}");
    }
}

/// The shaded sample back to front and the VOI's front to back, in Icarus
/// (back to front a window of the first 2500 cycles, past the first
/// visible samples: Icarus runs the composed module at a few hundred
/// clocks a second).
#[test]
fn cosim_covers_shading_and_the_voi_in_icarus() {
    if !have(
        "iverilog",
        "iverilog",
        "the shading and VOI cosim in Icarus",
    ) {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    for frame in [
        "--scene ml:16 --size 12x12 --pes 2 --shade --max-cycles 2500",
        "--scene ml:16 --size 12x12 --pes 2 --order ftb --voi sphere:8,8,8,5 --voi-ramp 2 --voi-scale 3",
    ] {
        let s = passes(d, &format!("{frame} --simulator iverilog"));
        assert_eq!(s["model_latency"], s["rtl_depth"], "{frame}");
        assert!(s["samples"].as_u64().unwrap() > 100, "{frame}");
    }
}

/// One operator of the shading unit inside the composed sample (the gain's
/// sum `ka + kd D`, `n_shade_gain`, as `ercube vectors` writes the module)
/// turned from `+` into `-`: cosim exits 1 naming the first differing
/// cycle, PE and accumulator with both words.
#[test]
fn a_mutated_shading_operator_is_caught() {
    if !have("iverilog", "iverilog", "the shading cosim mutation test") {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let frame = "--scene ml:16 --size 12x12 --pes 2 --shade";
    let (a, out) = run(d, &format!("vectors {frame} --cycles 1-10 --out-dir v"));
    assert!(out.status.success(), "{}", describe(&a, &out));
    let v = std::fs::read_to_string(d.join("v/ercube_sample.v")).unwrap();
    let (broken, line) = crate::mutate::break_sum(&v, "n_shade_gain").expect("the gain's sum");
    std::fs::write(d.join("broken.v"), broken).unwrap();
    let args = format!(
        "cosim {frame} --simulator iverilog --verilog broken.v --max-cycles 2500 --cache-dir {}",
        cache().display()
    );
    let cycle = assert_caught_at_an_output(d, &args, &line);
    assert!(cycle > 0);
}

/// Runs `ercube ARGS` in `d`, a cosim of a module broken at `line`, and
/// checks it fails (exit 1) naming a first mismatch at a PE's `acc_out_*`
/// whose RTL word differs from the model's; returns its cycle.
pub(crate) fn assert_caught_at_an_output(d: &Path, args: &str, line: &str) -> u64 {
    let (a, out) = run(d, args);
    let text = describe(&a, &out);
    assert_eq!(out.status.code(), Some(1), "{text} ({line})");
    let err = String::from_utf8_lossy(&out.stderr);
    let tail = err
        .trim()
        .split("mismatches; the first: ")
        .nth(1)
        .unwrap_or_else(|| panic!("{text}"));
    let parts: Vec<&str> = tail.split(", ").collect();
    assert_eq!(parts.len(), 4, "{text}");
    assert!(parts[1].starts_with("PE "), "{text}");
    let (signal, model) = parts[2].split_once(": model ").unwrap();
    assert!(signal.starts_with("acc_out_"), "{text} ({line})");
    assert_ne!(model, parts[3].trim_start_matches("RTL "), "{text}");
    parts[0].trim_start_matches("cycle ").parse().unwrap()
}

/// What the streams do not cover yet is refused in one line, before any
/// simulator runs: pre-integration in the PE's sample stage and as
/// vectors, the exact colouring anywhere.
#[test]
fn cosim_refuses_what_is_not_emitted() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    for (flag, needle) in [
        ("--preintegrate", "pre-integration"),
        (
            "--preintegrate --pre-colouring exact",
            "fast colouring only",
        ),
    ] {
        for cmd in [
            "cosim --simulator iverilog --stage pe --pes 2",
            "vectors --out-dir v",
        ] {
            let args: Vec<String> = format!("{cmd} --scene ml:16 --size 8x8 {flag}")
                .split_whitespace()
                .map(String::from)
                .collect();
            if cmd.starts_with("cosim") && !have("iverilog", "iverilog", "a cosim refusal") {
                continue;
            }
            let out = ercube(d, &args);
            assert_refused(&args, &out, needle);
        }
    }
    assert!(!d.join("v").exists(), "a refused run leaves nothing");
    // The sample stage has no place for the shading unit's taps yet.
    if have("iverilog", "iverilog", "a cosim refusal") {
        let args: Vec<String> =
            "cosim --stage pe --simulator iverilog --scene ml:16 --size 8x8 --pes 2 --shade"
                .split_whitespace()
                .map(String::from)
                .collect();
        assert_refused(&args, &ercube(d, &args), "shade_tx_0_0");
    }
    let args: Vec<String> = "vectors --scene ml:16 --cycles 5-2 --out-dir v"
        .split_whitespace()
        .map(String::from)
        .collect();
    assert_refused(&args, &ercube(d, &args), "--cycles");
}

/// The vector files of a window replay against the emitted module in
/// Icarus with no mismatch; the manifest names every file with its signal,
/// width and cycle range; a copy with one expected word changed fails.
#[test]
fn vectors_replay_in_icarus() {
    if !have("iverilog", "iverilog", "the vectors replay") {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let cfg = config(d, "btf", 35, "");
    let (a, out) = run(
        d,
        &format!(
            "vectors --scene ml:16 --size 12x12 --pes 2 --config {cfg} --cycles 40-300 --out-dir v"
        ),
    );
    assert!(out.status.success(), "{}", describe(&a, &out));
    let v = d.join("v");
    let m: Value =
        serde_json::from_str(&std::fs::read_to_string(v.join("manifest.json")).unwrap()).unwrap();
    let rows = m["rows"].as_u64().unwrap();
    assert_eq!(rows, 300 - 40 + 1 + 35);
    let files = m["files"].as_array().unwrap();
    assert_eq!(files.len(), 2 * (2 + 21), "every port of both PEs");
    for f in files {
        assert_rows_fit(&v, f, rows);
        assert_eq!(f["first_cycle"], 40);
    }
    let issued: u64 = files
        .iter()
        .filter(|f| f["signal"] == "in_valid")
        .map(|f| {
            let t = std::fs::read_to_string(v.join(f["path"].as_str().unwrap())).unwrap();
            t.lines().filter(|l| *l == "1").count() as u64
        })
        .sum();
    assert!(issued > 0, "no sample in the window");
    let files = ["ercube_sample.v", "vectors_tb.v"];
    let good = replay(&v, &files);
    let checks = passed_checks(&good);
    assert!(checks > issued, "{good}");
    // Break one expected accumulator word where a sample is written back.
    let valid = std::fs::read_to_string(v.join("pe0_out_valid.hex")).unwrap();
    let row = valid.lines().position(|l| l == "1").expect("a write-back");
    let path = v.join("pe0_acc_out_a.hex");
    let mut words: Vec<String> = std::fs::read_to_string(&path)
        .unwrap()
        .lines()
        .map(String::from)
        .collect();
    let w = u64::from_str_radix(&words[row], 16).unwrap();
    words[row] = format!("{:x}", w ^ 1);
    std::fs::write(&path, words.join("\n") + "\n").unwrap();
    let bad = replay(&v, &files);
    assert!(
        bad.contains(&format!("MISMATCH row {row} pe 0 acc_out_a"))
            && !bad.contains(" 0 mismatches"),
        "{bad}"
    );
}

/// A cosim of one small frame in Icarus: `scene`, eye `eye`, `pes` PEs,
/// front to back when `ftb`.
fn icarus_case(scene: &str, eye: [i32; 3], pes: u16, ftb: bool) {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let (order, depth) = if ftb { ("ftb", 36) } else { ("btf", 35) };
    let cfg = config(d, "c", depth, "");
    passes(
        d,
        &format!(
            "--scene {scene} --size 10x10 --eye {},{},{} --pes {pes} --order {order} --config {cfg} --simulator iverilog",
            eye[0], eye[1], eye[2]
        ),
    );
}

fn case_strategy() -> impl Strategy<Value = (&'static str, [i32; 3], u16, bool)> {
    (
        prop::sample::select(vec!["ml:12", "sphere:12", "checker:12"]),
        (-30i32..30, -30i32..30, -60i32..-25),
        1u16..=4,
        any::<bool>(),
    )
        .prop_map(|(s, (x, y, z), p, ftb)| (s, [x, y, z], p, ftb))
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 2, ..ProptestConfig::default() })]
    /// Scene, eye, PEs and order drawn at random: 0 mismatches in Icarus.
    #[test]
    fn cosim_property((scene, eye, pes, ftb) in case_strategy()) {
        if have("iverilog", "iverilog", "the cosim property test") {
            icarus_case(scene, eye, pes, ftb);
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 40, ..ProptestConfig::default() })]
    /// The property test's many cases (`-- --ignored cosim::many`).
    #[test]
    #[ignore = "many cases: 10 to 25 s each in Icarus"]
    fn many_cosim_property((scene, eye, pes, ftb) in case_strategy()) {
        if have("iverilog", "iverilog", "the cosim property test") {
            icarus_case(scene, eye, pes, ftb);
        }
    }
}
