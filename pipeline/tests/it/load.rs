//! The host's load of the PE memories: from golden's slice stack (what
//! `ercube render` does, holding the voxels once) the frame is the one the
//! volume loads, bit for bit and cycle for cycle, for 8- and 16-bit data,
//! every mapping, both orders, views along every axis and a near clip.
//!
//! `cargo test --release -p pipeline --test it -- load::`

use glam::DVec3;
use golden::camera::Camera;
use golden::render::{PrepareOptions, Prepared};
use golden::skip::Skips;
use golden::tf::Lut;
use golden::volume::VoxelType;
use pipeline::array::{FrameRun, Voxels};
use pipeline::config::{Mapping, Order, PipelineConfig};
use waves::Tracer;

use crate::chip::signature;
use crate::scenes::{tf, volume};

#[test]
fn the_stack_loads_what_the_volume_loads() {
    let table = tf(&[(20.0, [0.9, 0.5, 0.2, 0.0]), (200.0, [1.0, 1.0, 1.0, 0.7])]);
    for kind in [VoxelType::U8, VoxelType::U16] {
        let top = if kind == VoxelType::U8 {
            255.0
        } else {
            65535.0
        };
        let vol = volume([20, 17, 23], kind, |x, y, z| {
            let r =
                ((x as f64 - 9.5).powi(2) + (y as f64 - 8.0).powi(2) + (z as f64 - 11.0).powi(2))
                    .sqrt();
            (top * (1.0 - r / 11.0)).max(0.0) as u16
        });
        for (eye, near) in [
            (DVec3::new(9.5, 8.0, -25.0), golden::render::DEFAULT_NEAR),
            (DVec3::new(40.0, 8.0, 11.0), golden::render::DEFAULT_NEAR),
            (DVec3::new(9.5, -30.0, 11.0), golden::render::DEFAULT_NEAR),
            (DVec3::new(9.5, 8.0, -6.0), 9.0),
        ] {
            let cam = Camera::new(
                eye,
                DVec3::new(9.5, 8.0, 11.0),
                DVec3::Z.cross(eye).normalize_or(DVec3::Y),
                60.0,
                24,
                20,
            )
            .expect("camera");
            for (order, mapping) in [
                (Order::BackToFront, Mapping::Blocks),
                (Order::FrontToBack, Mapping::Interleave),
            ] {
                let cfg = PipelineConfig {
                    order,
                    mapping,
                    pes: 4,
                    occupancy_block: 4,
                    ..PipelineConfig::default()
                };
                let opts = PrepareOptions {
                    block: 4,
                    near,
                    ..PrepareOptions::default()
                };
                let prep = Prepared::with(&vol, &cam, &opts).expect("view");
                let lut = Lut::for_bits(&table, cfg.table_entries as usize, kind.bits());
                let skips = Skips::default();
                let t = Tracer::disabled;
                let a = FrameRun::prepared(&cfg, &lut, &prep, Voxels::Volume(&vol))
                    .skips(skips)
                    .trace(t())
                    .run()
                    .expect("frame");
                let b = FrameRun::prepared(
                    &cfg,
                    &lut,
                    &prep,
                    Voxels::Stack {
                        data_bits: kind.bits(),
                    },
                )
                .skips(skips)
                .trace(t())
                .run()
                .expect("frame");
                assert_eq!(
                    signature(&a),
                    signature(&b),
                    "{kind:?} eye {eye} near {near}"
                );
                assert!(a.samples > 0);
            }
        }
    }
}

/// Frames that keep their memories (resident, or as spare buffers the
/// next frame loads into) keep the datapath's tables only while the
/// configuration and the classification table are the same: a frame
/// with another table, or another opacity word, after one with the
/// first, is the frame a fresh load gives, as is a return to the first.
#[test]
fn kept_memories_keep_their_tables_only_for_the_same_table() {
    use pipeline::fixed::{Format, Overflow, Quant};
    let first = tf(&[(20.0, [0.9, 0.5, 0.2, 0.0]), (200.0, [1.0, 1.0, 1.0, 0.7])]);
    let second = tf(&[(60.0, [0.2, 0.5, 0.9, 0.0]), (120.0, [1.0, 0.8, 0.6, 0.4])]);
    let vol = volume([20, 17, 23], VoxelType::U8, |x, y, z| {
        ((x * 13 + y * 7 + z * 5) % 256) as u16
    });
    let eye = DVec3::new(9.5, 8.0, -25.0);
    let cam = Camera::new(eye, DVec3::new(9.5, 8.0, 11.0), DVec3::Y, 60.0, 24, 20).expect("camera");
    let base = PipelineConfig {
        pes: 4,
        occupancy_block: 4,
        ..PipelineConfig::default()
    };
    let narrow = PipelineConfig {
        alpha: Format::new(10, 10, false, Quant::Rnd, Overflow::Sat).unwrap(),
        ..base
    };
    let opts = PrepareOptions {
        block: 4,
        ..PrepareOptions::default()
    };
    let prep = Prepared::with(&vol, &cam, &opts).expect("view");
    let lut = |t| Lut::for_bits(t, base.table_entries as usize, 8);
    let (a, b) = (lut(&first), lut(&second));
    let skips = Skips::default();
    let fresh = |cfg: &PipelineConfig, l: &Lut| {
        signature(
            &FrameRun::prepared(cfg, l, &prep, Voxels::Stack { data_bits: 8 })
                .skips(skips)
                .run()
                .expect("frame"),
        )
    };
    assert_ne!(fresh(&base, &a), fresh(&base, &b), "the tables differ");
    assert_ne!(fresh(&base, &a), fresh(&narrow, &a), "the words differ");
    for stale in [false, true] {
        let mut kept = None;
        for (n, (cfg, l)) in [
            (&base, &a),
            (&base, &b),
            (&base, &a),
            (&narrow, &a),
            (&base, &a),
        ]
        .into_iter()
        .enumerate()
        {
            if stale {
                kept = kept.map(pipeline::Resident::stale);
            }
            let f = FrameRun::prepared(cfg, l, &prep, Voxels::Stack { data_bits: 8 })
                .skips(skips)
                .resident(&mut kept)
                .run()
                .expect("frame");
            assert_eq!(signature(&f), fresh(cfg, l), "frame {n}, stale {stale}");
        }
    }
}
