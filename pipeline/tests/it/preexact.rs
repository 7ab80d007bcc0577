//! The pre-integration unit's exact colouring (`pipeline::preint`, its
//! depth layers) against golden's (`golden::preint::Colouring::Exact`):
//! within one grey level at the default widths on thin shells, the folded
//! ribbon and brainsmall in both orders, and on thin, opaque,
//! high-frequency volumes its image is never further from golden's
//! reference than the pipeline's plain frame.
//!
//! `cargo test --release -p pipeline --test it -- preexact`

use glam::DVec3;
use golden::camera::{Camera, ImagePlane};
use golden::preint::{Colouring, PreTable};
use golden::render::{render, Prepared, RenderOptions, Technique};
use golden::tf::{Lut, TransferFunction};
use golden::volume::{Volume, DEFAULT_MEMORY_LIMIT};
use pipeline::array::{Array, Frame};
use pipeline::config::{Order, PipelineConfig};
use waves::Tracer;

/// The pipeline's frame, plain or pre-integrated with table `pt` (of
/// `lut`).
fn pipe(
    cfg: &PipelineConfig,
    vol: &Volume,
    lut: &Lut,
    prep: &Prepared,
    pt: Option<&PreTable>,
) -> Frame {
    let mut a = Array::new(cfg, vol, lut, &prep.view, Tracer::disabled()).unwrap();
    if let Some(pt) = pt {
        a.set_units(&[pt], &prep.view, vol.kind().bits(), false)
            .unwrap();
    }
    a.set_clocked(false);
    a.run(&prep.view).unwrap()
}

/// Thin spherical shells, `thickness` voxels, in a 32^3 volume.
fn shells(thickness: f64) -> Volume {
    let n = 32;
    let c = (n as f64 - 1.0) / 2.0;
    Volume::from_fn(
        [n, n, n],
        golden::volume::VoxelType::U8,
        DEFAULT_MEMORY_LIMIT,
        |x, y, z| {
            let d =
                ((x as f64 - c).powi(2) + (y as f64 - c).powi(2) + (z as f64 - c).powi(2)).sqrt();
            let u = [6.4, 10.2, 14.1]
                .iter()
                .map(|r| ((d - r) / (thickness / 2.0)).abs())
                .fold(f64::INFINITY, f64::min);
            (220.0 * (-u * u).exp()).round() as u16
        },
    )
    .unwrap()
}

fn ribbon() -> (Volume, TransferFunction) {
    let s = golden::scenes::Scene::Ribbon { n: 32 };
    (s.build(DEFAULT_MEMORY_LIMIT).unwrap(), s.preset())
}

/// Front, oblique and near views of a 32^3 volume, 40x40.
fn views() -> Vec<(&'static str, Camera)> {
    let centre = DVec3::splat(15.5);
    [
        ("front", DVec3::new(15.5, 15.5, -48.0), 40.0),
        ("oblique", centre + DVec3::new(-35.0, 22.0, -51.0), 35.0),
        ("near", DVec3::new(18.5, 13.5, -10.0), 90.0),
    ]
    .into_iter()
    .map(|(name, eye, fov)| {
        let up = crate::scenes::up_for(centre - eye);
        let mut cam = Camera::new(eye, centre, up, fov, 40, 40).unwrap();
        cam.image_plane = ImagePlane::Camera;
        (name, cam)
    })
    .collect()
}

/// At the default widths the exact colouring's frame is within one grey
/// level of golden's exact frame, both orders, on thin shells, the ribbon
/// and brainsmall.
#[test]
fn preexact_default_widths_within_one_grey_level() {
    let (rv, rtf) = ribbon();
    let mut cases: Vec<(String, Volume, TransferFunction, Camera)> = Vec::new();
    for (name, cam) in views() {
        cases.push((format!("shells 1.5, {name}"), shells(1.5), rtf.clone(), cam));
        cases.push((format!("ribbon, {name}"), rv.clone(), rtf.clone(), cam));
    }
    if let Some((vol, cam)) = crate::scenes::brainsmall_view() {
        let tf = golden::scenes::tf_preset("grey-ramp").unwrap();
        cases.push(("brainsmall".into(), vol, tf, cam));
    }
    let mut tables: Vec<(Lut, PreTable)> = Vec::new();
    for (name, vol, tf, cam) in &cases {
        for order in [Order::BackToFront, Order::FrontToBack] {
            let cfg = PipelineConfig {
                order,
                terminate: 1.0,
                ..PipelineConfig::default()
            };
            let lut = Lut::for_bits(tf, cfg.table_entries as usize, vol.kind().bits());
            // Golden's twin shares the process's table; the unit gets
            // its own copy once per classification.
            if !tables.iter().any(|(l, _)| l.rgba == lut.rgba) {
                let pt = PreTable::with_colouring(&lut, Colouring::Exact);
                tables.push((lut.clone(), pt));
            }
            let pt = &tables.iter().find(|(l, _)| l.rgba == lut.rgba).unwrap().1;
            let prep = Prepared::new(vol, cam).unwrap();
            let g = crate::chip::golden_twin(&cfg, &prep, &lut, |o| {
                o.preintegrate = true;
                o.pre_colouring = Colouring::Exact;
            });
            let f = pipe(&cfg, vol, &lut, &prep, Some(pt));
            let image = golden::warp::warp(&prep.view, &f.baseplane);
            let m = golden::metrics::compare(&image, &g.image)
                .unwrap()
                .max_abs_255;
            eprintln!("{name}, {order:?}: max {m} /255");
            assert!(
                m <= 1.0,
                "{name}, {order:?}: max difference {m} grey levels"
            );
        }
    }
}

/// On thin shells at two thicknesses and the ribbon, from three views,
/// both orders: the pipeline's exact pre-integrated image is at most as
/// far (RMSE) from golden's reference (a 1/20-voxel step) as its plain
/// frame's, and closer than its fast pre-integrated one's on the ribbon.
#[test]
fn preexact_pipeline_never_worse_than_plain_on_thin_shells() {
    let (rv, rtf) = ribbon();
    let vols = [
        ("shells 1", shells(1.0)),
        ("shells 2", shells(2.0)),
        ("ribbon", rv),
    ];
    let mut fine = RenderOptions::default();
    fine.reference.step = 0.05;
    let lut = Lut::for_bits(&rtf, PipelineConfig::default().table_entries as usize, 8);
    let (fast_t, exact_t) = (
        PreTable::with_colouring(&lut, Colouring::Fast),
        PreTable::with_colouring(&lut, Colouring::Exact),
    );
    for (name, vol) in &vols {
        for (view, cam) in views() {
            let prep = Prepared::new(vol, &cam).unwrap();
            let cfg0 = PipelineConfig::default();
            let reference = render(&prep, &lut, Technique::Reference, &fine)
                .unwrap()
                .image;
            for order in [Order::BackToFront, Order::FrontToBack] {
                let cfg = PipelineConfig {
                    order,
                    terminate: 1.0,
                    ..cfg0
                };
                let rmse = |pt: Option<&PreTable>| {
                    let f = pipe(&cfg, vol, &lut, &prep, pt);
                    let img = golden::warp::warp(&prep.view, &f.baseplane);
                    golden::metrics::compare(&img, &reference).unwrap().rmse
                };
                let (plain, fast, exact) = (rmse(None), rmse(Some(&fast_t)), rmse(Some(&exact_t)));
                eprintln!(
                    "{name:8} {view:8} {order:?}: plain {plain:.4} fast {fast:.4} exact {exact:.4}"
                );
                assert!(
                    exact <= plain,
                    "{name}, {view}, {order:?}: exact {exact} above plain {plain}"
                );
            }
        }
    }
}
