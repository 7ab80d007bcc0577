//! The emitted dense split (`pipeline::hw::split_rtl`: the bilinear
//! split's x and y filters and the line buffer between them, one module a
//! PE) against the model, clock for clock: every dense split pass of a
//! front-to-back frame replayed (the pass broadcast and the parents the
//! model's PE read) and every PE's line-buffer write and child word with
//! its termination flag compared on every clock, in Verilator and Icarus;
//! a y pass that reads its second parent row one row late is caught at
//! its first clock, PE and signal. Without the tools the tests print one
//! line and skip (`ERCUBE_REQUIRE_TOOLS=1` makes that a failure).
//!
//! `cargo test --release -p pipeline --test it -- split_rtl::`

use std::path::PathBuf;
use std::sync::{Arc, Mutex};

use pipeline::config::{Order, PipelineConfig};
use pipeline::cosim::build::Simulator;
use pipeline::cosim::split::{simulate, SplitRecord, SplitRun};
use pipeline::hw::split_rtl::{emit, SplitShape};
use pipeline::FrameRun;

use crate::chip::{subject, view_from};
use crate::tools::have;

/// A frame's split passes as the model ran them, and the emitted module.
struct Split {
    shape: SplitShape,
    module: String,
    rec: SplitRecord,
}

fn frame(cfg: &PipelineConfig, scene: &str, eye: [f64; 3], size: u32) -> Split {
    let s = subject(scene);
    let prep = view_from(&s.vol, eye, size);
    let rec = Arc::new(Mutex::new(SplitRecord::default()));
    FrameRun::new(cfg, &s.lut, &s.vol, &prep.view)
        .capture(rec.clone())
        .run()
        .unwrap();
    let shape = SplitShape::for_view(cfg, &prep.view).unwrap();
    let module = emit(cfg, &shape).unwrap();
    let rec = rec.lock().unwrap().clone();
    Split { shape, module, rec }
}

fn run(f: &Split, module: &str, sim: Simulator) -> SplitRun {
    let dir = tempfile::tempdir().unwrap();
    let cache = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("split-cosim");
    simulate(&f.shape, module, &f.rec.passes, sim, &cache, dir.path()).unwrap()
}

fn cfg(pes: u16) -> PipelineConfig {
    PipelineConfig {
        pes,
        order: Order::FrontToBack,
        ..PipelineConfig::default()
    }
}

/// 0 mismatches, every model clock simulated, every write compared, and
/// non-zero children written (a split of empty rays checks little).
fn assert_matches(f: &Split, s: &SplitRun, what: &str) {
    let p = s.problems();
    assert!(p.is_empty(), "{what}: {p:?}");
    assert!(s.passes > 0, "{what}: the frame splits");
    let (lines, words) = s.outcome.compared();
    assert!(lines > 0 && words > 0, "{what}");
    let nonzero = f
        .rec
        .passes
        .iter()
        .flat_map(|p| p.ticks.iter().flatten())
        .filter(|t| t.child.is_some_and(|c| c.0 != [0; 4]))
        .count();
    assert!(nonzero > 0, "{what}: only zero children");
}

/// Near the volume (several regions: the rays split at each boundary).
const EYE: [f64; 3] = [-6.0, 12.2, 10.2];
/// Below it, near.
const BELOW: [f64; 3] = [13.4, -4.25, 13.7];

/// Verilator: three PEs.
#[test]
fn split_matches_the_model_in_verilator() {
    if !have("verilator", "verilator", "the split cosim in Verilator") {
        return;
    }
    let f = frame(&cfg(3), "ml:24", EYE, 24);
    let s = run(&f, &f.module, Simulator::Verilator);
    assert_matches(&f, &s, "verilator ml 3 PEs");
}

/// Icarus: one PE and four PEs.
#[test]
fn split_matches_the_model_in_icarus() {
    if !have("iverilog", "iverilog", "the split cosim in Icarus") {
        return;
    }
    for (pes, scene, eye) in [(1, "sphere:24", EYE), (4, "ml:24", BELOW)] {
        let f = frame(&cfg(pes), scene, eye, 24);
        let s = run(&f, &f.module, Simulator::Icarus);
        assert_matches(&f, &s, &format!("icarus {scene} {pes} PEs"));
    }
}
