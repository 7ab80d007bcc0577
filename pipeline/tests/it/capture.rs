//! The capture of every PE's datapath issues (`pipeline::cosim::capture`),
//! without a simulator: a captured frame is the uncaptured one (raw words,
//! cycles, counters); it records exactly the frame's samples, at most one
//! per PE per cycle, each written back `latency` cycles after issue; and
//! the datapath's description (`hw::unit`'s `sample`) evaluated on every
//! captured input bundle, with the frame's tables, gives the accumulators
//! the model wrote back and the tap column. On a real frame, then, the
//! model's words are those the emitted module computes from the same
//! inputs (`tests/it/cosim.rs` runs the module itself).

use std::sync::{Arc, Mutex};

use pipeline::config::{Order, PipelineConfig};
use pipeline::cosim::capture::Recorded;
use pipeline::cosim::replay::word_of;
use pipeline::hw::unit::Unit;
use pipeline::FrameRun;

use crate::chip::{signature, subject, view_from};

fn check(order: Order, pes: u16, eye: [f64; 3]) {
    let s = subject("ml:24");
    let cfg = PipelineConfig {
        pes,
        order,
        ..PipelineConfig::default()
    };
    let prep = view_from(&s.vol, eye, 24);
    let plain = FrameRun::new(&cfg, &s.lut, &s.vol, &prep.view)
        .run()
        .unwrap();
    let rec = Arc::new(Mutex::new(Recorded::new()));
    let captured = FrameRun::new(&cfg, &s.lut, &s.vol, &prep.view)
        .capture(rec.clone())
        .run()
        .unwrap();
    assert_eq!(signature(&captured), signature(&plain), "{order:?}");
    let rec = rec.lock().unwrap();
    assert_eq!(rec.issues.len() as u64, plain.samples, "{order:?}");
    assert_eq!(
        rec.latency,
        u64::from(pipeline::cost::datapath_latency(&cfg))
    );
    let mut last = vec![0u64; usize::from(pes)];
    for i in &rec.issues {
        assert!(i.cycle > last[i.pe], "PE {} issued twice in a cycle", i.pe);
        last[i.pe] = i.cycle;
        assert_eq!(i.input.land, i.cycle + rec.latency);
        assert!(i.cycle <= plain.cycles);
    }
    let mut unit = Unit::new(&cfg, "sample").unwrap();
    for (name, words) in &rec.tables {
        unit.load_table(name, words).unwrap();
    }
    let mut visible = 0;
    for i in &rec.issues {
        let words: Vec<i64> = unit
            .inputs()
            .iter()
            .map(|p| word_of(i, &p.name).unwrap_or_else(|| panic!("no word for {}", p.name)))
            .collect();
        let out = unit.eval(&words).unwrap();
        for (p, w) in unit.outputs().iter().zip(&out) {
            assert_eq!(
                Some(*w),
                word_of(i, &p.name),
                "{order:?}: cycle {}, PE {}, {}",
                i.cycle,
                i.pe,
                p.name
            );
        }
        visible += usize::from(i.out != i.input.acc);
    }
    assert!(
        visible > rec.issues.len() / 10,
        "few visible samples: {visible}"
    );
}

#[test]
fn captured_issues_are_the_datapaths_words() {
    check(Order::BackToFront, 3, [40.0, 30.0, -40.0]);
    check(Order::FrontToBack, 2, [-10.0, 12.0, -30.0]);
}

/// The sample composed with its units (`hw::compose`: the shading unit,
/// the volume-of-interest stage, both), evaluated by `hw::eval` on every
/// captured bundle of a shaded, a VOI and a shaded VOI frame (with the
/// units' taps, row words, per-frame words and the power table as
/// captured), gives the accumulators the model wrote back and the tap
/// column; the model writes back after the composed schedule's depth.
#[test]
fn captured_unit_issues_are_the_composed_datapaths_words() {
    use golden::shading::Shade;
    use golden::voi::{Shape, Voi};
    use pipeline::hw::compose::{sample, Units};
    use pipeline::hw::pipeline_rtl::verilog_name;
    use pipeline::hw::Op;

    let s = subject("ml:24");
    let prep = view_from(&s.vol, [30.0, 20.0, -40.0], 20);
    let shade = Shade::default();
    let c = s.vol.center_world();
    let voi = Voi {
        shape: Shape::Sphere {
            centre: c,
            radius: 7.0,
        },
        scale: 3.0,
        outside: false,
        ramp: 2.0,
    };
    for (order, shading, with_voi) in [
        (Order::BackToFront, true, false),
        (Order::FrontToBack, false, true),
        (Order::BackToFront, true, true),
    ] {
        let cfg = PipelineConfig {
            pes: 3,
            order,
            ..PipelineConfig::default()
        };
        let run = || {
            FrameRun::new(&cfg, &s.lut, &s.vol, &prep.view)
                .unit(shading.then_some(&shade))
                .unit(with_voi.then_some(&voi))
        };
        let plain = run().run().unwrap();
        let rec = Arc::new(Mutex::new(Recorded::new()));
        let captured = run().capture(rec.clone()).run().unwrap();
        assert_eq!(signature(&captured), signature(&plain));
        let rec = rec.lock().unwrap();
        assert_eq!(rec.issues.len() as u64, plain.samples);
        let units = Units {
            lights: shading.then_some(1),
            voi: with_voi,
            ..Units::default()
        };
        let g = sample(&cfg, units);
        let depth = pipeline::hw::schedule::schedule(&g).depth;
        assert_eq!(rec.latency, u64::from(depth), "{units:?}");
        assert_eq!(
            pipeline::cost::sample_latency(&cfg, units),
            depth,
            "{units:?}"
        );
        let tables: Vec<(String, Vec<i64>)> = rec.tables.clone();
        let frame = rec.frame.clone();
        assert!(!frame.is_empty());
        let mut visible = 0;
        for i in &rec.issues {
            let replay_word = |name: &str| -> Option<i64> {
                let v = verilog_name(name);
                word_of(i, &v).or_else(|| frame.iter().find(|f| f.0 == v).map(|f| f.1))
            };
            let taps = ["v00", "v01", "v10", "v11"];
            let read = |node: &str, m: pipeline::hw::MemId, addr: i128| -> Option<i64> {
                let mem = &g.mems[m.0];
                if mem.depth == 0 {
                    let k = taps.iter().position(|t| *t == node)?;
                    return Some(i64::from(i.input.taps[k]));
                }
                let words = &tables.iter().find(|t| t.0 == mem.name)?.1;
                words.get(usize::try_from(addr).ok()?).copied()
            };
            let v = pipeline::hw::eval::eval(
                &g,
                &replay_word,
                &read,
                &mut pipeline::fixed::QuantStats::default(),
            )
            .unwrap_or_else(|e| panic!("{units:?}: cycle {}: {e}", i.cycle));
            for (name, id) in &g.outputs {
                assert_eq!(
                    Some(v[id.0] as i64),
                    word_of(i, name),
                    "{units:?}: cycle {}, PE {}, {name}",
                    i.cycle,
                    i.pe
                );
            }
            visible += usize::from(i.out != i.input.acc);
        }
        assert!(
            visible > rec.issues.len() / 10,
            "{units:?}: few visible samples: {visible}"
        );
        // Every input of the composed graph has a word.
        for n in g.nodes.iter().filter(|n| matches!(n.op, Op::Input)) {
            let v = verilog_name(&n.name);
            let known = frame.iter().any(|f| f.0 == v) || word_of(&rec.issues[0], &v).is_some();
            assert!(known, "{units:?}: no word for {}", n.name);
        }
    }
}

/// The sample composed with the pre-integration unit (`hw::compose`),
/// evaluated on every captured bundle of a pre-integrated frame, each of a
/// sample's steps as the replay drives it (`PreIn::steps`: back to front
/// slice 0's second step reading the accumulators between the two), with
/// the unit's banks and table scale as captured, gives the accumulators
/// the model wrote back and the tap column, in both orders; the frame has
/// samples that only keep their scalar, lead steps, half-path steps and
/// (back to front) second steps.
#[test]
fn captured_preintegrated_issues_are_the_composed_datapaths_words() {
    use pipeline::cosim::capture::PreIn;
    use pipeline::hw::compose::{sample, Units};
    use pipeline::hw::pipeline_rtl::verilog_name;

    let s = subject("ml:24");
    let prep = view_from(&s.vol, [30.0, 20.0, -40.0], 20);
    let pt = golden::preint::PreTable::new(&s.lut);
    for order in [Order::BackToFront, Order::FrontToBack] {
        let cfg = PipelineConfig {
            pes: 3,
            order,
            ..PipelineConfig::default()
        };
        let run = || FrameRun::new(&cfg, &s.lut, &s.vol, &prep.view).unit(Some(&pt));
        let plain = run().run().unwrap();
        let rec = Arc::new(Mutex::new(Recorded::new()));
        let captured = run().capture(rec.clone()).run().unwrap();
        assert_eq!(signature(&captured), signature(&plain));
        let rec = rec.lock().unwrap();
        assert_eq!(rec.issues.len() as u64, plain.samples);
        let units = Units {
            preint: true,
            ..Units::default()
        };
        let g = sample(&cfg, units);
        assert_eq!(
            rec.latency,
            u64::from(pipeline::hw::schedule::schedule(&g).depth)
        );
        let tables = rec.tables.clone();
        let frame = rec.frame.clone();
        assert_eq!(frame.len(), 1, "the table scale: {frame:?}");
        // Kept only, lead, half path, second step, steps that changed the
        // accumulators.
        let mut seen = [0usize; 5];
        for issue in &rec.issues {
            let pre = issue.input.units.pre;
            seen[0] += usize::from(!pre.step);
            // Back to front a lead step is always a second one.
            seen[1] += usize::from(pre.lead || pre.then.is_some());
            seen[2] += usize::from(pre.step && pre.half);
            seen[3] += usize::from(pre.then.is_some());
            let (first, second) = PreIn::steps(issue);
            for i in std::iter::once(first).chain(second) {
                seen[4] += usize::from(i.out != i.input.acc);
                let word = |name: &str| -> Option<i64> {
                    let v = verilog_name(name);
                    word_of(&i, &v).or_else(|| frame.iter().find(|f| f.0 == v).map(|f| f.1))
                };
                let read = |node: &str, m: pipeline::hw::MemId, addr: i128| -> Option<i64> {
                    let mem = &g.mems[m.0];
                    if mem.depth == 0 {
                        let k = ["v00", "v01", "v10", "v11"]
                            .iter()
                            .position(|t| *t == node)?;
                        return Some(i64::from(i.input.taps[k]));
                    }
                    let words = &tables.iter().find(|t| t.0 == mem.name)?.1;
                    words.get(usize::try_from(addr).ok()?).copied()
                };
                let v = pipeline::hw::eval::eval(
                    &g,
                    &word,
                    &read,
                    &mut pipeline::fixed::QuantStats::default(),
                )
                .unwrap_or_else(|e| panic!("{order:?}: cycle {}: {e}", i.cycle));
                for (name, id) in &g.outputs {
                    assert_eq!(
                        Some(v[id.0] as i64),
                        word_of(&i, name),
                        "{order:?}: cycle {}, PE {}, {name}, {pre:?}",
                        i.cycle,
                        i.pe
                    );
                }
            }
        }
        let btf = order == Order::BackToFront;
        assert!(seen[..3].iter().all(|&n| n > 0), "{order:?}: {seen:?}");
        assert_eq!(seen[3] > 0, btf, "{order:?}: {seen:?}");
        assert!(seen[4] > rec.issues.len() / 10, "{order:?}: {seen:?}");
    }
}
