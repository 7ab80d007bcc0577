//! The volume-of-interest stage (`pipeline::voi`) against golden's VOI:
//! every pixel channel within the derived bound over random volumes,
//! views, tables, orders, PE counts and VOIs (box and sphere, inside and
//! outside, with and without a ramp, scales 0, 0.5 and 2); within one grey
//! level at the default widths on brainsmall and the checkerboard; scale 1
//! renders as no VOI, bit for bit; the clocked and whole-slice paths agree;
//! a constant that does not fit its format is refused in one line.

use glam::DVec3;
use golden::camera::Camera;
use golden::render::Prepared;
use golden::tf::{Lut, TransferFunction};
use golden::voi::{Shape, Voi};
use golden::volume::{Volume, DEFAULT_MEMORY_LIMIT};
use pipeline::array::{Array, Frame};
use pipeline::bound::{
    region_slices, voi_error_bound, voi_ftb_error_bound, BoundInputs, VoiInputs,
};
use pipeline::config::{Order, PipelineConfig};
use proptest::prelude::*;
use waves::{Trace, TraceConfig, Tracer};

use crate::chip::signature;
use crate::scenes::{checker128_views, eye_for, max_diff, small_views, tf};

/// Golden `er` or `er-ftb` (by `cfg.order`), unskipped, with `voi`.
fn golden_voi(cfg: &PipelineConfig, prep: &Prepared, lut: &Lut, voi: Voi) -> golden::render::Frame {
    crate::chip::golden_twin(cfg, prep, lut, |o| o.voi = Some(voi))
}

/// The pipeline's frame with `voi` (none: without); `clocked` steps the
/// sampling stage cycle by cycle.
fn pipe_voi(
    cfg: &PipelineConfig,
    vol: &Volume,
    lut: &Lut,
    prep: &Prepared,
    voi: Option<&Voi>,
    clocked: bool,
) -> Result<Frame, pipeline::RunError> {
    pipe_traced(cfg, vol, lut, prep, voi, clocked, Tracer::disabled())
}

/// [`pipe_voi`] traced by `tracer`.
fn pipe_traced(
    cfg: &PipelineConfig,
    vol: &Volume,
    lut: &Lut,
    prep: &Prepared,
    voi: Option<&Voi>,
    clocked: bool,
    tracer: Tracer,
) -> Result<Frame, pipeline::RunError> {
    let mut a = Array::new(cfg, vol, lut, &prep.view, tracer)?;
    if let Some(v) = voi {
        a.set_units(&[v], &prep.view, vol.kind().bits(), false)?;
    }
    a.set_clocked(clocked);
    a.run(&prep.view)
}

/// One random case.
struct VoiCase {
    vol: Volume,
    tf: TransferFunction,
    eye: DVec3,
    up: DVec3,
    cfg: PipelineConfig,
    voi: Voi,
}

impl std::fmt::Debug for VoiCase {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("VoiCase")
            .field("dims", &self.vol.dims())
            .field("tf", &self.tf.points)
            .field("eye", &self.eye)
            .field("cfg.pes", &self.cfg.pes)
            .field("cfg.order", &self.cfg.order)
            .field("voi", &self.voi)
            .finish()
    }
}

/// The derived bound of `cfg`'s order for a frame with `voi`.
fn bound(cfg: &PipelineConfig, vol: &Volume, lut: &Lut, prep: &Prepared, voi: &Voi) -> f64 {
    let d = BoundInputs::measure(vol, lut, &prep.view).expect("ER layout");
    let v = VoiInputs::measure(cfg, &d, &prep.view, lut, voi).expect("VOI");
    match cfg.order {
        Order::BackToFront => voi_error_bound(cfg, &d, None, &v),
        Order::FrontToBack => {
            voi_ftb_error_bound(cfg, &d, &region_slices(&prep.view).unwrap(), None, &v)
        }
    }
}

/// Runs a case; returns (image difference, bound).
fn run_case(c: &VoiCase) -> Result<(f64, f64), TestCaseError> {
    let prep = crate::scenes::centred_view(&c.vol, c.eye, c.up, 50.0, 24, 20)
        .ok_or_else(|| TestCaseError::reject("no view"))?;
    let lut = Lut::for_bits(&c.tf, c.cfg.table_entries as usize, c.vol.kind().bits());
    let d = BoundInputs::measure(&c.vol, &lut, &prep.view).expect("ER layout");
    if d.ds_max >= c.cfg.path.max_value().to_f64() {
        return Err(TestCaseError::reject("ds_max beyond the path format"));
    }
    let golden = golden_voi(&c.cfg, &prep, &lut, c.voi);
    let frame = pipe_voi(&c.cfg, &c.vol, &lut, &prep, Some(&c.voi), false)
        .map_err(|e| TestCaseError::fail(e.to_string()))?;
    let image = golden::warp::warp(&prep.view, &frame.baseplane);
    let b = bound(&c.cfg, &c.vol, &lut, &prep, &c.voi);
    let gbase = &golden.slice.as_ref().unwrap().baseplane;
    let d_base = max_diff(&frame.baseplane.data, &gbase.data);
    let d_img = max_diff(&image.data, &golden.image.data);
    prop_assert!(d_base <= b, "baseplane differs by {d_base}, bound {b}");
    prop_assert!(d_img <= b, "image differs by {d_img}, bound {b}");
    Ok((d_img, b))
}

/// A VOI of `shape` (0 box, 1 sphere) in a volume of `dims` at spacing 1,
/// from unit-cube coordinates `p` and size `s`.
fn make_voi(
    dims: [usize; 3],
    sphere: bool,
    p: [f64; 3],
    s: f64,
    outside: bool,
    ramp: f64,
    scale: f64,
) -> Voi {
    let n = dims.map(|d| d as f64);
    let c = [p[0] * n[0], p[1] * n[1], p[2] * n[2]];
    let shape = if sphere {
        Shape::Sphere {
            centre: c,
            radius: s * n[0].min(n[1]).min(n[2]),
        }
    } else {
        let h = n.map(|d| s * d / 2.0);
        Shape::Box {
            lo: [c[0] - h[0], c[1] - h[1], c[2] - h[2]],
            hi: [c[0] + h[0], c[1] + h[1], c[2] + h[2]],
        }
    };
    Voi {
        shape,
        scale,
        outside,
        ramp,
    }
}

fn cases() -> impl Strategy<Value = VoiCase> {
    let dims = [8usize..=28, 8usize..=28, 8usize..=28];
    let eye = (0usize..6, 0.5..50.0f64, (-0.5..1.5f64, -0.5..1.5f64));
    let voi = (
        any::<bool>(),
        [0.1..0.9f64, 0.1..0.9f64, 0.1..0.9f64],
        0.15..0.6f64,
        any::<bool>(),
        prop_oneof![Just(0.0), 0.5..6.0f64],
        prop_oneof![Just(0.0), Just(0.5), Just(2.0)],
    );
    (
        dims,
        crate::scenes::blob_strategy(),
        0u16..30,
        any::<u64>(),
        crate::scenes::tf_points_strategy(),
        eye,
        voi,
        (1u16..=8, any::<bool>()),
    )
        .prop_filter_map(
            "the case must validate",
            |(dims, blobs, noise, seed, points, (side, dist, off), v, (pes, ftb))| {
                let cfg = PipelineConfig {
                    pes,
                    order: if ftb {
                        Order::FrontToBack
                    } else {
                        Order::BackToFront
                    },
                    ..PipelineConfig::default()
                };
                cfg.validate().ok()?;
                let (sphere, p, s, outside, ramp, scale) = v;
                let vol = crate::scenes::blobs(dims, &blobs, noise, seed);
                let (eye, up) = eye_for(dims, side, dist, off);
                Some(VoiCase {
                    vol,
                    tf: tf(&points),
                    eye,
                    up,
                    cfg,
                    voi: make_voi(dims, sphere, p, s, outside, ramp, scale),
                })
            },
        )
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(128))]

    /// Random small volumes, eyes on all sides, tables, both orders, PE
    /// counts and VOIs: the derived bound holds for every channel.
    #[test]
    fn voi_pipeline_matches_golden_within_the_derived_bound(c in cases()) {
        run_case(&c)?;
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(2048))]

    /// The long run: `cargo test --release -p pipeline --test it -- --ignored voi_long`.
    #[test]
    #[ignore = "long run: 2048 cases"]
    fn voi_long_run(c in cases()) {
        run_case(&c)?;
    }
}

/// The bound means something with a ramp on smooth data: well under the
/// range, and the measured difference inside it.
#[test]
fn voi_bound_is_informative_on_smooth_data() {
    let vol = crate::scenes::blobs([24, 20, 28], &[(0.5, 0.5, 0.5, 0.35, 250.0)], 0, 1);
    let tf = tf(&[(20.0, [1.0, 0.6, 0.2, 0.0]), (200.0, [1.0, 1.0, 1.0, 0.6])]);
    let c = VoiCase {
        voi: make_voi(vol.dims(), true, [0.5, 0.4, 0.5], 0.3, false, 3.0, 2.0),
        vol,
        tf,
        eye: DVec3::new(11.0, 9.0, -12.0),
        up: DVec3::Y,
        cfg: PipelineConfig::default(),
    };
    let (d, b) = run_case(&c).unwrap();
    eprintln!("smooth VOI case: image {d:.2e}, bound {b:.2e}");
    assert!(b < 0.1, "bound {b} is too loose to mean anything here");
}

/// Max difference in grey levels between the pipeline and golden at the
/// default widths with `voi`.
fn default_width_voi(vol: &Volume, tf: &TransferFunction, cam: &Camera, voi: &Voi) -> f64 {
    let cfg = PipelineConfig::default();
    let lut = Lut::for_bits(tf, cfg.table_entries as usize, vol.kind().bits());
    let prep = Prepared::new(vol, cam).unwrap();
    let g = golden_voi(&cfg, &prep, &lut, *voi);
    let f = pipe_voi(&cfg, vol, &lut, &prep, Some(voi), false).unwrap();
    let image = golden::warp::warp(&prep.view, &f.baseplane);
    golden::metrics::compare(&image, &g.image)
        .unwrap()
        .max_abs_255
}

/// At the default widths with a ramped sphere and a stepped box, within
/// one grey level of golden on the checkerboard's views.
#[test]
fn voi_default_widths_within_one_grey_level_on_the_checkerboard() {
    let scene: golden::scenes::Scene = "checker:128".parse().unwrap();
    let vol = scene.build(DEFAULT_MEMORY_LIMIT).unwrap();
    let vois = [
        make_voi([128; 3], true, [0.5, 0.5, 0.5], 0.3, false, 4.0, 2.0),
        make_voi([128; 3], false, [0.4, 0.5, 0.6], 0.5, true, 0.0, 0.5),
    ];
    for (d, fov, cam) in checker128_views() {
        for v in &vois {
            let m = default_width_voi(&vol, &scene.preset(), &cam, v);
            eprintln!("checker:128 eye z = -{d}, fov {fov}, {v:?}: max {m} /255");
            assert!(m <= 1.0, "max difference {m} grey levels");
        }
    }
}

/// The same on brainsmall.
#[test]
fn voi_default_widths_within_one_grey_level_on_brainsmall() {
    let Some((vol, cam)) = crate::scenes::brainsmall_view() else {
        return;
    };
    let tf = golden::scenes::tf_preset("grey-ramp").unwrap();
    let n = vol.dims();
    let vois = [
        make_voi(n, true, [0.5, 0.5, 0.5], 0.3, false, 4.0, 2.0),
        make_voi(n, false, [0.5, 0.5, 0.5], 0.5, true, 0.0, 0.5),
    ];
    for v in &vois {
        let m = default_width_voi(&vol, &tf, &cam, v);
        eprintln!("brainsmall {v:?}: max {m} /255");
        assert!(m <= 1.0, "max difference {m} grey levels");
    }
}

/// A VOI of scale 1 changes no bit; any VOI takes the same samples and
/// the same sampling, merge and readout cycles, its deeper datapath (the
/// distance's square root, [`pipeline::cost::unit_latency`]) only
/// lengthening what waits for samples in flight (drains, stalls, and
/// migrations of rays still being written back); and the clocked path
/// gives the whole-slice path's bits and counters.
#[test]
fn voi_scale_one_is_none_and_only_the_drains_grow() {
    let (vol, lut, views) = small_views(PipelineConfig::default().table_entries as usize);
    assert!(!views.is_empty());
    for order in [Order::BackToFront, Order::FrontToBack] {
        for pes in [1u16, 3, 4] {
            let cfg = PipelineConfig {
                pes,
                order,
                ..PipelineConfig::default()
            };
            for prep in &views {
                let none = pipe_voi(&cfg, &vol, &lut, prep, None, false).unwrap();
                for (sphere, outside, ramp) in [(true, false, 3.0), (false, true, 0.0)] {
                    let v = make_voi(vol.dims(), sphere, [0.5; 3], 0.3, outside, ramp, 1.0);
                    let one = pipe_voi(&cfg, &vol, &lut, prep, Some(&v), false).unwrap();
                    assert!(one.raw == none.raw, "scale 1 changed the raw words");
                    let v2 = Voi { scale: 2.0, ..v };
                    let two = pipe_voi(&cfg, &vol, &lut, prep, Some(&v2), false).unwrap();
                    assert!(
                        two.raw != none.raw,
                        "scale 2 changed nothing: {order:?}, {pes} PEs, {v2:?}"
                    );
                    let (a, b) = (two.stages, none.stages);
                    assert_eq!(two.samples, none.samples);
                    assert_eq!(
                        (a.sample, a.merge, a.readout, a.split, a.fold),
                        (b.sample, b.merge, b.readout, b.split, b.fold)
                    );
                    let waits =
                        |s: pipeline::array::StageCycles| s.drain + s.stall + s.migrate + s.plan;
                    assert!(two.cycles >= none.cycles);
                    assert_eq!(two.cycles - none.cycles, waits(a) - waits(b));
                    let clocked = pipe_voi(&cfg, &vol, &lut, prep, Some(&v2), true).unwrap();
                    assert!(signature(&clocked) == signature(&two), "clocked differs");
                }
            }
        }
    }
}

/// A ramp so narrow that `spacing / ramp` overflows `voi_axis` is refused
/// in one line naming the field.
#[test]
fn voi_constant_that_does_not_fit_is_refused() {
    let (vol, lut, views) = small_views(PipelineConfig::default().table_entries as usize);
    let v = make_voi(vol.dims(), true, [0.5; 3], 0.3, false, 1e-3, 2.0);
    let cfg = PipelineConfig::default();
    let Err(e) = pipe_voi(&cfg, &vol, &lut, &views[0], Some(&v), false) else {
        panic!("a 1e-3 ramp was accepted");
    };
    let m = e.to_string();
    assert!(m.contains("voi_axis") && !m.contains('\n'), "{m}");
}

/// A trace with a VOI carries the stage's weight and factor registers,
/// which move; one without a VOI has neither.
#[test]
fn voi_waveforms_carry_the_weight_and_factor() {
    let (vol, lut, views) = small_views(PipelineConfig::default().table_entries as usize);
    let cfg = PipelineConfig {
        pes: 4,
        ..PipelineConfig::default()
    };
    let v = make_voi(vol.dims(), true, [0.5; 3], 0.3, false, 3.0, 2.0);
    let dir = tempfile::tempdir().unwrap();
    let names = |with: bool| {
        let p = dir.path().join(format!("v{with}.vcd"));
        let tc = TraceConfig::new(&p).with_groups(["ctrl", "datapath"]);
        let tr = Tracer::new(tc).unwrap();
        pipe_traced(&cfg, &vol, &lut, &views[0], with.then_some(&v), false, tr).unwrap();
        let t = Trace::read(&p).unwrap();
        let set: std::collections::BTreeSet<String> = t.names().map(str::to_owned).collect();
        (t, set)
    };
    let (t, with) = names(true);
    let (_, plain) = names(false);
    for s in ["top.pe_1.voi_weight", "top.pe_1.voi_factor"] {
        assert!(with.contains(s), "{s} missing from the VOI trace");
        assert!(!plain.contains(s), "{s} in the trace without a VOI");
        let changes = t.signal(s).unwrap().changes().len();
        assert!(changes > 2, "{s} changes {changes} times");
    }
}
