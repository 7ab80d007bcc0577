//! Position drift: the pipeline's ray positions `A + m t` against the
//! exact `f64` positions and their documented bound.

use glam::DVec3;
use golden::camera::Camera;
use golden::geometry::View;
use golden::methods::Method;
use golden::render::Prepared;
use golden::tf::Lut;
use golden::volume::Volume;
use pipeline::bound::r;
use pipeline::config::PipelineConfig;
use pipeline::datapath::Datapath;
use pipeline::fixed::{Format, Overflow, Quant, QuantStats};
use pipeline::tables::Tables;

use super::{blob, ramp};
use crate::scenes::up_for;

/// Worst position error of a view.
#[derive(Debug, Default, Clone, Copy)]
struct Drift {
    /// Largest |fixed - exact| in voxels.
    worst: f64,
    /// Largest error / bound.
    ratio: f64,
    /// Positions checked.
    count: u64,
}

/// Every ray of every region and slice (on x every ray the region holds,
/// as the owner computation forms them; on y every row sampled): the
/// pipeline's `A + m t` from the host's per-slice constants against the
/// exact `f64` position, within `2 r(position) + |m| r(step)` plus the
/// `f64` evaluation's own rounding (`2^-52 (|a| + |m t|)`, far below).
fn position_drift(cfg: &PipelineConfig, view: &View) -> Drift {
    let lut = Lut::for_bits(&ramp(), cfg.table_entries as usize, 8);
    let dp = Datapath::new(*cfg, Tables::new(cfg, &lut).unwrap());
    let plan = pipeline::host::plan(cfg, view).unwrap();
    let layout = Method::Er.layout(view).unwrap();
    let (rp, rs) = (r(cfg.position), r(cfg.step));
    let mut st = QuantStats::default();
    let mut d = Drift::default();
    for (region, grid) in plan.regions.iter().zip(&layout.grids) {
        assert_eq!(region.grid, *grid);
        for s in &region.slices {
            for k in 0..2 {
                let exact = grid.at(view.eye, view.d, s.z as f64, k);
                let ms = if k == 0 {
                    (grid.lo[0], grid.hi[0])
                } else {
                    s.range[1]
                };
                for m in ms.0..=ms.1 {
                    let fixed = dp.position(s.a[k], s.t[k], m, &mut st).unwrap().to_f64();
                    let want = exact.a + m as f64 * exact.t;
                    let err = (fixed - want).abs();
                    let slack = f64::EPSILON * (exact.a.abs() + (m as f64 * exact.t).abs());
                    let bound = 2.0 * rp + m.unsigned_abs() as f64 * rs + slack;
                    assert!(
                        err <= bound,
                        "z {} axis {k} ray {m}: position {fixed} vs {want}, error {err:e} > \
                         {bound:e}",
                        s.z
                    );
                    d.worst = d.worst.max(err);
                    d.ratio = d.ratio.max(err / bound);
                    d.count += 1;
                }
            }
        }
    }
    assert_eq!(st.overflows, 0, "a position saturated");
    d
}

fn view_of(vol: &Volume, eye: DVec3) -> View {
    let c = DVec3::from_array(vol.center_world());
    let cam = Camera::new(eye, c, up_for(c - eye), 60.0, 8, 8).unwrap();
    Prepared::new(vol, &cam).unwrap().view
}

#[test]
fn ray_positions_stay_within_the_documented_bound() {
    let fmt = |bits, frac, signed, q| Format::new(bits, frac, signed, q, Overflow::Sat).unwrap();
    let configs = [
        ("default", PipelineConfig::default()),
        (
            "narrow RND (position fixed<20,12>, step ufixed<13,1>)",
            PipelineConfig {
                position: fmt(20, 8, true, Quant::Rnd),
                step: fmt(13, 12, false, Quant::Rnd),
                ..PipelineConfig::default()
            },
        ),
        (
            "TRN (position fixed<28,12>, step ufixed<25,1>)",
            PipelineConfig {
                position: fmt(28, 16, true, Quant::Trn),
                step: fmt(25, 24, false, Quant::Trn),
                ..PipelineConfig::default()
            },
        ),
    ];
    let views: Vec<(&str, Volume, DVec3)> = vec![
        (
            "far, 128 slices in one region",
            blob([16, 16, 128], 0),
            DVec3::new(7.8, 7.3, -1e4),
        ),
        (
            "far, 1024 slices in one region",
            blob([8, 8, 1024], 0),
            DVec3::new(4.3, 3.9, -1e4),
        ),
        (
            "near, D = 0.5",
            blob([32, 32, 32], 0),
            DVec3::new(15.3, 16.7, -0.5),
        ),
        (
            "oblique, non-integer eye",
            blob([24, 20, 28], 0),
            DVec3::new(-10.3, 30.2, -7.9),
        ),
        (
            "wide, rays up to |m| ~ 1000",
            blob([512, 512, 16], 0),
            DVec3::new(200.3, 301.7, -0.75),
        ),
    ];
    for (cname, cfg) in &configs {
        cfg.validate().unwrap();
        let lsb = cfg.position.lsb();
        for (vname, vol, eye) in &views {
            let view = view_of(vol, *eye);
            let d = position_drift(cfg, &view);
            let layout = Method::Er.layout(&view).unwrap();
            let longest = layout.grids.iter().map(|g| g.slices.len()).max().unwrap();
            eprintln!(
                "{cname}, {vname} ({} regions, longest {longest} slices): {} positions, \
                 worst {:.3} LSB = {:.2e} voxels, {:.2} of the bound",
                layout.grids.len(),
                d.count,
                d.worst / lsb,
                d.worst,
                d.ratio
            );
        }
    }
}
