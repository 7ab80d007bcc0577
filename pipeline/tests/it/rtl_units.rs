//! The pipelined Verilog of the shading unit, the volume-of-interest
//! stage, the pre-integration unit and the merge's tents against their
//! descriptions' evaluator: random ports and random tables streamed
//! through each module in Verilator and in Icarus, back to back and with
//! bubbles, every output word compared with `hw::eval` at the clock its
//! port says. Without the simulators the test prints one line and skips
//! (`ERCUBE_REQUIRE_TOOLS=1` makes that a failure).
//!
//! `cargo test --release -p pipeline --test it -- rtl_units::`

use pipeline::config::PipelineConfig;
use pipeline::fixed::{Format, QuantStats};
use pipeline::hw::pipeline_rtl::emit;
use pipeline::hw::sim::Simulator;
use pipeline::hw::testbench::{Expected, Sample};
use pipeline::hw::{eval::eval, Graph, MemId, Word};
use proptest::prelude::Rng;
use proptest::test_runner::{RngAlgorithm, TestRng};

use crate::rtl::{issue_order, run, word, Case};
use crate::tools::have;

/// A random raw word of an input port: its format's, or any of its word.
fn port_word(rng: &mut TestRng, w: Word, f: Option<Format>) -> i64 {
    match f {
        Some(f) => word(rng, f),
        None if w.signed => {
            let span = 1i128 << w.bits;
            (i128::from(rng.next_u64()) % span - span / 2) as i64
        }
        None => (u128::from(rng.next_u64()) % (1u128 << w.bits)) as i64,
    }
}

/// `n` random samples of unit `g` through the evaluator: the first half
/// issued back to back, the rest with random bubbles, then the pipeline
/// drained.
fn unit_case(g: &Graph, name: &str, n: usize, seed: u8) -> Case {
    let module = emit(g, name).unwrap_or_else(|e| panic!("{name} emits: {e}"));
    let mut rng = TestRng::from_seed(RngAlgorithm::ChaCha, &[seed; 32]);
    let tables: Vec<(String, Vec<i64>)> = g
        .mems
        .iter()
        .map(|m| {
            let words = (0..m.depth)
                .map(|_| {
                    // A quarter of the words zero (zero extinctions).
                    if rng.next_u64().is_multiple_of(4) {
                        0
                    } else {
                        word(&mut rng, m.fmt)
                    }
                })
                .collect();
            (m.name.clone(), words)
        })
        .collect();
    let read = |m: MemId, addr: i128| -> Option<i64> {
        tables[m.0].1.get(usize::try_from(addr).ok()?).copied()
    };
    let inputs: Vec<usize> = (0..g.nodes.len())
        .filter(|&i| g.nodes[i].op == pipeline::hw::Op::Input)
        .collect();
    let mut samples = Vec::new();
    let mut expected: Vec<Expected> = Vec::new();
    let mut tries = 0;
    while samples.len() < n {
        tries += 1;
        assert!(
            tries < 100 * n,
            "{name}: the evaluator refuses most samples"
        );
        let s: Sample = inputs
            .iter()
            .map(|&i| {
                let node = &g.nodes[i];
                (
                    node.name.replace('.', "_"),
                    port_word(&mut rng, node.word, node.fmt),
                )
            })
            .collect();
        let input = |name: &str| {
            let v = name.replace('.', "_");
            s.iter().find(|x| x.0 == v).map(|x| x.1)
        };
        let rd = |_: &str, m: MemId, a: i128| read(m, a);
        // A sample the description refuses (a value past its wired word)
        // is not one the unit takes: draw another.
        let Ok(v) = eval(g, &input, &rd, &mut QuantStats::default()) else {
            continue;
        };
        expected.push(
            g.outputs
                .iter()
                .map(|(o, id)| (o.replace('.', "_"), v[id.0]))
                .collect(),
        );
        samples.push(s);
    }
    let issue = issue_order(&mut rng, n, module.depth);
    Case {
        module,
        samples,
        expected,
        issue,
        tables,
    }
}

/// A configuration with a 64-entry classification table: the
/// pre-integration table is 65 x 65 words a channel, loaded through the
/// host port in a fraction of the simulation.
fn small_table() -> PipelineConfig {
    let d = PipelineConfig::default();
    let voxel = Format::new(6, 0, false, d.voxel.quant(), d.voxel.overflow()).expect("voxel");
    let s = d.sample;
    let sample = Format::new(10, 4, false, s.quant(), s.overflow()).expect("sample");
    let cfg = PipelineConfig {
        voxel,
        sample,
        table_entries: 64,
        ..d
    };
    cfg.validate().expect("small table");
    cfg
}

/// Every output word of 32 samples of each unit is the evaluator's, at
/// its clock, in both simulators.
#[test]
fn pipelined_units_match_their_descriptions() {
    let d = PipelineConfig::default();
    let units: Vec<(&str, Graph)> = vec![
        ("shading", pipeline::hw::shading::shading(&d, 1)),
        ("shading2", pipeline::hw::shading::shading(&d, 2)),
        ("voi", pipeline::hw::voi::voi(&d)),
        ("preint", pipeline::hw::preint::preint(&small_table())),
        ("tents", pipeline::hw::tents::tents(&d)),
    ];
    let cases: Vec<Case> = units
        .iter()
        .enumerate()
        .map(|(k, (n, g))| unit_case(g, &format!("ercube_{n}"), 32, k as u8 + 20))
        .collect();
    let verilog: Vec<String> = cases.iter().map(|c| c.module.verilog.clone()).collect();
    for sim in Simulator::ALL {
        if !have(sim.tool(), sim.tool(), "the pipelined units' simulation") {
            continue;
        }
        for ((name, g), (c, r)) in units
            .iter()
            .zip(cases.iter().zip(run(sim, &cases, &verilog)))
        {
            let checked = r.unwrap_or_else(|m| panic!("{sim:?} {name}: {m}"));
            eprintln!(
                "{sim:?} {name}: depth {}, {checked} words equal",
                c.module.depth
            );
            // Every sample's outputs and every clock's out_valid.
            assert!(checked >= c.issue.len() + g.outputs.len() * c.samples.len());
        }
    }
}
