//! The array as a whole: PE step order, neighbour-only access, cycle
//! accounting and independence from P.

use golden::methods::Method;
use golden::render::{render, Prepared, RenderOptions, Technique};
use waves::Tracer;

use super::{prepare, run, run_with, Eye};
use crate::chip::{config, signature, subject, Subject};

/// A pseudo-random permutation of `0..n` (xorshift Fisher-Yates), so a
/// failure is reproducible.
fn shuffled(n: usize, mut seed: u64) -> Vec<usize> {
    let mut v: Vec<usize> = (0..n).collect();
    for i in (1..n).rev() {
        seed ^= seed << 13;
        seed ^= seed >> 7;
        seed ^= seed << 17;
        let j = (seed % (i as u64 + 1)) as usize;
        v.swap(i, j);
    }
    v
}

/// Golden `er` with the same table the pipeline uses.
fn golden_er(s: &Subject, prep: &Prepared) -> golden::methods::Output {
    render(
        prep,
        &s.lut,
        Technique::Slice(Method::Er),
        &RenderOptions::unskipped(),
    )
    .expect("golden er renders")
    .slice
    .expect("er is a slice-order method")
}

// ---------------------------------------------------------------------------
// 1. Step order
// ---------------------------------------------------------------------------

/// Within a clock the array steps PEs one after another, but every PE reads
/// only the port outputs its neighbours committed in the *previous* cycle
/// and writes its own into a spare buffer that is swapped in after all PEs
/// stepped. So the order is unobservable: reversed and shuffled orders give
/// the same words, cycles, stage split and per-PE counters as the natural
/// one. One view is far (one region), two are near (three regions, so the
/// merge's port exchange is exercised too), one of them along -x.
#[test]
fn step_order_cannot_matter() {
    let s = subject("ml:24");
    let n = s.n as f64;
    let eyes = [
        Eye {
            axis: 2,
            positive: false,
            d: 1.5 * n,
            off: [0.3, -0.2],
        },
        Eye {
            axis: 2,
            positive: false,
            d: n / 4.0,
            off: [2.3, -1.7],
        },
        Eye {
            axis: 0,
            positive: true,
            d: 5.3,
            off: [1.1, 0.6],
        },
    ];
    let mut merged_views = 0;
    for e in eyes {
        let prep = prepare(&s, e);
        let k = prep.view.regions().count();
        if k >= 2 {
            merged_views += 1;
        }
        for p in [1u16, 3, 8] {
            let cfg = config(p);
            let natural = signature(&run(&cfg, &s, &prep));
            assert_eq!(natural.merges as usize, k - 1, "{e:?}, P = {p}");
            let n_pe = usize::from(p);
            let orders = [
                (0..n_pe).rev().collect::<Vec<_>>(),
                shuffled(n_pe, 0x9e37_79b9_7f4a_7c15 ^ u64::from(p)),
            ];
            for order in orders {
                let other = signature(&run_with(
                    &cfg,
                    &s,
                    &prep,
                    Some(order.clone()),
                    Tracer::disabled(),
                ));
                assert!(
                    other == natural,
                    "{e:?}, P = {p}: step order {order:?} changed the frame \
                     (cycles {} vs {}, stages {:?} vs {:?})",
                    other.cycles,
                    natural.cycles,
                    other.stages,
                    natural.stages
                );
            }
        }
    }
    assert!(merged_views >= 2, "two views must have merges");
}

/// The untraced default samples each slice PE by PE instead of cycle by
/// cycle; it must give the clocked path's bits, cycles and every counter.
#[test]
fn whole_slice_sampling_equals_the_clocked_path() {
    let mut compared = 0;
    for spec in ["sphere:24", "checker:32", "ml:24"] {
        let s = subject(spec);
        let n = s.vol.dims()[0] as f64;
        let eyes = [
            Eye {
                axis: 2,
                positive: false,
                d: n / 4.0,
                off: [0.5, 0.5],
            },
            Eye {
                axis: 0,
                positive: true,
                d: 3.7,
                off: [0.2, 0.9],
            },
            Eye {
                axis: 1,
                positive: false,
                d: 2.0 * n,
                off: [-0.4, 1.3],
            },
        ];
        for e in eyes {
            let prep = prepare(&s, e);
            let nx = prep.view.dims[0] as u16;
            for p in [1u16, 2, 5, 16, nx] {
                let cfg = config(p);
                let whole = signature(&run(&cfg, &s, &prep));
                let clocked = signature(&run_with(
                    &cfg,
                    &s,
                    &prep,
                    Some((0..usize::from(p)).collect()),
                    Tracer::disabled(),
                ));
                assert!(
                    whole == clocked,
                    "{spec} {e:?}, P = {p}: whole-slice sampling differs from the clocked path"
                );
                compared += 1;
            }
        }
    }
    assert_eq!(compared, 45);
}

// ---------------------------------------------------------------------------
// 2. Neighbour-only access
// ---------------------------------------------------------------------------

/// Why neighbour-only access is structural rather than something to test
/// for: `Pe::sample_step`, `Pe::migrate_step` and `Pe::merge_x` take
/// `&mut self` (the PE's own memory, rays and counters), the controller's
/// broadcast (`SampleBus`, the datapath constants, the child list) and the
/// `Ports` its left and right neighbours drove (`from_left`,
/// `from_right`); they return only the PE's own port outputs. No argument
/// reaches another PE's state, so a PE cannot read a voxel or a ray that
/// is neither its own nor on a neighbour's port; and a ray needing any
/// other column is a `StepError::Ownership`, which would fail the run.
///
/// What can be tested is that this discipline loses nothing: for P from 1
/// to more PEs than voxel columns, and with the eye outside each of the six
/// faces, the PEs together take exactly golden `er`'s samples, slice by
/// slice, and every run completes without an ownership error.
#[test]
fn neighbour_only_array_takes_goldens_samples() {
    let s = subject("sphere:24");
    let eyes = [
        (0, false, 6.0, [0.7, -1.3]),
        (0, true, 9.5, [-2.1, 0.4]),
        (1, false, 4.25, [1.9, 2.2]),
        (1, true, 6.0, [-0.6, -0.9]),
        (2, false, 7.0, [0.0, 0.0]),
        (2, true, 5.5, [3.1, -2.7]),
    ];
    for (axis, positive, d, off) in eyes {
        let e = Eye {
            axis,
            positive,
            d,
            off,
        };
        let prep = prepare(&s, e);
        let g = golden_er(&s, &prep).stats;
        assert!(g.samples_total > 0, "{e:?}: golden samples nothing");
        for p in [1u16, 2, 5, 16, 32] {
            let f = run(&config(p), &s, &prep);
            let per_pe: u64 = f.pes.iter().map(|c| c.samples).sum();
            assert_eq!(per_pe, f.samples, "{e:?}, P = {p}: PE sum vs frame");
            assert_eq!(f.samples, g.samples_total, "{e:?}, P = {p}: vs golden");
            assert_eq!(
                f.samples_per_slice, g.samples_per_slice,
                "{e:?}, P = {p}: samples per slice"
            );
            assert_eq!(f.merges, g.merges, "{e:?}, P = {p}: merges");
        }
    }
}

// ---------------------------------------------------------------------------
// 3. Cycle accounting
// ---------------------------------------------------------------------------

/// Every cycle belongs to one stage; in a sampling cycle each PE either
/// samples (busy) or idles; a busy cycle is one sample; the ideal is the
/// samples spread evenly over P; the array cannot beat the ideal. With one
/// PE nothing migrates and nothing idles. Rays are conserved in transit.
#[test]
fn cycle_accounting_adds_up() {
    let s = subject("checker:24");
    let eyes = [
        Eye {
            axis: 2,
            positive: false,
            d: 36.0,
            off: [0.0, 0.0],
        },
        Eye {
            axis: 2,
            positive: false,
            d: 6.0,
            off: [1.4, -2.6],
        },
        Eye {
            axis: 1,
            positive: true,
            d: 4.7,
            off: [-1.2, 0.8],
        },
    ];
    for e in eyes {
        let prep = prepare(&s, e);
        for p in [1u16, 3, 8, 16] {
            let f = run(&config(p), &s, &prep);
            let st = f.stages;
            let ctx = format!("{e:?}, P = {p}");
            assert_eq!(
                f.cycles,
                st.migrate + st.sample + st.merge + st.readout + st.drain + st.stall + st.plan,
                "{ctx}: stages {st:?}"
            );
            for (k, c) in f.pes.iter().enumerate() {
                assert_eq!(c.busy + c.idle, st.sample, "{ctx}, PE {k}: {c:?}");
                assert_eq!(c.stalls, st.stall, "{ctx}, PE {k}: {c:?}");
                assert_eq!(c.busy, c.samples, "{ctx}, PE {k}: {c:?}");
            }
            assert_eq!(f.ideal_cycles, f.samples as f64 / f64::from(p), "{ctx}");
            let u = f.utilization();
            assert!(u > 0.0 && u <= 1.0, "{ctx}: utilization {u}");
            assert!(f.ideal_cycles <= st.sample as f64, "{ctx}");
            let sent: u64 = f.pes.iter().map(|c| c.rays_sent).sum();
            let received: u64 = f.pes.iter().map(|c| c.rays_received).sum();
            assert_eq!(sent, received, "{ctx}: rays lost or invented in transit");
            assert_eq!(st.merge > 0, f.merges > 0, "{ctx}: {st:?}");
            assert!(st.readout > 0, "{ctx}: no readout");
            if p == 1 {
                assert_eq!(st.migrate, 0, "{ctx}: one PE migrates");
                assert_eq!(sent, 0, "{ctx}: one PE sends rays");
                // A lone PE has no neighbour whose edge voxels it could
                // wait for, so no sampling cycle of it can be idle.
                let sliced = f.samples_per_slice.iter().filter(|&&n| n > 0).count();
                assert_eq!(
                    f.pes[0].idle, 0,
                    "{ctx}: one PE idles ({sliced} slices sampled, {} sampling cycles \
                     for {} samples)",
                    st.sample, f.samples
                );
                assert_eq!(f.utilization(), f.samples as f64 / f.cycles as f64);
            } else {
                assert!(st.migrate > 0 && sent > 0, "{ctx}: nothing migrated");
            }
        }
    }
}

// ---------------------------------------------------------------------------
// 4. P independence
// ---------------------------------------------------------------------------

/// A sample's arithmetic does not depend on which PE performs it, so the
/// baseplane's raw words are the same for every P: blocks of many columns,
/// uneven blocks (7 PEs), PEs without columns (16 PEs on 24 columns), and
/// one column per PE, where every sample's right-hand voxels arrive over
/// the neighbour port.
#[test]
fn baseplane_words_do_not_depend_on_p() {
    let cases = [
        (
            "sphere:24",
            Eye {
                axis: 2,
                positive: false,
                d: 6.0,
                off: [1.3, -0.4],
            },
        ),
        (
            "checker:32",
            Eye {
                axis: 2,
                positive: false,
                d: 8.0,
                off: [-2.2, 3.1],
            },
        ),
        (
            "ml:24",
            Eye {
                axis: 0,
                positive: false,
                d: 5.5,
                off: [0.9, 1.7],
            },
        ),
    ];
    let mut failures = Vec::new();
    for (spec, e) in cases {
        let s = subject(spec);
        let prep = prepare(&s, e);
        let reference = run(&config(1), &s, &prep);
        assert!(
            reference.raw.iter().any(|w| w[3] > 0),
            "{spec}: an empty baseplane proves nothing"
        );
        let nx = prep.view.dims[0] as u16;
        for p in [2u16, 7, 16, nx] {
            let f = run(&config(p), &s, &prep);
            assert_eq!(f.raw.len(), reference.raw.len());
            let differ: Vec<usize> = (0..f.raw.len())
                .filter(|&i| f.raw[i] != reference.raw[i])
                .collect();
            if !differ.is_empty() {
                let [w, _] = f.baseplane.grid.counts;
                let i = differ[0];
                failures.push(format!(
                    "{spec} {e:?}: P = {p} differs from P = 1 in {} of {} baseplane words; \
                     first at (x {}, row {}): {:?} vs {:?}",
                    differ.len(),
                    f.raw.len(),
                    i % w,
                    i / w,
                    f.raw[i],
                    reference.raw[i]
                ));
            }
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}
