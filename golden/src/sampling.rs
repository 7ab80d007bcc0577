//! One region's slices: every ray of the region that crosses a slice
//! samples the volume there, classifies the sample post-interpolation,
//! corrects its opacity for the ray's step length and composites it, for
//! the rays and slices the frame's [`SampleMask`] keeps.
//!
//! With one substep (the paper's scheme) a ray takes one bilinear sample
//! where it crosses slice `z`. With `k > 1` substeps it takes `k` samples
//! spread evenly over the slice's thickness, at `z + (j + 1/2)/k - 1/2`
//! along the ray, each trilinear between the two nearest slices, and each
//! with `1/k` of the step's path length. Sampling only at integer `z`
//! misses the soft half of every boundary layer that trilinear
//! reconstruction puts between slices (a hard-edged cube's face is seen as
//! a step at the half-way plane); two substeps remove most of that bias.
//!
//! The pipeline's PEs mirror [`sample_region`] sample for sample: the same
//! rays (from [`crate::geometry`]), positions, slopes and compositing order.

mod lanes;
mod preint;

use rayon::prelude::*;

use self::lanes::LANES;
use self::preint::TapCache;

use crate::geometry::{inside, Affine, RayGrid, View};
use crate::merge::Rgba;
use crate::preint::{segment_attenuation, segment_exact, segment_opacity, Colouring, PreTable};
use crate::shading::Shader;
use crate::skip::SampleMask;
use crate::slices::{Plane, SliceStack};
use crate::tf::{correct_opacity, Lut};
use crate::voi::ViewVoi;

/// Compositing direction.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Order {
    /// `C = c' + (1 - a') C`, `A = a' + (1 - a') A`.
    BackToFront,
    /// `C += (1 - A) c'`, `A += (1 - A) a'`; rays at or above `terminate`
    /// opacity take no more samples (1.0 disables termination).
    FrontToBack {
        /// Early-termination opacity threshold.
        terminate: f32,
    },
}

/// Largest number of substeps per slice.
pub const MAX_SUBSTEPS: u32 = 8;

/// The ray index ranges of `grid` that sample slice `z`, per axis, and the
/// rays' affine positions there.
pub fn slice_rays(view: &View, grid: &RayGrid, z: usize) -> ([Affine; 2], [(i64, i64); 2]) {
    let p: [Affine; 2] = std::array::from_fn(|k| grid.at(view.eye, view.d, z as f64, k));
    let r = std::array::from_fn(|k| {
        let (lo, hi) = inside(p[k], view.dims[k]);
        (lo.max(grid.lo[k]), hi.min(grid.hi[k]))
    });
    (p, r)
}

/// What every region of one frame shares.
#[derive(Clone, Copy)]
pub struct Pass<'a> {
    /// The view.
    pub view: &'a View,
    /// The permuted volume.
    pub stack: &'a SliceStack,
    /// The classification table.
    pub lut: &'a Lut,
    /// Which rays sample which slices.
    pub mask: &'a SampleMask,
    /// Compositing direction.
    pub order: Order,
    /// Samples per slice crossing.
    pub substeps: u32,
    /// Shading before compositing, if any.
    pub shader: Option<&'a Shader>,
    /// A volume of interest scaling opacity, if any.
    pub voi: Option<&'a ViewVoi>,
    /// Pre-integrated classification of each slice step (one substep,
    /// no shading or volume of interest), if any.
    pub preint: Option<&'a PreTable>,
    /// Plain samples in batches of rays ([`crate::methods::Options::lanes`]).
    pub lanes: bool,
    /// At most the table's [`Lut::clear_below`]: a batch of plain samples
    /// whose table positions all lie below it composites nothing and stops
    /// early (`f32::NEG_INFINITY` never stops one).
    pub clear_below: f32,
}

/// What sampling one region did.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct RegionCount {
    /// Ray crossings sampled per slice of the region (`grid.slices` order).
    pub samples: Vec<u64>,
    /// Ray rows (beams) of sampled slices that sampled nothing because
    /// their blocks are empty, their rays are clipped or all their rays
    /// have terminated.
    pub beams_skipped: u64,
    /// Slices skipped whole (empty or clipped away).
    pub slices_skipped: u64,
}

/// One slice of a region as every row sees it.
struct SliceGeom<'a> {
    z: usize,
    px: Affine,
    py: Affine,
    /// Rays sampling the slice, per axis (after culling).
    x: (i64, i64),
    y: (i64, i64),
    data: Plane<'a>,
    /// Padded slice `z + 1` (the padding behind the last slice).
    next: Plane<'a>,
    visible: bool,
    /// With substeps or pre-integration: the rays' positions (`x` affine, `y` affine) at the
    /// first and last substep's depth, where empty-space runs are decided.
    reach: Option<[[Affine; 2]; 2]>,
}

/// The first live ray at or after `i` in one row's "next live ray" links
/// (path compression: a row visits only live rays, and a row whose rays
/// have all stopped costs one lookup).
#[inline]
fn find(next: &mut [u32], mut i: usize) -> usize {
    let mut r = i;
    while next[r] as usize != r {
        r = next[r] as usize;
    }
    while next[i] as usize != r {
        let n = next[i] as usize;
        next[i] = r as u32;
        i = n;
    }
    r
}

/// Samples every slice of region `region` (`grid`, ray states in `buf`)
/// for every ray the pass's mask keeps, with `substeps` samples per
/// crossing, compositing in `order` (back to front: the region's slices
/// from the rear). Rays of one region never meet until the region ends,
/// so each ray row walks all the region's slices on its own: one parallel
/// pass per region, and a row's rays stay in cache. Front to back, a ray
/// at or above the termination threshold takes no more samples.
pub fn sample_region(pass: &Pass, region: usize, grid: &RayGrid, buf: &mut [Rgba]) -> RegionCount {
    let Pass {
        view,
        stack,
        mask,
        order,
        ..
    } = *pass;
    let zs: Vec<usize> = match order {
        Order::BackToFront => grid.slices.clone().rev().collect(),
        Order::FrontToBack { .. } => grid.slices.clone().collect(),
    };
    let geo: Vec<SliceGeom> = zs
        .iter()
        .map(|&z| {
            let ([px, py], range) = slice_rays(view, grid, z);
            let [x, y] = mask.rays(region, range);
            let span = if pass.preint.is_some() {
                // The step [z, z + 1] (a half step at either face).
                Some(preint_span(z, view.dims[2]))
            } else {
                (pass.substeps > 1).then(|| {
                    let h = 0.5 - 0.5 / pass.substeps as f64;
                    [-h, h]
                })
            };
            let reach = span.map(|span| {
                span.map(|o| {
                    let at = |k| grid.at(view.eye, view.d, z as f64 + o, k);
                    [at(0), at(1)]
                })
            });
            SliceGeom {
                z,
                px,
                py,
                x,
                y,
                data: stack.slice(z),
                next: stack.slice(z + 1),
                visible: mask.slice_visible(z),
                reach,
            }
        })
        .collect();
    let n = zs.len();
    let mut count = RegionCount {
        samples: vec![0; grid.slices.len()],
        slices_skipped: geo.iter().filter(|g| !g.visible).count() as u64,
        beams_skipped: 0,
    };
    let w = grid.counts()[0];
    if w == 0 || geo.iter().all(|g| !g.visible) {
        return count;
    }
    // A threshold of 1 disables termination: even an opaque ray samples on
    // (it composites nothing more), as in the pipeline.
    let terminate = match order {
        Order::FrontToBack { terminate } if terminate < 1.0 => terminate,
        _ => f32::INFINITY,
    };
    let links = terminate.is_finite();
    let at = |m: i64| (m - grid.lo[0]) as usize;
    let x_terms: Vec<f32> = (0..w)
        .map(|c| RayRow::path_x_term(pass, grid, grid.lo[0] + c as i64))
        .collect();
    let row_pass = |acc: &mut RowScratch, r: usize, row: &mut [Rgba]| {
        let RowScratch {
            counts,
            beams,
            runs,
            next,
            ds,
            taps,
        } = acc;
        let my = grid.lo[1] + r as i64;
        ds.clear();
        taps.clear();
        // The one-ray path of `Options::lanes = false` takes both taps of
        // every step: the slow path the cache is tested against.
        if pass.preint.is_some() && pass.lanes {
            taps.resize(w, TapCache::NONE);
        }
        if links {
            next.clear();
            next.extend(row.iter().enumerate().map(|(i, ray)| {
                if ray[3] >= terminate {
                    i as u32 + 1
                } else {
                    i as u32
                }
            }));
            next.push(w as u32);
        }
        for (s, g) in geo.iter().enumerate() {
            if !g.visible || my < g.y.0 || my > g.y.1 || g.x.0 > g.x.1 {
                continue;
            }
            let mut first = g.x.0;
            if links {
                // A row whose rays in range have all stopped is skipped.
                let f = find(next, at(g.x.0));
                if f > at(g.x.1) {
                    *beams += 1;
                    continue;
                }
                first = grid.lo[0] + f as i64;
            }
            let yf = g.py.a + my as f64 * g.py.t;
            match g.reach {
                Some([f, b]) => {
                    let ys = [f[1].a + my as f64 * f[1].t, b[1].a + my as f64 * b[1].t];
                    mask.substep_runs(g.z, [f[0], b[0]], ys, (first, g.x.1), runs);
                }
                None => mask.row_runs(g.z, g.px, yf, (first, g.x.1), runs),
            }
            if runs.is_empty() {
                *beams += 1;
                continue;
            }
            if ds.is_empty() {
                // A ray's path length per slice is constant over a region.
                // Its column's term is shared by every row of the region.
                let y_term = RayRow::path_y_term(pass, grid, my);
                ds.extend(x_terms.iter().map(|&x| RayRow::path(x, y_term)));
            }
            let ray_row = RayRow::new(pass, grid, g, my, yf, ds);
            let mut taken = 0u64;
            if let Some(kind) = ray_row.batch() {
                // A ray's termination only stops its later slices, so a
                // batch may gather live rays before any of them composites.
                let mut batch = [0usize; LANES];
                for &(m0, m1) in runs.iter() {
                    let (mut i, end) = (at(m0), at(m1));
                    if links {
                        i = find(next, i);
                    }
                    while i <= end {
                        let mut k = 0;
                        while k < LANES && i <= end {
                            batch[k] = i;
                            k += 1;
                            i = if links { find(next, i + 1) } else { i + 1 };
                        }
                        ray_row.sample_batch(kind, row, &batch[..k]);
                        taken += k as u64;
                        if links {
                            for &j in &batch[..k] {
                                if row[j][3] >= terminate {
                                    next[j] = j as u32 + 1;
                                }
                            }
                        }
                    }
                }
                counts[s] += taken;
                continue;
            }
            for &(m0, m1) in runs.iter() {
                if !links {
                    for mx in m0..=m1 {
                        ray_row.sample(&mut row[at(mx)], mx, taps.get_mut(at(mx)));
                    }
                    taken += (m1 - m0 + 1) as u64;
                    continue;
                }
                let mut i = find(next, at(m0));
                while i <= at(m1) {
                    let ray = &mut row[i];
                    ray_row.sample(ray, grid.lo[0] + i as i64, taps.get_mut(i));
                    taken += 1;
                    if ray[3] >= terminate {
                        next[i] = i as u32 + 1;
                    }
                    i = find(next, i + 1);
                }
            }
            counts[s] += taken;
        }
    };
    let (per_slice, beams) = buf
        .par_chunks_mut(w)
        .enumerate()
        .fold(
            || RowScratch {
                counts: vec![0u64; n],
                beams: 0,
                runs: Vec::new(),
                next: Vec::new(),
                ds: Vec::new(),
                taps: Vec::new(),
            },
            |mut acc, (r, row)| {
                row_pass(&mut acc, r, row);
                acc
            },
        )
        .map(|a| (a.counts, a.beams))
        .reduce(
            || (vec![0u64; n], 0),
            |(mut a, x), (b, y)| {
                a.iter_mut().zip(b).for_each(|(a, b)| *a += b);
                (a, x + y)
            },
        );
    for (g, c) in geo.iter().zip(per_slice) {
        count.samples[g.z - grid.slices.start] = c;
    }
    count.beams_skipped = beams;
    count
}

/// One worker's counts and scratch while it walks ray rows.
struct RowScratch {
    /// Samples per slice of the region.
    counts: Vec<u64>,
    /// Beams skipped.
    beams: u64,
    /// The current row's runs.
    runs: Vec<(i64, i64)>,
    /// The current row's "next live ray" links.
    next: Vec<u32>,
    /// The current row's path lengths per slice step, per ray.
    ds: Vec<f32>,
    /// Pre-integrated: per ray of the current row its last scalar taken at
    /// a slice's own position and that slice ([`TapCache`]).
    taps: Vec<TapCache>,
}

/// One ray row crossing one slice: what its rays share.
struct RayRow<'a> {
    pass: &'a Pass<'a>,
    grid: &'a RayGrid,
    z: usize,
    px: Affine,
    data: Plane<'a>,
    next: Plane<'a>,
    y: f32,
    slope_y: f32,
    inv: f64,
    /// Path length per slice step of each ray of the row.
    ds: &'a [f32],
    /// Pre-integrated, when the step ends on slice `z + 1`: the rays' `x`
    /// there and the row's `y` (clamped into the padding), the positions
    /// slice `z + 1` samples them at itself.
    back: Option<(Affine, f32)>,
}

impl<'a> RayRow<'a> {
    fn new(
        pass: &'a Pass<'a>,
        grid: &'a RayGrid,
        g: &SliceGeom<'a>,
        my: i64,
        yf: f64,
        ds: &'a [f32],
    ) -> RayRow<'a> {
        let view = pass.view;
        let inv = 1.0 / (grid.z_ref + view.d);
        let slope_y = ((grid.phi[1] + my as f64 - view.eye.y) * inv) as f32;
        let whole = g.z + 1 < view.dims[2];
        let back = match (pass.preint, g.reach) {
            (Some(_), Some([_, [bx, by]])) if whole => {
                let y = (by.a + my as f64 * by.t) as f32;
                Some((bx, y.clamp(-1.0, pass.stack.dims[1] as f32 - 1e-3)))
            }
            _ => None,
        };
        RayRow {
            pass,
            grid,
            z: g.z,
            px: g.px,
            data: g.data,
            next: g.next,
            y: yf as f32,
            slope_y,
            inv,
            ds,
            back,
        }
    }

    /// A ray's world path length per slice step (its slopes are constant
    /// over the region) from its column's and its row's terms
    /// ([`RayRow::path_x_term`], [`RayRow::path_y_term`]):
    /// `sqrt((slope_x sx)^2 + ((slope_y sy)^2 + sz^2))`.
    #[inline(always)]
    fn path(x_term: f32, y_term: f32) -> f32 {
        (x_term + y_term).sqrt()
    }

    /// Column `mx`'s term of [`RayRow::path`], `(slope_x sx)^2`.
    fn path_x_term(pass: &Pass, grid: &RayGrid, mx: i64) -> f32 {
        let view = pass.view;
        let inv = 1.0 / (grid.z_ref + view.d);
        let slope_x = ((grid.phi[0] + mx as f64 - view.eye.x) * inv) as f32;
        (slope_x * view.spacing[0] as f32).powi(2)
    }

    /// Row `my`'s term of [`RayRow::path`], `(slope_y sy)^2 + sz^2`.
    fn path_y_term(pass: &Pass, grid: &RayGrid, my: i64) -> f32 {
        let view = pass.view;
        let inv = 1.0 / (grid.z_ref + view.d);
        let [sy, sz] = [view.spacing[1] as f32, view.spacing[2] as f32];
        let slope_y = ((grid.phi[1] + my as f64 - view.eye.y) * inv) as f32;
        (slope_y * sy).powi(2) + sz * sz
    }

    /// Ray `mx`'s samples in this slice, composited into `ray` (`slot`:
    /// its tap cache in a pre-integrated frame).
    #[inline(always)]
    fn sample(&self, ray: &mut Rgba, mx: i64, slot: Option<&mut TapCache>) {
        let Pass {
            view,
            stack,
            lut,
            mask,
            order,
            substeps,
            shader,
            voi,
            preint,
            ..
        } = *self.pass;
        let (y, slope_y, z) = (self.y, self.slope_y, self.z);
        let x = (self.px.a + mx as f64 * self.px.t) as f32;
        let ds = self.ds[(mx - self.grid.lo[0]) as usize];
        if let Some(pt) = preint {
            let clip = mask.clip();
            if !clip.is_empty() && !clip.keeps(x.into(), y.into(), z as f64) {
                return;
            }
            let slope_x = ((self.grid.phi[0] + mx as f64 - view.eye.x) * self.inv) as f32;
            let [front, back] = preint_span(z, view.dims[2]).map(|o| o as f32);
            let (sf, sb) = self.step_scalars(mx, (x, slope_x), slot);
            // A volume of interest scales the segment's extinction by its
            // factor at the segment's middle (the colour stays).
            let factor = |o: f32| {
                voi.map_or(1.0, |v| {
                    v.factor_f32(x + o * slope_x, y + o * slope_y, z as f32 + o)
                })
            };
            let step = |ray: &mut Rgba, s0: f32, s1: f32, len: f32, f: f32| {
                let (e, k) = pt.lookup_with_slope(s0, s1);
                if pt.colouring() == Colouring::Exact {
                    let (a, at) = segment_exact(e[3] * f, len);
                    if a > 0.0 {
                        let c = pt.layered_colour(s0, s1, &e, at);
                        composite_alpha(ray, [c[0], c[1], c[2], 0.0], a, order);
                    }
                    return;
                }
                let (a, h) = match pt.colouring() {
                    Colouring::Attenuated => segment_attenuation(e[3] * f, len),
                    _ => (segment_opacity(e[3] * f, len), 0.0),
                };
                if a > 0.0 {
                    let c = pt.step_colour(&e, &k, h);
                    composite_alpha(ray, [c[0], c[1], c[2], 0.0], a, order);
                }
            };
            // Slice 0 also owns the half step in front of it, at its scalar.
            let lead = (front < 0.0).then(|| (ds * -front, factor(front / 2.0)));
            let main = (ds * back, factor(back / 2.0));
            match order {
                Order::FrontToBack { .. } => {
                    if let Some((l, f)) = lead {
                        step(ray, sf, sf, l, f);
                    }
                    step(ray, sf, sb, main.0, main.1);
                }
                Order::BackToFront => {
                    step(ray, sf, sb, main.0, main.1);
                    if let Some((l, f)) = lead {
                        step(ray, sf, sf, l, f);
                    }
                }
            }
            return;
        }
        if substeps == 1 {
            let mut c = lut.lookup(stack.bilinear(self.data, x, y));
            if let Some(v) = voi {
                c[3] *= v.factor_f32(x, y, z as f32);
            }
            if c[3] > 0.0 {
                if let Some(sh) = shader {
                    c = sh.shade_f32(c, sh.gradient_bilinear(stack, z, x, y));
                }
                composite(ray, c, ds, order);
            }
            return;
        }
        let slope_x = ((self.grid.phi[0] + mx as f64 - view.eye.x) * self.inv) as f32;
        let clip = mask.clip();
        for j in 0..substeps {
            // Back-to-front walks the substeps from the rear.
            let j = match order {
                Order::BackToFront => substeps - 1 - j,
                Order::FrontToBack { .. } => j,
            };
            let o = (j as f32 + 0.5) / substeps as f32 - 0.5;
            let p = [x + o * slope_x, y + o * slope_y, z as f32 + o];
            // An eye less than half a slice in front of slice 0 has
            // substeps behind it, which its rays never reach.
            if p[2] + view.d as f32 <= 0.0 {
                continue;
            }
            if !clip.is_empty() && !clip.keeps(p[0].into(), p[1].into(), p[2].into()) {
                continue;
            }
            let mut c = lut.lookup(stack.trilinear_f32(p[0], p[1], p[2]));
            if let Some(v) = voi {
                c[3] *= v.factor_f32(p[0], p[1], p[2]);
            }
            if c[3] > 0.0 {
                if let Some(sh) = shader {
                    c = sh.shade_f32(c, sh.gradient_trilinear_f32(stack, p[0], p[1], p[2]));
                }
                composite(ray, c, ds / substeps as f32, order);
            }
        }
    }
}

/// The depths, relative to slice `z` of `nz`, where slice `z`'s
/// pre-integrated step begins and ends: `[0, 1]`, from `-1/2` at slice 0
/// and to `1/2` at the last slice (the volume's faces). The pipeline's
/// controller plans its pre-integrated skipping over the same steps.
pub fn preint_span(z: usize, nz: usize) -> [f64; 2] {
    [
        if z == 0 { -0.5 } else { 0.0 },
        if z + 1 >= nz { 0.5 } else { 1.0 },
    ]
}

/// Composites one classified sample `c` over a path of length `ds`.
#[inline(always)]
fn composite(ray: &mut Rgba, c: [f32; 4], ds: f32, order: Order) {
    composite_alpha(ray, c, correct_opacity(c[3], ds), order);
}

/// Composites colour `c` (its opacity ignored) at corrected opacity `a`.
#[inline(always)]
fn composite_alpha(ray: &mut Rgba, c: [f32; 4], a: f32, order: Order) {
    match order {
        Order::BackToFront => {
            let k = 1.0 - a;
            ray[0] = a * c[0] + k * ray[0];
            ray[1] = a * c[1] + k * ray[1];
            ray[2] = a * c[2] + k * ray[2];
            ray[3] = a + k * ray[3];
        }
        Order::FrontToBack { .. } => {
            let k = (1.0 - ray[3]) * a;
            ray[0] += k * c[0];
            ray[1] += k * c[1];
            ray[2] += k * c[2];
            ray[3] += k;
        }
    }
}
