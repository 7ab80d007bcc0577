//! Integration tests of the bit-accurate, cycle-level PE-array model
//! (`pipeline`): properties of the array as a whole that unit tests of one
//! PE or one datapath step cannot see.
//!
//! 1. The order in which PEs are stepped within a clock cannot change
//!    anything (the two-phase port discipline).
//! 2. Every PE only talks to its neighbours, and the array takes exactly
//!    golden `er`'s samples, for any P and any principal axis.
//! 3. The cycle counters add up.
//! 4. The baseplane's raw words do not depend on P.
//! 5. The VCD waveform shows exactly the model's compositing results,
//!    converts to FST with GTKWave's `vcd2fst`, and comes with a `.gtkw`
//!    naming only traced signals.
//! 6. Tracing does not perturb the model.
//! 7. Fixed-point ray positions rarely disagree with golden's float
//!    positions about whether a ray is inside a slice.
//! 8. Bad configurations are refused with one-line errors, by the library
//!    and by the `ercube` binary.
//! 9. `ercube render --method pipeline` writes what it promises, and its
//!    raw words are those of the in-process model.
//!
//! Volumes are 24^3 to 32^3 so the whole file runs in well under a minute
//! in release.

use std::path::Path;

use glam::DVec3;
use golden::camera::Camera;
use golden::methods::Method;
use golden::render::{render, Prepared, RenderOptions, Technique};
use pipeline::array::{Array, Frame};
use pipeline::config::PipelineConfig;
use pipeline::datapath::Datapath;
use pipeline::fixed::{Format, Overflow, Quant, QuantStats};
use pipeline::host::plan;
use pipeline::probes::Stage;
use pipeline::tables::Tables;
use waves::{PeFilter, Trace, TraceConfig, Tracer, TIME_UNITS_PER_CYCLE};

use crate::chip::{check_gtkw, config, signature, subject, Subject};
use crate::scenes::up_for;

// ---------------------------------------------------------------------------
// Helpers
// ---------------------------------------------------------------------------

/// Where the eye sits: outside the face of index axis `axis` on the side
/// `positive`, `d` voxels from the nearest slice (so the view's `D` is `d`),
/// shifted by `off` along the other two axes (in increasing axis order)
/// from the volume's centre line.
#[derive(Debug, Clone, Copy)]
struct Eye {
    axis: usize,
    positive: bool,
    d: f64,
    off: [f64; 2],
}

impl Eye {
    fn position(&self, n: usize) -> DVec3 {
        let c = (n as f64 - 1.0) / 2.0;
        let mut p = [c; 3];
        let others: Vec<usize> = (0..3).filter(|&k| k != self.axis).collect();
        p[others[0]] += self.off[0];
        p[others[1]] += self.off[1];
        p[self.axis] = if self.positive {
            n as f64 - 1.0 + self.d
        } else {
            -self.d
        };
        DVec3::from_array(p)
    }
}

/// The eye `e` looking at the volume's centre with a 60 degree, 32x32
/// camera. (The image only matters to the warp, which the array never
/// sees.)
fn prepare(s: &Subject, e: Eye) -> Prepared {
    let eye = e.position(s.n);
    let centre = DVec3::from_array(s.vol.center_world());
    let cam = Camera::new(eye, centre, up_for(centre - eye), 60.0, 32, 32).expect("camera");
    let prep = Prepared::new(&s.vol, &cam).expect("view");
    assert!(
        (prep.view.d - e.d).abs() < 1e-9,
        "{e:?}: the view's D is {}, not {}",
        prep.view.d,
        e.d
    );
    prep
}

/// Runs one frame, optionally with a PE step order (which also makes the
/// sampling stage step cycle by cycle, where the order could matter) and a
/// tracer.
fn run_with(
    cfg: &PipelineConfig,
    s: &Subject,
    prep: &Prepared,
    order: Option<Vec<usize>>,
    tracer: Tracer,
) -> Frame {
    let mut array = match Array::new(cfg, &s.vol, &s.lut, &prep.view, tracer) {
        Ok(a) => a,
        Err(e) => panic!("Array::new with {} PEs: {e}", cfg.pes),
    };
    if let Some(o) = order {
        array.set_step_order(o);
        array.set_clocked(true);
    }
    array
        .run(&prep.view)
        .unwrap_or_else(|e| panic!("run with {} PEs: {e}", cfg.pes))
}

/// Runs one untraced frame in the natural step order.
fn run(cfg: &PipelineConfig, s: &Subject, prep: &Prepared) -> Frame {
    run_with(cfg, s, prep, None, Tracer::disabled())
}

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
                st.migrate + st.sample + st.merge + st.readout + st.drain + st.stall,
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

// ---------------------------------------------------------------------------
// 5. Waveform read-back
// ---------------------------------------------------------------------------

/// What [`check_slice0_trace`] saw.
#[derive(Debug, Default)]
struct Slice0 {
    /// (PE, cycle) pairs checked: busy in the slice-0 sampling stage.
    cycles: u64,
    /// Distinct rays `(mx, row)` among them.
    rays: std::collections::BTreeSet<(i64, usize)>,
}

/// Reads `vcd` and checks, for every traced PE `pe_K` and every cycle of
/// the slice-0 sampling stage in which it is busy, that its traced
/// accumulators are the frame's baseplane word of the ray it traces.
///
/// Slice 0 is the last slice sampled and no merge follows it, so the value
/// a ray's accumulators take when it samples slice 0 is its final value;
/// this holds even for a sample with zero opacity (the accumulators are
/// traced unchanged).
fn check_slice0_trace(vcd: &Path, frame: &Frame, lo_x: i64, pes: &[usize]) -> Slice0 {
    let trace = Trace::read(vcd).unwrap_or_else(|e| panic!("reading {}: {e}", vcd.display()));
    let sig = |name: &str| {
        trace
            .signal(name)
            .unwrap_or_else(|| panic!("{name} is not in {}", vcd.display()))
    };
    let stage = sig("top.ctrl.stage");
    let slice = sig("top.ctrl.slice");
    let [w, h] = frame.baseplane.grid.counts;
    struct PeSigs<'a> {
        k: usize,
        busy: &'a waves::SignalTrace,
        mx: &'a waves::SignalTrace,
        row: &'a waves::SignalTrace,
        acc: [&'a waves::SignalTrace; 4],
    }
    let sigs: Vec<PeSigs> = pes
        .iter()
        .map(|&k| {
            let s = |n: &str| sig(&format!("top.pe_{k}.{n}"));
            PeSigs {
                k,
                busy: s("busy"),
                mx: s("ray_mx"),
                row: s("ray_row"),
                acc: [s("acc_r"), s("acc_g"), s("acc_b"), s("acc_a")],
            }
        })
        .collect();
    let end = trace.end_time() / TIME_UNITS_PER_CYCLE;
    let mut seen = Slice0::default();
    for c in 0..end {
        if stage.u64_at_cycle(c) != Some(STAGE_SAMPLE) || slice.u64_at_cycle(c) != Some(0) {
            continue;
        }
        for p in &sigs {
            if p.busy.u64_at_cycle(c) != Some(1) {
                continue;
            }
            let value = |t: &waves::SignalTrace| {
                t.u64_at_cycle(c)
                    .unwrap_or_else(|| panic!("PE {} has no value at cycle {c}", p.k))
            };
            // Ray indices are 16-bit two's complement on the wire.
            let mx = i64::from(value(p.mx) as u16 as i16);
            let row = value(p.row) as usize;
            let x = mx - lo_x;
            assert!(
                (0..w as i64).contains(&x) && row < h,
                "cycle {c}, PE {}: ray ({mx}, row {row}) outside the {w}x{h} baseplane",
                p.k
            );
            let want = frame.raw[row * w + x as usize];
            let got: Vec<i64> = p.acc.iter().map(|t| value(t) as i64).collect();
            assert_eq!(
                got, want,
                "cycle {c}, PE {}: traced accumulators of ray ({mx}, row {row}) \
                 differ from the baseplane",
                p.k
            );
            seen.cycles += 1;
            seen.rays.insert((mx, row));
        }
    }
    seen
}

/// The cycles in `range` for which the VCD has no record at all (no rising
/// edge of `top.clk`): cycles the model clocked without tracing them, which
/// a viewer shows with the previous cycle's values.
fn unrecorded_cycles(trace: &Trace, range: std::ops::RangeInclusive<u64>) -> Vec<u64> {
    let clk = trace.signal("top.clk").expect("clock traced");
    let recorded: std::collections::BTreeSet<u64> = clk
        .changes()
        .iter()
        .filter(|c| c.value.as_u64() == Some(1) && c.time % TIME_UNITS_PER_CYCLE == 0)
        .map(|c| c.cycle())
        .collect();
    range.filter(|c| !recorded.contains(c)).collect()
}

/// `cycles` as a few `a..=b` runs, for messages.
fn runs(cycles: &[u64]) -> String {
    let mut out: Vec<(u64, u64)> = Vec::new();
    for &c in cycles {
        match out.last_mut() {
            Some((_, b)) if *b + 1 == c => *b = c,
            _ => out.push((c, c)),
        }
    }
    let shown: Vec<String> = out
        .iter()
        .take(6)
        .map(|(a, b)| format!("{a}..={b}"))
        .collect();
    format!(
        "{} in {} runs: {}{}",
        cycles.len(),
        out.len(),
        shown.join(", "),
        if out.len() > 6 { ", ..." } else { "" }
    )
}

/// Stage codes on `top.ctrl.stage`.
const STAGE_SAMPLE: u64 = Stage::Sample as u64;
const STAGE_READOUT: u64 = Stage::Readout as u64;

/// The readout stage takes the frame's last `stages.readout` cycles
/// (cycles are numbered from 1: the model records cycle `c` after its
/// `c`-th clock). Returns the traced cycles of that stretch in which the
/// VCD does *not* show the readout stage, and how many PE-cycles of them
/// show a busy PE.
fn readout_mislabelled(vcd: &Path, frame: &Frame, pes: &[usize]) -> (Vec<u64>, u64) {
    let trace = Trace::read(vcd).expect("VCD reads");
    let stage = trace.signal("top.ctrl.stage").expect("stage traced");
    let first = frame.cycles - frame.stages.readout + 1;
    let mut wrong = Vec::new();
    let mut busy = 0;
    for c in first..=frame.cycles {
        let Some(s) = stage.u64_at_cycle(c) else {
            continue;
        };
        if s != STAGE_READOUT {
            wrong.push(c);
            for k in pes {
                let b = trace.signal(&format!("top.pe_{k}.busy")).expect("busy");
                busy += u64::from(b.u64_at_cycle(c) == Some(1));
            }
        }
    }
    (wrong, busy)
}

/// The traced compositing outputs are the model's. Two runs: four PEs all
/// traced over the whole frame, where every slice-0 sample must show up
/// in the trace and match; and eight PEs with only 0-3 traced over a
/// window at the end of the frame (the tail of slice 0 and the readout).
/// Both VCDs convert with `vcd2fst` and have a matching `.gtkw`.
///
/// Last, the waveform must follow the model's schedule: every clocked
/// cycle has a record (a rising `top.clk`), and the frame's last
/// `stages.readout` cycles, the readout, show `stage = 3`. A cycle without
/// a record shows the previous one's values in a viewer, so an untraced
/// readout shows the last sampling cycle (`stage = 0`, a PE busy) for
/// hundreds of cycles.
#[test]
fn waveform_reads_back_as_the_models_results() {
    let s = subject("ml:24");
    let prep = prepare(
        &s,
        Eye {
            axis: 2,
            positive: false,
            d: 6.0,
            off: [1.6, -0.8],
        },
    );
    assert!(prep.view.regions().count() >= 2, "the view must merge");
    let lo_x = Method::Er.layout(&prep.view).expect("layout").grids[0].lo[0];
    let dir = tempfile::tempdir().expect("temporary directory");
    let mut schedule_errors = Vec::new();

    // Whole frame, every PE traced.
    let vcd = dir.path().join("whole.vcd");
    let cfg = config(4);
    let tracer =
        Tracer::new(TraceConfig::new(&vcd).with_pes(PeFilter::parse("0-3").expect("PE list")))
            .expect("tracer");
    let frame = run_with(&cfg, &s, &prep, None, tracer);
    let seen = check_slice0_trace(&vcd, &frame, lo_x, &[0, 1, 2, 3]);
    eprintln!(
        "whole-frame trace: {} busy slice-0 PE-cycles matched the baseplane, \
         {} distinct rays ({} samples in slice 0)",
        seen.cycles,
        seen.rays.len(),
        frame.samples_per_slice[0]
    );
    assert!(seen.cycles > 0);
    assert_eq!(
        seen.rays.len() as u64,
        frame.samples_per_slice[0],
        "every slice-0 sample of a fully traced array is in the trace"
    );
    let lines = check_gtkw(&vcd);
    // clk, ten controller signals (stage, slice, row and the pass's
    // broadcast), eleven per PE: the default groups (ctrl, datapath, acc);
    // the link ports and registers are off by default.
    assert_eq!(lines, 1 + 10 + 4 * 11, "signals in the .gtkw");
    crate::tools::vcd2fst(&vcd);
    let (wrong, busy) = readout_mislabelled(&vcd, &frame, &[0, 1, 2, 3]);
    if !wrong.is_empty() {
        schedule_errors.push(format!(
            "P = 4, whole frame: {} of the {} readout cycles ({}..={}) show stage {} \
             instead of readout ({STAGE_READOUT}), with {busy} busy PE-cycles; \
             {} busy slice-0 PE-cycles are traced for {} samples",
            wrong.len(),
            frame.stages.readout,
            frame.cycles - frame.stages.readout + 1,
            frame.cycles,
            STAGE_SAMPLE,
            seen.cycles,
            frame.samples_per_slice[0],
        ));
    }

    let trace = Trace::read(&vcd).expect("VCD reads");
    let missing = unrecorded_cycles(&trace, 1..=frame.cycles);
    if !missing.is_empty() {
        schedule_errors.push(format!(
            "P = 4, whole frame: of cycles 1..={}, {} are never recorded \
             (stages {:?}, {} merges)",
            frame.cycles,
            runs(&missing),
            frame.stages,
            frame.merges
        ));
    }

    // A window at the end, half the PEs traced.
    let cfg = config(8);
    let plain = run(&cfg, &s, &prep);
    let start = plain.cycles - plain.stages.readout - 200;
    let vcd = dir.path().join("window.vcd");
    let tracer = Tracer::new(
        TraceConfig::new(&vcd)
            .with_pes(PeFilter::parse("0-3").expect("PE list"))
            .with_cycles(start..=plain.cycles),
    )
    .expect("tracer");
    let frame = run_with(&cfg, &s, &prep, None, tracer);
    assert_eq!(signature(&frame), signature(&plain));
    let trace = Trace::read(&vcd).expect("VCD reads");
    assert!(
        trace.names().all(|n| !n.starts_with("top.pe_4.")),
        "PE 4 is not traced"
    );
    let first = trace
        .signal("top.ctrl.stage")
        .expect("stage traced")
        .changes()
        .first()
        .expect("stage has a value")
        .cycle();
    assert!(
        first >= start,
        "trace starts at cycle {first}, before {start}"
    );
    let seen = check_slice0_trace(&vcd, &frame, lo_x, &[0, 1, 2, 3]);
    eprintln!(
        "windowed trace: {} busy slice-0 PE-cycles matched, {} distinct rays",
        seen.cycles,
        seen.rays.len()
    );
    assert!(!seen.rays.is_empty(), "the window holds slice-0 samples");
    check_gtkw(&vcd);
    crate::tools::vcd2fst(&vcd);
    let (wrong, busy) = readout_mislabelled(&vcd, &frame, &[0, 1, 2, 3]);
    if !wrong.is_empty() {
        schedule_errors.push(format!(
            "P = 8, window: {} of the {} readout cycles show a stage other than \
             readout, with {busy} busy PE-cycles of PEs 0-3",
            wrong.len(),
            frame.stages.readout,
        ));
    }

    assert!(
        schedule_errors.is_empty(),
        "the VCD's stage signal does not follow the model's schedule:\n  {}",
        schedule_errors.join("\n  ")
    );
}

// ---------------------------------------------------------------------------
// 6. Tracing off vs on
// ---------------------------------------------------------------------------

/// Probes only observe: a traced frame (every PE, every cycle) is the same
/// frame as an untraced one.
#[test]
fn tracing_does_not_change_the_frame() {
    let s = subject("checker:24");
    let prep = prepare(
        &s,
        Eye {
            axis: 2,
            positive: false,
            d: 6.0,
            off: [-1.1, 2.4],
        },
    );
    let dir = tempfile::tempdir().expect("temporary directory");
    for p in [1u16, 5] {
        let cfg = config(p);
        let off = run(&cfg, &s, &prep);
        let vcd = dir.path().join(format!("p{p}.vcd"));
        let tracer = Tracer::new(TraceConfig::new(&vcd)).expect("tracer");
        let on = run_with(&cfg, &s, &prep, None, tracer);
        assert!(vcd.exists(), "P = {p}: no VCD written");
        assert_eq!(on.raw, off.raw, "P = {p}: raw words");
        assert_eq!(on.cycles, off.cycles, "P = {p}: cycles");
        assert_eq!(signature(&on), signature(&off), "P = {p}");
    }
}

// ---------------------------------------------------------------------------
// 7. Edge exceptions
// ---------------------------------------------------------------------------

/// Views for the edge-exception count: integer and non-integer eyes, eyes
/// on voxel centres and on voxel boundaries, and eyes whose region
/// boundaries `b_i = D (2^i - 1)` fall exactly on slices (`D` = 1, 3, 6, 31,
/// 48 give integer `b_i`).
fn edge_views() -> Vec<(&'static str, Eye)> {
    let eye = |axis, positive, d, off| Eye {
        axis,
        positive,
        d,
        off,
    };
    vec![
        ("sphere:24", eye(2, false, 3.0, [0.0, 0.0])),
        ("sphere:24", eye(2, false, 1.0, [0.5, -0.5])),
        ("sphere:24", eye(0, true, 6.0, [0.5, 0.0])),
        ("sphere:24", eye(1, false, 5.37, [0.731, -2.113])),
        (
            "ml:32",
            eye(
                2,
                true,
                23.0 / 7.0,
                [std::f64::consts::PI, -std::f64::consts::E],
            ),
        ),
        ("ml:32", eye(0, false, 31.0, [0.25, 0.75])),
        ("ml:32", eye(1, true, 7.75, [-4.5, 3.5])),
        ("checker:32", eye(2, false, 48.0, [0.0, 0.0])),
        ("checker:32", eye(2, false, 0.4, [9.3, 11.1])),
    ]
}

/// Edge exceptions of one configuration over [`edge_views`].
#[derive(Debug, Default)]
struct EdgeCount {
    /// Rays (x, y) sampled in one decision and not in the other.
    exceptions: u64,
    /// Golden's samples.
    samples: u64,
    /// Closest any ray's fixed-point position came to a slice edge, in
    /// position LSBs (0: exactly on `-0.5` or `n - 0.5`).
    closest_lsb: i64,
    /// Exceptions per view.
    per_view: Vec<String>,
}

/// Counts, over every slice and every ray of every region of
/// [`edge_views`], the rays golden samples (its broadcast range) whose
/// fixed-point position under `cfg` is outside `[-0.5, n - 0.5]`, or the
/// other way round. A ray is a sample when it is inside on both axes.
fn count_edge_exceptions(cfg: &PipelineConfig) -> EdgeCount {
    let f = u32::from(cfg.position.frac());
    let half = 1i64 << (f - 1);
    let mut out = EdgeCount {
        closest_lsb: i64::MAX,
        ..EdgeCount::default()
    };
    for (spec, e) in edge_views() {
        let s = subject(spec);
        let prep = prepare(&s, e);
        let view = &prep.view;
        let dp = Datapath::new(*cfg, Tables::new(cfg, &s.lut).expect("tables"));
        let fp = plan(cfg, view).expect("plan");
        let mut st = QuantStats::default();
        let mut view_exceptions = 0;
        for region in &fp.regions {
            let g = &region.grid;
            for sp in &region.slices {
                let (_, range) = golden::sampling::slice_rays(view, g, sp.z);
                assert_eq!(sp.range, range, "the host broadcasts golden's ranges");
                // Per axis: golden's and the fixed-point decision for
                // every ray of the region.
                let inside: [Vec<(bool, bool)>; 2] = std::array::from_fn(|k| {
                    let (lo, hi) = (-half, (2 * view.dims[k] as i64 - 1) * half);
                    (g.lo[k]..=g.hi[k])
                        .map(|m| {
                            let gold = (range[k].0..=range[k].1).contains(&m);
                            let x = dp
                                .position(sp.a[k], sp.t[k], m, &mut st)
                                .expect("position")
                                .raw();
                            out.closest_lsb =
                                out.closest_lsb.min((x - lo).abs().min((x - hi).abs()));
                            (gold, x >= lo && x <= hi)
                        })
                        .collect()
                });
                let gx = inside[0].iter().filter(|v| v.0).count() as u64;
                let gy = inside[1].iter().filter(|v| v.0).count() as u64;
                out.samples += gx * gy;
                for &(gxi, fxi) in &inside[0] {
                    for &(gyi, fyi) in &inside[1] {
                        if (gxi && gyi) != (fxi && fyi) {
                            view_exceptions += 1;
                        }
                    }
                }
            }
        }
        out.per_view
            .push(format!("{spec} {e:?}: {view_exceptions}"));
        out.exceptions += view_exceptions;
    }
    out
}

/// The host broadcasts golden's per-slice ray ranges, so the array samples
/// the same rays as golden by construction. But a PE forms the ray's
/// position in fixed point (`a`, `t` rounded into `position` / `step`); a
/// ray whose fixed-point position lies on the other side of the slice
/// extent `[-0.5, n - 0.5]` than golden's f64 position is an "edge
/// exception": the hardware samples (clamped) where the decision was made
/// in float. With the default formats they must be fewer than 1 in 10^4
/// samples. So that the count is known to detect anything, a position
/// format with only 4 fraction bits must produce some.
#[test]
fn edge_exceptions_are_rare() {
    let cfg = PipelineConfig::default();
    let c = count_edge_exceptions(&cfg);
    eprintln!(
        "edge exceptions: {} of {} samples; closest fixed-point position to a slice edge: {} LSB\n  {}",
        c.exceptions,
        c.samples,
        c.closest_lsb,
        c.per_view.join("\n  ")
    );
    assert!(
        c.samples > 100_000,
        "{} samples is too few to judge",
        c.samples
    );
    assert!(
        (c.exceptions as f64) < c.samples as f64 * 1e-4,
        "{} edge exceptions in {} samples:\n  {}",
        c.exceptions,
        c.samples,
        c.per_view.join("\n  ")
    );

    let coarse = PipelineConfig {
        position: Format::new(20, 4, true, Quant::Rnd, Overflow::Sat).expect("format"),
        ..cfg
    };
    let c = count_edge_exceptions(&coarse);
    eprintln!(
        "edge exceptions with 4 position fraction bits: {} of {}",
        c.exceptions, c.samples
    );
    assert!(c.exceptions > 0, "the count cannot see rounding errors");
}

// ---------------------------------------------------------------------------
// 8. Bad configurations
// ---------------------------------------------------------------------------

#[track_caller]
fn assert_one_line(msg: &str, needle: &str) {
    assert!(!msg.contains('\n'), "not one line: {msg:?}");
    assert!(msg.contains(needle), "{msg:?} does not name {needle:?}");
}

/// The library refuses, with one-line errors and without panicking, a
/// position format too narrow for the volume and an array of no PEs.
#[test]
fn bad_configurations_are_refused_by_the_library() {
    let s = subject("sphere:24");
    let prep = prepare(
        &s,
        Eye {
            axis: 2,
            positive: false,
            d: 6.0,
            off: [0.0, 0.0],
        },
    );

    // fixed<10,4>: coordinates up to 7, the volume is 24 wide. The format is
    // valid on its own; only the volume makes it too narrow.
    let narrow = PipelineConfig {
        position: Format::new(10, 6, true, Quant::Rnd, Overflow::Sat).expect("format"),
        pes: 4,
        ..PipelineConfig::default()
    };
    assert!(narrow.validate().is_ok(), "the format alone is valid");
    let e = narrow.check_extent(24).expect_err("24 > 7");
    assert_one_line(&e.to_string(), "position");
    assert_eq!(e.field(), Some("position"));
    let e = Array::new(&narrow, &s.vol, &s.lut, &prep.view, Tracer::disabled())
        .err()
        .expect("Array::new refuses a position format narrower than the volume");
    assert_eq!(
        e.to_string(),
        "position holds coordinates up to 7, below the volume extent 24"
    );

    let none = config(0);
    let e = none.validate().expect_err("no PEs");
    assert_one_line(&e.to_string(), "pes");
    assert_eq!(e.field(), Some("pes"));
    let e = Array::new(&none, &s.vol, &s.lut, &prep.view, Tracer::disabled())
        .err()
        .expect("Array::new refuses zero PEs");
    assert_one_line(&e.to_string(), "pes = 0");
    let e = pipeline::run_frame(&none, &s.vol, &s.lut, &prep.view, Tracer::disabled())
        .expect_err("run_frame refuses zero PEs");
    assert_one_line(&e.to_string(), "pes = 0");
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
