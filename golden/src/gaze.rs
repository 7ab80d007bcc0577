//! Gaze-directed variable resolution (Levoy and Whitaker, seed 000) for
//! the image-order ray casters, the reference and the mip-map method
//! ([`crate::mipcast::render_gaze`], whose level-`l` rays also read the
//! pyramid `l` levels coarser): full resolution near where the viewer
//! looks, fewer rays and fewer samples per ray towards the periphery.
//! [`render_with`] holds the profile, the partially populated ray pyramid
//! and the interpolation; a caster supplies one ray.
//!
//! **Profile.** A pixel at distance `r` from the gaze point has level
//! `lev(r) = L clamp((r - inner) / (outer - inner), 0, 1)`: 0 (one ray per
//! pixel, the full sample rate) inside the sweet spot `r <= inner`, rising
//! linearly to `L` (one ray per `2^L x 2^L` pixels, the sample rate divided
//! by `2^L`) at `outer` and beyond. The defaults are the paper's: `L = 2`,
//! one ray per 16 pixels and a quarter of the sample rate at the periphery.
//!
//! **Rays.** Level `l`'s rays sit at pixel positions `((a + 1/2) 2^l,
//! (b + 1/2) 2^l)`, so level 0's are the pixel centres; each steps `2^l`
//! times the reference's step. The pyramid is **partially populated**: a
//! level-`l` ray is cast only if a pixel whose level brackets `l` needs it
//! for its bilinear interpolation.
//!
//! **Pixels.** A pixel of level `lev` takes the bilinear interpolation of
//! the two bracketing levels' rays at its centre and blends them linearly
//! with `lev - floor(lev)`. In the sweet spot a pixel is exactly its own
//! ray.
//!
//! The rays are the reference's (`f64`, trilinear, the same compositing,
//! shading and volume of interest), one per pixel at level 0 instead of
//! the reference's supersampled grid: the saving is measured against that
//! one-ray-per-pixel caster, `Gaze::full`.
//!
//! ER does not take this profile. Its rays live in object space, and every
//! region's grid covers the whole baseplane. A coarser grid could be used
//! outside the sweet spot, by merging the periphery's rays a region
//! earlier, but the Bartlett merge would then mix densities across the
//! boundary of the sweet spot's footprint. That is not sound without a
//! second merge kind, so it is left out.

use rayon::prelude::*;

use crate::clip::ViewClip;
use crate::error::{input, Result};
use crate::geometry::View;
use crate::image::Image;
use crate::reference::{cast_ray, RefOptions, RefPass};
use crate::slices::SliceStack;
use crate::tf::Lut;

/// Coarsest level allowed (one ray per 2^6 x 2^6 pixels).
pub const MAX_LEVEL: u32 = 6;

/// The sweet spot: gaze point and radii in pixels, coarsest level.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Gaze {
    /// Gaze point in pixel coordinates (pixel `i` spans `[i, i + 1)`).
    pub at: [f64; 2],
    /// Radius of full resolution.
    pub inner: f64,
    /// Radius from which the coarsest level holds.
    pub outer: f64,
    /// Coarsest level `L`.
    pub levels: u32,
}

impl Gaze {
    /// The paper's profile around `at` for a `w x h` image: full resolution
    /// within a tenth of the larger side, the coarsest level (2) from
    /// four tenths.
    pub fn around(at: [f64; 2], w: u32, h: u32) -> Gaze {
        let side = f64::from(w.max(h));
        Gaze {
            at,
            inner: 0.1 * side,
            outer: 0.4 * side,
            levels: 2,
        }
    }

    /// Every pixel at full resolution: the one-ray-per-pixel caster the
    /// savings are measured against.
    pub fn full(w: u32, h: u32) -> Gaze {
        let side = f64::from(w.max(h));
        Gaze {
            at: [0.0, 0.0],
            inner: 4.0 * side,
            outer: 5.0 * side,
            levels: 0,
        }
    }

    /// Every pixel at level `levels` (a uniform profile: the gaze point
    /// off the image and the coarsest level from radius zero), as
    /// `--rays footprint` renders ER ([`crate::ergaze::footprint_level`]).
    pub fn uniform(levels: u32) -> Gaze {
        Gaze {
            at: [-1.0, -1.0],
            inner: 0.0,
            outer: 1e-6,
            levels,
        }
    }

    /// Refuses non-finite values, `outer < inner` and levels past
    /// [`MAX_LEVEL`].
    pub fn validate(&self) -> Result<()> {
        if !(self.at.iter().all(|v| v.is_finite())
            && self.inner.is_finite()
            && self.outer.is_finite())
        {
            return Err(input("gaze point and radii must be finite"));
        }
        if !(self.inner >= 0.0 && self.outer > self.inner) {
            return Err(input(format!(
                "gaze radii {},{} must satisfy 0 <= inner < outer",
                self.inner, self.outer
            )));
        }
        if self.levels > MAX_LEVEL {
            return Err(input(format!(
                "gaze levels {} must be at most {MAX_LEVEL}",
                self.levels
            )));
        }
        Ok(())
    }

    /// The level of the pixel centred at `(x, y)`.
    pub fn level(&self, x: f64, y: f64) -> f64 {
        let r = ((x - self.at[0]).powi(2) + (y - self.at[1]).powi(2)).sqrt();
        let t = ((r - self.inner) / (self.outer - self.inner)).clamp(0.0, 1.0);
        t * f64::from(self.levels)
    }
}

/// What a gaze-directed frame cast.
#[derive(Debug, Clone, PartialEq, Eq, serde::Serialize)]
pub struct GazeStats {
    /// Rays cast per level, finest first.
    pub rays_per_level: Vec<u64>,
    /// Rays in all.
    pub rays: u64,
    /// Pixels (the rays of one ray per pixel).
    pub pixels: u64,
}

/// One level's grid of rays: `nx x ny` positions, which were cast, the
/// results.
struct Level {
    nx: usize,
    ny: usize,
    scale: f64,
    need: Vec<bool>,
    rays: Vec<[f64; 4]>,
}

impl Level {
    fn new(l: u32, w: usize, h: usize) -> Level {
        let s = 1usize << l;
        // One ray past each edge, so every pixel centre has its four.
        let (nx, ny) = (w.div_ceil(s) + 1, h.div_ceil(s) + 1);
        Level {
            nx,
            ny,
            scale: s as f64,
            need: vec![false; nx * ny],
            rays: vec![[0.0; 4]; nx * ny],
        }
    }

    /// The four rays around pixel position `(x, y)` and the bilinear
    /// weights `(tx, ty)`.
    fn taps(&self, x: f64, y: f64) -> ([usize; 2], [usize; 2], f64, f64) {
        let fx = (x / self.scale - 0.5).clamp(0.0, (self.nx - 1) as f64);
        let fy = (y / self.scale - 0.5).clamp(0.0, (self.ny - 1) as f64);
        let (a, b) = (fx.floor() as usize, fy.floor() as usize);
        let (a1, b1) = ((a + 1).min(self.nx - 1), (b + 1).min(self.ny - 1));
        ([a, a1], [b, b1], fx - a as f64, fy - b as f64)
    }

    fn mark(&mut self, x: f64, y: f64) {
        let ([a0, a1], [b0, b1], tx, ty) = self.taps(x, y);
        for (a, wa) in [(a0, 1.0 - tx), (a1, tx)] {
            for (b, wb) in [(b0, 1.0 - ty), (b1, ty)] {
                if wa * wb > 0.0 {
                    self.need[b * self.nx + a] = true;
                }
            }
        }
    }

    fn at(&self, x: f64, y: f64) -> [f64; 4] {
        let ([a0, a1], [b0, b1], tx, ty) = self.taps(x, y);
        let mut out = [0.0; 4];
        for (a, wa) in [(a0, 1.0 - tx), (a1, tx)] {
            for (b, wb) in [(b0, 1.0 - ty), (b1, ty)] {
                let w = wa * wb;
                if w > 0.0 {
                    let r = self.rays[b * self.nx + a];
                    for c in 0..4 {
                        out[c] += w * r[c];
                    }
                }
            }
        }
        out
    }
}

/// Renders `view` with `gaze`'s variable resolution; the rays are the
/// reference's with `opts`.
pub fn render(
    view: &View,
    stack: &SliceStack,
    clip: &ViewClip,
    lut: &Lut,
    opts: &RefOptions,
    gaze: &Gaze,
) -> Result<(Image, GazeStats)> {
    gaze.validate()?;
    let pass = RefPass::new(view, stack, opts)?;
    let (img, stats, ()) = render_with(
        view.size,
        gaze,
        || (),
        |(), ()| {},
        |x, y, l, ()| {
            let step = RefOptions {
                step: opts.step * f64::from(1u32 << l),
                ..*opts
            };
            // Pixel i's centre is at i + 1/2 in the camera's ray
            // coordinates, as in the reference.
            cast_ray(&pass, clip, lut, &step, view.rays.dir(x, y))
        },
    )?;
    Ok((img, stats))
}

/// The gaze-directed frame of any ray caster: `cast(x, y, l, counts)`
/// casts the level-`l` ray through pixel position `(x, y)` (standing for
/// `2^l x 2^l` pixels: it should take `2^-l` of the full sample rate)
/// and adds what it did to `counts`; per-row counts start from `init()`
/// and are summed with `add` in row order, so they are the same for any
/// thread count.
pub fn render_with<S: Send>(
    size: [u32; 2],
    gaze: &Gaze,
    init: impl Fn() -> S + Sync,
    add: impl Fn(&mut S, &S),
    cast: impl Fn(f64, f64, u32, &mut S) -> [f64; 4] + Sync,
) -> Result<(Image, GazeStats, S)> {
    gaze.validate()?;
    let (w, h) = (size[0] as usize, size[1] as usize);
    let mut levels: Vec<Level> = (0..=gaze.levels).map(|l| Level::new(l, w, h)).collect();
    // Which rays the pixels need.
    let centre = |i: usize| i as f64 + 0.5;
    for j in 0..h {
        for i in 0..w {
            let (x, y) = (centre(i), centre(j));
            let lev = gaze.level(x, y);
            let l0 = lev.floor() as usize;
            levels[l0].mark(x, y);
            if lev > l0 as f64 {
                levels[l0 + 1].mark(x, y);
            }
        }
    }
    let mut stats = GazeStats {
        rays_per_level: Vec::new(),
        rays: 0,
        pixels: (w * h) as u64,
    };
    let mut counts = init();
    for (l, level) in levels.iter_mut().enumerate() {
        let (nx, scale) = (level.nx, level.scale);
        let need = &level.need;
        let rows: Vec<S> = level
            .rays
            .par_chunks_mut(nx)
            .enumerate()
            .map(|(b, row)| {
                let mut st = init();
                for (a, out) in row.iter_mut().enumerate() {
                    if need[b * nx + a] {
                        let x = (a as f64 + 0.5) * scale;
                        let y = (b as f64 + 0.5) * scale;
                        *out = cast(x, y, l as u32, &mut st);
                    }
                }
                st
            })
            .collect();
        for r in &rows {
            add(&mut counts, r);
        }
        let n = level.need.iter().filter(|&&b| b).count() as u64;
        stats.rays_per_level.push(n);
        stats.rays += n;
    }
    let mut img = Image::new(w, h);
    img.data.par_chunks_mut(w).enumerate().for_each(|(j, row)| {
        for (i, out) in row.iter_mut().enumerate() {
            let (x, y) = (centre(i), centre(j));
            let lev = gaze.level(x, y);
            let l0 = lev.floor() as usize;
            let t = lev - l0 as f64;
            let mut c = levels[l0].at(x, y);
            if t > 0.0 {
                let d = levels[l0 + 1].at(x, y);
                for k in 0..4 {
                    c[k] += t * (d[k] - c[k]);
                }
            }
            *out = c.map(|v| v as f32);
        }
    });
    Ok((img, stats, counts))
}
