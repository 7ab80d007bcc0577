//! The pre-integration unit (`pipeline::preint`) in the array against
//! golden's pre-integrated `er` and `er-ftb`: every pixel channel within
//! the derived bound over random volumes, views, tables, orders and PE
//! counts; within one grey level at the default widths on the
//! checkerboard and brainsmall; the clocked and whole-slice paths agree
//! and the PEs' step order within a cycle changes nothing; every planned
//! pass samples exactly its rays; shading and a volume of interest are
//! refused in one line.

use glam::DVec3;
use golden::camera::Camera;
use golden::preint::PreTable;
use golden::render::Prepared;
use golden::tf::{Lut, TransferFunction};
use golden::volume::{Volume, DEFAULT_MEMORY_LIMIT};
use pipeline::array::{Array, Frame};
use pipeline::bound::{
    preint_error_bound, preint_ftb_error_bound, region_slices, BoundInputs, PreintInputs,
};
use pipeline::config::{Mapping, Order, PipelineConfig};
use pipeline::fixed::{Format, Overflow, Quant};
use proptest::prelude::*;
use waves::{Trace, TraceConfig, Tracer};

use crate::chip::signature;
use crate::scenes::{checker128_views, eye_for, max_diff, small_views, tf};

/// Golden `er` or `er-ftb` (by `cfg.order`), unskipped, pre-integrated.
fn golden_pre(cfg: &PipelineConfig, prep: &Prepared, lut: &Lut) -> golden::render::Frame {
    crate::chip::golden_twin(cfg, prep, lut, |o| o.preintegrate = true)
}

/// The pipeline's pre-integrated frame (`clocked`: the sampling stage
/// cycle by cycle; `order`: the PEs' step order within a cycle).
fn pipe_pre(
    cfg: &PipelineConfig,
    vol: &Volume,
    lut: &Lut,
    prep: &Prepared,
    clocked: bool,
    order: Option<Vec<usize>>,
    tracer: Tracer,
) -> Result<Frame, pipeline::RunError> {
    let mut a = Array::new(cfg, vol, lut, &prep.view, tracer)?;
    a.set_units(&[&PreTable::new(lut)], &prep.view, vol.kind().bits(), false)?;
    a.set_clocked(clocked);
    if let Some(o) = order {
        a.set_step_order(o);
    }
    a.run(&prep.view)
}

/// One random case.
struct PreCase {
    vol: Volume,
    tf: TransferFunction,
    eye: DVec3,
    up: DVec3,
    cfg: PipelineConfig,
}

impl std::fmt::Debug for PreCase {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("PreCase")
            .field("dims", &self.vol.dims())
            .field("tf", &self.tf.points)
            .field("eye", &self.eye)
            .field("cfg.pes", &self.cfg.pes)
            .field("cfg.order", &self.cfg.order)
            .field("cfg.mapping", &self.cfg.mapping)
            .field("cfg.table_entries", &self.cfg.table_entries)
            .field("cfg.weight", &self.cfg.weight.to_string())
            .field("cfg.color", &self.cfg.color.to_string())
            .field("cfg.accum", &self.cfg.accum_color.to_string())
            .field("cfg.preint", &self.cfg.preint_tau.to_string())
            .finish()
    }
}

/// Runs a case; returns (image difference, bound). Termination off, the
/// frame is within the derived bound of golden's; front to back with
/// termination on, within `1 - threshold + 3 bound` of the frame without
/// (the argument of `ftb.rs`), taking the same samples less the
/// terminated ones.
fn run_case(c: &PreCase) -> Result<(f64, f64), TestCaseError> {
    let prep = crate::scenes::centred_view(&c.vol, c.eye, c.up, 50.0, 24, 20)
        .ok_or_else(|| TestCaseError::reject("no view"))?;
    let lut = Lut::for_bits(&c.tf, c.cfg.table_entries as usize, c.vol.kind().bits());
    let d = BoundInputs::measure(&c.vol, &lut, &prep.view).expect("ER layout");
    if d.ds_max >= c.cfg.path.max_value().to_f64() {
        return Err(TestCaseError::reject("ds_max beyond the path format"));
    }
    let off = PipelineConfig {
        terminate: 1.0,
        ..c.cfg
    };
    let golden = golden_pre(&off, &prep, &lut);
    let run = |cfg: &PipelineConfig| {
        pipe_pre(cfg, &c.vol, &lut, &prep, false, None, Tracer::disabled())
            .map_err(|e| TestCaseError::fail(e.to_string()))
    };
    let frame = run(&off)?;
    let image = golden::warp::warp(&prep.view, &frame.baseplane);
    let b = bound(&off, &d, &lut, &prep);
    let gbase = &golden.slice.as_ref().unwrap().baseplane;
    let d_base = max_diff(&frame.baseplane.data, &gbase.data);
    let d_img = max_diff(&image.data, &golden.image.data);
    prop_assert!(d_base <= b, "baseplane differs by {d_base}, bound {b}");
    prop_assert!(d_img <= b, "image differs by {d_img}, bound {b}");
    if c.cfg.terminate < 1.0 {
        let on = run(&c.cfg)?;
        prop_assert_eq!(on.samples + on.terminated_samples, frame.samples);
        let tol = (1.0 - c.cfg.terminate) + 3.0 * b;
        let img_on = golden::warp::warp(&prep.view, &on.baseplane);
        let d_on = max_diff(&img_on.data, &image.data);
        prop_assert!(
            d_on <= tol,
            "termination moved the image by {d_on}, tolerance {tol}"
        );
    }
    Ok((d_img, b))
}

/// The derived bound of `cfg`'s order for a pre-integrated frame
/// (termination off).
fn bound(cfg: &PipelineConfig, d: &BoundInputs, lut: &Lut, prep: &Prepared) -> f64 {
    let p = PreintInputs::measure(cfg, d, &PreTable::new(lut));
    match cfg.order {
        Order::BackToFront => preint_error_bound(cfg, d, &p),
        Order::FrontToBack => {
            preint_ftb_error_bound(cfg, d, &p, &region_slices(&prep.view).unwrap())
        }
    }
}

fn cases() -> impl Strategy<Value = PreCase> {
    let dims = [8usize..=28, 8usize..=28, 8usize..=28];
    let eye = (0usize..6, 0.5..50.0f64, (-0.5..1.5f64, -0.5..1.5f64));
    (
        dims,
        crate::scenes::blob_strategy(),
        0u16..30,
        any::<u64>(),
        crate::scenes::tf_points_strategy(),
        eye,
        (1u16..=8, any::<bool>(), 0usize..3, any::<bool>()),
        // Widths: weight, colour fraction, accumulators, the unit's
        // fraction bits (half the cases at the defaults).
        prop_oneof![
            Just(None),
            (8u8..=14, 6u8..=10, 12u8..=20, 8u8..=18).prop_map(Some)
        ],
    )
        .prop_filter_map(
            "the case must validate",
            |(dims, blobs, noise, seed, points, (side, dist, off), (pes, ftb, map, small), w)| {
                let d = PipelineConfig::default();
                let f = |bits: u8, frac: u8, q| Format::new(bits, frac, false, q, Overflow::Sat);
                let (weight, color, accum, pre) = match w {
                    Some((wb, cb, ab, pf)) => (
                        f(wb, wb, Quant::Trn).ok()?,
                        f(cb + 1, cb, Quant::Rnd).ok()?,
                        f(ab, ab, Quant::Rnd).ok()?,
                        f(pf + 7, pf, Quant::Rnd).ok()?,
                    ),
                    None => (d.weight, d.color, d.accum_color, d.preint_tau),
                };
                let cfg = PipelineConfig {
                    weight,
                    color,
                    accum_color: accum,
                    accum_alpha: accum,
                    merge: f(accum.bits() + 4, accum.frac(), Quant::Rnd).ok()?,
                    preint_tau: pre,
                    preint_color: pre,
                    pes,
                    order: if ftb {
                        Order::FrontToBack
                    } else {
                        Order::BackToFront
                    },
                    terminate: if ftb { 0.95 } else { 1.0 },
                    mapping: [Mapping::Blocks, Mapping::Interleave, Mapping::Cyclic][map],
                    // 256 entries: bins are the entries (the table scale
                    // is a power of two); 4096: 16 entries a bin.
                    table_entries: if small { 256 } else { 4096 },
                    ..PipelineConfig::default()
                };
                cfg.validate().ok()?;
                let vol = crate::scenes::blobs(dims, &blobs, noise, seed);
                let (eye, up) = eye_for(dims, side, dist, off);
                Some(PreCase {
                    vol,
                    tf: tf(&points),
                    eye,
                    up,
                    cfg,
                })
            },
        )
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(96))]

    /// Random small volumes, eyes on all sides (some inside the volume's
    /// slab), tables, widths, both orders, mappings and PE counts: the
    /// derived bound holds for every channel.
    #[test]
    fn preint_pipeline_matches_golden_within_the_derived_bound(c in cases()) {
        run_case(&c)?;
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(2048))]

    /// The long run: `cargo test --release -p pipeline --test it -- --ignored preint_long`.
    #[test]
    #[ignore = "long run: 2048 cases"]
    fn preint_long_run(c in cases()) {
        run_case(&c)?;
    }
}

/// Max difference in grey levels between the pipeline and golden at the
/// default widths, pre-integrated, in `order`.
fn default_width_pre(vol: &Volume, tf: &TransferFunction, cam: &Camera, order: Order) -> f64 {
    let cfg = PipelineConfig {
        order,
        terminate: if order == Order::FrontToBack {
            0.99
        } else {
            1.0
        },
        ..PipelineConfig::default()
    };
    let lut = Lut::for_bits(tf, cfg.table_entries as usize, vol.kind().bits());
    let prep = Prepared::new(vol, cam).unwrap();
    let g = golden_pre(&cfg, &prep, &lut);
    let f = pipe_pre(&cfg, vol, &lut, &prep, false, None, Tracer::disabled()).unwrap();
    let image = golden::warp::warp(&prep.view, &f.baseplane);
    golden::metrics::compare(&image, &g.image)
        .unwrap()
        .max_abs_255
}

/// At the default widths, within one grey level of golden on the paper's
/// two checkerboard views (the two-material preset, whose thin skin is
/// what pre-integration sees), both orders.
#[test]
fn preint_default_widths_within_one_grey_level_on_the_checkerboard() {
    let scene: golden::scenes::Scene = "checker:128".parse().unwrap();
    let vol = scene.build(DEFAULT_MEMORY_LIMIT).unwrap();
    for (d, fov, cam) in checker128_views() {
        for order in [Order::BackToFront, Order::FrontToBack] {
            let m = default_width_pre(&vol, &scene.preset(), &cam, order);
            eprintln!("checker:128 eye z = -{d}, fov {fov}, {order:?}: max {m} /255");
            assert!(m <= 1.0, "max difference {m} grey levels");
        }
    }
}

/// The same on brainsmall.
#[test]
fn preint_default_widths_within_one_grey_level_on_brainsmall() {
    let Some((vol, cam)) = crate::scenes::brainsmall_view() else {
        return;
    };
    let tf = golden::scenes::tf_preset("grey-ramp").unwrap();
    for order in [Order::BackToFront, Order::FrontToBack] {
        let m = default_width_pre(&vol, &tf, &cam, order);
        eprintln!("brainsmall {order:?}: max {m} /255");
        assert!(m <= 1.0, "max difference {m} grey levels");
    }
}

/// The clocked path gives the whole-slice path's bits and counters, and
/// the PEs' order within a cycle changes nothing (each step sees only
/// last cycle's ports).
#[test]
fn preint_clocked_and_whole_slice_agree() {
    let (vol, lut, views) = small_views(PipelineConfig::default().table_entries as usize);
    assert_eq!(views.len(), 3);
    for order in [Order::BackToFront, Order::FrontToBack] {
        for pes in [1u16, 3, 4] {
            let cfg = PipelineConfig {
                pes,
                order,
                terminate: if order == Order::FrontToBack {
                    0.9
                } else {
                    1.0
                },
                ..PipelineConfig::default()
            };
            for prep in &views {
                let off = Tracer::disabled;
                let whole = pipe_pre(&cfg, &vol, &lut, prep, false, None, off()).unwrap();
                let clocked = pipe_pre(&cfg, &vol, &lut, prep, true, None, off()).unwrap();
                assert!(
                    signature(&clocked) == signature(&whole),
                    "clocked differs: {order:?}, {pes} PEs"
                );
                let rev: Vec<usize> = (0..usize::from(pes)).rev().collect();
                let reversed = pipe_pre(&cfg, &vol, &lut, prep, true, Some(rev), off()).unwrap();
                assert!(
                    signature(&reversed) == signature(&whole),
                    "the step order changed the frame: {order:?}, {pes} PEs"
                );
            }
        }
    }
}

/// Every pass the host plans samples exactly its rays: back to front
/// without termination the frame's samples are the sum over every
/// region's passes (the prime pass included) of the rays in the pass's
/// hull, and front to back (no termination) likewise with the finish pass;
/// so a pre-integrated frame takes one more pass per region than the
/// plain one, whose samples it also takes.
#[test]
fn preint_samples_every_planned_pass() {
    let (vol, lut, views) = small_views(PipelineConfig::default().table_entries as usize);
    for order in [Order::BackToFront, Order::FrontToBack] {
        let cfg = PipelineConfig {
            pes: 4,
            order,
            ..PipelineConfig::default()
        };
        for prep in &views {
            let plan = pipeline::host::plan(&cfg, &prep.view).unwrap();
            let mut st = pipeline::fixed::QuantStats::default();
            let (mut want, mut passes) = (0u64, 0usize);
            for r in &plan.regions {
                let ps = pipeline::host::preint_passes(&cfg, &prep.view, r, &mut st).unwrap();
                if !r.slices.is_empty() {
                    assert_eq!(ps.len(), r.slices.len() + 1, "one extra pass a region");
                }
                passes += ps.len();
                for p in &ps {
                    let n = |k: usize| (p.range[k].1 - p.range[k].0 + 1).max(0) as u64;
                    want += n(0) * n(1);
                }
            }
            assert!(passes > 0);
            let f = pipe_pre(&cfg, &vol, &lut, prep, false, None, Tracer::disabled()).unwrap();
            assert_eq!(f.samples, want, "{order:?}");
            // The plain frame without skipping samples the slices' own
            // ranges, a subset.
            let mut a = Array::new(&cfg, &vol, &lut, &prep.view, Tracer::disabled()).unwrap();
            a.set_clocked(false);
            let plain = a.run(&prep.view).unwrap();
            assert!(plain.samples < f.samples, "{order:?}");
        }
    }
}

/// Shading and a volume of interest are refused in one line.
#[test]
fn preint_refuses_shading_and_a_voi() {
    let (vol, lut, views) = small_views(PipelineConfig::default().table_entries as usize);
    let cfg = PipelineConfig::default();
    let view = &views[0].view;
    let pt = PreTable::new(&lut);
    let mut a = Array::new(&cfg, &vol, &lut, view, Tracer::disabled()).unwrap();
    let shade = golden::shading::Shade::default();
    a.set_units(&[&shade], view, 8, false).unwrap();
    let e = a.set_units(&[&pt], view, 8, false).unwrap_err().to_string();
    assert!(e.contains("shading") && !e.contains('\n'), "{e}");
    // In either order, and in one load.
    let mut a = Array::new(&cfg, &vol, &lut, view, Tracer::disabled()).unwrap();
    a.set_units(&[&pt], view, 8, false).unwrap();
    let e = a
        .set_units(&[&shade], view, 8, false)
        .unwrap_err()
        .to_string();
    assert!(e.contains("shading") && !e.contains('\n'), "{e}");
    let mut a = Array::new(&cfg, &vol, &lut, view, Tracer::disabled()).unwrap();
    let e = a
        .set_units(&[&pt, &shade], view, 8, false)
        .unwrap_err()
        .to_string();
    assert!(e.contains("shading") && !e.contains('\n'), "{e}");
    let mut a = Array::new(&cfg, &vol, &lut, view, Tracer::disabled()).unwrap();
    let voi = golden::voi::Voi {
        shape: golden::voi::Shape::Sphere {
            centre: [10.0; 3],
            radius: 4.0,
        },
        scale: 2.0,
        outside: false,
        ramp: 0.0,
    };
    a.set_units(&[&voi], view, 8, false).unwrap();
    let e = a.set_units(&[&pt], view, 8, false).unwrap_err().to_string();
    assert!(e.contains("volume of interest") && !e.contains('\n'), "{e}");
}

/// Pre-integration changes the image where golden's does: on the
/// checkerboard's steep view the pipeline's pre-integrated frame is far
/// from its plain one and close to golden's pre-integrated one.
#[test]
fn preint_sees_what_golden_pre_integration_sees() {
    let scene: golden::scenes::Scene = "checker:64".parse().unwrap();
    let vol = scene.build(DEFAULT_MEMORY_LIMIT).unwrap();
    let mut cam = Camera::new(
        DVec3::new(32.0, 32.0, -16.0),
        DVec3::splat(31.5),
        DVec3::Y,
        127.0,
        96,
        96,
    )
    .unwrap();
    cam.image_plane = golden::camera::ImagePlane::Front;
    let prep = Prepared::new(&vol, &cam).unwrap();
    let cfg = PipelineConfig::default();
    let lut = Lut::for_bits(&scene.preset(), cfg.table_entries as usize, 8);
    let pre = pipe_pre(&cfg, &vol, &lut, &prep, false, None, Tracer::disabled()).unwrap();
    let mut a = Array::new(&cfg, &vol, &lut, &prep.view, Tracer::disabled()).unwrap();
    a.set_clocked(false);
    let plain = a.run(&prep.view).unwrap();
    let g = golden_pre(&cfg, &prep, &lut);
    let img = |f: &Frame| golden::warp::warp(&prep.view, &f.baseplane);
    let to_golden = max_diff(&img(&pre).data, &g.image.data);
    let to_plain = max_diff(&img(&pre).data, &img(&plain).data);
    eprintln!("pre-integrated vs golden {to_golden:.4}, vs plain {to_plain:.4}");
    assert!(to_plain > 0.1, "pre-integration changed little: {to_plain}");
    assert!(
        to_golden < to_plain / 20.0,
        "{to_golden} against {to_plain}"
    );
}

/// A pre-integrated trace carries the unit's back scalar and extinction
/// and the links' previous-sample words, which move; a plain trace has
/// none of them.
#[test]
fn preint_waveforms_carry_the_back_scalar_and_extinction() {
    let (vol, lut, views) = small_views(PipelineConfig::default().table_entries as usize);
    let cfg = PipelineConfig {
        pes: 4,
        ..PipelineConfig::default()
    };
    let dir = tempfile::tempdir().unwrap();
    let names = |with: bool| {
        let p = dir.path().join(format!("p{with}.vcd"));
        let tc = TraceConfig::new(&p).with_groups(["ctrl", "datapath", "ports"]);
        let tr = Tracer::new(tc).unwrap();
        if with {
            pipe_pre(&cfg, &vol, &lut, &views[0], false, None, tr).unwrap();
        } else {
            Array::new(&cfg, &vol, &lut, &views[0].view, tr)
                .unwrap()
                .run(&views[0].view)
                .unwrap();
        }
        let t = Trace::read(&p).unwrap();
        let set: std::collections::BTreeSet<String> = t.names().map(str::to_owned).collect();
        (t, set)
    };
    let (t, with) = names(true);
    let (_, plain) = names(false);
    for s in ["top.pe_1.pre_back", "top.pe_1.pre_tau"] {
        assert!(
            with.contains(s),
            "{s} missing from the pre-integrated trace"
        );
        assert!(!plain.contains(s), "{s} in the plain trace");
        let changes = t.signal(s).unwrap().changes().len();
        assert!(changes > 2, "{s} changes {changes} times");
    }
    // The previous-sample word travels with the migrating rays.
    let links: Vec<&String> = with.iter().filter(|n| n.ends_with(".ray_prev")).collect();
    assert_eq!(links.len(), 8, "one per port of 4 PEs: {links:?}");
    assert!(!plain.iter().any(|n| n.ends_with(".ray_prev")));
    let moved: usize = links
        .iter()
        .map(|n| t.signal(n).unwrap().changes().len())
        .sum();
    assert!(
        moved > 2,
        "the links' previous samples change {moved} times"
    );
}
