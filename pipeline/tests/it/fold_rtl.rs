//! The emitted dense fold (`pipeline::hw::fold_rtl`: the differences, the
//! Bartlett merge's x and y tents with the line buffer between them and
//! the add of the kept finals, one module a PE) against the model, clock
//! for clock: every dense fold pass of a front-to-back frame replayed (the
//! pass broadcast, the held results and inherited states, the left edge
//! differences and the kept finals the model's PE read) and every PE's
//! line-buffer write and child word compared on every clock, in Verilator
//! and Icarus; an x tent taking a wrong difference as its centre is caught
//! at its first clock, PE and signal. Without the tools the tests print
//! one line and skip (`ERCUBE_REQUIRE_TOOLS=1` makes that a failure).
//!
//! `cargo test --release -p pipeline --test it -- fold_rtl::`

use std::collections::HashMap;

use pipeline::config::{Order, PipelineConfig};
use pipeline::cosim::build::Simulator;
use pipeline::cosim::fold::{Fold, FoldRun};
use pipeline::hw::fold_rtl::FoldShape;

use crate::pass_rtl::{
    assert_lints_without_latches, assert_ran_clean, assert_synthesizes_without_latches, run,
};
use crate::tools::have;

/// A frame's fold passes as the model ran them, and the emitted module.
type Frame = crate::pass_rtl::Frame<Fold>;

fn frame(cfg: &PipelineConfig, scene: &str, eye: [f64; 3], size: u32) -> Frame {
    crate::pass_rtl::frame(cfg, scene, eye, size)
}

fn cfg(pes: u16) -> PipelineConfig {
    PipelineConfig {
        pes,
        order: Order::FrontToBack,
        ..PipelineConfig::default()
    }
}

/// 0 mismatches, every model clock simulated, every write compared,
/// non-zero children written and non-zero differences filtered (a fold of
/// empty rays checks little), and with several PEs some tap taken from
/// the left neighbour's non-zero edge difference.
fn assert_matches(f: &Frame, s: &FoldRun, what: &str) {
    assert_ran_clean(s, what);
    let ticks = || f.rec.passes.iter().flat_map(|p| p.ticks.iter().flatten());
    let nonzero = ticks()
        .filter(|t| t.child.is_some_and(|c| c != [0; 4]))
        .count();
    assert!(nonzero > 0, "{what}: only zero children");
    let lines = ticks()
        .filter(|t| t.line.is_some_and(|c| c != [0; 4]))
        .count();
    assert!(lines > 0, "{what}: only zero differences");
    if f.shape.pass.pes > 1 {
        let edge = f.rec.passes.iter().any(|p| {
            p.ticks.iter().flatten().enumerate().any(|(i, e)| {
                let (_, m0, lo, _) = p.children[i % f.shape.pass.pes];
                let m = m0 + e.col as i64;
                e.line.is_some()
                    && e.edge != [0; 4]
                    && (2 * m - 1..=2 * m + 1).any(|mx| mx == lo - 1)
            })
        });
        assert!(edge, "{what}: no tap from an edge difference");
    }
}

/// Near the volume (several regions: the rays fold at each boundary).
const EYE: [f64; 3] = [-6.0, 12.2, 10.2];
/// Below it, near.
const BELOW: [f64; 3] = [13.4, -4.25, 13.7];

/// Verilator: three PEs.
#[test]
fn fold_matches_the_model_in_verilator() {
    if !have("verilator", "verilator", "the fold cosim in Verilator") {
        return;
    }
    let f = frame(&cfg(3), "ml:24", EYE, 24);
    let s = run(&f, &f.module, Simulator::Verilator);
    assert_matches(&f, &s, "verilator ml 3 PEs");
}

/// Icarus: three PEs, one PE and four PEs.
#[test]
fn fold_matches_the_model_in_icarus() {
    if !have("iverilog", "iverilog", "the fold cosim in Icarus") {
        return;
    }
    for (pes, scene, eye) in [
        (3, "ml:24", EYE),
        (1, "sphere:24", EYE),
        (4, "ml:24", BELOW),
    ] {
        let f = frame(&cfg(pes), scene, eye, 24);
        let s = run(&f, &f.module, Simulator::Icarus);
        assert_matches(&f, &s, &format!("icarus {scene} {pes} PEs"));
    }
}

/// The red outputs of `hw::fold_rtl::folds` for the shape's formats, on
/// inputs `given` (absent ones zero), by output name.
fn red_folds(s: &FoldShape, given: &HashMap<String, i64>) -> HashMap<String, i64> {
    let cfg = PipelineConfig {
        merge: s.pass.merge,
        accum_color: s.pass.acc[0],
        accum_alpha: s.pass.acc[1],
        ..cfg(1)
    };
    let g = pipeline::hw::fold_rtl::folds(&cfg);
    let input = |n: &str| Some(given.get(n).copied().unwrap_or(0));
    let v = pipeline::hw::eval::eval(
        &g,
        &input,
        &|_, _, _| None,
        &mut pipeline::fixed::QuantStats::default(),
    )
    .unwrap();
    g.outputs
        .iter()
        .map(|(n, id)| (n.clone(), v[id.0] as i64))
        .collect()
}

/// The x tent taking tap 0's difference as its centre too (the emitted
/// `x1_r` picking `d0_r_w`) is reported at the first clock, PE and signal
/// where the red line-buffer word of that tent differs from the model's:
/// the taps picked as the model picks them (a held column's difference,
/// the left neighbour's edge difference just below the held span, or
/// zero), the model's own tent checked on the way.
#[test]
fn an_x_tent_with_the_wrong_centre_is_caught() {
    if !have("iverilog", "iverilog", "the fold mutation test") {
        return;
    }
    let f = frame(&cfg(3), "ml:24", EYE, 24);
    let good = "assign x1_r = held1 ? d1_r_w";
    assert_eq!(f.module.matches(good).count(), 1, "{good}");
    let bad = f.module.replace(good, "assign x1_r = held1 ? d0_r_w");
    let s = run(&f, &bad, Simulator::Icarus);
    let m = s.outcome.first.clone().expect("the mutation is caught");
    assert_eq!(m.signal, "lx_r", "{m}");
    assert_ne!(m.model, m.rtl, "{m}");
    let mut want = None;
    'passes: for p in &f.rec.passes {
        for (t, tick) in p.ticks.iter().enumerate() {
            for (k, e) in tick.iter().enumerate() {
                let Some(line) = e.line else { continue };
                let (_, m0, lo, hi) = p.children[k];
                let mc = m0 + e.col as i64;
                let mut given = HashMap::new();
                for j in 0..3 {
                    given.insert(format!("d.r.{j}.r"), e.result[j][0]);
                    given.insert(format!("d.r.{j}.i"), e.inherited[j][0]);
                }
                let d = red_folds(&f.shape, &given);
                let tap = |j: usize| {
                    let mx = 2 * mc - 1 + j as i64;
                    if (lo..=hi).contains(&mx) {
                        d[&format!("d_r_{j}")]
                    } else if mx == lo - 1 {
                        e.edge[0]
                    } else {
                        0
                    }
                };
                let tent = |taps: [i64; 3]| {
                    let given = (0..3).map(|j| (format!("x.r.{j}"), taps[j])).collect();
                    red_folds(&f.shape, &given)["x_r"]
                };
                let centre = if (lo..=hi).contains(&(2 * mc)) {
                    d["d_r_0"]
                } else {
                    tap(1)
                };
                assert_eq!(tent([tap(0), tap(1), tap(2)]), line[0], "the model's tent");
                if tent([tap(0), centre, tap(2)]) != line[0] {
                    want = Some((p.first + t as u64, k));
                    break 'passes;
                }
            }
        }
    }
    assert_eq!(want, Some((m.cycle, m.pe)), "{m}");
    let p = s.problems();
    assert!(
        p[0].contains(&format!("cycle {}, PE {}, lx_r", m.cycle, m.pe)),
        "{p:?}"
    );
}

/// `verilator --lint-only -Wall` and `iverilog -Wall` print nothing on the
/// module (its waivers named in the file); yosys's `proc` infers no latch.
#[test]
fn fold_module_lints_without_latches() {
    assert_lints_without_latches::<Fold>(&cfg(4));
}

/// Back to front and the sparse fold are refused in one line each.
#[test]
fn the_shape_refuses_what_the_module_does_not_cover() {
    let geo = pipeline::cost::inventory::Geometry::new([8, 8, 8], 4);
    let btf = PipelineConfig {
        order: Order::BackToFront,
        ..cfg(4)
    };
    let e = FoldShape::new(&btf, &geo).unwrap_err();
    assert!(e.contains("back to front has no fold"), "{e}");
    let sparse = PipelineConfig {
        pass_skip_empty: true,
        ..cfg(4)
    };
    let e = FoldShape::new(&sparse, &geo).unwrap_err();
    assert!(e.contains("the sparse fold"), "{e}");
}

/// yosys `synth -top`, `synth_ice40` and `synth_xilinx` finish without
/// error and leave no latch (the line buffer, a register file read three
/// times without a clock, is mapped to flip-flops; minutes on the shared
/// 2-core machine, docs/rtl.md gives the time).
/// `cargo test --release -p pipeline --test it -- --ignored fold_rtl::`
#[test]
#[ignore]
fn fold_module_synthesizes_without_latches() {
    assert_synthesizes_without_latches::<Fold>(&cfg(4));
}
