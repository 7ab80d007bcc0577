//! The baseplane-to-image warp: a 3x3 projective map from final pixels to
//! baseplane samples, and the resampling that folds the last merge in.

use glam::{DMat3, DVec3};
use rayon::prelude::*;

use crate::geometry::{BaseGrid, View};
use crate::image::Image;

/// The image of region 0's rays at slice 0 (premultiplied RGBA), before the
/// warp; row-major, `y` rows of `x` samples.
#[derive(Debug, Clone, PartialEq)]
pub struct Baseplane {
    /// Where the samples lie on slice 0.
    pub grid: BaseGrid,
    /// Samples, `grid.counts[1]` rows of `grid.counts[0]`.
    pub data: Vec<[f32; 4]>,
}

impl Baseplane {
    /// As an image (for `--baseplane-npy`); rows follow view-space `y`.
    pub fn to_image(&self) -> Image {
        Image {
            width: self.grid.counts[0],
            height: self.grid.counts[1],
            data: self.data.clone(),
        }
    }
}

/// The projective map taking continuous pixel position `(px, py, 1)` to
/// homogeneous baseplane sample coordinates `(u w, v w, w)`; `w <= 0` means
/// the pixel's ray never reaches the baseplane.
pub fn pixel_to_base(view: &View, grid: &BaseGrid) -> DMat3 {
    let r = &view.rays;
    // Direction d = L (px, py, 1); it meets z = 0 at e + d D / d_z, which in
    // homogeneous form is P d with P = [[D, 0, e_x], [0, D, e_y], [0, 0, 1]].
    let l = DMat3::from_cols(r.b, r.c, r.a);
    let (d, e) = (view.d, view.eye);
    let p = DMat3::from_cols(
        DVec3::new(d, 0.0, 0.0),
        DVec3::new(0.0, d, 0.0),
        DVec3::new(e.x, e.y, 1.0),
    );
    let s = 1.0 / grid.spacing;
    let to_samples = DMat3::from_cols(
        DVec3::new(s, 0.0, 0.0),
        DVec3::new(0.0, s, 0.0),
        DVec3::new(-grid.origin[0] * s, -grid.origin[1] * s, 1.0),
    );
    to_samples * p * l
}

/// The integers `k` with `|u - k| < h`: the first and how many.
#[inline]
fn tent_span(u: f64, h: f64) -> (i64, usize) {
    let k0 = floor(u - h) + 1;
    let k1 = -floor(-(u + h)) - 1;
    (k0, (k1 - k0 + 1).max(0) as usize)
}

/// Normalised tent weights of half-width `h` (in samples) around `u` over
/// `w.len()` integers from `k0` (a [`tent_span`]).
#[inline]
fn tent(u: f64, h: f64, k0: i64, w: &mut [f32]) {
    // A multiply, not a division per tap (exact for ER's h = 2).
    let inv_h = 1.0 / h;
    let mut sum = 0.0;
    for (k, x) in (k0..).zip(w.iter_mut()) {
        let t = (1.0 - (u - k as f64).abs() * inv_h).max(0.0);
        sum += t;
        *x = t as f32;
    }
    if sum > 0.0 {
        let inv = (1.0 / sum) as f32;
        w.iter_mut().for_each(|x| *x *= inv);
    }
}

/// The most integers a [`tent_span`] holds for half-width `h`: the integers
/// strictly within `h` of a point, and one more for the rounding of
/// `u - h` and `u + h`.
fn tent_taps(h: f64) -> usize {
    (2.0 * h).ceil() as usize + 2
}

/// `floor` of a finite value below `2^52` in magnitude, without a libm
/// call on targets without SSE4.1 (the warp calls it four times a pixel).
#[inline]
fn floor(x: f64) -> i64 {
    let t = x as i64;
    t - i64::from((t as f64) > x)
}

/// Resamples the baseplane into the final image with a tent of half-width
/// one voxel on the baseplane: for ER (samples half a voxel apart) this is
/// the last Bartlett merge, `(1/4, 1/2, 1/4)` at a sample, folded into the
/// warp; for every method it is the same filter in voxel units.
pub fn warp(view: &View, base: &Baseplane) -> Image {
    warp_window(view, base, &PixelWindow::all(view.size))
}

/// A rectangle of pixels, `x[0]..=x[1]` by `y[0]..=y[1]` (pixel indices).
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
pub struct PixelWindow {
    /// First and last column.
    pub x: [u32; 2],
    /// First and last row.
    pub y: [u32; 2],
}

impl PixelWindow {
    /// Every pixel of a `size[0] x size[1]` image (which must not be empty).
    pub fn all(size: [u32; 2]) -> PixelWindow {
        PixelWindow {
            x: [0, size[0].saturating_sub(1)],
            y: [0, size[1].saturating_sub(1)],
        }
    }

    /// Pixels in the window.
    pub fn pixels(&self) -> u64 {
        u64::from(self.x[1] - self.x[0] + 1) * u64::from(self.y[1] - self.y[0] + 1)
    }

    /// The centres of the window's corner pixels.
    pub fn corners(&self) -> [(f64, f64); 4] {
        let c = |v: u32| f64::from(v) + 0.5;
        let (x0, x1, y0, y1) = (c(self.x[0]), c(self.x[1]), c(self.y[0]), c(self.y[1]));
        [(x0, y0), (x1, y0), (x0, y1), (x1, y1)]
    }
}

/// [`warp`] of the pixels in `win` only (the rest stay zero): what a
/// frame culled to that window ([`crate::skip::SampleMask::within`])
/// can show. Every pixel it computes has the bits [`warp`] gives it.
pub fn warp_window(view: &View, base: &Baseplane, win: &PixelWindow) -> Image {
    warp_tiles(view, base, win, &Occupied::new(base))
}

/// [`warp_window`] with the baseplane's non-zero tiles given.
fn warp_tiles(view: &View, base: &Baseplane, win: &PixelWindow, occupied: &Occupied) -> Image {
    let (w, h) = (view.size[0] as usize, view.size[1] as usize);
    let map = Footprint {
        m: pixel_to_base(view, &base.grid),
        half: 1.0 / base.grid.spacing,
        counts: base.grid.counts,
    };
    // The image's buffer comes from the ray-buffer pool (see
    // `crate::merge::recycle`; a caller done with a frame can give it back).
    let mut img = Image {
        width: w,
        height: h,
        data: crate::merge::zeroed(w * h),
    };
    let taps = tent_taps(map.half);
    const T: usize = PIXEL_TILE;
    // A band of `T` rows per task, `T x T` pixels at a time: a tile whose
    // whole footprint on the baseplane reads only zero tiles stays zero
    // without a pixel computed (most of a frame's air).
    img.data.par_chunks_mut(w * T).enumerate().for_each_init(
        || (vec![0f32; taps], vec![0f32; taps]),
        |(wx, wy), (band, rows)| {
            let j0 = band * T;
            let j1 = (j0 + rows.len() / w).min(win.y[1] as usize + 1);
            let j0 = j0.max(win.y[0] as usize);
            for i0 in (0..w).step_by(T) {
                let i1 = (i0 + T).min(win.x[1] as usize + 1);
                let i0 = i0.max(win.x[0] as usize);
                if i0 >= i1 || j0 >= j1 || !map.may_show([i0, i1], [j0, j1], occupied) {
                    continue;
                }
                for j in j0..j1 {
                    let row = &mut rows[(j - band * T) * w..][..w];
                    for (i, out) in row.iter_mut().enumerate().take(i1).skip(i0) {
                        if let Some(p) = map.pixel(base, occupied, i, j, wx, wy) {
                            *out = p;
                        }
                    }
                }
            }
        },
    );
    img
}

/// Pixels a side of the warp's tiles.
const PIXEL_TILE: usize = 8;

/// The warp's map from pixels to the baseplane samples they read.
struct Footprint {
    /// [`pixel_to_base`].
    m: DMat3,
    /// The tent's half-width in samples.
    half: f64,
    /// The baseplane's samples per row and rows.
    counts: [usize; 2],
}

impl Footprint {
    /// False only when no pixel of columns `i[0]..i[1]`, rows `j[0]..j[1]`
    /// can read a non-zero sample. Where the map's denominator is positive
    /// at the four corner pixels it is positive over the tile, and the
    /// tile maps to the convex quadrilateral of their images, so the
    /// corners bound every pixel's `(u, v)`; a sample of margin on each
    /// side covers the rounding of one pixel's map against another's.
    fn may_show(&self, i: [usize; 2], j: [usize; 2], occupied: &Occupied) -> bool {
        let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
        for (x, y) in [
            (i[0], j[0]),
            (i[1] - 1, j[0]),
            (i[0], j[1] - 1),
            (i[1] - 1, j[1] - 1),
        ] {
            let q = self.m * DVec3::new(x as f64 + 0.5, y as f64 + 0.5, 1.0);
            if q.z <= 0.0 || q.z.is_nan() {
                return true;
            }
            for (a, v) in [q.x / q.z, q.y / q.z].into_iter().enumerate() {
                lo[a] = lo[a].min(v);
                hi[a] = hi[a].max(v);
            }
        }
        let mut range = [[0usize; 2]; 2];
        for a in 0..2 {
            let n = self.counts[a] as f64;
            // A tap `k` read by a pixel at `u` has `|u - k| < half`.
            let (k0, k1) = (lo[a] - self.half - 1.0, hi[a] + self.half + 1.0);
            if !(k1 >= 0.0 && k0 <= n - 1.0) {
                // Every tap lies off the baseplane (or the map is not finite).
                return k0.is_nan() || k1.is_nan();
            }
            range[a] = [k0.max(0.0) as usize, (k1.min(n - 1.0)) as usize];
        }
        occupied.any(range[0], range[1])
    }

    /// Pixel `(i, j)`, or `None` where it stays zero; `wx`, `wy` hold room
    /// for [`tent_taps`] weights.
    #[inline]
    fn pixel(
        &self,
        base: &Baseplane,
        occupied: &Occupied,
        i: usize,
        j: usize,
        wx: &mut [f32],
        wy: &mut [f32],
    ) -> Option<[f32; 4]> {
        let (half, [nx, ny]) = (self.half, self.counts);
        let q = self.m * DVec3::new(i as f64 + 0.5, j as f64 + 0.5, 1.0);
        if q.z <= 0.0 {
            return None;
        }
        let (u, v) = (q.x / q.z, q.y / q.z);
        if !(u > -half - 1.0 && u < nx as f64 + half && v > -half - 1.0 && v < ny as f64 + half) {
            return None;
        }
        let ((x0, nwx), (y0, nwy)) = (tent_span(u, half), tent_span(v, half));
        // Taps outside the baseplane read nothing: clip the tap ranges once
        // instead of testing every tap.
        let span = |k0: i64, n: usize, len: usize| {
            let lo = (-k0).clamp(0, len as i64) as usize;
            let hi = (n as i64 - k0).clamp(lo as i64, len as i64) as usize;
            lo..hi
        };
        let (xs, ys) = (span(x0, nx, nwx), span(y0, ny, nwy));
        let first = |k0: i64, r: &std::ops::Range<usize>| (k0 + r.start as i64) as usize;
        if xs.is_empty()
            || ys.is_empty()
            || !occupied.any(
                [first(x0, &xs), first(x0, &xs) + xs.len() - 1],
                [first(y0, &ys), first(y0, &ys) + ys.len() - 1],
            )
        {
            // Every tap is zero: the pixel stays the zero it is (decided
            // before the weights, which cost more than the test).
            return None;
        }
        let (wx, wy) = (&mut wx[..nwx], &mut wy[..nwy]);
        tent(u, half, x0, wx);
        tent(v, half, y0, wy);
        let mut acc = [0f32; 4];
        for dy in ys {
            let fy = wy[dy];
            let y = (y0 + dy as i64) as usize;
            let first = y * nx + (x0 + xs.start as i64) as usize;
            let line = &base.data[first..first + xs.len()];
            for (&fx, p) in wx[xs.clone()].iter().zip(line) {
                let f = fx * fy;
                for c in 0..4 {
                    acc[c] += f * p[c];
                }
            }
        }
        // The normalised f32 weights may sum to a hair over 1.
        Some(acc.map(|v| v.min(1.0)))
    }
}

/// Which `BLOCK x BLOCK` tiles of a baseplane hold a sample that is not
/// all zero bits, so the warp can leave a pixel whose taps all read zero
/// at its zero (summing zeros with non-negative weights gives `+0`, the
/// bits the image starts with): most of a frame's pixels see only air.
struct Occupied {
    /// Tiles per row.
    cols: usize,
    bits: Vec<bool>,
}

impl Occupied {
    const BLOCK: usize = 8;

    fn new(base: &Baseplane) -> Occupied {
        let [nx, ny] = base.grid.counts;
        let (cols, rows) = (nx.div_ceil(Self::BLOCK), ny.div_ceil(Self::BLOCK));
        let mut bits = vec![false; cols * rows];
        // A row of tiles per task (the scan reads the whole baseplane).
        bits.par_chunks_mut(cols.max(1))
            .zip(base.data.par_chunks((nx * Self::BLOCK).max(1)))
            .for_each(|(tiles, band)| {
                for line in band.chunks(nx.max(1)) {
                    for (x, p) in line.iter().enumerate() {
                        if p.iter().any(|c| c.to_bits() != 0) {
                            tiles[x / Self::BLOCK] = true;
                        }
                    }
                }
            });
        Occupied { cols, bits }
    }

    /// Every tile occupied: the warp computes every pixel (the slow path
    /// the tiles are tested against).
    #[cfg(test)]
    fn all(base: &Baseplane) -> Occupied {
        let mut o = Occupied::new(base);
        o.bits.fill(true);
        o
    }

    /// True when a sample of columns `x[0]..=x[1]`, rows `y[0]..=y[1]`
    /// (inside the baseplane) may be non-zero.
    #[inline]
    fn any(&self, x: [usize; 2], y: [usize; 2]) -> bool {
        let b = Self::BLOCK;
        (y[0] / b..=y[1] / b)
            .any(|ty| (x[0] / b..=x[1] / b).any(|tx| self.bits[ty * self.cols + tx]))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Leaving pixels whose taps read only zero tiles changes no bit of
    /// any pixel: sparse baseplanes (a few lit samples, at tile corners and
    /// edges too) warped through perspective views, against every pixel
    /// computed.
    #[test]
    fn skipping_zero_tiles_changes_no_pixel() {
        use crate::camera::Camera;
        use crate::geometry::BaseGrid;
        use crate::render::Prepared;
        use crate::scenes::Scene;
        let vol = "sphere:24"
            .parse::<Scene>()
            .unwrap()
            .build(1 << 30)
            .unwrap();
        let mut skipped_some = false;
        for (k, (eye, fov)) in [([12.0, 12.0, -30.0], 60.0), ([40.0, 5.0, -8.0], 110.0)]
            .into_iter()
            .enumerate()
        {
            let at = glam::DVec3::splat(11.5);
            let cam = Camera::new(eye.into(), at, glam::DVec3::Y, fov, 53, 41).unwrap();
            let prep = Prepared::new(&vol, &cam).unwrap();
            let grid = BaseGrid {
                origin: [-3.0, -2.0],
                spacing: 0.5,
                counts: [61, 57],
            };
            let mut base = Baseplane {
                grid,
                data: vec![[0.0; 4]; 61 * 57],
            };
            for (i, p) in [0, 7, 8, 60, 61 * 8 + 15, 61 * 30 + 31, 61 * 56 + 60]
                .into_iter()
                .enumerate()
            {
                base.data[p] = [0.1 * (i + 1) as f32, 0.3, 0.05, 0.5];
            }
            base.data[61 * 20 + 40 + k] = [0.0, 0.0, 0.0, 1e-30];
            let win = PixelWindow::all(prep.view.size);
            let fast = warp_tiles(&prep.view, &base, &win, &Occupied::new(&base));
            let slow = warp_tiles(&prep.view, &base, &win, &Occupied::all(&base));
            let bits = |im: &Image| -> Vec<[u32; 4]> {
                im.data.iter().map(|p| p.map(f32::to_bits)).collect()
            };
            assert_eq!(bits(&fast), bits(&slow), "view {k}");
            assert!(
                fast.data.iter().any(|p| p[3] > 0.0),
                "view {k} sees a lit sample"
            );
            skipped_some |= Occupied::new(&base).bits.iter().any(|b| !b);
            // Some pixel tiles are left whole, and some are computed.
            let map = Footprint {
                m: pixel_to_base(&prep.view, &base.grid),
                half: 1.0 / base.grid.spacing,
                counts: base.grid.counts,
            };
            let occupied = Occupied::new(&base);
            let (w, h) = (prep.view.size[0] as usize, prep.view.size[1] as usize);
            let shown: Vec<bool> = (0..h)
                .step_by(PIXEL_TILE)
                .flat_map(|j| (0..w).step_by(PIXEL_TILE).map(move |i| (i, j)))
                .map(|(i, j)| {
                    let (i1, j1) = ((i + PIXEL_TILE).min(w), (j + PIXEL_TILE).min(h));
                    map.may_show([i, i1], [j, j1], &occupied)
                })
                .collect();
            assert!(
                shown.iter().any(|&s| s) && shown.iter().any(|&s| !s),
                "view {k}"
            );
        }
        assert!(skipped_some);
    }

    #[test]
    fn tent_of_two_samples_is_bartlett_on_a_sample() {
        let mut w = vec![0f32; tent_taps(2.0)];
        let (k0, n) = tent_span(5.0, 2.0);
        assert_eq!((k0, n), (4, 3));
        tent(5.0, 2.0, k0, &mut w[..n]);
        assert_eq!(w[..n], [0.25, 0.5, 0.25]);
        let (k0, n) = tent_span(5.5, 2.0);
        assert_eq!((k0, n), (4, 4));
        tent(5.5, 2.0, k0, &mut w[..n]);
        let want = [0.125, 0.375, 0.375, 0.125];
        for (a, b) in w[..n].iter().zip(want) {
            assert!((a - b).abs() < 1e-7);
        }
    }
}
