//! The emitted sample stage (`pipeline::hw::pe_sample_rtl`: each PE's
//! control walking its rays one a clock into the pipelined datapath, its
//! voxel memory and edge register, its compositing buffer read before
//! issue and written back) against the model, clock for clock, driven by
//! the controller's broadcast replayed from the model: every PE's issues
//! (ray, accumulators read), taps and write-backs compared, the buffers at
//! the readout's start compared with the model's rays, and the readout fed
//! from the RTL's buffers. A control that skips a ray is caught; the
//! module lints clean and synthesizes without a latch. Without the tools
//! the tests print one line and skip (`ERCUBE_REQUIRE_TOOLS=1` fails).
//!
//! `cargo test --release -p pipeline --test it -- pe_sample::`

use std::path::PathBuf;

use golden::camera::Camera;
use golden::render::Prepared;
use pipeline::config::{Order, PipelineConfig};
use pipeline::cosim::build::Simulator;
use pipeline::cosim::pe_sample::run::{simulate, PeStageRun};
use pipeline::hw::pe_sample_rtl::{emit, PeSampleShape, MODULE};
use pipeline::hw::pipeline_rtl::{emit as emit_dp, PipelinedModule};
use pipeline::FrameRun;

use crate::chip::subject;
use crate::tools::have;

fn cache() -> PathBuf {
    PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("pe-sample-cosim")
}

fn datapath(cfg: &PipelineConfig) -> PipelinedModule {
    emit_dp(&pipeline::hw::sample::plain(cfg), "ercube_sample").unwrap()
}

fn cfg(pes: u16) -> PipelineConfig {
    PipelineConfig {
        pes,
        order: Order::BackToFront,
        ..PipelineConfig::default()
    }
}

/// The frame of `scene` seen from `eye`, `size` square, through the
/// sample stage in `sim`.
fn run(
    c: &PipelineConfig,
    (scene, eye, size): (&str, [f64; 3], u32),
    sim: Simulator,
    mutate: Option<&dyn Fn(&str) -> String>,
) -> PeStageRun {
    let s = subject(scene);
    let centre = glam::DVec3::from_array(s.vol.center_world());
    let cam = Camera::new(
        glam::DVec3::from_array(eye),
        centre,
        glam::DVec3::Y,
        60.0,
        size,
        size,
    )
    .unwrap();
    let prep = Prepared::new(&s.vol, &cam).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let frame = || FrameRun::new(c, &s.lut, &s.vol, &prep.view);
    simulate(
        &frame,
        c,
        &prep.view,
        &datapath(c),
        sim,
        &cache(),
        dir.path(),
        mutate,
    )
    .unwrap()
}

/// 0 mismatches; every issue, tap and write-back compared; the buffers
/// read back at the readout's start.
fn assert_matches(r: &PeStageRun, what: &str) {
    assert!(r.unfit.is_none(), "{what}: {:?}", r.unfit);
    assert!(
        r.samples > 100,
        "{what}: {} samples check little",
        r.samples
    );
    assert_eq!(r.outcome.mismatches, 0, "{what}: {:?}", r.outcome.first);
    assert_eq!(r.outcome.compared, [r.samples; 3], "{what}");
    let b = r.buffers.as_ref().expect("the frame reached its readout");
    assert!(b.compared > 0, "{what}");
    assert_eq!(b.differ, 0, "{what}: buffer at the readout: {:?}", b.first);
    assert!(r.problems().is_empty(), "{what}: {:?}", r.problems());
}

/// Icarus: two frames on 2 PEs and one on a lone PE (no prologue, no
/// neighbour). Every buffer word at the readout equals the model's ray,
/// and the readout fed from them matches: on `ml:24` the readout starts
/// while the last row's write-backs are still in the datapath, which the
/// buffers must hold when they are read.
#[test]
fn sample_stage_matches_the_model_in_icarus() {
    if !have("iverilog", "iverilog", "the sample stage cosim in Icarus") {
        return;
    }
    for (p, frame) in [
        (2, ("sphere:24", [16.0, 10.0, -60.0], 16)),
        (2, ("ml:24", [16.0, 10.0, -60.0], 16)),
        (1, ("ml:24", [12.0, -60.0, 12.0], 12)),
    ] {
        let r = run(&cfg(p), frame, Simulator::Icarus, None);
        assert_matches(&r, &format!("{p} PEs {frame:?}"));
        if p == 2 && frame.0 == "ml:24" {
            let (start, dump) = r.dump.expect("a readout");
            assert!(
                dump > start,
                "the write-backs land by the readout's start ({start})"
            );
        }
    }
}

/// Verilator: the same testbench built by Verilator 5.006 (two-state,
/// its own scheduler) on `ml:24` at 2 PEs, the frame whose last
/// write-backs land after the readout's start: 0 mismatches, every
/// sample compared, the buffers and the readout clean.
#[test]
fn sample_stage_matches_the_model_in_verilator() {
    if !have(
        "verilator",
        "verilator",
        "the sample stage cosim in Verilator",
    ) {
        return;
    }
    let frame = ("ml:24", [16.0, 10.0, -60.0], 16);
    let r = run(&cfg(2), frame, Simulator::Verilator, None);
    assert_matches(&r, &format!("Verilator, 2 PEs {frame:?}"));
}

/// A control whose row counter steps by two (every other ray skipped) is
/// caught at the row's second clock, naming the PE and the ray index.
#[test]
fn a_control_that_skips_a_ray_is_caught() {
    if !have(
        "iverilog",
        "iverilog",
        "the sample stage mutation in Icarus",
    ) {
        return;
    }
    let broken = |v: &str| {
        assert!(v.contains("cnt <= idx + 1'b1;"));
        v.replace("cnt <= idx + 1'b1;", "cnt <= idx + 2'd2;")
    };
    let r = run(
        &cfg(2),
        ("sphere:24", [16.0, 10.0, -60.0], 16),
        Simulator::Icarus,
        Some(&broken),
    );
    let m = r.outcome.first.as_ref().expect("a mismatch");
    assert_eq!(m.signal, "slot_m", "{m}");
    let (model, rtl): (i64, i64) = (m.model.parse().unwrap(), m.rtl.parse().unwrap());
    assert_eq!(rtl, model + 1, "{m}");
    assert!(!r.problems().is_empty());
}

/// `verilator --lint-only -Wall` and `iverilog -Wall` print nothing on the
/// PE module (with its datapath); yosys's coarse synthesis (`proc`, where
/// latches are inferred, and the memories) leaves no latch cell.
#[test]
fn pe_sample_module_lints_and_synthesizes_without_latches() {
    let c = cfg(3);
    let dp = datapath(&c);
    let s = subject("ml:24");
    let centre = glam::DVec3::from_array(s.vol.center_world());
    let cam = Camera::new(
        glam::DVec3::new(16.0, 10.0, -36.0),
        centre,
        glam::DVec3::Y,
        60.0,
        24,
        24,
    )
    .unwrap();
    let prep = Prepared::new(&s.vol, &cam).unwrap();
    let shape = PeSampleShape::for_view(&c, &prep.view).unwrap();
    let pe = emit(&shape, &dp).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let a = dir.path().join("ercube_sample.v");
    let b = dir.path().join(format!("{MODULE}.v"));
    std::fs::write(&a, &dp.verilog).unwrap();
    std::fs::write(&b, &pe.verilog).unwrap();
    let quiet = |prog: &str, args: &[&str]| {
        crate::tools::assert_quiet(prog, args, &[&a, &b], "the sample stage module")
    };
    if have("verilator", "verilator", "the sample stage lint") {
        quiet(
            "verilator",
            &["--lint-only", "-Wall", "--top-module", MODULE],
        );
    }
    if have("iverilog", "iverilog", "the sample stage compile") {
        quiet("iverilog", &["-g2005", "-Wall", "-o", "/dev/null"]);
    }
    if !have("yosys", "yosys", "the sample stage synthesis") {
        return;
    }
    let script = format!(
        "read_verilog {} {}; hierarchy -top {MODULE}; proc; opt -fast; memory -nomap; select -assert-none t:$dlatch t:$adlatch t:$dlatchsr t:$_DLATCH*",
        a.display(),
        b.display()
    );
    let out = std::process::Command::new("yosys")
        .args(["-q", "-p", &script])
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "yosys: {}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
}
