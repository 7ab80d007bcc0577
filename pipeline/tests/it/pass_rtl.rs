//! Helpers shared by the boundary passes' RTL tests ([`crate::split_rtl`],
//! [`crate::merge_rtl`], [`crate::fold_rtl`]): a frame's passes captured with the emitted
//! module, their co-simulation, the checks every pass's match passes, and
//! the small module's lint and synthesis runs.

use std::path::PathBuf;
use std::sync::{Arc, Mutex};

use pipeline::config::PipelineConfig;
use pipeline::cosim::build::Simulator;
use pipeline::cosim::pass::{PassKind, PassRecord, PassRun};
use pipeline::cost::inventory::Geometry;
use pipeline::FrameRun;

use crate::chip::{subject, view_from};
use crate::tools::have;

/// A frame's passes of kind `K` as the model ran them, and the emitted
/// module.
pub struct Frame<K: PassKind> {
    pub shape: K::Shape,
    pub module: String,
    pub rec: PassRecord<K>,
}

/// `scene` seen from `eye` at `size` pixels, run with a capture of its
/// passes; a capture changes no word and no cycle.
pub fn frame<K: PassKind>(cfg: &PipelineConfig, scene: &str, eye: [f64; 3], size: u32) -> Frame<K> {
    let s = subject(scene);
    let prep = view_from(&s.vol, eye, size);
    let rec = Arc::new(Mutex::new(PassRecord::<K>::default()));
    let captured = FrameRun::new(cfg, &s.lut, &s.vol, &prep.view)
        .capture(rec.clone())
        .run()
        .unwrap();
    let plain = FrameRun::new(cfg, &s.lut, &s.vol, &prep.view)
        .run()
        .unwrap();
    assert_eq!(captured.raw, plain.raw, "{scene}: raw words");
    assert_eq!(captured.cycles, plain.cycles, "{scene}: cycles");
    let shape = K::shape_for_view(cfg, &prep.view).unwrap();
    let module = K::emit(cfg, &shape).unwrap();
    let passes = std::mem::take(&mut rec.lock().unwrap().passes);
    let rec = PassRecord { passes };
    Frame { shape, module, rec }
}

/// `module` (the emitted one or a modified copy) co-simulated with `sim`
/// on the frame's passes.
pub fn run<K: PassKind>(f: &Frame<K>, module: &str, sim: Simulator) -> PassRun<K> {
    let dir = tempfile::tempdir().unwrap();
    let cache = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join(format!("{}-cosim", K::STAGE));
    K::simulate(&f.shape, module, &f.rec.passes, sim, &cache, dir.path()).unwrap()
}

/// 0 mismatches, every model clock simulated, every write compared, at
/// least one pass and one line-buffer write and child word.
pub fn assert_ran_clean<K: PassKind>(s: &PassRun<K>, what: &str) {
    let p = s.problems();
    assert!(p.is_empty(), "{what}: {p:?}");
    assert!(s.passes > 0, "{what}: the frame has a {}", K::STAGE);
    let (lines, words) = s.outcome.compared();
    assert!(lines > 0 && words > 0, "{what}");
}

/// `K`'s module of a small view (8^3, 4 PEs, `cfg`), written to a
/// temporary folder.
pub fn small_module<K: PassKind>(cfg: &PipelineConfig) -> (tempfile::TempDir, PathBuf) {
    let geo = Geometry::new([8, 8, 8], 4);
    let module = K::emit(cfg, &K::shape(cfg, &geo).unwrap()).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join(format!("{}.v", K::MODULE));
    std::fs::write(&path, &module).unwrap();
    (dir, path)
}

/// Runs yosys `script` on the module at `path` and fails on an error or a
/// latch.
fn yosys_without_latches(path: &std::path::Path, flow: &str) {
    let script = format!(
        "read_verilog {}; {flow}; select -assert-none t:$dlatch t:$adlatch t:$dlatchsr t:$_DLATCH* t:LD* t:SB_LATCH*",
        path.display()
    );
    let out = std::process::Command::new("yosys")
        .args(["-q", "-p", &script])
        .output()
        .expect("yosys runs");
    assert!(
        out.status.success(),
        "yosys {flow}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
}

/// `verilator --lint-only -Wall` and `iverilog -Wall` print nothing on
/// `K`'s small module (its waivers named in the file); yosys's `proc`
/// infers no latch.
pub fn assert_lints_without_latches<K: PassKind>(cfg: &PipelineConfig) {
    let (_dir, path) = small_module::<K>(cfg);
    let st = K::STAGE;
    let what = format!("the {st} module");
    let quiet = |prog: &str, args: &[&str]| crate::tools::assert_quiet(prog, args, &[&path], &what);
    if have("verilator", "verilator", &format!("the {st} lint")) {
        quiet("verilator", &["--lint-only", "-Wall"]);
    }
    if have("iverilog", "iverilog", &format!("the {st} compile")) {
        quiet("iverilog", &["-g2005", "-Wall", "-o", "/dev/null"]);
    }
    if have("yosys", "yosys", &format!("the {st}'s processes")) {
        yosys_without_latches(&path, &format!("hierarchy -top {}; proc", K::MODULE));
    }
}

/// yosys `synth -top`, `synth_ice40` and `synth_xilinx` finish without
/// error on `K`'s small module and leave no latch.
pub fn assert_synthesizes_without_latches<K: PassKind>(cfg: &PipelineConfig) {
    if !have("yosys", "yosys", &format!("the {} synthesis", K::STAGE)) {
        return;
    }
    let (_dir, path) = small_module::<K>(cfg);
    let m = K::MODULE;
    for flow in [
        format!("synth -top {m}"),
        format!("synth_ice40 -top {m}"),
        format!("synth_xilinx -top {m}"),
    ] {
        yosys_without_latches(&path, &flow);
    }
}
