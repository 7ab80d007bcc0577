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
use pipeline::array::{run_frame_from_stack, run_frame_shaded};
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
                let a = run_frame_shaded(&cfg, &vol, &lut, &prep, skips, None, t()).expect("frame");
                let b = run_frame_from_stack(&cfg, kind.bits(), &lut, &prep, skips, None, t())
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
