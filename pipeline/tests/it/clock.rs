//! The one clock: the datapath's latency moves cycles, never bits; the
//! whole-slice sampling path counts exactly what the clocked path ticks,
//! stalls included; a stage's step is a function of the PE's own state and
//! its links only.

use glam::DVec3;
use golden::camera::Camera;
use golden::render::Prepared;
use pipeline::array::{Array, Frame, Links};
use pipeline::config::{Order, PipelineConfig};
use pipeline::datapath::Datapath;
use pipeline::pe::{Pe, Ports, StepError};
use pipeline::stages::passes::PassBus;
use waves::Tracer;

use crate::chip::{signature, subject, Subject};
use crate::scenes::up_for;

fn view(s: &Subject, eye: DVec3, fov: f64) -> Prepared {
    let centre = DVec3::from_array(s.vol.center_world());
    let cam = Camera::new(eye, centre, up_for(centre - eye), fov, 40, 36).expect("camera");
    Prepared::new(&s.vol, &cam).expect("view")
}

fn run(cfg: &PipelineConfig, s: &Subject, prep: &Prepared, clocked: Option<u64>) -> Frame {
    run_with(cfg, s, prep, clocked, false)
}

/// [`run`], pre-integrated when `preint` (its rays carry their previous
/// samples over the links).
fn run_with(
    cfg: &PipelineConfig,
    s: &Subject,
    prep: &Prepared,
    clocked: Option<u64>,
    preint: bool,
) -> Frame {
    let mut a = Array::new(cfg, &s.vol, &s.lut, &prep.view, Tracer::disabled()).expect("array");
    if preint {
        let pt = golden::preint::PreTable::new(&s.lut);
        a.set_units(&[&pt], &prep.view, s.vol.kind().bits(), false)
            .expect("pre-integration");
    }
    if let Some(seed) = clocked {
        let n = usize::from(cfg.pes);
        // A rotation of the natural order: any order must give the same.
        a.set_step_order((0..n).map(|k| (k + seed as usize) % n).collect());
        a.set_clocked(true);
    }
    a.run(&prep.view).expect("frame")
}

/// Eyes on `ml:20` from outside, at the face and inside, and on a
/// `sphere:6`, whose slices take fewer cycles than the datapath is deep
/// once its six columns are spread over four or more PEs, so rows stall.
fn cases() -> Vec<(Subject, DVec3, f64)> {
    let mut out = Vec::new();
    let s = |spec| subject(spec);
    let c = 9.5;
    for (eye, fov) in [
        (DVec3::new(c + 0.7, c - 0.4, -12.0), 70.0),
        (DVec3::new(c + 0.3, c + 0.2, -0.6), 100.0),
        (DVec3::new(c - 1.1, c + 0.9, c - 2.3), 90.0),
    ] {
        out.push((s("ml:20"), eye, fov));
    }
    out.push((s("sphere:6"), DVec3::new(3.5, 3.2, -5.0), 60.0));
    out
}

#[test]
fn latency_moves_cycles_not_bits() {
    let (mut stalled, mut drained, mut waited) = (0, 0, 0);
    for order in [Order::BackToFront, Order::FrontToBack] {
        for (s, eye, fov) in cases() {
            let s = &s;
            let prep = view(s, eye, fov);
            for p in [1u16, 4, 8, 16] {
                let cfg = |latency: u16| PipelineConfig {
                    pes: p,
                    order,
                    datapath_latency: latency,
                    ..PipelineConfig::default()
                };
                let ctx = format!("{order:?}, eye {eye}, P = {p}");
                let base = run(&cfg(1), s, &prep, None);
                let bs = base.stages;
                // Written back the cycle after issue: nothing to wait for.
                assert_eq!((bs.stall, bs.drain), (0, 0), "{ctx}: {bs:?}");
                assert!(base.pes.iter().all(|c| c.waits == 0), "{ctx}");
                let mut last = base.cycles;
                for latency in [2u16, 26, 64] {
                    let f = run(&cfg(latency), s, &prep, None);
                    let clocked = run(&cfg(latency), s, &prep, Some(u64::from(latency)));
                    let ctx = format!("{ctx}, latency {latency}");
                    assert!(
                        signature(&f) == signature(&clocked),
                        "{ctx}: the whole-slice path differs from the clocked one \
                         ({:?} vs {:?})",
                        f.stages,
                        clocked.stages
                    );
                    assert_eq!(f.raw, base.raw, "{ctx}: raw words changed");
                    assert_eq!(f.quant, base.quant, "{ctx}: quantisation events");
                    assert_eq!(f.samples_per_slice, base.samples_per_slice, "{ctx}");
                    let st = f.stages;
                    assert_eq!(
                        (st.sample, st.merge, st.split, st.fold, st.readout, st.skip),
                        (bs.sample, bs.merge, bs.split, bs.fold, bs.readout, bs.skip),
                        "{ctx}: only waiting may grow"
                    );
                    // A row held back for a ray in the datapath waits less
                    // (or not at all) for its plan's runs.
                    assert!(st.plan <= bs.plan, "{ctx}: {st:?}");
                    assert_eq!(
                        f.cycles + (bs.plan - st.plan),
                        base.cycles + st.drain + st.stall + st.migrate - bs.migrate,
                        "{ctx}: {st:?}"
                    );
                    assert!(f.cycles >= last, "{ctx}: a deeper datapath ran faster");
                    last = f.cycles;
                    // A drain waits at most for one sample's write-back.
                    let drains = f.merges + 1 + u64::from(order == Order::FrontToBack) * f.merges;
                    assert!(st.drain <= drains * u64::from(latency), "{ctx}: {st:?}");
                    for c in &f.pes {
                        assert_eq!(c.stalls, st.stall, "{ctx}: {c:?}");
                    }
                    stalled += u64::from(st.stall > 0);
                    drained += u64::from(st.drain > 0);
                    waited += f.pes.iter().map(|c| c.waits).sum::<u64>();
                }
            }
        }
    }
    eprintln!("{stalled} runs stalled, {drained} drained, {waited} PE-cycles of waiting rays");
    assert!(stalled > 0, "no view stalled a row: the hazard is untested");
    assert!(drained > 0, "no frame drained its datapath");
}

/// The derived latency is the depth of the module `ercube rtl` emits
/// (`hw::pipeline_rtl` on the configuration's schedule) at narrow,
/// default and wide widths, both orders, one operator a stage and
/// pipelined to a clock on both families; a stated latency is kept.
#[test]
fn derived_latency_is_the_emitted_modules_depth() {
    use pipeline::cost::Target;
    use pipeline::hw::pipeline_rtl::emit_scheduled;
    let widths = [
        ("default", PipelineConfig::default()),
        (
            "narrow",
            PipelineConfig::from_toml_str(crate::cost::NARROW).expect("narrow"),
        ),
        (
            "wide",
            PipelineConfig::from_toml_str(crate::cost::WIDE).expect("wide"),
        ),
    ];
    let clocks = [
        (Target::Ecp5, 0),
        (Target::Ecp5, 40),
        (Target::Ecp5, 80),
        (Target::Ice40, 20),
    ];
    let mut depths = Vec::new();
    for (name, base) in &widths {
        for order in [Order::BackToFront, Order::FrontToBack] {
            for (family, mhz) in clocks {
                let cfg = PipelineConfig {
                    order,
                    target_family: family,
                    target_mhz: mhz,
                    ..*base
                };
                cfg.validate().expect("a reachable clock");
                let g = pipeline::hw::sample::plain(&cfg);
                let sch = pipeline::cost::latency::sample_schedule(&cfg);
                let m = emit_scheduled(&g, &sch, "ercube_sample").expect("emits");
                let latency = pipeline::cost::datapath_latency(&cfg);
                assert_eq!(
                    latency, m.depth,
                    "{name} {order:?} {family:?} {mhz} MHz: the model's latency"
                );
                if mhz == 0 {
                    // One operator a stage: the schedule the module
                    // documents.
                    assert_eq!(latency, pipeline::hw::schedule::schedule(&g).depth);
                }
                // The pre-integrated sample: the composed module's depth
                // (one operator a stage; a clock's schedule packs the
                // colour dividers' stages, which the divider's Verilog
                // does not emit).
                if mhz > 0 {
                    depths.push((name, order, family, mhz, latency));
                    continue;
                }
                let pre = pipeline::hw::compose::sample(
                    &cfg,
                    pipeline::hw::compose::Units {
                        preint: true,
                        ..Default::default()
                    },
                );
                let sch = pipeline::cost::latency::graph_schedule(&cfg, &pre);
                let m = emit_scheduled(&pre, &sch, "ercube_sample").expect("emits");
                assert_eq!(
                    pipeline::cost::preint_latency(&cfg),
                    m.depth,
                    "{name} {order:?} {family:?} {mhz} MHz: the pre-integrated latency"
                );
                assert!(m.depth > latency, "{name}: the unit deepens it");
                depths.push((name, order, family, mhz, latency));
            }
        }
    }
    eprintln!("{depths:?}");
    // The default widths: 35 clocks back to front, 36 front to back.
    assert_eq!(depths[0].4, 35);
    assert_eq!(depths[4].4, 36);
    // A slow clock packs stages: fewer than one operator a stage.
    for group in depths.chunks(clocks.len()) {
        assert!(group[1].4 < group[0].4, "{group:?}");
    }
    let cfg = PipelineConfig::default();
    let set = PipelineConfig {
        datapath_latency: 7,
        ..cfg
    };
    assert_eq!(pipeline::cost::datapath_latency(&set), 7);
    let bad = PipelineConfig {
        datapath_latency: 257,
        ..cfg
    };
    let e = bad.validate().unwrap_err().to_string();
    assert!(e.contains("datapath_latency") && e.contains("257"), "{e}");
}

/// `target_mhz` is checked in one line: its range, a family without a
/// delay model, a clock no schedule reaches.
#[test]
fn target_mhz_is_validated() {
    use pipeline::cost::Target;
    let d = PipelineConfig::default();
    let cases = [
        (Target::Ecp5, 1001, "outside 0..=1000"),
        (Target::Xc7, 50, "delay model"),
        (Target::Ecp5, 900, "no schedule reaches"),
        (Target::Ice40, 400, "no schedule reaches"),
    ];
    for (family, mhz, needle) in cases {
        let c = PipelineConfig {
            target_family: family,
            target_mhz: mhz,
            ..d
        };
        let e = c.validate().unwrap_err().to_string();
        assert!(
            e.contains(needle) && !e.contains('\n'),
            "{family:?} {mhz}: {e}"
        );
        assert!(e.contains("target_mhz"), "{e}");
    }
    let text = "target_family = \"ice40\"\ntarget_mhz = 30\n";
    let c = PipelineConfig::from_toml_str(text).expect("reads");
    assert_eq!((c.target_family, c.target_mhz), (Target::Ice40, 30));
    let back = PipelineConfig::from_toml_str(&c.to_toml()).expect("round trip");
    assert_eq!(back, c);
    let e = PipelineConfig::from_toml_str("target_family = \"xc9\"\n").unwrap_err();
    assert!(!e.to_string().contains('\n'), "{e}");
}

/// Every stage's step has the shape of a clocked process: the PE's own
/// state, the controller's broadcast and the links (its neighbours' port
/// outputs of the last cycle, by value) in; its own port registers out
/// (written in place), each stage's as a named [`Step`](pipeline::stages::Step). The
/// types are the check: these coercions compile only while no step takes
/// anything that could reach another PE (the clock's rustdoc holds a
/// `compile_fail` example of a step that tries).
#[test]
fn steps_see_only_their_own_state_and_links() {
    type PassStep<P> = for<'l, 'o> fn(
        &mut Pe,
        &P,
        &Datapath,
        &PassBus,
        Links<'l>,
        &'o mut Ports,
    ) -> Result<(), StepError>;
    use pipeline::stages::{fold::FoldGrids, merge::MergePass, split::SplitPass};
    let merge: PassStep<MergePass> = Pe::pass_step;
    let split: PassStep<SplitPass> = Pe::pass_step;
    let fold: PassStep<FoldGrids> = Pe::pass_step;
    let sparse: PassStep<FoldGrids> = Pe::pass_step_sparse;
    type SampleStep = for<'l, 'o> fn(
        &mut Pe,
        &Datapath,
        &pipeline::stages::sample::SampleBus,
        Links<'l>,
        usize,
        &'o mut Ports,
    ) -> Result<(), StepError>;
    let sample: SampleStep = Pe::sample_step;
    let stall: fn(&mut Pe, &Datapath, &mut Ports) = Pe::stall_step;
    let readout: fn(&mut Pe, &mut Ports) = Pe::readout_step;
    // `Links` is two shared views of port registers: copyable, so it
    // cannot hold anything mutable.
    fn shared<T: Copy + Send + Sync>() {}
    shared::<Links<'static>>();
    let steps = [
        merge as usize,
        split as usize,
        fold as usize,
        sparse as usize,
        sample as usize,
        stall as usize,
        readout as usize,
    ];
    assert!(steps.iter().all(|&f| f != 0));
    // Each stage's cycle is one of these named steps, the only thing the
    // clock ticks.
    use pipeline::stages::{boundary, migrate::LinkStep, readout::StreamStep};
    use pipeline::stages::{sample, Idle, Step};
    fn step<S: Step>() {}
    step::<sample::RowStep<'static>>();
    step::<sample::Hold<'static>>();
    step::<sample::Stall<'static>>();
    step::<boundary::PassStep<'static, MergePass<'static>>>();
    step::<boundary::PassStep<'static, SplitPass<'static>>>();
    step::<boundary::PassStep<'static, FoldGrids<'static>>>();
    step::<LinkStep<'static, fn(i64) -> usize>>();
    step::<StreamStep>();
    step::<Idle>();
}

/// The untraced dense merge (each PE's whole merge at once, in parallel,
/// with its neighbours' edge rays known before the pass) gives the
/// clocked merge's bits, cycles and counters, for PE counts from one to
/// sixteen and the mappings whose passes migrate rays home first.
#[test]
fn untraced_merges_equal_clocked_merges() {
    use pipeline::config::Mapping;
    let mut merges = 0;
    for (s, eye, fov) in cases() {
        let prep = view(&s, eye, fov);
        for p in [1u16, 3, 8, 16] {
            for mapping in [Mapping::Blocks, Mapping::Interleave] {
                let cfg = PipelineConfig {
                    pes: p,
                    mapping,
                    ..PipelineConfig::default()
                };
                let whole = run(&cfg, &s, &prep, None);
                let clocked = run(&cfg, &s, &prep, Some(1));
                assert!(
                    signature(&whole) == signature(&clocked),
                    "eye {eye}, P = {p}, {mapping:?}: the untraced merge differs"
                );
                merges += whole.merges;
            }
        }
    }
    assert!(merges > 0, "no view merged");
}

/// The untraced migration (each link queue's departures worked out, not
/// ticked) gives the clocked migration's bits, cycles and counters, waits
/// and link queues included: along a line and around a ring, with the
/// links sending every row or only the non-empty ones, in both orders,
/// with write-backs that make rays wait to leave, and pre-integrated
/// (the rays carry their previous samples).
#[test]
fn untraced_migrations_equal_clocked_migrations() {
    use pipeline::config::Mapping;
    let (mut moved, mut waited, mut queued) = (0, 0, 0);
    for (s, eye, fov) in cases() {
        let prep = view(&s, eye, fov);
        for (order, preint) in [
            (Order::BackToFront, false),
            (Order::FrontToBack, false),
            (Order::BackToFront, true),
            (Order::FrontToBack, true),
        ] {
            for mapping in [Mapping::Blocks, Mapping::Interleave, Mapping::Cyclic] {
                for (p, latency, sparse) in [(3u16, 1u16, false), (16, 26, true), (8, 64, false)] {
                    let cfg = PipelineConfig {
                        pes: p,
                        order,
                        mapping,
                        datapath_latency: latency,
                        link_skip_empty: sparse,
                        ..PipelineConfig::default()
                    };
                    let whole = run_with(&cfg, &s, &prep, None, preint);
                    let clocked = run_with(&cfg, &s, &prep, Some(2), preint);
                    assert!(
                        signature(&whole) == signature(&clocked),
                        "eye {eye}, {order:?}, {mapping:?}, P = {p}, latency {latency}, \
                         sparse {sparse}, preint {preint}: the untraced migration differs \
                         ({:?} vs {:?})",
                        whole.stages,
                        clocked.stages
                    );
                    moved += whole.stages.migrate;
                    waited += whole.pes.iter().map(|c| c.waits).sum::<u64>();
                    queued += whole.pes.iter().map(|c| c.link_queue).sum::<u64>();
                }
            }
        }
    }
    assert!(moved > 0 && queued > 0, "no ray migrated or queued");
    assert!(waited > 0, "no ray waited to leave: the waits are untested");
}
