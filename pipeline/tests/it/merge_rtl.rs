//! The emitted dense merge (`pipeline::hw::merge_rtl`: the Bartlett
//! merge's x and y tents and the line buffer between them, one module a
//! PE) against the model, clock for clock: every dense merge pass of a
//! back-to-front frame replayed (the pass broadcast, the held parents and
//! the neighbours' edge rays the model's PE read) and every PE's
//! line-buffer write and child word compared on every clock, in Verilator
//! and Icarus; a y tent whose centre tap is not doubled, and a y pass
//! reading its centre parent row one row late, are caught at their first
//! clock, PE and signal. Without the tools the tests print one line and
//! skip (`ERCUBE_REQUIRE_TOOLS=1` makes that a failure).
//!
//! `cargo test --release -p pipeline --test it -- merge_rtl::`

use std::collections::HashMap;

use pipeline::config::PipelineConfig;
use pipeline::cosim::build::Simulator;
use pipeline::cosim::merge::{Merge, MergeRun};
use pipeline::hw::merge_rtl::MergeShape;

use crate::pass_rtl::{
    assert_lints_without_latches, assert_ran_clean, assert_synthesizes_without_latches, run,
};
use crate::tools::have;

/// A frame's merge passes as the model ran them, and the emitted module.
type Frame = crate::pass_rtl::Frame<Merge>;

fn frame(cfg: &PipelineConfig, scene: &str, eye: [f64; 3], size: u32) -> Frame {
    crate::pass_rtl::frame(cfg, scene, eye, size)
}

fn cfg(pes: u16) -> PipelineConfig {
    PipelineConfig {
        pes,
        ..PipelineConfig::default()
    }
}

/// 0 mismatches, every model clock simulated, every write compared,
/// non-zero children written (a merge of empty rays checks little) and
/// some parent taken from a neighbour's edge ray.
fn assert_matches(f: &Frame, s: &MergeRun, what: &str) {
    assert_ran_clean(s, what);
    let nonzero = f
        .rec
        .passes
        .iter()
        .flat_map(|p| p.ticks.iter().flatten())
        .filter(|t| t.child.is_some_and(|c| c != [0; 4]))
        .count();
    assert!(nonzero > 0, "{what}: only zero children");
    if f.shape.pes > 1 {
        // A child whose parent is a neighbour's non-zero edge ray.
        let edge = f.rec.passes.iter().any(|p| {
            p.ticks.iter().flatten().enumerate().any(|(i, e)| {
                let (_, m0, lo, hi) = p.children[i % f.shape.pes];
                let m = m0 + e.col as i64;
                e.line.is_some()
                    && (2 * m - 1..=2 * m + 1).any(|mx| {
                        (mx == lo - 1 && e.edges[0] != [0; 4])
                            || (mx == hi + 1 && e.edges[1] != [0; 4])
                    })
            })
        });
        assert!(edge, "{what}: no parent from an edge ray");
    }
}

/// Near the volume (several regions: the rays merge at each boundary).
const EYE: [f64; 3] = [-6.0, 12.2, 10.2];
/// Below it, near.
const BELOW: [f64; 3] = [13.4, -4.25, 13.7];

/// Verilator: three PEs.
#[test]
fn merge_matches_the_model_in_verilator() {
    if !have("verilator", "verilator", "the merge cosim in Verilator") {
        return;
    }
    let f = frame(&cfg(3), "ml:24", EYE, 24);
    let s = run(&f, &f.module, Simulator::Verilator);
    assert_matches(&f, &s, "verilator ml 3 PEs");
}

/// Icarus: three PEs, one PE and four PEs.
#[test]
fn merge_matches_the_model_in_icarus() {
    if !have("iverilog", "iverilog", "the merge cosim in Icarus") {
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

/// The first clock, PE and signal at which the model's y pass wrote a
/// child whose word `tent` (of the three line-buffer taps the model's
/// x pass left there, zero outside the back grid) tells apart from the
/// model's: where a mutated y tent must first differ.
fn first_y_difference(
    f: &Frame,
    tent: impl Fn([i64; 3]) -> i64,
    rows: impl Fn(i64) -> [i64; 3],
) -> Option<(u64, usize)> {
    let mut line = HashMap::new();
    for p in &f.rec.passes {
        let (bg_lo, bg_rows, fg_lo) = p.grids;
        for (t, tick) in p.ticks.iter().enumerate() {
            for (k, e) in tick.iter().enumerate() {
                let (Some(i), Some(child)) = (e.y, e.child) else {
                    continue;
                };
                let my = fg_lo + i as i64;
                let taps = rows(my).map(|py| {
                    let r = py - bg_lo;
                    if (0..bg_rows as i64).contains(&r) {
                        line.get(&(k, r as usize % 3, e.col))
                            .filter(|(q, _)| *q == r as usize)
                            .map(|(_, w): &(usize, [i64; 4])| w[0])
                    } else {
                        Some(0)
                    }
                });
                if let [Some(a), Some(b), Some(c)] = taps {
                    if tent([a, b, c]) != child[0] {
                        return Some((p.first + t as u64, k));
                    }
                }
            }
            for (k, e) in tick.iter().enumerate() {
                if let (Some(q), Some(w)) = (e.x, e.line) {
                    line.insert((k, q % 3, e.col), (q, w));
                }
            }
        }
    }
    None
}

/// The y pass reading its centre tap from parent row `2 my + 1` (the
/// emitted `r1` one row late) is reported at the first clock, PE and
/// signal where the red child word differs: where the model's taps
/// `(2 my - 1, 2 my + 1, 2 my + 1)` give another tent than it wrote.
#[test]
fn a_y_pass_that_reads_the_wrong_parent_row_is_caught() {
    if !have("iverilog", "iverilog", "the merge mutation test") {
        return;
    }
    let f = frame(&cfg(2), "ml:24", EYE, 24);
    let good = "wire signed [18:0] r1 = my + my - bg_x;";
    assert!(f.module.contains(good), "{good}");
    let bad = f
        .module
        .replace(good, "wire signed [18:0] r1 = my + my + 19'sd1 - bg_x;");
    let s = run(&f, &bad, Simulator::Icarus);
    let m = s.outcome.first.clone().expect("the mutation is caught");
    assert!(m.signal.starts_with("w_"), "{m}");
    assert_ne!(m.model, m.rtl, "{m}");
    // The model's own tent of those rows, read as the RTL's arithmetic
    // does for the red channel (merge words, then the accumulator).
    let sh = f.shape;
    let want = first_y_difference(
        &f,
        |t| red_tent(&sh, "y", t),
        |my| [2 * my - 1, 2 * my + 1, 2 * my + 1],
    );
    if m.signal == "w_r" {
        assert_eq!(want, Some((m.cycle, m.pe)), "{m}");
    } else {
        // Another channel differed first: no earlier red difference.
        assert!(want.is_none_or(|w| w >= (m.cycle, m.pe)), "{m}: {want:?}");
    }
    let p = s.problems();
    assert!(
        p[0].contains(&format!("cycle {}, PE {}, {}", m.cycle, m.pe, m.signal)),
        "{p:?}"
    );
}

/// The red tent of pass `pass` (`x`: three parents' accumulator words
/// into `merge`; `y`: three line-buffer `merge` words into the colour
/// accumulator), as `hw::tents` describes it.
fn red_tent(s: &MergeShape, pass: &str, t: [i64; 3]) -> i64 {
    let cfg = PipelineConfig {
        merge: s.merge,
        accum_color: s.acc[0],
        accum_alpha: s.acc[1],
        ..PipelineConfig::default()
    };
    let g = pipeline::hw::tents::tents(&cfg);
    let input = |n: &str| {
        let k = n.strip_prefix(&format!("{pass}.r."))?;
        Some(t[k.parse::<usize>().ok()?])
    };
    let input = |n: &str| Some(input(n).unwrap_or(0));
    let v = pipeline::hw::eval::eval(
        &g,
        &input,
        &|_, _, _| None,
        &mut pipeline::fixed::QuantStats::default(),
    )
    .unwrap();
    let name = format!("{pass}_r");
    let id = g.outputs.iter().find(|o| o.0 == name).expect("an output").1;
    v[id.0] as i64
}

/// The x tent taking its left parent as its centre too (`{x0_r, 1'b0}`
/// for the doubled centre) is reported at the first clock, PE and signal
/// where the red line-buffer word of that tent differs from the model's:
/// the parents picked as the model picks them (a held column, the
/// neighbours' edge rays just beyond the held span, or zero).
#[test]
fn an_x_tent_with_the_wrong_centre_is_caught() {
    if !have("iverilog", "iverilog", "the merge mutation test") {
        return;
    }
    let f = frame(&cfg(3), "ml:24", EYE, 24);
    let good = "_sh = {x1_r, 1'b0};";
    assert_eq!(f.module.matches(good).count(), 1, "{good}");
    let bad = f.module.replace(good, "_sh = {x0_r, 1'b0};");
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
                let parent = |j: usize| {
                    let mx = 2 * mc - 1 + j as i64;
                    if (lo..=hi).contains(&mx) {
                        e.held[j][0]
                    } else if mx == lo - 1 {
                        e.edges[0][0]
                    } else if mx == hi + 1 {
                        e.edges[1][0]
                    } else {
                        0
                    }
                };
                assert_eq!(
                    red_tent(&f.shape, "x", [parent(0), parent(1), parent(2)]),
                    line[0],
                    "the model's red tent"
                );
                if red_tent(&f.shape, "x", [parent(0), parent(0), parent(2)]) != line[0] {
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
fn merge_module_lints_without_latches() {
    assert_lints_without_latches::<Merge>(&cfg(4));
}

/// Front to back and the sparse merge are refused in one line each.
#[test]
fn the_shape_refuses_what_the_module_does_not_cover() {
    let geo = pipeline::cost::inventory::Geometry::new([8, 8, 8], 4);
    let ftb = PipelineConfig {
        order: pipeline::config::Order::FrontToBack,
        ..cfg(4)
    };
    let e = MergeShape::new(&ftb, &geo).unwrap_err();
    assert!(e.contains("front to back has no merge"), "{e}");
    let sparse = PipelineConfig {
        pass_skip_empty: true,
        ..cfg(4)
    };
    let e = MergeShape::new(&sparse, &geo).unwrap_err();
    assert!(e.contains("the sparse merge"), "{e}");
}

/// yosys `synth -top`, `synth_ice40` and `synth_xilinx` finish without
/// error and leave no latch (about 200 s on the shared 2-core machine:
/// the line buffer, a register file read three times without a clock, is
/// mapped to flip-flops).
/// `cargo test --release -p pipeline --test it -- --ignored merge_rtl::`
#[test]
#[ignore]
fn merge_module_synthesizes_without_latches() {
    assert_synthesizes_without_latches::<Merge>(&cfg(4));
}
