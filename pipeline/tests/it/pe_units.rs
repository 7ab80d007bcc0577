//! The emitted sample stage (`pipeline::hw::pe_sample_rtl`) around the
//! sample composed with the volume-of-interest stage
//! (`pipeline::hw::compose`, wired by `pipeline::hw::pe_units_rtl`: the
//! VOI's row position and slice from the controller's broadcast, its
//! per-frame constants from frame registers the host writes) against the
//! model, clock for clock: every issue, tap and write-back, the buffers
//! at the readout and the readout fed from them. The VOI changes the
//! frame's raw words, and a PE that takes the wrong slice is caught.
//! Without the tools the tests print one line and skip
//! (`ERCUBE_REQUIRE_TOOLS=1` fails).
//!
//! `cargo test --release -p pipeline --test it -- pe_units::`

use std::path::PathBuf;

use golden::voi::{Shape, Voi};
use pipeline::config::{Order, PipelineConfig};
use pipeline::cosim::build::Simulator;
use pipeline::cosim::pe_sample::run::{simulate, PeStageRun};
use pipeline::hw::compose::{sample, Units};
use pipeline::hw::pipeline_rtl::{emit_scheduled, PipelinedModule};
use pipeline::FrameRun;

use crate::chip::{subject, view_from};
use crate::pe_sample::{assert_matches, Shot};
use crate::tools::have;

fn cache() -> PathBuf {
    PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("pe-units-cosim")
}

/// The sample composed with the VOI stage on the model's schedule (its
/// depth the model's write-back latency), as `ercube cosim` emits it.
pub(crate) fn datapath(cfg: &PipelineConfig) -> PipelinedModule {
    let units = Units {
        voi: true,
        ..Units::default()
    };
    let g = sample(cfg, units);
    let sch = pipeline::cost::latency::graph_schedule(cfg, &g);
    emit_scheduled(&g, &sch, "ercube_sample").unwrap()
}

fn cfg(pes: u16, order: Order) -> PipelineConfig {
    PipelineConfig {
        pes,
        order,
        terminate: 0.9,
        ..PipelineConfig::default()
    }
}

/// A sphere through the front of `ml:24`'s shell with a ramp, its
/// opacity scaled by 3 inside (`--voi sphere:12,12,4,8 --voi-ramp 2
/// --voi-scale 3`).
fn sphere() -> Voi {
    Voi {
        shape: Shape::Sphere {
            centre: [12.0, 12.0, 4.0],
            radius: 8.0,
        },
        scale: 3.0,
        outside: false,
        ramp: 2.0,
    }
}

const FRAME: Shot = ("ml:24", [16.0, 10.0, -60.0], 16);

/// The model's raw words of `shot` under `c`, with `voi` or without.
fn raw_words(c: &PipelineConfig, (scene, eye, size): Shot, voi: Option<&Voi>) -> Vec<[i64; 4]> {
    let s = subject(scene);
    let prep = view_from(&s.vol, eye, size);
    let f = FrameRun::new(c, &s.lut, &s.vol, &prep.view)
        .unit(voi)
        .run()
        .unwrap();
    f.raw
}

/// `shot` with `voi` through the sample stage in `sim`; `mutate` edits
/// the PE module's text.
fn run(
    c: &PipelineConfig,
    (scene, eye, size): Shot,
    voi: &Voi,
    sim: Simulator,
    mutate: Option<&dyn Fn(&str) -> String>,
) -> PeStageRun {
    let s = subject(scene);
    let prep = view_from(&s.vol, eye, size);
    let dir = tempfile::tempdir().unwrap();
    let frame = || FrameRun::new(c, &s.lut, &s.vol, &prep.view).unit(Some(voi));
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

/// `ml:24` on 2 PEs, 16x16, with a VOI sphere: back to front in Icarus
/// and Verilator, front to back with termination in Icarus. 0
/// mismatches, every issue, tap and write-back compared, the buffers and
/// the readout from them clean; and the VOI changes the frame's raw
/// words (the same frame without it differs), so the units' ports
/// reached the write-backs.
#[test]
fn voi_frames_match_the_model() {
    let voi = sphere();
    for (order, sim, tool) in [
        (Order::BackToFront, Simulator::Icarus, "iverilog"),
        (Order::BackToFront, Simulator::Verilator, "verilator"),
        (Order::FrontToBack, Simulator::Icarus, "iverilog"),
    ] {
        if !have(tool, tool, "the sample stage cosim with a VOI") {
            continue;
        }
        let c = cfg(2, order);
        let r = run(&c, FRAME, &voi, sim, None);
        let what = format!("{tool}, {order:?}, 2 PEs {FRAME:?}, VOI");
        assert_matches(&r, &what);
        let ro = r.readout.as_ref().expect("the readout ran");
        assert!(ro.raw.0 > 0 && ro.raw.1 == 0, "{what}: raw {:?}", ro.raw);
        let (with, without) = (raw_words(&c, FRAME, Some(&voi)), raw_words(&c, FRAME, None));
        let differ = with.iter().zip(&without).filter(|(a, b)| a != b).count();
        println!(
            "{what}: the VOI changes {differ} of {} raw words",
            with.len()
        );
        assert!(
            differ > 10,
            "{what}: the VOI changes {differ} of {} raw words",
            with.len()
        );
    }
}

/// A PE that hands the VOI stage the next slice (`voi.z` wired one
/// slice off) is caught: a write-back differs from the model's.
#[test]
fn a_wrong_voi_slice_is_caught() {
    if !have("iverilog", "iverilog", "the VOI wiring mutation in Icarus") {
        return;
    }
    let (from, to) = (
        "s_voi_z <= go ? bc_voi_z : 0;",
        "s_voi_z <= go ? bc_voi_z + 1 : 0;",
    );
    let broken = |v: &str| {
        assert!(v.contains(from), "the emitted Verilog has `{from}`");
        v.replace(from, to)
    };
    let r = run(
        &cfg(2, Order::BackToFront),
        FRAME,
        &sphere(),
        Simulator::Icarus,
        Some(&broken),
    );
    let m = r.outcome.first.as_ref().expect("a mismatch");
    println!("first mismatch: {m}");
    assert!(m.signal.starts_with("acc_out"), "a write-back: {m}");
    assert_ne!(m.model, m.rtl, "{m}");
    assert!(r.outcome.mismatches > 0 && !r.problems().is_empty());
}
