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

use pipeline::config::{Order, PipelineConfig};
use pipeline::cosim::build::Simulator;
use pipeline::cosim::split::{Split, SplitRun};

use crate::pass_rtl::{
    assert_lints_without_latches, assert_ran_clean, assert_synthesizes_without_latches, run,
};
use crate::tools::have;

/// A frame's split passes as the model ran them, and the emitted module.
type Frame = crate::pass_rtl::Frame<Split>;

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

/// 0 mismatches, every model clock simulated, every write compared, and
/// non-zero children written (a split of empty rays checks little).
fn assert_matches(f: &Frame, s: &SplitRun, what: &str) {
    assert_ran_clean(s, what);
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

/// The y pass reading parent row `floor(my / 2) + 1` for an even child row
/// too (the emitted `r1` without its odd bit) is reported at its first
/// differing clock, PE and signal: a child word of an even child row
/// whose two parent rows' line-buffer entries differ, as the capture
/// shows them.
#[test]
fn a_y_pass_that_reads_the_wrong_parent_row_is_caught() {
    if !have("iverilog", "iverilog", "the split mutation test") {
        return;
    }
    let f = frame(&cfg(2), "ml:24", EYE, 24);
    let good = "my[0]});";
    assert!(f.module.contains(good), "{good}");
    let bad = f.module.replace(good, "1'b1});");
    assert_ne!(bad, f.module);
    let s = run(&f, &bad, Simulator::Icarus);
    let m = s.outcome.first.clone().expect("the mutation is caught");
    assert!(m.signal.starts_with("w_"), "{m}");
    assert_ne!(m.model, m.rtl, "{m}");
    // The model's clock at the mismatch: an even child row, two different
    // line-buffer entries under it.
    let mut line = std::collections::HashMap::new();
    let mut found = None;
    'passes: for p in &f.rec.passes {
        let (fg_lo, fg_rows, bg_lo) = p.grids;
        for (t, tick) in p.ticks.iter().enumerate() {
            let cycle = p.first + t as u64;
            for (k, e) in tick.iter().enumerate() {
                if cycle == m.cycle && k == m.pe {
                    let my = bg_lo + e.y.expect("a y clock") as i64;
                    let r0 = my.div_euclid(2) - fg_lo;
                    assert_eq!(my.rem_euclid(2), 0, "{m}: an even child row");
                    assert!(r0 + 1 < fg_rows as i64, "{m}");
                    let at = |r: i64| line.get(&(k, r as usize % 3, e.col)).copied();
                    assert_ne!(at(r0), at(r0 + 1), "{m}: the two rows' entries differ");
                    found = Some(cycle);
                    break 'passes;
                }
            }
            // The line buffer as the model's x pass wrote it this clock
            // (after the y pass read it).
            for (k, e) in tick.iter().enumerate() {
                if let (Some(q), Some(w)) = (e.x, e.line) {
                    line.insert((k, q % 3, e.col), (q, w));
                }
            }
        }
    }
    assert_eq!(found, Some(m.cycle), "{m}: a clock of the capture");
    let p = s.problems();
    assert!(
        p[0].contains(&format!("cycle {}, PE {}, {}", m.cycle, m.pe, m.signal)),
        "{p:?}"
    );
}

/// `verilator --lint-only -Wall` and `iverilog -Wall` print nothing on the
/// module (its waivers named in the file); yosys's `proc` infers no latch.
#[test]
fn split_module_lints_without_latches() {
    assert_lints_without_latches::<Split>(&cfg(4));
}

/// yosys `synth -top`, `synth_ice40` and `synth_xilinx` finish without
/// error and leave no latch (about 85 s: the line buffer, a register
/// file read without a clock, is mapped to flip-flops).
/// `cargo test --release -p pipeline --test it -- --ignored split_rtl::`
#[test]
#[ignore]
fn split_module_synthesizes_without_latches() {
    assert_synthesizes_without_latches::<Split>(&cfg(4));
}
