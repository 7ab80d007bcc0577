//! The gradient and shading unit (`pipeline::shading`) against golden's
//! shading: every pixel channel within the derived shaded bound over
//! random volumes, views, lights, materials, orders and widths; within one
//! grey level at the default widths on brainsmall and the checkerboard;
//! the clocked and whole-slice paths identical with the unit's port
//! traffic; the unit's latency, counters, waveforms and refusals.

use glam::DVec3;
use golden::camera::Camera;
use golden::render::Prepared;
use golden::shading::{Material, Shade};
use golden::tf::Lut;
use golden::volume::{Volume, DEFAULT_MEMORY_LIMIT};
use pipeline::array::{Array, Frame};
use pipeline::bound::{
    region_slices, shaded_error_bound, shaded_ftb_error_bound, BoundInputs, ShadeInputs,
};
use pipeline::config::{Order, PipelineConfig};
use pipeline::fixed::{Format, Overflow, Quant};
use proptest::prelude::*;
use waves::{Trace, TraceConfig, Tracer};

use crate::chip::{format, signature};
use crate::scenes::{checker128_views, eye_for, max_diff, tf};

/// Golden `er` or `er-ftb` (by `cfg.order`), unskipped, shaded with `sh`.
fn golden_shaded(
    cfg: &PipelineConfig,
    prep: &Prepared,
    lut: &Lut,
    sh: Shade,
) -> golden::render::Frame {
    crate::chip::golden_twin(cfg, prep, lut, |o| o.shade = Some(sh))
}

/// The pipeline's shaded frame; `clocked` steps the sampling stage cycle
/// by cycle in PE order rotated by the given amount.
fn pipe_shaded(
    cfg: &PipelineConfig,
    vol: &Volume,
    lut: &Lut,
    prep: &Prepared,
    sh: &Shade,
    clocked: Option<usize>,
    tracer: Tracer,
) -> Result<Frame, pipeline::RunError> {
    let mut a = Array::new(cfg, vol, lut, &prep.view, tracer)?;
    a.set_units(&[sh], &prep.view, vol.kind().bits(), false)?;
    if let Some(rot) = clocked {
        let n = usize::from(cfg.pes);
        a.set_step_order((0..n).map(|k| (k + rot) % n).collect());
        a.set_clocked(true);
    }
    a.run(&prep.view)
}

/// One random shaded case.
struct ShadeCase {
    vol: Volume,
    tf: golden::tf::TransferFunction,
    eye: DVec3,
    up: DVec3,
    cfg: PipelineConfig,
    shade: Shade,
}

impl std::fmt::Debug for ShadeCase {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("ShadeCase")
            .field("dims", &self.vol.dims())
            .field("tf", &self.tf.points)
            .field("eye", &self.eye)
            .field("cfg", &self.cfg)
            .field("shade", &self.shade)
            .finish()
    }
}

/// Runs a case; returns (image difference, bound).
fn run_case(c: &ShadeCase) -> Result<(f64, f64), TestCaseError> {
    let prep = crate::scenes::centred_view(&c.vol, c.eye, c.up, 50.0, 24, 20)
        .ok_or_else(|| TestCaseError::reject("no view"))?;
    let lut = Lut::for_bits(&c.tf, c.cfg.table_entries as usize, c.vol.kind().bits());
    let golden = golden_shaded(&c.cfg, &prep, &lut, c.shade);
    let frame = match pipe_shaded(
        &c.cfg,
        &c.vol,
        &lut,
        &prep,
        &c.shade,
        None,
        Tracer::disabled(),
    ) {
        Ok(f) => f,
        // Blocks of one column cannot shade (refused, tested below).
        Err(pipeline::RunError::Shade(e)) => return Err(TestCaseError::reject(e.to_string())),
        Err(e) => return Err(TestCaseError::fail(e.to_string())),
    };
    let image = golden::warp::warp(&prep.view, &frame.baseplane);
    let d = BoundInputs::measure(&c.vol, &lut, &prep.view).expect("ER layout");
    if d.ds_max >= c.cfg.path.max_value().to_f64() {
        return Err(TestCaseError::reject("ds_max beyond the path format"));
    }
    let s = ShadeInputs::measure(&c.vol, &prep.view, &c.shade).expect("gradients");
    let b = match c.cfg.order {
        Order::BackToFront => shaded_error_bound(&c.cfg, &d, &s),
        Order::FrontToBack => {
            shaded_ftb_error_bound(&c.cfg, &d, &region_slices(&prep.view).unwrap(), &s)
        }
    };
    let gbase = &golden.slice.as_ref().unwrap().baseplane;
    let d_base = max_diff(&frame.baseplane.data, &gbase.data);
    let d_img = max_diff(&image.data, &golden.image.data);
    prop_assert!(d_base <= b, "baseplane differs by {d_base}, bound {b}");
    prop_assert!(d_img <= b, "image differs by {d_img}, bound {b}");
    Ok((d_img, b))
}

fn cases() -> impl Strategy<Value = ShadeCase> {
    let dims = [8usize..=28, 8usize..=28, 8usize..=28];
    let eye = (0usize..6, 0.5..50.0f64, (-0.5..1.5f64, -0.5..1.5f64));
    let light = (-1.0..1.0f64, -1.0..1.0f64, -1.0..1.0f64);
    let shading = (
        prop::collection::vec(light, 0..=2),
        (0.0..0.5f64, 0.0..1.5f64, 0.0..1.0f64, 1.0..40.0f64),
        0.5..8.0f64,
        prop_oneof![Just(0.0), 2.0..40.0f64],
    );
    let widths = (
        1u16..=8,
        any::<bool>(),
        4u8..=8,
        10u8..=14,
        10u8..=16,
        6u8..=10,
    );
    (
        dims,
        crate::scenes::blob_strategy(),
        0u16..30,
        any::<u64>(),
        crate::scenes::tf_points_strategy(),
        eye,
        shading,
        widths,
    )
        .prop_filter_map(
            "the case must validate",
            |(dims, blobs, noise, seed, points, (side, dist, off), sh, w)| {
                let (lights, (ka, kd, ks, p), fade, g_op) = sh;
                let (pes, ftb, grad_frac, nd_frac, light_frac, table_bits) = w;
                let cfg = PipelineConfig {
                    pes,
                    order: if ftb {
                        Order::FrontToBack
                    } else {
                        Order::BackToFront
                    },
                    gradient: Format::new(
                        14 + grad_frac,
                        grad_frac,
                        true,
                        Quant::Rnd,
                        Overflow::Sat,
                    )
                    .ok()?,
                    normal_dot: format(nd_frac + 1, nd_frac, Quant::Trn),
                    light: Format::new(light_frac + 2, light_frac, true, Quant::Rnd, Overflow::Sat)
                        .ok()?,
                    shade_table_bits: table_bits.min(nd_frac),
                    ..PipelineConfig::default()
                };
                cfg.validate().ok()?;
                let mut shade = Shade::default();
                shade.material = Material {
                    ambient: ka,
                    diffuse: kd,
                    specular: ks,
                    shininess: p,
                };
                shade.normal_fade = fade;
                shade.gradient_opacity = g_op;
                for (x, y, z) in lights {
                    shade.add_light(DVec3::new(x, y, z)).ok()?;
                }
                let vol = crate::scenes::blobs(dims, &blobs, noise, seed);
                let (eye, up) = eye_for(dims, side, dist, off);
                Some(ShadeCase {
                    vol,
                    tf: tf(&points),
                    eye,
                    up,
                    cfg,
                    shade,
                })
            },
        )
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(128))]

    /// Random small volumes, eyes on all sides, tables, lights, materials,
    /// fades, gradient opacities, both orders and the unit's widths: the
    /// derived shaded bound holds for every channel.
    #[test]
    fn shaded_pipeline_matches_golden_within_the_derived_bound(c in cases()) {
        run_case(&c)?;
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(2048))]

    /// The long run: `cargo test --release -p pipeline --test it -- --ignored shaded_long`.
    #[test]
    #[ignore = "long run: 2048 cases"]
    fn shaded_long_run(c in cases()) {
        run_case(&c)?;
    }
}

/// The bound means something on smooth data with the default fade: well
/// under the range, and the measured difference inside it.
#[test]
fn shaded_bound_is_informative_on_smooth_data() {
    let vol = crate::scenes::blobs([24, 20, 28], &[(0.5, 0.5, 0.5, 0.35, 250.0)], 0, 1);
    let c = ShadeCase {
        vol,
        tf: tf(&[(20.0, [1.0, 0.6, 0.2, 0.0]), (200.0, [1.0, 1.0, 1.0, 0.6])]),
        eye: DVec3::new(11.0, 9.0, -12.0),
        up: DVec3::Y,
        cfg: PipelineConfig::default(),
        shade: Shade::default(),
    };
    let (d, b) = run_case(&c).unwrap();
    eprintln!("smooth shaded case: image {d:.2e}, bound {b:.2e}");
    assert!(b < 0.25, "bound {b} is too loose to mean anything here");
    assert!(d < b);
    // No fade: no finite bound (a tiny gradient's direction is arbitrary).
    let prep = crate::scenes::centred_view(&c.vol, c.eye, c.up, 50.0, 24, 20).unwrap();
    let lut = Lut::for_bits(&c.tf, 4096, 8);
    let d = BoundInputs::measure(&c.vol, &lut, &prep.view).unwrap();
    let mut abrupt = Shade::default();
    abrupt.normal_fade = 0.0;
    let s = ShadeInputs::measure(&c.vol, &prep.view, &abrupt).unwrap();
    assert!(shaded_error_bound(&c.cfg, &d, &s).is_infinite());
}

/// Max 8-bit difference of the shaded pipeline against golden at the
/// default widths, in both orders.
fn default_width_shaded(vol: &Volume, tf: &golden::tf::TransferFunction, cam: &Camera) -> [f64; 2] {
    let prep = Prepared::new(vol, cam).unwrap();
    [Order::BackToFront, Order::FrontToBack].map(|order| {
        let cfg = PipelineConfig {
            order,
            ..PipelineConfig::default()
        };
        let lut = Lut::for_bits(tf, cfg.table_entries as usize, vol.kind().bits());
        let sh = Shade::default();
        let g = golden_shaded(&cfg, &prep, &lut, sh);
        let f = pipe_shaded(&cfg, vol, &lut, &prep, &sh, None, Tracer::disabled()).unwrap();
        let image = golden::warp::warp(&prep.view, &f.baseplane);
        golden::metrics::compare(&image, &g.image)
            .unwrap()
            .max_abs_255
    })
}

/// Shaded, at the default widths: within one grey level on brainsmall
/// (its shaded preset, the view), both orders.
#[test]
fn shaded_default_widths_within_one_grey_level_on_brainsmall() {
    let Some((vol, cam)) = crate::scenes::brainsmall_view() else {
        return;
    };
    let tf = golden::scenes::tf_preset("brain-shaded").unwrap();
    let m = default_width_shaded(&vol, &tf, &cam);
    eprintln!("brainsmall shaded: max {m:?} /255 (back to front, front to back)");
    assert!(
        m.iter().all(|&m| m <= 1.0),
        "max differences {m:?} grey levels"
    );
}

/// The same on the paper's two checkerboard views (128^3).
#[test]
fn shaded_default_widths_within_one_grey_level_on_the_checkerboard() {
    let scene: golden::scenes::Scene = "checker:128".parse().unwrap();
    let vol = scene.build(DEFAULT_MEMORY_LIMIT).unwrap();
    for (d, fov, cam) in checker128_views() {
        let m = default_width_shaded(&vol, &scene.preset(), &cam);
        eprintln!("checker:128 shaded, eye z = -{d}, fov {fov}: max {m:?} /255");
        assert!(
            m.iter().all(|&m| m <= 1.0),
            "max differences {m:?} grey levels"
        );
    }
}

/// A small shaded scene: `ml:20` from outside and inside, a blue light
/// from the side and the headlight.
fn small() -> (Volume, Lut, Vec<(Prepared, Shade)>) {
    let s = crate::chip::subject("ml:20");
    let mut side = Shade::default();
    side.gradient_opacity = 10.0;
    side.add_light(DVec3::new(1.0, 0.3, -0.5)).unwrap();
    let views = [
        (DVec3::new(10.2, 9.1, -12.0), 70.0, Shade::default()),
        (DVec3::new(9.0, 10.4, 7.3), 90.0, side),
    ]
    .into_iter()
    .map(|(eye, fov, sh)| {
        let c = DVec3::from_array(s.vol.center_world());
        let cam = Camera::new(eye, c, crate::scenes::up_for(c - eye), fov, 40, 36).unwrap();
        (Prepared::new(&s.vol, &cam).unwrap(), sh)
    })
    .collect();
    (s.vol, s.lut, views)
}

/// The clocked path (any PE order) and the whole-slice path give the same
/// bits, cycles, counters and quantisation events with the unit's halo
/// on the ports; the unit deepens the datapath, reads more words and
/// receives the halo.
#[test]
fn shading_clocked_equals_whole_slice_and_costs_latency() {
    let (vol, lut, views) = small();
    for order in [Order::BackToFront, Order::FrontToBack] {
        for pes in [1u16, 3, 4] {
            let cfg = PipelineConfig {
                pes,
                order,
                ..PipelineConfig::default()
            };
            for (prep, sh) in &views {
                let fast =
                    pipe_shaded(&cfg, &vol, &lut, prep, sh, None, Tracer::disabled()).unwrap();
                for rot in [0, 1, 2] {
                    let clocked =
                        pipe_shaded(&cfg, &vol, &lut, prep, sh, Some(rot), Tracer::disabled())
                            .unwrap();
                    assert!(
                        signature(&fast) == signature(&clocked),
                        "{order:?}, {pes} PEs, rotation {rot}: clocked differs from whole-slice"
                    );
                }
                let plain = pipeline::FrameRun::new(&cfg, &lut, &vol, &prep.view)
                    .run()
                    .unwrap();
                assert_eq!(fast.samples, plain.samples, "shading changes no sample set");
                let reads = |f: &Frame| f.pes.iter().map(|p| p.mem_reads).sum::<u64>();
                let edges = |f: &Frame| f.pes.iter().map(|p| p.edge_voxels).sum::<u64>();
                assert!(reads(&fast) > reads(&plain));
                if pes > 1 {
                    assert!(
                        edges(&fast) > edges(&plain),
                        "{pes} PEs: no halo words used"
                    );
                }
                assert!(fast.cycles >= plain.cycles);
                assert!(fast.stages.drain > plain.stages.drain || plain.stages.drain == 0);
            }
        }
    }
    let cfg = PipelineConfig::default();
    let (plain, shaded) = (
        pipeline::cost::datapath_latency(&cfg),
        pipeline::cost::shaded_latency(&cfg),
    );
    eprintln!("datapath latency: {plain} clocks, shaded {shaded}");
    assert!(shaded > plain);
    // A stated latency is the whole datapath's, shaded or not.
    let fixed = PipelineConfig {
        datapath_latency: 40,
        ..cfg
    };
    assert_eq!(pipeline::cost::shaded_latency(&fixed), 40);
}

/// A block of one column cannot reach its gradient's right taps: refused
/// with one line, before any cycle.
#[test]
fn shading_refuses_one_column_blocks() {
    let (vol, lut, views) = small();
    let cfg = PipelineConfig {
        pes: 20,
        ..PipelineConfig::default()
    };
    let (prep, sh) = &views[0];
    let e = pipe_shaded(&cfg, &vol, &lut, prep, sh, None, Tracer::disabled())
        .unwrap_err()
        .to_string();
    assert!(e.contains("at least 2 voxel columns per PE"), "{e}");
    assert!(!e.contains('\n'));
    let mut samples = Shade::default();
    samples.gradient = golden::shading::GradientMode::Samples;
    let cfg = PipelineConfig::default();
    let e = pipe_shaded(&cfg, &vol, &lut, prep, &samples, None, Tracer::disabled())
        .unwrap_err()
        .to_string();
    assert!(e.contains("differences on voxels"), "{e}");
}

/// A shaded trace carries the unit's registers and the halo on the left
/// ports; an unshaded one has neither.
#[test]
fn shaded_waveforms_carry_the_unit_and_the_halo() {
    let (vol, lut, views) = small();
    let (prep, sh) = &views[0];
    let cfg = PipelineConfig {
        pes: 4,
        ..PipelineConfig::default()
    };
    let dir = tempfile::tempdir().unwrap();
    let names = |shaded: bool| {
        let p = dir.path().join(format!("s{shaded}.vcd"));
        let tc = TraceConfig::new(&p).with_groups(["ctrl", "datapath", "ports"]);
        let tr = Tracer::new(tc).unwrap();
        if shaded {
            pipe_shaded(&cfg, &vol, &lut, prep, sh, None, tr).unwrap();
        } else {
            pipeline::FrameRun::new(&cfg, &lut, &vol, &prep.view)
                .trace(tr)
                .run()
                .unwrap();
        }
        let t = Trace::read(&p).unwrap();
        let set: std::collections::BTreeSet<String> = t.names().map(str::to_owned).collect();
        (t, set)
    };
    let (t, shaded) = names(true);
    let (_, plain) = names(false);
    for s in [
        "top.pe_1.grad_x",
        "top.pe_1.grad_norm",
        "top.pe_1.shaded_r",
        "top.pe_1.left.halo_0",
    ] {
        assert!(shaded.contains(s), "{s} missing from the shaded trace");
        assert!(!plain.contains(s), "{s} in the unshaded trace");
    }
    // The halo and the gradient really move.
    for s in ["top.pe_1.left.halo_3", "top.pe_1.grad_norm"] {
        let changes = t.signal(s).unwrap().changes().len();
        assert!(changes > 2, "{s} changes {changes} times");
    }
}
