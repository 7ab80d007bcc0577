//! Edge exceptions: fixed-point ray positions rarely disagree with
//! golden's float positions about whether a ray is inside a slice.

use pipeline::config::PipelineConfig;
use pipeline::datapath::Datapath;
use pipeline::fixed::{Format, Overflow, Quant, QuantStats};
use pipeline::host::plan;
use pipeline::tables::Tables;

use super::{prepare, Eye};
use crate::chip::subject;

/// Views for the edge-exception count: integer and non-integer eyes, eyes
/// on voxel centres and on voxel boundaries, and eyes whose region
/// boundaries `b_i = D (2^i - 1)` fall exactly on slices (`D` = 1, 3, 6, 31,
/// 48 give integer `b_i`).
fn edge_views() -> Vec<(&'static str, Eye)> {
    let eye = |axis, positive, d, off| Eye {
        axis,
        positive,
        d,
        off,
    };
    vec![
        ("sphere:24", eye(2, false, 3.0, [0.0, 0.0])),
        ("sphere:24", eye(2, false, 1.0, [0.5, -0.5])),
        ("sphere:24", eye(0, true, 6.0, [0.5, 0.0])),
        ("sphere:24", eye(1, false, 5.37, [0.731, -2.113])),
        (
            "ml:32",
            eye(
                2,
                true,
                23.0 / 7.0,
                [std::f64::consts::PI, -std::f64::consts::E],
            ),
        ),
        ("ml:32", eye(0, false, 31.0, [0.25, 0.75])),
        ("ml:32", eye(1, true, 7.75, [-4.5, 3.5])),
        ("checker:32", eye(2, false, 48.0, [0.0, 0.0])),
        ("checker:32", eye(2, false, 0.4, [9.3, 11.1])),
    ]
}

/// Edge exceptions of one configuration over [`edge_views`].
#[derive(Debug, Default)]
struct EdgeCount {
    /// Rays (x, y) sampled in one decision and not in the other.
    exceptions: u64,
    /// Golden's samples.
    samples: u64,
    /// Closest any ray's fixed-point position came to a slice edge, in
    /// position LSBs (0: exactly on `-0.5` or `n - 0.5`).
    closest_lsb: i64,
    /// Exceptions per view.
    per_view: Vec<String>,
}

/// Counts, over every slice and every ray of every region of
/// [`edge_views`], the rays golden samples (its broadcast range) whose
/// fixed-point position under `cfg` is outside `[-0.5, n - 0.5]`, or the
/// other way round. A ray is a sample when it is inside on both axes.
fn count_edge_exceptions(cfg: &PipelineConfig) -> EdgeCount {
    let f = u32::from(cfg.position.frac());
    let half = 1i64 << (f - 1);
    let mut out = EdgeCount {
        closest_lsb: i64::MAX,
        ..EdgeCount::default()
    };
    for (spec, e) in edge_views() {
        let s = subject(spec);
        let prep = prepare(&s, e);
        let view = &prep.view;
        let dp = Datapath::new(*cfg, Tables::new(cfg, &s.lut).expect("tables"));
        let fp = plan(cfg, view).expect("plan");
        let mut st = QuantStats::default();
        let mut view_exceptions = 0;
        for region in &fp.regions {
            let g = &region.grid;
            for sp in &region.slices {
                let (_, range) = golden::sampling::slice_rays(view, g, sp.z);
                assert_eq!(sp.range, range, "the host broadcasts golden's ranges");
                // Per axis: golden's and the fixed-point decision for
                // every ray of the region.
                let inside: [Vec<(bool, bool)>; 2] = std::array::from_fn(|k| {
                    let (lo, hi) = (-half, (2 * view.dims[k] as i64 - 1) * half);
                    (g.lo[k]..=g.hi[k])
                        .map(|m| {
                            let gold = (range[k].0..=range[k].1).contains(&m);
                            let x = dp
                                .position(sp.a[k], sp.t[k], m, &mut st)
                                .expect("position")
                                .raw();
                            out.closest_lsb =
                                out.closest_lsb.min((x - lo).abs().min((x - hi).abs()));
                            (gold, x >= lo && x <= hi)
                        })
                        .collect()
                });
                let gx = inside[0].iter().filter(|v| v.0).count() as u64;
                let gy = inside[1].iter().filter(|v| v.0).count() as u64;
                out.samples += gx * gy;
                for &(gxi, fxi) in &inside[0] {
                    for &(gyi, fyi) in &inside[1] {
                        if (gxi && gyi) != (fxi && fyi) {
                            view_exceptions += 1;
                        }
                    }
                }
            }
        }
        out.per_view
            .push(format!("{spec} {e:?}: {view_exceptions}"));
        out.exceptions += view_exceptions;
    }
    out
}

/// The host broadcasts golden's per-slice ray ranges, so the array samples
/// the same rays as golden by construction. But a PE forms the ray's
/// position in fixed point (`a`, `t` rounded into `position` / `step`); a
/// ray whose fixed-point position lies on the other side of the slice
/// extent `[-0.5, n - 0.5]` than golden's f64 position is an "edge
/// exception": the hardware samples (clamped) where the decision was made
/// in float. With the default formats they must be fewer than 1 in 10^4
/// samples. So that the count is known to detect anything, a position
/// format with only 4 fraction bits must produce some.
#[test]
fn edge_exceptions_are_rare() {
    let cfg = PipelineConfig::default();
    let c = count_edge_exceptions(&cfg);
    eprintln!(
        "edge exceptions: {} of {} samples; closest fixed-point position to a slice edge: {} LSB\n  {}",
        c.exceptions,
        c.samples,
        c.closest_lsb,
        c.per_view.join("\n  ")
    );
    assert!(
        c.samples > 100_000,
        "{} samples is too few to judge",
        c.samples
    );
    assert!(
        (c.exceptions as f64) < c.samples as f64 * 1e-4,
        "{} edge exceptions in {} samples:\n  {}",
        c.exceptions,
        c.samples,
        c.per_view.join("\n  ")
    );

    let coarse = PipelineConfig {
        position: Format::new(20, 4, true, Quant::Rnd, Overflow::Sat).expect("format"),
        ..cfg
    };
    let c = count_edge_exceptions(&coarse);
    eprintln!(
        "edge exceptions with 4 position fraction bits: {} of {}",
        c.exceptions, c.samples
    );
    assert!(c.exceptions > 0, "the count cannot see rounding errors");
}
