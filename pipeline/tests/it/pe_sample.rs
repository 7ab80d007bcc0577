//! The emitted sample stage (`pipeline::hw::pe_sample_rtl`: each PE's
//! control walking its row plan one ray a clock into the pipelined
//! datapath, its voxel memory and edge register, its compositing buffer
//! read before issue and written back) against the model, clock for
//! clock, driven by the controller's broadcast replayed from the model:
//! every PE's issues (ray, accumulators read), taps and write-backs
//! compared, the buffers at the readout's start compared with the model's
//! rays, and the readout fed from the RTL's buffers; with and without the
//! controller's empty-space skipping, whose runs reach each PE's row plan
//! through its plan port and comparators, and front to back with early
//! ray termination, whose termination bits leave terminated rays out of
//! each row. A control that skips a ray, one that ignores the row plan or
//! the termination bits, and comparators that drop a run's last column
//! are caught; the module lints clean and synthesizes without a latch.
//! Without the tools the tests print one line and skip
//! (`ERCUBE_REQUIRE_TOOLS=1` fails).
//!
//! `cargo test --release -p pipeline --test it -- pe_sample::`

use std::path::PathBuf;

use golden::skip::Skips;
use pipeline::config::{Order, PipelineConfig};
use pipeline::cosim::build::Simulator;
use pipeline::cosim::outcome::Mismatch;
use pipeline::cosim::pe_sample::run::{simulate, PeStageRun};
use pipeline::hw::pe_sample_rtl::{emit, PeSampleShape, MODULE};
use pipeline::hw::pipeline_rtl::{emit as emit_dp, PipelinedModule};
use pipeline::{FrameRun, Voxels};

use crate::chip::{subject, view_from};
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

/// A frame: scene, eye, image size (square).
pub(crate) type Shot = (&'static str, [f64; 3], u32);

/// The frame `shot` through the sample stage in `sim`: a bare view
/// (nothing skipped) without `skips`, with them a prepared frame whose
/// controller skips them (its occupancy memory from the volume's blocks).
pub(crate) fn run(
    c: &PipelineConfig,
    (scene, eye, size): Shot,
    skips: Option<Skips>,
    sim: Simulator,
    mutate: Option<&dyn Fn(&str) -> String>,
) -> PeStageRun {
    let s = subject(scene);
    let prep = view_from(&s.vol, eye, size);
    let dir = tempfile::tempdir().unwrap();
    let frame = || match skips {
        Some(k) => FrameRun::prepared(c, &s.lut, &prep, Voxels::Volume(&s.vol)).skips(k),
        None => FrameRun::new(c, &s.lut, &s.vol, &prep.view),
    };
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
pub(crate) fn assert_matches(r: &PeStageRun, what: &str) {
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
        let r = run(&cfg(p), frame, None, Simulator::Icarus, None);
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
    let r = run(&cfg(2), frame, None, Simulator::Verilator, None);
    assert_matches(&r, &format!("Verilator, 2 PEs {frame:?}"));
}

/// A frame whose controller skips empty space inside its rows:
/// `checker:24`, whose empty cells leave gaps in the runs of most rows.
const SKIPPING: Shot = ("checker:24", [16.0, 10.0, -60.0], 16);

/// The skipping frame takes fewer samples than the same frame without
/// skipping, and its sampled rows leave held columns of the slices' x
/// ranges out (the runs' gaps, which only the row plan knows of).
fn assert_skips_inside_rows(r: &PeStageRun, what: &str) {
    let c = cfg(2);
    let s = subject(SKIPPING.0);
    let prep = view_from(&s.vol, SKIPPING.1, SKIPPING.2);
    let whole = FrameRun::prepared(&c, &s.lut, &prep, Voxels::Volume(&s.vol))
        .skips(Skips::NONE)
        .run()
        .unwrap();
    assert!(
        r.samples < whole.samples,
        "{what}: {} samples skipping, {} without",
        r.samples,
        whole.samples
    );
    assert!(
        r.skipped_in_rows > 1000,
        "{what}: {} held columns left out inside sampled rows",
        r.skipped_in_rows
    );
}

/// Empty-space skipping (and culling) on `checker:24` at 2 PEs, in
/// Icarus and in Verilator: the controller's runs driven through the plan
/// port, one a clock, and every PE issues exactly the rays its
/// comparators planned from them: 0 mismatches, every sample compared,
/// the buffers and readout clean.
#[test]
fn a_skipping_frame_matches_the_model() {
    for (sim, tool) in [
        (Simulator::Icarus, "iverilog"),
        (Simulator::Verilator, "verilator"),
    ] {
        if !have(tool, tool, "the skipping sample stage cosim") {
            continue;
        }
        let r = run(&cfg(2), SKIPPING, Some(Skips::default()), sim, None);
        let what = format!("{tool}, 2 PEs {SKIPPING:?}, skipping");
        assert_matches(&r, &what);
        assert_skips_inside_rows(&r, &what);
    }
}

/// The frame `shot` in Icarus with the emitted Verilog's `from` replaced
/// by `to` (a mutation of one line, which must occur in the text), or
/// `None` (after one line) without Icarus.
fn icarus_mutant(
    what: &str,
    c: &PipelineConfig,
    shot: Shot,
    skips: Option<Skips>,
    (from, to): (&str, &str),
) -> Option<PeStageRun> {
    if !have("iverilog", "iverilog", what) {
        return None;
    }
    let broken = |v: &str| {
        assert!(v.contains(from), "the emitted Verilog has `{from}`");
        v.replace(from, to)
    };
    Some(run(c, shot, skips, Simulator::Icarus, Some(&broken)))
}

/// The mutant is caught, its first mismatch an issued ray (`slot_m` or
/// `in_valid`), which is returned.
fn assert_caught_issuing(r: &PeStageRun) -> &Mismatch {
    let m = r.outcome.first.as_ref().expect("a mismatch");
    assert!(
        m.signal == "slot_m" || m.signal == "in_valid",
        "the first mismatch is an issued ray: {m}"
    );
    assert!(r.outcome.mismatches > 0 && !r.problems().is_empty());
    m
}

/// Comparators that leave out a run's last column (the run end's
/// thermometer code shifted one bit too far) are caught on the skipping frame: the first mismatch is an
/// issued ray, named with its clock, PE, model and RTL values.
#[test]
fn a_comparator_that_drops_a_run_end_is_caught() {
    let Some(r) = icarus_mutant(
        "the row plan comparator mutation in Icarus",
        &cfg(2),
        SKIPPING,
        Some(Skips::default()),
        ("pl_all >> (", "pl_all >> (1 + "),
    ) else {
        return;
    };
    let m = assert_caught_issuing(&r);
    println!("first mismatch: {m}");
    assert!(m.pe < 2, "{m}");
    assert_ne!(m.model, m.rtl, "{m}");
}

/// A control that ignores the row plan (issuing every held column of a
/// row, as one that knows only the held range would) is caught on the
/// skipping frame: a ray the model skipped issues.
#[test]
fn a_control_that_ignores_the_row_plan_is_caught() {
    let Some(r) = icarus_mutant(
        "the sample stage row plan mutation in Icarus",
        &cfg(2),
        SKIPPING,
        Some(Skips::default()),
        ("bc_first ? hq : rem;", "bc_first ? ~0 : rem;"),
    ) else {
        return;
    };
    assert_caught_issuing(&r);
}

/// The plan FIFO's registered head sees a run written to it in the last
/// clock only through its bypass: a FIFO that drops it issues a row from
/// a stale word on the skipping frame, where a row's last run lands in the
/// clock before its pick. (The memory's read-ahead bypass, a run written
/// to the entry after the head in the clock before the head's row
/// starts, is not reached by this frame: its runs keep further ahead.)
#[test]
fn a_plan_fifo_that_drops_its_head_bypass_is_caught() {
    let Some(r) = icarus_mutant(
        "the plan FIFO bypass mutation in Icarus",
        &cfg(2),
        SKIPPING,
        Some(Skips::default()),
        ("hq = p_byp ? p_bw : p_h;", "hq = p_h;"),
    ) else {
        return;
    };
    let m = assert_caught_issuing(&r);
    println!("first mismatch: {m}");
    assert_ne!(m.model, m.rtl, "{m}");
}

/// A control that steps past two of the row plan's rays at each clock
/// (every other ray skipped) is caught at the row's second clock, naming
/// the PE and the ray index.
#[test]
fn a_control_that_skips_a_ray_is_caught() {
    // Each clock clears the issued bit and the one above it.
    let Some(r) = icarus_mutant(
        "the sample stage mutation in Icarus",
        &cfg(2),
        ("sphere:24", [16.0, 10.0, -60.0], 16),
        None,
        (
            "rem <= row_bits & ~one;",
            "rem <= row_bits & ~one & ~(one << 1);",
        ),
    ) else {
        return;
    };
    let m = r.outcome.first.as_ref().expect("a mismatch");
    assert_eq!(m.signal, "slot_m", "{m}");
    let (model, rtl): (i64, i64) = (m.model.parse().unwrap(), m.rtl.parse().unwrap());
    assert_eq!(rtl, model + 1, "{m}");
    assert!(!r.problems().is_empty());
}

/// Front to back with early ray termination at 0.9 (the comparator's
/// raw threshold in the PE's termination bits).
fn ftb_cfg(pes: u16) -> PipelineConfig {
    PipelineConfig {
        order: Order::FrontToBack,
        terminate: 0.9,
        ..cfg(pes)
    }
}

/// 0 mismatches front to back, with rays terminated: the termination bits
/// left terminated rays out of sampled rows.
fn assert_terminates(r: &PeStageRun, what: &str) {
    assert_matches(r, what);
    assert!(
        r.terminated_in_rows > 100,
        "{what}: {} terminated rays left out of sampled rows",
        r.terminated_in_rows
    );
}

/// Front to back on 2 PEs: `ml:24`, whose rays terminate inside the
/// volume, in Icarus, and the skipping frame (`checker:24`, gaps in the
/// rows' runs besides the terminated rays) in Icarus and in Verilator:
/// every PE issues its row plan's rays less those its termination bits
/// mark, 0 mismatches, every sample compared, the buffers and the readout
/// clean.
#[test]
fn front_to_back_frames_match_the_model() {
    if have(
        "iverilog",
        "iverilog",
        "the front-to-back sample stage cosim",
    ) {
        let frame = ("ml:24", [16.0, 10.0, -60.0], 16);
        let r = run(&ftb_cfg(2), frame, None, Simulator::Icarus, None);
        assert_terminates(&r, &format!("iverilog, front to back, 2 PEs {frame:?}"));
    }
    for (sim, tool) in [
        (Simulator::Icarus, "iverilog"),
        (Simulator::Verilator, "verilator"),
    ] {
        if !have(tool, tool, "the front-to-back skipping sample stage cosim") {
            continue;
        }
        let r = run(&ftb_cfg(2), SKIPPING, Some(Skips::default()), sim, None);
        let what = format!("{tool}, front to back, 2 PEs {SKIPPING:?}, skipping");
        assert_terminates(&r, &what);
        assert!(r.skipped_in_rows > 1000, "{what}: {}", r.skipped_in_rows);
    }
}

/// A control that ignores the termination bits (issuing every planned
/// column, terminated or not) is caught: a ray the model left out issues.
#[test]
fn a_control_that_ignores_the_termination_bits_is_caught() {
    let Some(r) = icarus_mutant(
        "the sample stage termination mutation in Icarus",
        &ftb_cfg(2),
        ("ml:24", [16.0, 10.0, -60.0], 16),
        None,
        ("bc_first ? hq & ~dead : rem;", "bc_first ? hq : rem;"),
    ) else {
        return;
    };
    assert_caught_issuing(&r);
}

/// `verilator --lint-only -Wall` and `iverilog -Wall` print nothing on the
/// PE module (with its datapath); yosys's coarse synthesis (`proc`, where
/// latches are inferred, and the memories) leaves no latch cell. Around
/// the plain sample and the sample composed with the VOI stage (its
/// frame registers and broadcast words), both orders.
#[test]
fn pe_sample_module_lints_and_synthesizes_without_latches() {
    for c in [cfg(3), ftb_cfg(3)] {
        lints_and_synthesizes(&c, &datapath(&c));
        lints_and_synthesizes(&c, &crate::pe_units::datapath(&c));
    }
}

/// [`pe_sample_module_lints_and_synthesizes_without_latches`] for `c`'s
/// PE (front to back with its termination bits) around `dp`.
fn lints_and_synthesizes(c: &PipelineConfig, dp: &PipelinedModule) {
    let s = subject("ml:24");
    let prep = view_from(&s.vol, [16.0, 10.0, -36.0], 24);
    let shape = PeSampleShape::for_view(c, &prep.view).unwrap();
    assert_eq!(shape.termination.is_some(), c.order == Order::FrontToBack);
    let pe = emit(&shape, dp).unwrap();
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

/// A right tap read at the left tap's column (the registered row base's
/// `+ 1` form left out of its address) is caught at a tap word.
#[test]
fn a_right_tap_read_at_the_left_column_is_caught() {
    let Some(r) = icarus_mutant(
        "the sample stage mutation in Icarus",
        &cfg(2),
        ("sphere:24", [16.0, 10.0, -60.0], 16),
        None,
        (
            "a01 = lo1 ? rl0 : hi1 ? rh0 : rp0 + x0_a;",
            "a01 = lo1 ? rl0 : hi1 ? rh0 : rl0 + x0_a;",
        ),
    ) else {
        return;
    };
    let m = r.outcome.first.as_ref().expect("a mismatch");
    assert_eq!(m.signal, "v01", "{m}");
    assert!(!r.problems().is_empty());
}
