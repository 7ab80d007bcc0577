//! Criterion benches of the hot paths (`cargo bench`):
//!
//! - golden: sampling and compositing one ER region (`sample_region`,
//!   every ray of the back region crossing each of its slices: bilinear
//!   sample, classification, opacity correction, compositing; nothing
//!   skipped, so it times the per-sample cost), and the Bartlett merge of
//!   one region boundary, and re-classifying the empty-space blocks after
//!   a transfer-function change;
//! - pipeline: one busy PE cycle of the fixed-point datapath (position,
//!   address, bilinear, classify, path length, opacity correction,
//!   compositing) over a row of rays of a real frame plan, and one clock of
//!   the whole PE array, measured as clocked frames divided into their
//!   cycles (criterion's throughput is array clocks per second), beside the
//!   default whole-slice path that produces the same bits and cycles.
//!
//! Inputs are small (Marschner-Lobb 64^3, 90 degrees) so each iteration
//! is short and `cargo bench` finishes in about a minute.

use std::hint::black_box;

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use glam::DVec3;

use golden::camera::{Camera, ImagePlane};
use golden::geometry::{Merge, View};
use golden::methods::Method;
use golden::render::{lut_for, Prepared};
use golden::sampling::{sample_region, Order, Pass};
use golden::scenes::Scene;
use golden::skip::SampleMask;
use golden::tf::Lut;
use golden::volume::{Volume, DEFAULT_MEMORY_LIMIT};
use pipeline::config::PipelineConfig;
use pipeline::datapath::{Acc, Datapath};
use pipeline::fixed::{QuantStats, Wide};
use pipeline::tables::Tables;

/// Marschner-Lobb `n`^3 seen from `d` voxels in front, 90 degrees, front face.
fn setup(n: usize, d: f64) -> (Volume, golden::tf::TransferFunction, Prepared) {
    let scene = Scene::MarschnerLobb { n };
    let vol = scene.build(DEFAULT_MEMORY_LIMIT).expect("scene");
    let c = DVec3::from_array(vol.center_world());
    let mut cam =
        Camera::new(DVec3::new(c.x, c.y, -d), c, DVec3::Y, 90.0, 128, 128).expect("camera");
    cam.image_plane = ImagePlane::Front;
    let prep = Prepared::new(&vol, &cam).expect("view");
    (vol, scene.preset(), prep)
}

fn golden_benches(c: &mut Criterion) {
    let (vol, tf, prep) = setup(64, 32.0);
    let lut = lut_for(vol.kind(), &tf);
    let layout = Method::Er.layout(&prep.view).expect("layout");
    let k = layout.grids.len() - 1;
    let grid = &layout.grids[k];
    let mut buf = vec![[0f32; 4]; grid.len()];
    // Every ray samples: the per-sample cost, not what skipping saves.
    let mask = SampleMask::everything(&prep.view, &layout, prep.clip.clone(), 1);
    let pass = Pass {
        view: &prep.view,
        stack: &prep.stack,
        lut: &lut,
        mask: &mask,
        order: Order::BackToFront,
        substeps: 1,
        shader: None,
        voi: None,
        preint: None,
        lanes: true,
        clear_below: lut.clear_below(),
    };
    let n: u64 = sample_region(&pass, k, grid, &mut buf).samples.iter().sum();
    let mut g = c.benchmark_group("golden");
    g.sample_size(30);
    g.throughput(Throughput::Elements(n));
    g.bench_function("sample_region_er_btf", |b| {
        b.iter(|| black_box(sample_region(&pass, black_box(k), grid, &mut buf)))
    });
    // The same frame one ray at a time (the path the batches must match).
    let one_ray = Pass {
        lanes: false,
        ..pass
    };
    g.bench_function("sample_region_er_btf_one_ray", |b| {
        b.iter(|| black_box(sample_region(&one_ray, black_box(k), grid, &mut buf)))
    });
    // The front region's merge: the back region's rays into region k - 1's.
    if k >= 1 {
        let back = vec![[0.25f32, 0.5, 0.75, 0.5]; layout.grids[k].len()];
        g.throughput(Throughput::Elements(layout.grids[k - 1].len() as u64));
        g.bench_function("bartlett_merge", |b| {
            b.iter(|| {
                black_box(golden::merge::merge(
                    Merge::Bartlett,
                    black_box(&back),
                    &layout.grids[k],
                    &layout.grids[k - 1],
                ))
            })
        });
    }
    // Re-classifying the empty-space blocks after a transfer-function
    // change: one table query per block (here 8^3 blocks of a 64^3 volume,
    // and of a 256^3 one).
    for n in [64usize, 256] {
        let vol = golden::scenes::Scene::Sphere { n }
            .build(golden::volume::DEFAULT_MEMORY_LIMIT)
            .expect("scene");
        let mm = golden::occupancy::MinMax::new(&vol, 8).expect("blocks");
        g.throughput(Throughput::Elements(mm.range.len() as u64));
        g.bench_function(format!("occupancy_for_lut_{n}"), |b| {
            b.iter(|| black_box(golden::occupancy::Occupancy::for_lut(&mm, &lut)))
        });
    }
    g.finish();
}

/// One busy PE cycle's arithmetic, ray after ray along one row of a real
/// slice plan (what `Pe::sample_ray` computes, without the PE bookkeeping).
fn pe_cycle_benches(c: &mut Criterion) {
    let (vol, tf, prep) = setup(64, 32.0);
    let cfg = PipelineConfig::default();
    let lut = Lut::for_bits(&tf, cfg.table_entries as usize, vol.kind().bits());
    let view: &View = &prep.view;
    let plan = pipeline::host::plan(&cfg, view).expect("plan");
    let mut st = QuantStats::default();
    let words = pipeline::host::voxel_words(&cfg, &vol, view, &mut st);
    let dp = Datapath::new(cfg, Tables::new(&cfg, &lut).expect("tables"));
    let region = plan.regions.last().expect("a region");
    let slice = &region.slices[region.slices.len() / 2];
    let [nx, ny, _] = view.dims;
    let (xlo, xhi) = slice.range[0];
    let (ylo, yhi) = slice.range[1];
    let my = (ylo + yhi) / 2;
    let rays = (xhi - xlo + 1).max(0) as u64;
    let voxel = |z: usize, y: usize, x: usize| words[(z * ny + y) * nx + x];
    let mut g = c.benchmark_group("pipeline");
    g.sample_size(30);
    g.throughput(Throughput::Elements(rays));
    g.bench_function("pe_busy_cycle", |b| {
        b.iter(|| {
            let mut st = QuantStats::default();
            let mut acc = Acc::default();
            let y = dp.position(slice.a[1], slice.t[1], my, &mut st).unwrap();
            let (y0, wy) = dp.address(y, &mut st);
            let last_y = ny as i64 - 1;
            let (r0, r1) = (
                y0.clamp(0, last_y) as usize,
                (y0 + 1).clamp(0, last_y) as usize,
            );
            let mt = Wide::new(i128::from(my), 0)
                .checked_mul(region.slope_k[1])
                .unwrap();
            let sy = dp.cfg.position.assign(
                Wide::from(region.slope_b[1]).checked_add(mt).unwrap(),
                &mut st,
            );
            for mx in xlo..=xhi {
                let x = dp.position(slice.a[0], slice.t[0], mx, &mut st).unwrap();
                let (x0, wx) = dp.address(x, &mut st);
                let last = nx as i64 - 1;
                let (c0, c1) = (x0.clamp(0, last) as usize, (x0 + 1).clamp(0, last) as usize);
                let v = [
                    [voxel(slice.z, r0, c0), voxel(slice.z, r0, c1)],
                    [voxel(slice.z, r1, c0), voxel(slice.z, r1, c1)],
                ];
                let s = dp.bilinear(v, wx, wy, &mut st).unwrap();
                let (rgb, alpha) = dp.classify(s, &mut st).unwrap();
                let mt = Wide::new(i128::from(mx), 0)
                    .checked_mul(region.slope_k[0])
                    .unwrap();
                let sx = dp.cfg.position.assign(
                    Wide::from(region.slope_b[0]).checked_add(mt).unwrap(),
                    &mut st,
                );
                let ds = dp.path(sx, sy, region.slope_z, &mut st).unwrap();
                let a = dp.correct(alpha, ds, &mut st).unwrap();
                dp.composite_btf(&mut acc, rgb, a, &mut st).unwrap();
            }
            black_box(acc)
        })
    });
    g.finish();
}

/// Whole frames of the PE array, clocked cycle by cycle and on the default
/// whole-slice path; throughput in array clocks.
fn array_benches(c: &mut Criterion) {
    let (vol, tf, prep) = setup(32, 16.0);
    let cfg = PipelineConfig {
        pes: 8,
        ..PipelineConfig::default()
    };
    let lut = Lut::for_bits(&tf, cfg.table_entries as usize, vol.kind().bits());
    let frame = |clocked: bool| {
        let mut a =
            pipeline::array::Array::new(&cfg, &vol, &lut, &prep.view, waves::Tracer::disabled())
                .expect("array");
        a.set_clocked(clocked);
        a.run(&prep.view).expect("frame")
    };
    let cycles = frame(true).cycles;
    assert_eq!(
        cycles,
        frame(false).cycles,
        "both paths count the same cycles"
    );
    let mut g = c.benchmark_group("array");
    g.sample_size(10);
    g.throughput(Throughput::Elements(cycles));
    g.bench_function("clock_8_pes_clocked", |b| b.iter(|| black_box(frame(true))));
    g.bench_function("clock_8_pes_whole_slice", |b| {
        b.iter(|| black_box(frame(false)))
    });
    g.finish();
}

criterion_group!(benches, golden_benches, pe_cycle_benches, array_benches);
criterion_main!(benches);
