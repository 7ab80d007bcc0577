//! A frame stepped one clock at a time from outside ([`Stepper`]): every
//! cycle it hands over holds, for the controller and every PE, exactly
//! the values the traced frame's VCD shows for that cycle; the cycles run
//! 1, 2, ... to the frame's count; the stepped frame ends with the bits,
//! cycles and counters of the untraced one, stepped to the end or finished
//! early; and dropping a stepper mid-frame stops the frame and returns.

use std::sync::mpsc::channel;

use glam::DVec3;
use golden::camera::Camera;
use golden::render::Prepared;
use pipeline::config::{Order, PipelineConfig};
use pipeline::pe::Command;
use pipeline::probes::GROUPS;
use pipeline::stepper::{Stepper, Tap};
use pipeline::{Frame, FrameRun, RunError};
use waves::{Trace, TraceConfig, Tracer};

use crate::chip::{config, signature, subject, Subject};
use crate::scenes::up_for;

/// `ml:24` seen from close (two merges) by a 32x32 camera.
fn scene() -> (Subject, Prepared) {
    let s = subject("ml:24");
    let c = (s.n as f64 - 1.0) / 2.0;
    let eye = DVec3::new(c + 1.6, c - 0.8, -6.0);
    let centre = DVec3::from_array(s.vol.center_world());
    let cam = Camera::new(eye, centre, up_for(centre - eye), 60.0, 32, 32).expect("camera");
    let prep = Prepared::new(&s.vol, &cam).expect("view");
    assert!(prep.view.regions().count() >= 2, "the view must merge");
    (s, prep)
}

/// The frame of `s` through `prep`'s view in `cfg`, traced by `tracer`
/// and stepped through `tap` when given.
fn frame(
    cfg: &PipelineConfig,
    (s, prep): (&Subject, &Prepared),
    tracer: Tracer,
    tap: Option<Tap>,
) -> Result<Frame, RunError> {
    let run = FrameRun::new(cfg, &s.lut, &s.vol, &prep.view).trace(tracer);
    match tap {
        Some(t) => run.tap(t),
        None => run,
    }
    .run()
}

/// A stepper over the frame of `ml:24` in `cfg`.
fn stepper(cfg: PipelineConfig) -> Stepper<Result<Frame, RunError>> {
    Stepper::start(move |tap| {
        let (s, prep) = scene();
        frame(&cfg, (&s, &prep), Tracer::disabled(), Some(tap))
    })
    .expect("the worker starts")
}

#[test]
fn every_stepped_cycle_holds_the_vcds_values() {
    let dir = tempfile::tempdir().expect("temporary directory");
    let vcd = dir.path().join("all.vcd");
    let cfg = config(4);
    let (s, prep) = scene();
    let tc = TraceConfig::new(&vcd).with_groups(GROUPS.iter().map(|g| g.name));
    let traced = frame(&cfg, (&s, &prep), Tracer::new(tc).expect("tracer"), None).expect("traced");
    let trace = Trace::read(&vcd).expect("the VCD reads");
    let at = |name: &str, c: u64| {
        trace
            .signal(name)
            .unwrap_or_else(|| panic!("{name} is not in the VCD"))
            .u64_at_cycle(c)
    };
    let mut st = stepper(cfg);
    let (mut n, mut values, mut commands, mut busy) = (0u64, 0u64, 0usize, 0u64);
    while let Some(c) = st.step() {
        n += 1;
        assert_eq!(c.number, n, "cycles count from 1, one per step");
        commands += c.commands.len();
        for s in c.signals.ctrl(&c.ctrl) {
            assert_eq!(
                Some(s.value),
                at(&format!("top.ctrl.{}", s.name), n),
                "cycle {n}: ctrl.{}",
                s.name
            );
            values += 1;
        }
        assert_eq!(c.pes.len(), 4);
        for (k, pe) in c.pes.iter().enumerate() {
            for s in c.signals.pe(pe) {
                let name = match s.scope {
                    "" => format!("top.pe_{k}.{}", s.name),
                    scope => format!("top.pe_{k}.{scope}.{}", s.name),
                };
                assert_eq!(Some(s.value), at(&name, n), "cycle {n}: {name}");
                assert!(
                    s.width == 64 || s.value >> s.width == 0,
                    "{name} wider than {}",
                    s.width
                );
                busy += u64::from(s.name == "busy" && s.value == 1);
                values += 1;
            }
        }
    }
    assert!(st.done() && st.step().is_none());
    assert_eq!(
        st.current().map(|c| c.number),
        Some(n),
        "the last cycle stays"
    );
    let stepped = st.finish().expect("no panic").expect("the frame runs");
    eprintln!("{n} cycles, {values} values equal to the VCD's, {commands} commands, {busy} busy PE-cycles");
    assert_eq!(
        n, traced.cycles,
        "as many steps as the traced frame's cycles"
    );
    assert!(busy > 0 && commands > 0, "an idle frame proves nothing");
    assert_eq!(
        signature(&stepped),
        signature(&traced),
        "stepping changed the frame"
    );
    let untraced = frame(&cfg, (&s, &prep), Tracer::disabled(), None).expect("untraced");
    assert_eq!(signature(&stepped), signature(&untraced));
}

/// Front to back (splits and a fold), finished after some cycles: the
/// frame the untraced path renders; the commands before the cycles show
/// the schedule (a slice begins, rows are planned, the fold runs).
#[test]
fn a_front_to_back_frame_finished_early_is_the_untraced_frame() {
    let cfg = PipelineConfig {
        order: Order::FrontToBack,
        ..config(3)
    };
    let (s, prep) = scene();
    let untraced = frame(&cfg, (&s, &prep), Tracer::disabled(), None).expect("untraced");
    let mut st = stepper(cfg);
    let mut seen = Vec::new();
    for _ in 0..2000 {
        let c = st.step().expect("the frame is longer");
        seen.extend(c.commands.iter().map(Command::name));
    }
    assert!(
        seen.contains(&"begin_slice") && seen.contains(&"plan_rows"),
        "{seen:?}"
    );
    let stepped = st.finish().expect("no panic").expect("the frame runs");
    assert_eq!(signature(&stepped), signature(&untraced));
    // Stepped to the end, the fold is among the commands.
    let mut st = stepper(cfg);
    let mut folds = 0;
    while let Some(c) = st.step() {
        folds += c
            .commands
            .iter()
            .filter(|c| **c == Command::BeginFold)
            .count();
    }
    assert!(folds > 0, "a front-to-back frame of two regions folds");
}

/// Dropped mid-frame, the stepper stops the frame (its tick fails with
/// `Stopped`) and joins the worker before the drop returns.
#[test]
fn dropping_a_stepper_mid_frame_stops_the_frame() {
    let (tx, rx) = channel();
    let mut st = Stepper::start(move |tap| {
        let (s, prep) = scene();
        let r = frame(&config(4), (&s, &prep), Tracer::disabled(), Some(tap));
        tx.send(r.err().map(|e| e.to_string()))
            .expect("the test listens");
    })
    .expect("the worker starts");
    for _ in 0..50 {
        st.step().expect("the frame is longer");
    }
    drop(st);
    let ended = rx
        .try_recv()
        .expect("the worker ended before the drop returned");
    assert_eq!(
        ended.as_deref(),
        Some("the frame was stopped before its end (its stepper was dropped)")
    );
    // Dropped before its first cycle too.
    let st = stepper(config(2));
    drop(st);
}
