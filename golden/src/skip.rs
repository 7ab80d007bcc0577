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
use crate::warp::{pixel_to_base, PixelWindow};

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
        SampleMask::within(view, layout, spec, None)
    }

    /// [`SampleMask::new`] for a frame whose image is needed only in
    /// `window` (the gaze-directed ER frame's levels, [`crate::ergaze`]):
    /// rays are culled to what the warp reads for those pixels, whatever
    /// `spec.cull` says, so the window's pixels have the bits of the whole
    /// frame and the rest are not computed.
    pub fn within(
        view: &View,
        layout: &Layout,
        spec: MaskSpec,
        window: Option<&PixelWindow>,
    ) -> SampleMask {
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
        let keep = if cull || window.is_some() {
            let all = PixelWindow::all(view.size);
            needed(view, layout, ftb, window.unwrap_or(&all)).unwrap_or_else(|| full.clone())
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
    /// ascending, disjoint, non-empty: clipped rays and rays in empty
    /// blocks are left out. With substeps the row keeps all its rays here
    /// (the pipeline samples one substep); golden's substep path asks
    /// [`SampleMask::substep_runs`].
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
        let ny = self.dims[1] as f64;
        let cell = |v: f64| v.floor().clamp(0.0, ny - 1.0) as usize / o.block;
        let rows = cell(y - self.margin)..=cell(y + self.margin);
        if !o.rows_any(z, rows.clone()) {
            return;
        }
        self.block_runs(o, |w| o.word(z, rows.clone(), w), &[px], (lo, hi), out);
    }

    /// [`SampleMask::row_runs`] for `k > 1` substeps: the runs of rays
    /// `x.0..=x.1` on row `my` of slice `z` whose substep samples may read
    /// an occupied block, into `out` (cleared). A ray's substeps lie on its
    /// segment between depths `z - 1/2` and `z + 1/2`, where its positions
    /// are `px[0]`, `py[0]` and `px[1]`, `py[1]` (the affine positions of
    /// the row's rays at those depths, `py` at row `my`), and each
    /// trilinear sample reads slices `z - 1 ..= z + 1`. Clip planes are
    /// left to the caller, which tests every substep. A skipped ray's
    /// substeps would all classify to zero opacity and composite nothing,
    /// so skipping leaves the image bit for bit unchanged.
    pub fn substep_runs(
        &self,
        z: usize,
        px: [Affine; 2],
        py: [f64; 2],
        x: (i64, i64),
        out: &mut Vec<(i64, i64)>,
    ) {
        out.clear();
        if x.0 > x.1 {
            return;
        }
        let Some(o) = &self.occ else {
            out.push(x);
            return;
        };
        let ny = self.dims[1] as f64;
        let cell = |v: f64| v.floor().clamp(0.0, ny - 1.0) as usize / o.block;
        let rows = cell(py[0].min(py[1]) - self.margin)..=cell(py[0].max(py[1]) + self.margin);
        let (lo, hi) = self.slice_span(z, self.dims[2]);
        let slices = lo..=hi;
        if !slices.clone().any(|s| o.rows_any(s, rows.clone())) {
            return;
        }
        let occupied = |w: usize| {
            slices
                .clone()
                .fold(0, |acc, s| acc | o.word(s, rows.clone(), w))
        };
        self.block_runs(o, occupied, &px, x, out);
    }

    /// The runs of rays `lo..=hi` whose positions (between the affine
    /// positions `px` of each ray, widened by the margin) fall in the
    /// blocks `occupied` marks (its word `w`: blocks `64 w ..`, see
    /// [`ViewOccupancy::word`]), appended to `out` in ascending order.
    fn block_runs(
        &self,
        o: &ViewOccupancy,
        occupied: impl Fn(usize) -> u64,
        px: &[Affine],
        (lo, hi): (i64, i64),
        out: &mut Vec<(i64, i64)>,
    ) {
        let b = o.block as f64;
        let nbx = o.counts[0];
        // A substep in front of slice 0 can lie behind an eye that close to
        // the face, where positions fall with the ray index; the bounds
        // below assume they grow, so such a row keeps every ray of a run.
        let growing = px.iter().all(|p| p.t > 0.0 && p.t.is_finite());
        set_runs(o.words(), nbx, occupied, |b0, b1| {
            // Cells b0 B ..= (b1 + 1) B - 1 are occupied; the first and last
            // blocks also hold the positions clamped onto the edge voxels.
            // A ray is kept when any of its positions reaches the run, so
            // the first ray is the least and the last the greatest over the
            // affines (positions grow with the ray index: `t > 0`).
            let m_lo = if b0 == 0 || !growing {
                lo
            } else {
                px.iter()
                    .map(|p| (((b0 as f64 * b - self.margin) - p.a) / p.t).floor() as i64)
                    .min()
                    .unwrap_or(lo)
            };
            let m_hi = if b1 + 1 == nbx || !growing {
                hi
            } else {
                px.iter()
                    .map(|p| ((((b1 + 1) as f64 * b + self.margin) - p.a) / p.t).ceil() as i64)
                    .max()
                    .unwrap_or(hi)
            };
            let run = (m_lo.max(lo), m_hi.min(hi));
            if run.0 <= run.1 {
                match out.last_mut() {
                    Some(last) if last.1 + 1 >= run.0 => last.1 = last.1.max(run.1),
                    _ => out.push(run),
                }
            }
        });
    }
}

/// Calls `emit(first, last)` for each run of set bits, in ascending order,
/// of the `n` bits held in `words` words (`word(w)`: bits `64 w ..`, those
/// at `n` and past it clear).
fn set_runs(
    words: usize,
    n: usize,
    word: impl Fn(usize) -> u64,
    mut emit: impl FnMut(usize, usize),
) {
    let mut start = None;
    for w in 0..words {
        let x = word(w);
        let mut from = 0u32;
        while from < 64 {
            // Inside a run look for its first clear bit, else for a set one.
            let y = if start.is_some() { !x } else { x };
            let ahead = y & (u64::MAX << from);
            if ahead == 0 {
                break;
            }
            let k = ahead.trailing_zeros();
            let at = w * 64 + k as usize;
            match start.take() {
                Some(s) => emit(s, at - 1),
                None => start = Some(at),
            }
            from = k;
        }
    }
    if let Some(s) = start {
        emit(s, n - 1);
    }
}

/// Per region, the rays whose result can reach the image: region 0's rays
/// under the warp's reach, and behind them what the merges (and, front to
/// back, the splits) carry into those. `None` when the image's rays do not
/// all meet the baseplane (no bound).
fn needed(
    view: &View,
    layout: &Layout,
    ftb: bool,
    window: &PixelWindow,
) -> Option<Vec<[(i64, i64); 2]>> {
    let base = layout.baseplane();
    let m = pixel_to_base(view, &base);
    let (mut umin, mut umax) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
    // The map is projective and every corner is in front of the eye (or
    // there is no bound), so the window's image on the baseplane lies in
    // the box of its corners' images.
    for (px, py) in window.corners() {
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

#[cfg(test)]
mod tests {
    use super::set_runs;
    use proptest::prelude::*;

    proptest! {
        /// The runs a word at a time are the runs a bit at a time, across
        /// word edges and at the last bit.
        #[test]
        fn set_runs_are_the_bitwise_runs(
            bits in prop::collection::vec(any::<bool>(), 0..300),
            dense in any::<bool>(),
        ) {
            // Long runs as well as random ones.
            let bits: Vec<bool> = if dense {
                bits.iter().enumerate().map(|(i, &b)| b || i % 97 > 20).collect()
            } else {
                bits
            };
            let n = bits.len();
            let words = n.div_ceil(64).max(1);
            let mut packed = vec![0u64; words];
            for (i, &b) in bits.iter().enumerate() {
                packed[i / 64] |= u64::from(b) << (i % 64);
            }
            let mut got = Vec::new();
            set_runs(words, n, |w| packed[w], |a, b| got.push((a, b)));
            let mut want = Vec::new();
            let mut i = 0;
            while i < n {
                if bits[i] {
                    let s = i;
                    while i + 1 < n && bits[i + 1] {
                        i += 1;
                    }
                    want.push((s, i));
                }
                i += 1;
            }
            prop_assert_eq!(got, want);
        }
    }
}
