//! The waveform: the VCD reads back as the model's results, and tracing
//! does not perturb the model.

use std::path::Path;

use golden::methods::Method;
use pipeline::array::Frame;
use pipeline::probes::Stage;
use waves::{PeFilter, Trace, TraceConfig, Tracer, TIME_UNITS_PER_CYCLE};

use super::{prepare, run, run_with, Eye};
use crate::chip::{check_gtkw, config, signature, subject};

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
    // broadcast), per PE eleven of the datapath and accumulators and the
    // ports (two links of 16, the host's 7): the default groups (ctrl,
    // ports, datapath, acc); the registers are off by default.
    assert_eq!(
        lines,
        1 + 10 + 4 * (11 + 2 * 16 + 7),
        "signals in the .gtkw"
    );
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
