//! What a slice-order frame need not sample, decided once per view and
//! shared by golden and the pipeline's controller (one source of truth for
//! which samples are taken):
//!
//! - **empty space**: slices, ray rows (beams) and runs of rays whose
//!   samples fall in blocks the [`crate::occupancy`] map calls empty;
//! - **culling**: rays whose result cannot reach the final image (outside
//!   what the warp reads, traced back through the merges), and regions
//!   behind the last visible slice;
//! - **clipping**: rays whose sample lies beyond a [`crate::clip`] plane.
//!
//! Empty-space skipping and culling never change the image: a skipped
//! sample would have composited zero opacity, a culled ray feeds no pixel.
//! Clipping does change it, by definition. Early ray termination is not
//! here: it depends on the rays' state, which [`crate::methods`] keeps.
//!
//! Empty-space runs are decided on the exact `f64` ray positions widened
//! by a margin, so that a renderer whose own position of a ray differs
//! from the exact one by less than the margin (golden's `f32`, the
//! pipeline's fixed point) never skips a ray whose interpolation cell it
//! would place in an occupied block.

use crate::clip::ViewClip;
use crate::geometry::{Affine, Layout, Merge, View};
use crate::occupancy::{Occupancy, ViewOccupancy};
use crate::warp::pixel_to_base;

/// Position margin of golden's empty-space runs (voxels): far above the
/// `f32` rounding of a ray position (below `2^-10` voxel for volumes up to
/// 8192 voxels wide).
pub const GOLDEN_MARGIN: f64 = 1.0 / 64.0;

/// Which of the image-preserving skips a frame applies.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Skips {
    /// Skip empty slices, beams and runs of rays.
    pub empty: bool,
    /// Skip rays that cannot reach the image and regions behind the volume.
    pub cull: bool,
}

impl Skips {
    /// Nothing skipped: every sample taken (the reference for the
    /// identity tests and what `--no-skip-empty --no-cull` runs).
    pub const NONE: Skips = Skips {
        empty: false,
        cull: false,
    };
    /// Empty-space skipping alone.
    pub const EMPTY: Skips = Skips {
        empty: true,
        cull: false,
    };
    /// Culling alone.
    pub const CULL: Skips = Skips {
        empty: false,
        cull: true,
    };
}

impl Default for Skips {
    fn default() -> Skips {
        Skips {
            empty: true,
            cull: true,
        }
    }
}

/// What a [`SampleMask`] skips and how.
#[derive(Debug, Clone)]
pub struct MaskSpec<'a> {
    /// The occupancy map (`None` skips no empty space).
    pub occupancy: Option<&'a Occupancy>,
    /// Clip planes in view space.
    pub clip: ViewClip,
    /// Cull rays that cannot reach the image.
    pub cull: bool,
    /// Keep what the front-to-back split needs (er-ftb).
    pub ftb: bool,
    /// Widening of empty-space runs in voxels (see the module notes).
    pub margin: f64,
    /// Samples per slice crossing.
    pub substeps: u32,
}

/// What a frame samples: per region the rays that matter, per slice
/// whether anything is visible, per row the runs of rays to sample.
#[derive(Debug, Clone)]
pub struct SampleMask {
    occ: Option<ViewOccupancy>,
    clip: ViewClip,
    keep: Vec<[(i64, i64); 2]>,
    dims: [usize; 3],
    margin: f64,
    substeps: u32,
    /// Regions to run, front ones first.
    regions: usize,
    /// Rays removed by culling, summed over regions.
    pub culled_rays: u64,
}

impl SampleMask {
    /// The mask of `layout` for `view`, as `spec` asks.
    pub fn new(view: &View, layout: &Layout, spec: MaskSpec) -> SampleMask {
        let MaskSpec {
            occupancy: occ,
            clip,
            cull,
            ftb,
            margin,
            substeps,
        } = spec;
        let occ = occ.map(|o| ViewOccupancy::new(o, &view.axes, view.dims[2]));
        let full: Vec<[(i64, i64); 2]> = layout
            .grids
            .iter()
            .map(|g| [(g.lo[0], g.hi[0]), (g.lo[1], g.hi[1])])
            .collect();
        let keep = if cull {
            needed(view, layout, ftb).unwrap_or_else(|| full.clone())
        } else {
            full.clone()
        };
        let count = |r: &[(i64, i64); 2]| {
            r.iter()
                .map(|&(l, h)| (h - l + 1).max(0) as u64)
                .product::<u64>()
        };
        let culled_rays = full
            .iter()
            .zip(&keep)
            .map(|(f, k)| count(f) - count(k))
            .sum();
        let mut mask = SampleMask {
            occ,
            clip,
            keep,
            dims: view.dims,
            margin,
            substeps,
            regions: layout.grids.len(),
            culled_rays,
        };
        if cull {
            // Regions wholly behind the last visible slice composite nothing.
            let last = mask.last_visible_slice();
            mask.regions = layout
                .grids
                .iter()
                .rposition(|g| last.is_some_and(|z| g.slices.start <= z))
                .map_or(1, |i| i + 1);
        }
        mask
    }

    /// How many regions, front ones first, a frame runs: with culling,
    /// none behind the last visible slice (at least region 0, which
    /// carries the baseplane).
    pub fn regions_to_run(&self) -> usize {
        self.regions
    }

    /// A mask that skips nothing (clip planes still apply).
    pub fn everything(view: &View, layout: &Layout, clip: ViewClip, substeps: u32) -> SampleMask {
        let spec = MaskSpec {
            occupancy: None,
            clip,
            cull: false,
            ftb: false,
            margin: 0.0,
            substeps,
        };
        SampleMask::new(view, layout, spec)
    }

    /// The view-space clip planes.
    pub fn clip(&self) -> &ViewClip {
        &self.clip
    }

    /// The occupancy map as the view sees it, if empty space is skipped.
    pub fn occupancy(&self) -> Option<&ViewOccupancy> {
        self.occ.as_ref()
    }

    /// The rays of region `i` that can reach the image, per axis.
    pub fn kept(&self, i: usize) -> [(i64, i64); 2] {
        self.keep[i]
    }

    /// True when slice `z` may hold a visible sample: some block it (and,
    /// with substeps, its neighbours) crosses is occupied and no clip
    /// plane removes all of it.
    pub fn slice_visible(&self, z: usize) -> bool {
        let [nx, ny, nz] = self.dims;
        if let Some(o) = &self.occ {
            let (lo, hi) = self.slice_span(z, nz);
            if !(lo..=hi).any(|s| o.slice_any(s)) {
                return false;
            }
        }
        !self
            .clip
            .drops_rect([-0.5, nx as f64 - 0.5], [-0.5, ny as f64 - 0.5], z as f64)
    }

    /// Slices whose blocks a sample of slice `z` may read.
    fn slice_span(&self, z: usize, nz: usize) -> (usize, usize) {
        if self.substeps > 1 {
            (z.saturating_sub(1), (z + 1).min(nz - 1))
        } else {
            (z, z)
        }
    }

    /// The last slice that may hold a visible sample; regions behind it
    /// need not run.
    pub fn last_visible_slice(&self) -> Option<usize> {
        (0..self.dims[2]).rev().find(|&z| self.slice_visible(z))
    }

    /// Rows and columns of region `i`'s rays that sample slice `range`
    /// (from [`crate::sampling::slice_rays`]) and matter.
    pub fn rays(&self, i: usize, range: [(i64, i64); 2]) -> [(i64, i64); 2] {
        std::array::from_fn(|k| {
            let (l, h) = self.keep[i][k];
            (range[k].0.max(l), range[k].1.min(h))
        })
    }

    /// The runs of rays `x.0..=x.1` (positions `px.a + m px.t`) on the row
    /// at `y` of slice `z` that must be sampled, into `out` (cleared):
    /// ascending, disjoint, non-empty. With substeps the clip planes are
    /// tested per substep by the caller and the row keeps all its rays;
    /// otherwise clipped rays and rays in empty blocks are left out.
    pub fn row_runs(&self, z: usize, px: Affine, y: f64, x: (i64, i64), out: &mut Vec<(i64, i64)>) {
        out.clear();
        if x.0 > x.1 {
            return;
        }
        if self.substeps > 1 {
            out.push(x);
            return;
        }
        let (lo, hi) = self.clip.narrow(px.a, px.t, y, z as f64, x);
        if lo > hi {
            return;
        }
        let Some(o) = &self.occ else {
            out.push((lo, hi));
            return;
        };
        let (b, ny) = (o.block as f64, self.dims[1] as f64);
        let cell = |v: f64| v.floor().clamp(0.0, ny - 1.0) as usize / o.block;
        let rows = cell(y - self.margin)..=cell(y + self.margin);
        if !o.rows_any(z, rows.clone()) {
            return;
        }
        let nbx = o.counts[0];
        let mut bx = 0;
        while bx < nbx {
            if !o.block(z, rows.clone(), bx) {
                bx += 1;
                continue;
            }
            let b0 = bx;
            while bx + 1 < nbx && o.block(z, rows.clone(), bx + 1) {
                bx += 1;
            }
            // Cells b0 B ..= (bx + 1) B - 1 are occupied; the first and last
            // blocks also hold the positions clamped onto the edge voxels.
            let m_lo = if b0 == 0 {
                lo
            } else {
                (((b0 as f64 * b - self.margin) - px.a) / px.t).floor() as i64
            };
            let m_hi = if bx + 1 == nbx {
                hi
            } else {
                ((((bx + 1) as f64 * b + self.margin) - px.a) / px.t).ceil() as i64
            };
            let run = (m_lo.max(lo), m_hi.min(hi));
            if run.0 <= run.1 {
                match out.last_mut() {
                    Some(last) if last.1 + 1 >= run.0 => last.1 = last.1.max(run.1),
                    _ => out.push(run),
                }
            }
            bx += 1;
        }
    }
}

/// Per region, the rays whose result can reach the image: region 0's rays
/// under the warp's reach, and behind them what the merges (and, front to
/// back, the splits) carry into those. `None` when the image's rays do not
/// all meet the baseplane (no bound).
fn needed(view: &View, layout: &Layout, ftb: bool) -> Option<Vec<[(i64, i64); 2]>> {
    let base = layout.baseplane();
    let m = pixel_to_base(view, &base);
    let [w, h] = view.size.map(f64::from);
    let (mut umin, mut umax) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
    for (px, py) in [
        (0.5, 0.5),
        (w - 0.5, 0.5),
        (0.5, h - 0.5),
        (w - 0.5, h - 0.5),
    ] {
        let q = m * glam::DVec3::new(px, py, 1.0);
        // Not in front of the eye (or not a number): no bound.
        if q.z.is_nan() || q.z <= 0.0 {
            return None;
        }
        for (k, u) in [q.x / q.z, q.y / q.z].into_iter().enumerate() {
            umin[k] = umin[k].min(u);
            umax[k] = umax[k].max(u);
        }
    }
    // The warp reads samples within one baseplane voxel (`1 / spacing`
    // samples) of a pixel's position; one more sample of margin.
    let half = 1.0 / base.spacing;
    let g0 = &layout.grids[0];
    let clampi = |v: f64| v.clamp(-(1i64 << 52) as f64, (1i64 << 52) as f64) as i64;
    let mut keep = vec![[(0i64, -1i64); 2]; layout.grids.len()];
    keep[0] = std::array::from_fn(|k| {
        let lo = g0.lo[k] + clampi((umin[k] - half).floor()) - 1;
        let hi = g0.lo[k] + clampi((umax[k] + half).ceil()) + 1;
        (lo.max(g0.lo[k]), hi.min(g0.hi[k]))
    });
    for i in 1..layout.grids.len() {
        let g = &layout.grids[i];
        keep[i] = std::array::from_fn(|k| {
            let (lo, hi) = keep[i - 1][k];
            if lo > hi {
                return (0, -1);
            }
            let (l, h) = match layout.merge {
                Some(Merge::Box) => (2 * lo, 2 * hi + 1),
                _ => (2 * lo - 1, 2 * hi + 1),
            };
            (l.max(g.lo[k]), h.min(g.hi[k]))
        });
    }
    if ftb {
        // A child's split reads parents floor(c / 2) ..= ceil(c / 2).
        for i in (0..layout.grids.len() - 1).rev() {
            let g = &layout.grids[i];
            keep[i] = std::array::from_fn(|k| {
                let (cl, ch) = keep[i + 1][k];
                let (l, h) = keep[i][k];
                if cl > ch {
                    return (l, h);
                }
                let (pl, ph) = (cl.div_euclid(2), (ch + 1).div_euclid(2));
                let (l, h) = if l > h {
                    (pl, ph)
                } else {
                    (l.min(pl), h.max(ph))
                };
                (l.max(g.lo[k]), h.min(g.hi[k]))
            });
        }
    }
    Some(keep)
}
