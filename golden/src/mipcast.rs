//! 3D mip-map ray casting (Levoy and Whitaker): one perspective ray per
//! pixel whose samples grow apart with distance, each drawn from the two
//! levels of a [`MipMap`] that bracket the ray's footprint there.
//!
//! **Footprint.** Neighbouring pixel rays through `dir(px, py)` diverge by
//! `r |b_perp| / |dir|` and `r |c_perp| / |dir|` at world distance `r`
//! from the eye (`b`, `c` the per-pixel changes of direction, `_perp`
//! their parts across the ray), so a ray's footprint is `r * angle` with
//! `angle` the geometric mean of the two ([`Ray::angle`]): per ray, so the
//! wide-angle corners, whose pixels subtend less, are not blurred as the
//! centre is. The level is `L = log2(footprint / voxel)` (`voxel` the
//! geometric mean of the spacing: the paper sizes the level by the
//! mask's volume), clamped to `[0, top]`; a sample is trilinear in levels
//! `floor(L)` and `floor(L) + 1` and linear between them by `frac(L)`.
//!
//! **Steps.** The step at distance `r` is `k max(footprint, voxel)` with
//! `k` = [`MipOptions::step`] (default 1/2: two samples per voxel of the
//! level read, the Nyquist rate of its trilinear reconstruction). Near the
//! eye (footprint under a voxel) steps are uniform, `k voxel`; beyond they
//! grow geometrically by `1 + k angle` per sample. Step edges have a closed
//! form ([`Steps::edge`]), so a sample's position never depends on which
//! samples before it were taken or skipped; the steps tile the ray's path
//! through the volume exactly (the last is cut at the exit) and each
//! sample, at its step's midpoint, stands for the whole step: opacity per
//! unit length corrected as `1 - (1 - a)^ds`, colours composited
//! premultiplied front to back, as the reference does.
//!
//! **Skipping** (on unless [`MipOptions::skip_empty`] is false; exact). A
//! sample reads the cells of levels `lo <= hi` at its position; the cell of
//! level `l + 1` holds the parents of every voxel of the cell of level `l`
//! (checked in the module's tests and by the bit-identical test), so a
//! zero-opacity cell at a level `k >= hi` proves the sample transparent.
//! The walk takes the coarsest such `k` and jumps past every sample whose
//! midpoint lies in the box sharing that cell (shrunk by 1e-6 voxel against
//! rounding) and whose own `hi` is at most `k` (distance below
//! `2^k voxel / angle`): an octree descent per empty region, logarithmic in
//! its size. Early ray termination stops a ray once its opacity reaches
//! [`MipOptions::terminate`] (er-ftb's threshold; 1 disables it).

use glam::DVec3;
use rayon::prelude::*;

use crate::clip::ViewClip;
use crate::error::{input, Result};
use crate::geometry::{box_interval, View};
use crate::image::Image;
use crate::mipmap::{Classify, Level, MipMap};
use crate::occupancy::VisibleEntries;
use crate::shading::Shader;
use crate::tf::{correct_opacity, Lut};
use crate::voi::ViewVoi;

/// Settings of the mip-map ray caster.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MipOptions {
    /// Step as a fraction of `max(footprint, voxel)`.
    pub step: f64,
    /// Early ray termination opacity (1 disables it).
    pub terminate: f32,
    /// Skip empty space through the pyramid's opacity octree.
    pub skip_empty: bool,
    /// Pre- or post-classified pyramid ([`crate::mipmap`]).
    pub classify: Classify,
    /// Shading, post-classified only: the gradient is the central
    /// difference of the level-blended scalar half a level voxel either
    /// side of the sample (the footprint's own resolution), then
    /// [`crate::shading::Shader::shade`].
    pub shade: Option<crate::shading::Shade>,
    /// Volume of interest: each sample's opacity (and, pre-classified, its
    /// opacity-weighted colour, so its colour stays) scaled by the region's
    /// factor at the sample ([`crate::voi`]), after classification and
    /// filtering. The pyramid does not depend on it; an empty cell stays
    /// empty, so skipping stays exact.
    pub voi: Option<crate::voi::Voi>,
}

/// Default [`MipOptions::step`]: two samples per voxel of the level read.
pub const DEFAULT_MIP_STEP: f64 = 0.5;

/// Accepted [`MipOptions::step`] range: finer than 1/16 only costs time,
/// coarser than 4 skips whole voxels of the level read.
pub const MIP_STEP_RANGE: (f64, f64) = (1.0 / 16.0, 4.0);

impl Default for MipOptions {
    fn default() -> MipOptions {
        MipOptions {
            step: DEFAULT_MIP_STEP,
            terminate: 0.99,
            skip_empty: true,
            classify: Classify::Post,
            shade: None,
            voi: None,
        }
    }
}

/// Refuses a step factor outside [`MIP_STEP_RANGE`].
pub fn check_step(step: f64) -> Result<()> {
    let (lo, hi) = MIP_STEP_RANGE;
    if !(step.is_finite() && (lo..=hi).contains(&step)) {
        return Err(input(format!(
            "mip-map step {step} must be a number from {lo} to {hi} (times the footprint)"
        )));
    }
    Ok(())
}

impl MipOptions {
    /// Refuses options the caster cannot run with.
    pub fn validate(&self) -> Result<()> {
        check_step(self.step)?;
        if !(self.terminate.is_finite() && self.terminate > 0.0 && self.terminate <= 1.0) {
            return Err(input(format!(
                "termination threshold {} must lie in (0, 1]",
                self.terminate
            )));
        }
        Ok(())
    }
}

/// What one frame counted.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct MipStats {
    /// What the pyramid holds.
    pub classify: Classify,
    /// Levels in the pyramid.
    pub levels: usize,
    /// Samples interpolated and classified.
    pub samples_total: u64,
    /// Samples proven transparent by the octree and not taken.
    pub samples_skipped: u64,
    /// Jumps of the octree walk (each skips one or more samples).
    pub jumps: u64,
    /// Samples beyond a clip plane.
    pub samples_clipped: u64,
    /// Samples taken per finer bracketing level `floor(L)`.
    pub level_histogram: Vec<u64>,
    /// Rays stopped by early termination.
    pub rays_terminated: u64,
}

impl MipStats {
    pub(crate) fn add(&mut self, o: &MipStats) {
        self.samples_total += o.samples_total;
        self.samples_skipped += o.samples_skipped;
        self.samples_clipped += o.samples_clipped;
        self.jumps += o.jumps;
        self.rays_terminated += o.rays_terminated;
        for (a, b) in self.level_histogram.iter_mut().zip(&o.level_histogram) {
            *a += b;
        }
    }
}

/// One pixel's ray in view space, with distances in world units.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Ray {
    /// View-space displacement per world unit along the ray.
    pub unit: DVec3,
    /// Footprint per world unit of distance (radians, small-angle).
    pub angle: f64,
    /// World distance where the ray enters the stack's box.
    pub r_in: f64,
    /// World distance where it leaves.
    pub r_out: f64,
}

/// The footprint per world unit of distance of the ray through pixel
/// position `(px, py)`: the geometric mean of how fast it parts from its
/// right and lower neighbours (the parts of `b` and `c` across the ray,
/// over the direction's length, in world units).
pub fn footprint_angle(view: &View, px: f64, py: f64) -> f64 {
    let world = |v: DVec3| DVec3::from_array(std::array::from_fn(|k| v[k] * view.spacing[k]));
    let dw = world(view.rays.dir(px, py));
    let len2 = dw.length_squared();
    let across = |d: DVec3| {
        let w = world(d);
        (w - w.dot(dw) / len2 * dw).length()
    };
    (across(view.rays.b) * across(view.rays.c)).sqrt() / len2.sqrt()
}

impl Ray {
    /// The ray through pixel position `(px, py)` (centres at `i + 0.5`),
    /// `None` when it misses the volume.
    pub fn new(view: &View, px: f64, py: f64) -> Option<Ray> {
        let dir = view.rays.dir(px, py);
        let len = view.world_length(dir.x, dir.y, dir.z);
        let angle = footprint_angle(view, px, py);
        let (t0, t1) = box_interval(view.eye, dir, view.dims)?;
        Some(Ray {
            unit: dir / len,
            angle,
            r_in: t0 * len,
            r_out: t1 * len,
        })
    }

    /// View-space position at world distance `r`.
    #[inline]
    pub fn at(&self, eye: DVec3, r: f64) -> [f64; 3] {
        (eye + self.unit * r).to_array()
    }
}

/// The continuous level at world distance `r` for a ray of footprint
/// `angle` per unit distance over voxels of world size `voxel`, clamped
/// to `[0, top]`.
#[inline]
pub fn level_at(r: f64, angle: f64, voxel: f64, top: usize) -> f64 {
    (r * angle / voxel).log2().clamp(0.0, top as f64)
}

/// World size of a voxel for level selection: the geometric mean of the
/// spacing (a cube of the voxel's volume).
pub fn voxel_size(view: &View) -> f64 {
    view.spacing.iter().product::<f64>().cbrt()
}

/// Sample steps along one ray: uniform (`k voxel`) while the footprint is
/// under a voxel, then growing by `1 + k angle` per step.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Steps {
    r_in: f64,
    r_out: f64,
    h: f64,
    n0: u64,
    r_g: f64,
    g: f64,
}

impl Steps {
    /// The steps of `ray` with step factor `k` over voxels of `voxel`.
    pub fn new(ray: &Ray, k: f64, voxel: f64) -> Steps {
        let h = k * voxel;
        // Where the footprint reaches a voxel.
        let r0 = if ray.angle > 0.0 {
            voxel / ray.angle
        } else {
            f64::INFINITY
        };
        let span = ray.r_out - ray.r_in;
        let n0 = if ray.r_in >= r0 {
            0
        } else {
            (((r0 - ray.r_in) / h).ceil()).min((span / h).ceil() + 1.0) as u64
        };
        Steps {
            r_in: ray.r_in,
            r_out: ray.r_out,
            h,
            n0,
            r_g: ray.r_in + n0 as f64 * h,
            g: 1.0 + k * ray.angle,
        }
    }

    /// Start of step `n` (world distance), uncut.
    #[inline]
    pub fn edge(&self, n: u64) -> f64 {
        if n <= self.n0 {
            self.r_in + n as f64 * self.h
        } else {
            self.r_g * self.g.powi((n - self.n0).min(i32::MAX as u64) as i32)
        }
    }

    /// Step `n` cut at the exit: `(start, end)`, or `None` past the exit.
    #[inline]
    pub fn step(&self, n: u64) -> Option<(f64, f64)> {
        let a = self.edge(n);
        (a < self.r_out).then(|| (a, self.edge(n + 1).min(self.r_out)))
    }

    /// Midpoint of step `n` (infinite past the exit).
    #[inline]
    fn mid(&self, n: u64) -> f64 {
        self.step(n).map_or(f64::INFINITY, |(a, b)| 0.5 * (a + b))
    }

    /// The first step after `n` whose midpoint is at least `r`.
    fn first_mid_from(&self, n: u64, r: f64) -> u64 {
        // Every midpoint lies before the exit: past it the answer is the
        // first step beyond the exit, and the guess stays near it.
        let r = r.min(self.r_out);
        let guess = if r <= self.r_g {
            ((r - self.r_in) / self.h).floor()
        } else {
            self.n0 as f64 + ((r / self.r_g).ln() / self.g.ln()).floor()
        };
        let mut m = (guess.max(0.0) as u64).max(n + 1);
        // The guess is within a step or two; settle it on the exact edges.
        while m > n + 1 && self.mid(m - 1) >= r {
            m -= 1;
        }
        while self.mid(m) < r {
            m += 1;
        }
        m
    }
}

/// What a ray needs besides itself: the pyramid, the table and its
/// visible entries (post-classified), clipping and options.
struct Scene<'a> {
    view: &'a View,
    mip: &'a MipMap,
    lut: &'a Lut,
    visible: VisibleEntries,
    clip: &'a ViewClip,
    opts: &'a MipOptions,
    shader: Option<Shader>,
    voi: Option<ViewVoi>,
}

impl<'a> Scene<'a> {
    /// Checks `opts` against the pyramid and builds the shader (what both
    /// renderers share).
    fn new(
        view: &'a View,
        mip: &'a MipMap,
        clip: &'a ViewClip,
        lut: &'a Lut,
        opts: &'a MipOptions,
    ) -> Result<Scene<'a>> {
        opts.validate()?;
        if mip.classify != opts.classify {
            return Err(input(format!(
                "a {}-classified mip-map cannot render {}-classified",
                mip.classify.name(),
                opts.classify.name()
            )));
        }
        Ok(Scene {
            view,
            mip,
            lut,
            visible: lut.visible_ranges(),
            clip,
            opts,
            shader: shader_for(view, mip, opts)?,
            voi: opts.voi.map(|v| ViewVoi::new(view, &v)).transpose()?,
        })
    }

    /// Zero counts for this pyramid.
    fn empty_stats(&self) -> MipStats {
        MipStats {
            classify: self.mip.classify,
            levels: self.mip.levels.len(),
            level_histogram: vec![0; self.mip.levels.len()],
            ..MipStats::default()
        }
    }

    /// True when a sample at `p` reading `level`'s cell is proven
    /// transparent.
    #[inline]
    fn empty(&self, level: &Level, p: [f64; 3]) -> bool {
        match self.mip.classify {
            Classify::Pre => level.cell_empty(p),
            Classify::Post => level.cell_invisible(p, &self.visible),
        }
    }
}

/// The shader of `opts.shade`: its lights and material (the gradient comes
/// from the pyramid, so samples mode, which needs no voxel stacks).
fn shader_for(view: &View, mip: &MipMap, opts: &MipOptions) -> Result<Option<Shader>> {
    let Some(mut sh) = opts.shade else {
        return Ok(None);
    };
    if mip.classify == Classify::Pre {
        // The shading is in the pyramid's level 0 (mipmap::build_shaded);
        // it must be this frame's.
        if mip.shading == Some(crate::mipmap::shading_key(view, &sh)) {
            return Ok(None);
        }
        return Err(input(
            "this pre-classified mip-map was not built with the frame's shading (lights, eye direction, material): build it with Prepared::mipmap_shaded_for",
        ));
    }
    sh.gradient = crate::shading::GradientMode::Samples;
    Shader::with_gradients(view, None, &sh).map(Some)
}

/// Renders one image with pyramid `mip` (built with `lut` when
/// pre-classified): one ray per pixel centre, parallel over rows.
pub fn render(
    view: &View,
    mip: &MipMap,
    clip: &ViewClip,
    lut: &Lut,
    opts: &MipOptions,
) -> Result<(Image, MipStats)> {
    let scene = Scene::new(view, mip, clip, lut, opts)?;
    let (w, h) = (view.size[0] as usize, view.size[1] as usize);
    let mut img = Image::new(w, h);
    let empty = scene.empty_stats();
    let rows: Vec<MipStats> = img
        .data
        .par_chunks_mut(w)
        .enumerate()
        .map(|(j, row)| {
            let mut st = empty.clone();
            for (i, out) in row.iter_mut().enumerate() {
                *out = match Ray::new(view, i as f64 + 0.5, j as f64 + 0.5) {
                    Some(ray) => cast(&scene, &ray, 0, &mut st),
                    None => [0.0; 4],
                };
            }
            st
        })
        .collect();
    // Integer counts summed in row order: the same for any thread count.
    let mut stats = empty;
    for r in &rows {
        stats.add(r);
    }
    Ok((img, stats))
}

/// Casts one ray front to back. A gaze level `l > 0` ray stands for
/// `2^l x 2^l` pixels: its footprint, and so its mip-map level, is `2^l`
/// times the pixel's, and its steps are `2^l` times as long (`2^l k
/// max(footprint, voxel)`, `2^-l` of the full sample rate everywhere).
fn cast(sc: &Scene, pixel: &Ray, l: u32, st: &mut MipStats) -> [f32; 4] {
    let (view, mip, opts) = (sc.view, sc.mip, sc.opts);
    let voxel = voxel_size(view);
    let top = mip.top();
    let grow = f64::from(1u32 << l);
    let steps = Steps::new(pixel, opts.step * grow, voxel);
    let wide = Ray {
        angle: pixel.angle * grow,
        ..*pixel
    };
    let ray = &wide;
    let mut acc = [0f32; 4];
    let mut n = 0u64;
    // Probe the octree only at the ray's start and after a transparent
    // sample: inside matter the probe (eight more reads) never pays, and
    // which samples are probed changes no sample's value.
    let mut probe = true;
    while let Some((r0, r1)) = steps.step(n) {
        let rm = 0.5 * (r0 + r1);
        let p = ray.at(view.eye, rm);
        if !sc.clip.keeps(p[0], p[1], p[2]) {
            st.samples_clipped += 1;
            n += 1;
            continue;
        }
        let l = level_at(rm, ray.angle, voxel, top);
        let lo = l as usize;
        let hi = (lo + 1).min(top);
        if probe && opts.skip_empty && sc.empty(&mip.levels[hi], p) {
            let next = skip_to(sc, ray, &steps, n, p, hi, voxel);
            st.samples_skipped += next - n;
            st.jumps += 1;
            n = next;
            continue;
        }
        n += 1;
        st.samples_total += 1;
        st.level_histogram[lo] += 1;
        let frac = (l - lo as f64) as f32;
        let (lo, hi) = (&mip.levels[lo], &mip.levels[hi]);
        let (mut c, mut wgt_of) = match mip.classify {
            Classify::Pre => {
                let mut c = lo.trilinear(p);
                if frac > 0.0 {
                    let d = hi.trilinear(p);
                    c = std::array::from_fn(|k| c[k] + frac * (d[k] - c[k]));
                }
                // c holds colour times opacity per unit length: the
                // colour weight divides it back out.
                (c, c[3])
            }
            Classify::Post => {
                let blend = |q: [f64; 3]| {
                    let mut s = lo.scalar(q);
                    if frac > 0.0 {
                        s += frac * (hi.scalar(q) - s);
                    }
                    s
                };
                let mut c = sc.lut.lookup(blend(p));
                if let (Some(sh), true) = (&sc.shader, c[3] > 0.0) {
                    // Half a voxel of the finer level read, in base voxels.
                    let h = 0.5 / lo.scale;
                    let g: [f32; 3] = std::array::from_fn(|a| {
                        let (mut q0, mut q1) = (p, p);
                        q0[a] -= h;
                        q1[a] += h;
                        ((blend(q1) - blend(q0)) as f64 / (2.0 * h * view.spacing[a])) as f32
                    });
                    c = sh.shade_f32(c, g);
                }
                (c, 1.0)
            }
        };
        if let Some(v) = &sc.voi {
            let f = v.factor(DVec3::from_array(p)) as f32;
            match mip.classify {
                Classify::Pre => {
                    c = c.map(|x| x * f);
                    wgt_of *= f;
                }
                Classify::Post => c[3] *= f,
            }
        }
        probe = c[3] <= 0.0;
        if probe {
            continue;
        }
        let a = correct_opacity(c[3].min(1.0), (r1 - r0) as f32);
        let k = (1.0 - acc[3]) * a;
        let wgt = k / wgt_of;
        acc[0] += wgt * c[0];
        acc[1] += wgt * c[1];
        acc[2] += wgt * c[2];
        acc[3] += k;
        if acc[3] >= opts.terminate {
            st.rays_terminated += 1;
            break;
        }
    }
    acc
}

/// Renders `view` like [`render`] with `gaze`'s variable resolution
/// ([`crate::gaze`]): level-`l` rays read the mip-map `l` levels coarser
/// and take `2^-l` of the samples.
pub fn render_gaze(
    view: &View,
    mip: &MipMap,
    clip: &ViewClip,
    lut: &Lut,
    opts: &MipOptions,
    gaze: &crate::gaze::Gaze,
) -> Result<(Image, MipStats, crate::gaze::GazeStats)> {
    let scene = Scene::new(view, mip, clip, lut, opts)?;
    let empty = scene.empty_stats();
    let (img, g, stats) = crate::gaze::render_with(
        view.size,
        gaze,
        || empty.clone(),
        MipStats::add,
        |x, y, l, st| match Ray::new(view, x, y) {
            Some(ray) => cast(&scene, &ray, l, st).map(f64::from),
            None => [0.0; 4],
        },
    )?;
    Ok((img, stats, g))
}

/// Runs `f` with this scene's caster of full-resolution pixel rays
/// (what [`render`] casts through each pixel centre), for
/// [`crate::refine`]: `f(empty, cast)` gets zero counts and
/// `cast(x, y, counts)`, the ray through pixel position `(x, y)`.
pub(crate) fn with_pixel_caster<R>(
    view: &View,
    mip: &MipMap,
    clip: &ViewClip,
    lut: &Lut,
    opts: &MipOptions,
    f: impl FnOnce(MipStats, &(dyn Fn(f64, f64, &mut MipStats) -> [f64; 4] + Sync)) -> R,
) -> Result<R> {
    let scene = Scene::new(view, mip, clip, lut, opts)?;
    let empty = scene.empty_stats();
    let cast = |x: f64, y: f64, st: &mut MipStats| match Ray::new(view, x, y) {
        Some(ray) => cast(&scene, &ray, 0, st).map(f64::from),
        None => [0.0; 4],
    };
    Ok(f(empty, &cast))
}

/// Sample `n` at `p` reads an empty cell at level `hi`: finds the coarsest
/// empty level `k >= hi` there and returns the first sample after `n`
/// not proven transparent by it.
fn skip_to(
    sc: &Scene,
    ray: &Ray,
    steps: &Steps,
    n: u64,
    p: [f64; 3],
    hi: usize,
    voxel: f64,
) -> u64 {
    let (view, mip) = (sc.view, sc.mip);
    let top = mip.top();
    let mut k = hi;
    while k < top && sc.empty(&mip.levels[k + 1], p) {
        k += 1;
    }
    let b = mip.levels[k].cell_box(p);
    const EPS: f64 = 1e-6;
    let mut exit = f64::INFINITY;
    for (a, [lo, hi]) in b.iter().enumerate() {
        let (u, e) = (ray.unit[a], view.eye[a]);
        if u > 0.0 {
            exit = exit.min((hi - EPS - e) / u);
        } else if u < 0.0 {
            exit = exit.min((lo + EPS - e) / u);
        }
    }
    if k < top && ray.angle > 0.0 {
        // Beyond this distance a sample's finer level reaches k + 1.
        exit = exit.min((k as f64).exp2() * voxel / ray.angle * (1.0 - 1e-9));
    }
    steps.first_mid_from(n, exit)
}
