//! The pipelined Verilog of the plain sample against the description's
//! evaluator: random ports and random tables streamed through the module
//! in Verilator and in Icarus, back to back and with bubbles, every output
//! word compared with `hw::eval` at the clock its port says (the
//! accumulators `depth` clocks after issue, the tap column at the read's
//! address stage), for the default widths in both orders and a narrow and
//! a wide format; and a one-operator mutation of the emitted text is
//! caught. Without the simulators the tests print one line and skip
//! (`ERCUBE_REQUIRE_TOOLS=1` makes that a failure).
//!
//! `cargo test --release -p pipeline --test it -- rtl::`

use std::path::{Path, PathBuf};

use pipeline::config::{Order, PipelineConfig};
use pipeline::cost::latency::sample_schedule;
use pipeline::fixed::{Format, QuantStats};
use pipeline::hw::pipeline_rtl::{emit_scheduled, PipelinedModule};
use pipeline::hw::sim::{build, simulate, Simulator};
use pipeline::hw::testbench::{
    compare, stimulus, table_writes, testbench, Dut, Expected, Mismatch, Sample,
};
use pipeline::hw::{eval::eval, sample::plain, Graph, MemId};
use proptest::prelude::Rng;
use proptest::test_runner::{RngAlgorithm, TestRng};

use crate::cost::{NARROW, WIDE};
use crate::tools::have;

/// The clocks samples `0..n` issue on: the first half back to back, the
/// second each after random bubbles (another one with chance 1/3), then `depth + 2`
/// empty clocks to drain the pipeline.
pub(super) fn issue_order(rng: &mut TestRng, n: usize, depth: u32) -> Vec<Option<usize>> {
    let mut issue: Vec<Option<usize>> = (0..n / 2).map(Some).collect();
    for k in n / 2..n {
        while rng.next_u64().is_multiple_of(3) {
            issue.push(None);
        }
        issue.push(Some(k));
    }
    issue.extend((0..depth + 2).map(|_| None));
    issue
}

/// A random raw word of `f`.
pub(super) fn word(rng: &mut TestRng, f: Format) -> i64 {
    let span = (f.max_raw() as i128 - f.min_raw() as i128 + 1) as u128;
    (u128::from(rng.next_u64()) % span) as i64 + f.min_raw()
}

/// One configuration's module, samples, expected outputs, issue plan and
/// table contents.
pub(super) struct Case {
    pub(super) module: PipelinedModule,
    pub(super) samples: Vec<Sample>,
    pub(super) expected: Vec<Expected>,
    pub(super) issue: Vec<Option<usize>>,
    pub(super) tables: Vec<(String, Vec<i64>)>,
}

/// `n` random samples of `cfg` through the evaluator: the first half
/// issued back to back, the rest with random bubbles, then the pipeline
/// drained.
fn case(cfg: &PipelineConfig, name: &str, n: usize, seed: u8) -> Case {
    let g: Graph = plain(cfg);
    let module = emit_scheduled(&g, &sample_schedule(cfg), name).expect("the plain sample emits");
    let mut rng = TestRng::from_seed(RngAlgorithm::ChaCha, &[seed; 32]);
    // Random tables; a quarter of the opacities zero (invisible samples).
    let tables: Vec<(String, Vec<i64>)> = g
        .mems
        .iter()
        .filter(|m| m.depth > 0)
        .map(|m| {
            let words = (0..m.depth)
                .map(|_| {
                    let w = word(&mut rng, m.fmt);
                    if m.name == "class_a" && rng.next_u64().is_multiple_of(4) {
                        0
                    } else {
                        w
                    }
                })
                .collect();
            (m.name.clone(), words)
        })
        .collect();
    let read = |name: &str, m: MemId, addr: i128, taps: &Sample| -> Option<i64> {
        let mem = &g.mems[m.0];
        if mem.depth == 0 {
            return taps.iter().find(|t| t.0 == name).map(|t| t.1);
        }
        let t = tables.iter().find(|t| t.0 == mem.name)?;
        t.1.get(usize::try_from(addr).ok()?).copied()
    };
    let mut samples = Vec::new();
    let mut expected = Vec::new();
    while samples.len() < n {
        let r: Vec<u64> = (0..12).map(|_| rng.next_u64()).collect();
        let fx = |r: u64, f: Format, sh: u32| {
            let span = (f.max_raw() as i128 - f.min_raw() as i128 + 1) >> sh;
            (i128::from(r) % span.max(1)) as i64 + (f.min_raw() >> sh)
        };
        let mut s: Sample = vec![
            ("slot_m".into(), (r[0] % 800) as i64 - 400),
            ("a".into(), fx(r[1], cfg.position, 8)),
            ("t".into(), fx(r[2], cfg.step, 0)),
            ("b".into(), fx(r[3], cfg.position, 20)),
            ("k".into(), fx(r[4], cfg.step, 30)),
            ("row_wy".into(), fx(r[5], cfg.weight, 0)),
            ("sy".into(), fx(r[6], cfg.position, 24)),
            ("sz".into(), fx(r[7], cfg.position, 24)),
            ("acc_r".into(), fx(r[8], cfg.accum_color, 0)),
            ("acc_g".into(), fx(r[9], cfg.accum_color, 0)),
            ("acc_b".into(), fx(r[10], cfg.accum_color, 0)),
            ("acc_a".into(), fx(r[11], cfg.accum_alpha, 0)),
        ];
        for t in ["v00", "v01", "v10", "v11"] {
            s.push((t.into(), word(&mut rng, cfg.voxel)));
        }
        let input = |name: &str| {
            let v = name.replace('.', "_");
            s.iter().find(|x| x.0 == v).map(|x| x.1)
        };
        let rd = |name: &str, m: MemId, a: i128| read(name, m, a, &s);
        // A sample the description refuses (a value past its wired
        // word) is not one the datapath takes: draw another.
        let Ok(v) = eval(&g, &input, &rd, &mut QuantStats::default()) else {
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

/// Writes the cases' modules, stimulus and testbench into `dir`; returns
/// the sources and each case's output file.
fn write(dir: &Path, cases: &[Case], verilog: &[String]) -> (Vec<PathBuf>, Vec<PathBuf>) {
    let mut sources = Vec::new();
    let mut outs = Vec::new();
    let mut files = Vec::new();
    for (k, (c, v)) in cases.iter().zip(verilog).enumerate() {
        let src = dir.join(format!("{}.v", c.module.name));
        std::fs::write(&src, v).expect("write module");
        sources.push(src);
        let stim = dir.join(format!("stim{k}.txt"));
        let tables = dir.join(format!("tables{k}.txt"));
        std::fs::write(&stim, stimulus(&c.module, &c.samples, &c.issue)).expect("stim");
        std::fs::write(&tables, table_writes(&c.module, &c.tables)).expect("tables");
        outs.push(dir.join(format!("out{k}.txt")));
        files.push((stim, tables));
    }
    let duts: Vec<Dut> = cases
        .iter()
        .zip(&files)
        .zip(&outs)
        .map(|((c, (stim, tables)), out)| Dut {
            module: &c.module,
            stim,
            tables,
            out,
            rows: c.issue.len(),
            writes: c.tables.iter().map(|t| t.1.len()).sum(),
        })
        .collect();
    let tb = dir.join("tb.v");
    std::fs::write(&tb, testbench(&duts)).expect("testbench");
    sources.push(tb);
    (sources, outs)
}

/// Runs the cases (with `verilog` as each module's text) in `sim`; each
/// case's first mismatch, or the words it checked.
pub(super) fn run(
    sim: Simulator,
    cases: &[Case],
    verilog: &[String],
) -> Vec<Result<usize, Mismatch>> {
    let dir = tempfile::tempdir().expect("tempdir");
    let (sources, outs) = write(dir.path(), cases, verilog);
    let t = std::time::Instant::now();
    let exe = build(sim, dir.path(), &sources, "tb").unwrap_or_else(|e| panic!("{e}"));
    let built = t.elapsed();
    simulate(sim, &exe, dir.path()).unwrap_or_else(|e| panic!("{e}"));
    eprintln!(
        "{sim:?}: built in {:.1} s, ran in {:.1} s",
        built.as_secs_f64(),
        (t.elapsed() - built).as_secs_f64()
    );
    cases
        .iter()
        .zip(&outs)
        .map(|(c, out)| {
            let dump = std::fs::read_to_string(out).expect("the testbench wrote its outputs");
            compare(&c.module, &dump, &c.expected, &c.issue)
        })
        .collect()
}

/// `cost`'s wide widths with a 12-bit opacity: its log table is 4096
/// words, not 65536, so loading it through the host port takes a
/// fraction of the simulation.
fn wide() -> PipelineConfig {
    let alpha =
        r#"alpha = { bits = 12, frac = 12, quant = "RND", overflow = "SAT", signed = false }"#;
    let text: Vec<&str> = WIDE
        .lines()
        .map(|l| if l.starts_with("alpha ") { alpha } else { l })
        .collect();
    PipelineConfig::from_toml_str(&text.join("\n")).expect("wide")
}

/// The five configurations: default widths in both orders, narrow and
/// wide formats, and the default widths pipelined for 60 MHz on ECP5
/// (`target_mhz`: stages packed by the delay model, 24 against 35).
fn configs() -> Vec<(&'static str, PipelineConfig)> {
    let d = PipelineConfig::default();
    vec![
        ("btf", d),
        (
            "ecp5_60mhz",
            PipelineConfig {
                target_mhz: 60,
                ..d
            },
        ),
        (
            "ftb",
            PipelineConfig {
                order: Order::FrontToBack,
                ..d
            },
        ),
        (
            "narrow",
            PipelineConfig::from_toml_str(NARROW).expect("narrow"),
        ),
        ("wide", wide()),
    ]
}

/// Every output word of 48 samples per configuration is the evaluator's,
/// at its clock, in both simulators.
#[test]
fn pipelined_sample_matches_the_description() {
    let cases: Vec<Case> = configs()
        .iter()
        .enumerate()
        .map(|(k, (n, cfg))| case(cfg, &format!("ercube_sample_{n}"), 48, k as u8 + 1))
        .collect();
    let verilog: Vec<String> = cases.iter().map(|c| c.module.verilog.clone()).collect();
    for sim in Simulator::ALL {
        if !have(sim.tool(), sim.tool(), "the pipelined sample's simulation") {
            continue;
        }
        for ((name, _), (c, r)) in configs()
            .iter()
            .zip(cases.iter().zip(run(sim, &cases, &verilog)))
        {
            let checked = r.unwrap_or_else(|m| panic!("{sim:?} {name}: {m}"));
            eprintln!(
                "{sim:?} {name}: depth {}, {checked} words equal",
                c.module.depth
            );
            // Every sample's five outputs and every clock's out_valid.
            assert!(checked >= c.issue.len() + 5 * c.samples.len());
        }
    }
}

/// One `+` turned into `-` in a compositing line of the emitted text: the
/// comparison names the first clock, the signal, the word expected and
/// the word the mutant gave.
#[test]
fn a_mutated_operator_is_caught() {
    if !have("iverilog", "iverilog", "the mutation test") {
        return;
    }
    let c = case(&PipelineConfig::default(), "ercube_sample_mutant", 16, 9);
    let v = &c.module.verilog;
    let line = v
        .lines()
        .find(|l| l.contains("wire") && l.contains("n_comp_r_s ") && l.contains(" + "))
        .expect("the red compositing sum");
    let mutant = v.replacen(line, &line.replacen(" + ", " - ", 1), 1);
    assert_ne!(&mutant, v);
    let r = run(Simulator::Icarus, std::slice::from_ref(&c), &[mutant]);
    let m = r[0].clone().expect_err("the mutant differs");
    eprintln!("mutant: {m}");
    assert_eq!(m.signal, "acc_out_r");
    assert!(m.cycle >= c.module.depth as usize, "{m}");
    assert_ne!(m.expected, m.got);
}

/// The emitted module of every configuration passes `verilator
/// --lint-only -Wall` with no message (its two waivers are named and
/// justified in the file) and Icarus compiles it; yosys's `synth -top`
/// up to its fine-grained mapping (`proc`, where latches are inferred,
/// then the coarse passes and the memories) leaves no latch. (The whole
/// `synth -top`, memories mapped to flip-flops, takes a minute and a half
/// of CPU on the narrow module: docs/rtl.md has its figures.)
#[test]
fn emitted_module_lints_and_synthesizes_without_latches() {
    let dir = tempfile::tempdir().expect("tempdir");
    for (name, cfg) in configs() {
        let m = emit_scheduled(
            &plain(&cfg),
            &sample_schedule(&cfg),
            &format!("ercube_sample_{name}"),
        )
        .expect("emits");
        let src = dir.path().join(format!("{}.v", m.name));
        std::fs::write(&src, &m.verilog).expect("write");
        let tool =
            |prog: &str, args: &[&str]| crate::tools::assert_quiet(prog, args, &[&src], name);
        if have("verilator", "verilator", "the Verilator lint") {
            tool("verilator", &["--lint-only", "-Wall"]);
        }
        if have("iverilog", "iverilog", "the Icarus compile") {
            tool("iverilog", &["-g2005", "-Wall", "-o", "/dev/null"]);
        }
        if have("yosys", "yosys", "the latch check") {
            let script = format!(
                "read_verilog {}; synth -top {} -run begin:fine; select -assert-none t:$dlatch t:$adlatch t:$dlatchsr t:$_DLATCH*; stat",
                src.display(),
                m.name
            );
            let out = std::process::Command::new("yosys")
                .args(["-q", "-p", &script])
                .output()
                .expect("yosys runs");
            assert!(
                out.status.success(),
                "yosys {name}: {}",
                String::from_utf8_lossy(&out.stderr)
            );
        }
    }
}
