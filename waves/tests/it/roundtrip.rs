//! Write random value sequences, read them back with the `vcd` parser, and
//! compare with what was written, including the number of change records.

use std::collections::BTreeMap;

use proptest::prelude::*;
use waves::bitvec::prelude::*;
use waves::{ScopePath, SignalId, Trace, TraceConfig, Tracer, TIME_UNITS_PER_CYCLE};

/// How a probe is driven.
#[derive(Clone, Copy, Debug)]
enum Kind {
    Unsigned,
    Signed,
    Bits,
}

struct Probe {
    scope: ScopePath,
    name: &'static str,
    width: u32,
    kind: Kind,
}

fn probes(n_pe: u32) -> Vec<Probe> {
    let mut v = vec![
        Probe {
            scope: ScopePath::top().child("ctrl"),
            name: "flag",
            width: 1,
            kind: Kind::Unsigned,
        },
        Probe {
            scope: ScopePath::top(),
            name: "big",
            width: 100,
            kind: Kind::Bits,
        },
        Probe {
            scope: ScopePath::top().child("ctrl"),
            name: "delta",
            width: 12,
            kind: Kind::Signed,
        },
    ];
    for k in 0..n_pe {
        for (name, width) in [("byte", 8), ("odd", 13), ("word", 64)] {
            v.push(Probe {
                scope: ScopePath::pe(k),
                name,
                width,
                kind: Kind::Unsigned,
            });
        }
        v.push(Probe {
            scope: ScopePath::pe(k).child("mac"),
            name: "bits",
            width: 13,
            kind: Kind::Bits,
        });
    }
    v
}

/// A value as the model holds it: up to 128 bits, two's complement for
/// signed probes (then only the low `width` bits are meaningful).
fn mask(width: u32) -> u128 {
    if width >= 128 {
        u128::MAX
    } else {
        (1u128 << width) - 1
    }
}

/// Picks the value a probe is set to from the random choice `(sel, r)`:
/// `None` leaves it unset this cycle; repeats and extremes are frequent so
/// that deduplication is exercised.
fn choose(p: &Probe, prev: Option<i128>, sel: u8, r: u128) -> Option<i128> {
    let m = mask(p.width);
    let v = match (sel % 8, p.kind) {
        (0, _) => return None,
        (1..=3, _) if prev.is_some() => return prev,
        (4, _) => 0,
        (5, Kind::Signed) => -(1i128 << (p.width - 1)),
        (5, _) => m as i128,
        (6, Kind::Signed) => (1i128 << (p.width - 1)) - 1,
        (_, Kind::Signed) => ((r & m) as i128) - (1i128 << (p.width - 1)),
        _ => (r & m) as i128,
    };
    Some(v)
}

fn set(s: &mut waves::Sampler<'_>, p: &Probe, id: SignalId, v: i128) {
    match p.kind {
        Kind::Unsigned => s.set(id, v as u64),
        Kind::Signed => s.set_signed(id, v as i64),
        Kind::Bits => {
            let words = [v as u128 as u64, ((v as u128) >> 64) as u64];
            s.set_bits(id, &words.view_bits::<Lsb0>()[..p.width as usize]);
        }
    }
}

/// What the reader must give back for a model value.
fn expected_text(p: &Probe, v: i128) -> String {
    let u = (v as u128) & mask(p.width);
    format!("{u:0w$b}", w = p.width as usize)
}

#[derive(Debug, Clone)]
struct Case {
    n_pe: u32,
    clock: bool,
    first: u64,
    /// Gap before each sampled cycle (0 = two samples of the same cycle).
    gaps: Vec<u64>,
    choices: Vec<Vec<(u8, u128)>>,
}

fn case() -> impl Strategy<Value = Case> {
    (1u32..4, any::<bool>(), 0u64..1000, 1usize..30).prop_flat_map(|(n_pe, clock, first, n)| {
        let n_probes = probes(n_pe).len();
        (
            prop::collection::vec(prop_oneof![1 => Just(0u64), 8 => 1u64..4], n),
            prop::collection::vec(
                prop::collection::vec((any::<u8>(), any::<u128>()), n_probes),
                n,
            ),
        )
            .prop_map(move |(gaps, choices)| Case {
                n_pe,
                clock,
                first,
                gaps,
                choices,
            })
    })
}

fn run(case: &Case) -> Result<(), TestCaseError> {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("rt.vcd");
    let probes = probes(case.n_pe);
    let mut tracer = Tracer::new(TraceConfig::new(&path).with_clock(case.clock)).unwrap();
    let ids: Vec<SignalId> = probes
        .iter()
        .map(|p| tracer.register(&p.scope, p.name, p.width).unwrap())
        .collect();

    // Model side: current value and change count per probe, and the value
    // at each sampled cycle (after all samples of that cycle).
    let mut current: Vec<Option<i128>> = vec![None; probes.len()];
    let mut changes = vec![0usize; probes.len()];
    let mut at_cycle: BTreeMap<u64, Vec<Option<i128>>> = BTreeMap::new();
    let mut cycle = case.first;
    for (gap, choices) in case.gaps.iter().zip(&case.choices) {
        cycle += gap;
        let values: Vec<Option<i128>> = probes
            .iter()
            .zip(choices)
            .enumerate()
            .map(|(i, (p, &(sel, r)))| choose(p, current[i], sel, r))
            .collect();
        tracer.sample(cycle, |s| {
            for (i, v) in values.iter().enumerate() {
                if let Some(v) = *v {
                    set(s, &probes[i], ids[i], v);
                }
            }
        });
        for (i, v) in values.iter().enumerate() {
            if let Some(v) = *v {
                let norm = (v as u128) & mask(probes[i].width);
                if current[i].map(|c| (c as u128) & mask(probes[i].width)) != Some(norm) {
                    changes[i] += 1;
                }
                current[i] = Some(v);
            }
        }
        at_cycle.insert(cycle, current.clone());
    }
    let info = tracer.finish().unwrap().unwrap();
    let last = cycle;
    prop_assert_eq!(info.cycles.clone(), Some(case.first + case.gaps[0]..=last));
    prop_assert_eq!(info.signals.len(), probes.len() + usize::from(case.clock));

    let trace = Trace::read(&path).unwrap();
    prop_assert_eq!(trace.timescale(), Some("100ps"));
    prop_assert_eq!(trace.end_time(), (last + 1) * TIME_UNITS_PER_CYCLE);
    for (i, p) in probes.iter().enumerate() {
        let name = format!("{}.{}", p.scope, p.name);
        let sig = trace.signal(&name).unwrap();
        prop_assert_eq!(sig.width(), p.width);
        prop_assert_eq!(
            sig.changes().len(),
            changes[i],
            "change records of {}",
            name
        );
        // Consecutive records must differ: the writer dedups.
        for w in sig.changes().windows(2) {
            prop_assert_ne!(&w[0].value, &w[1].value, "redundant record in {}", name);
        }
        for ch in sig.changes() {
            prop_assert_eq!(ch.time % TIME_UNITS_PER_CYCLE, 0);
            prop_assert!(at_cycle.contains_key(&ch.cycle()));
        }
        // Every cycle from before the first sample to after the last,
        // including cycles skipped by the model, which hold their value.
        for c in case.first.saturating_sub(1)..=last + 1 {
            let model = at_cycle.range(..=c).next_back().and_then(|(_, v)| v[i]);
            let read = sig.value_at_cycle(c).map(|v| v.to_string());
            prop_assert_eq!(
                read,
                model.map(|v| expected_text(p, v)),
                "{} at cycle {}",
                name,
                c
            );
            if p.width <= 64 {
                let u = model.map(|v| ((v as u128) & mask(p.width)) as u64);
                prop_assert_eq!(sig.u64_at_cycle(c), u);
            }
        }
    }

    let clk = trace.signal("top.clk");
    prop_assert_eq!(clk.is_some(), case.clock);
    if let Some(clk) = clk {
        prop_assert_eq!(clk.changes().len(), 2 * at_cycle.len());
        for &c in at_cycle.keys() {
            let t = c * TIME_UNITS_PER_CYCLE;
            prop_assert_eq!(clk.value_at_time(t).and_then(|v| v.as_u64()), Some(1));
            let half = t + TIME_UNITS_PER_CYCLE / 2;
            prop_assert_eq!(clk.value_at_time(half).and_then(|v| v.as_u64()), Some(0));
        }
    }
    Ok(())
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]

    #[test]
    fn random_values_round_trip(case in case()) {
        run(&case)?;
    }
}

#[test]
fn quiet_cycles_write_no_timestamp_without_clock() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("q.vcd");
    let mut tracer = Tracer::new(TraceConfig::new(&path).with_clock(false)).unwrap();
    let id = tracer.register(&ScopePath::pe(0), "acc", 8).unwrap();
    for c in 0..100 {
        tracer.sample(c, |s| s.set(id, c / 40));
    }
    tracer.finish().unwrap();
    let text = std::fs::read_to_string(&path).unwrap();
    let stamps: Vec<&str> = text.lines().filter(|l| l.starts_with('#')).collect();
    // Cycles 0, 40, 80 and the end after cycle 99, 50 units (5 ns) each.
    assert_eq!(stamps, ["#0", "#2000", "#4000", "#5000"]);
    assert!(text.contains("$var wire 8 ! acc [7:0] $end"), "{text}");
    assert!(text.contains("$scope module pe_0 $end"), "{text}");
}
