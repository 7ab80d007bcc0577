//! Compositing the sheared slices into the intermediate image, front to
//! back, one intermediate scanline per task.
//!
//! **Resampling.** Slice `z` reaches the intermediate image with
//! `g = s(z) S` pixels per voxel. Intermediate pixel `u` reads slice `z`
//! at `x(u) = e_x + (X(u) - e_x) / s(z)` (`X(u)` the pixel's centre on
//! the plane of slice 0: the point of slice `z` on the line from the eye through the
//! pixel) with a separable tent of half-width `r = max(1, 1/g)` voxels,
//! weights normalised. Where a voxel covers more than a pixel (`g >= 1`)
//! that is bilinear interpolation; where it covers less, the tent is one
//! intermediate pixel wide, so every voxel is splatted with a tent
//! footprint of one pixel and none is skipped (Schulze et al.'s
//! footprint-based interpolation; a gather, so that each pixel is
//! written by one task and the image is the same for any thread count).
//! The weights depend on the pixel column and the slice only, so they are
//! tabulated per slice once per frame (`Taps`). A sample counts only
//! where `x(u)`, `y(v)` lie in `[-1/2, n - 1/2]`, as for every method;
//! taps beyond the faces read the edge voxel.
//!
//! **Compositing.** One sample per slice along each pixel's ray; its step
//! is the ray's length between slices, `|(X - e_x, Y - e_y, D) / D|` in
//! world units, constant per pixel; opacity corrected as `1 - (1 - a)^ds`,
//! colours premultiplied, front to back.
//!
//! **Skipping** (both exact; the tests compare bits). With the runs
//! ([`super::rle`]), a scanline of slice `z` visits only the pixels within
//! `r` voxels (plus a pixel) of a non-transparent run of the voxel rows
//! its taps read: every other pixel would read only zeros. Pixels that
//! reach the termination opacity are linked past (Lacroute's opaque-pixel
//! skip: `next[u]` points at the next pixel that may still change,
//! path-halved), so later slices never touch them.

use crate::clip::ViewClip;
use crate::geometry::View;
use crate::shading::Shader;
use crate::slices::SliceStack;
use crate::tf::correct_opacity;
use crate::voi::ViewVoi;

use super::factor::Factor;
use super::rle::Classified;
use super::SwStats;

/// One slice's resampling weights on one axis, for every intermediate
/// pixel whose centre falls inside the slice.
#[derive(Debug, Clone)]
pub(crate) struct Taps {
    /// First and last pixel inside (empty when `lo > hi`).
    pub lo: usize,
    pub hi: usize,
    /// Taps per pixel.
    pub n: usize,
    /// Tent half-width in voxels.
    pub r: f64,
    /// First voxel of each pixel's taps.
    pub k0: Vec<i64>,
    /// `n` normalised weights per pixel.
    pub w: Vec<f32>,
    /// Slice position of each pixel centre.
    pub pos: Vec<f64>,
}

impl Taps {
    /// Slice `z`'s weights on axis `a` (`n_vox` voxels, `count` pixels).
    pub fn new(f: &Factor, z: usize, a: usize, n_vox: usize, count: usize) -> Taps {
        let s = f.slice_scale(z as f64);
        let r = (1.0 / (s * f.scale)).max(1.0);
        let e = f.eye[a];
        let at = |u: usize| e + (f.pixel_pos(u, a) - e) / s;
        let edge = n_vox as f64 - 0.5;
        let inside: Vec<usize> = {
            // The inside pixels are contiguous; find them from the
            // rounded ends, then test each candidate exactly.
            let to_pix = |x: f64| f.plane_to_pixel(e + (x - e) * s, a);
            let lo = (to_pix(-0.5).floor() - 1.0).max(0.0) as usize;
            let hi = (to_pix(edge).ceil() + 1.0).min(count as f64 - 1.0);
            if hi < 0.0 {
                Vec::new()
            } else {
                (lo..=hi as usize)
                    .filter(|&u| (-0.5..=edge).contains(&at(u)))
                    .collect()
            }
        };
        let n = (2.0 * r).ceil() as usize + 1;
        let (lo, hi) = match (inside.first(), inside.last()) {
            (Some(&l), Some(&h)) => (l, h),
            _ => (1, 0),
        };
        let mut k0 = Vec::with_capacity(inside.len());
        let mut w = Vec::with_capacity(inside.len() * n);
        let mut pos = Vec::with_capacity(inside.len());
        let inv_r = 1.0 / r;
        let mut raw = vec![0f64; n];
        for u in inside {
            let x = at(u);
            let first = (x - r).floor() as i64 + 1;
            for (t, v) in raw.iter_mut().enumerate() {
                let d = (x - (first + t as i64) as f64).abs();
                *v = (1.0 - d * inv_r).max(0.0);
            }
            // The tap nearest x has weight above 1/2: the sum is positive.
            let inv = 1.0 / raw.iter().sum::<f64>();
            w.extend(raw.iter().map(|v| (v * inv) as f32));
            k0.push(first);
            pos.push(x);
        }
        Taps {
            lo,
            hi,
            n,
            r,
            k0,
            w,
            pos,
        }
    }

    /// Whether pixel `u` samples this slice.
    #[inline]
    pub fn covers(&self, u: usize) -> bool {
        self.lo <= u && u <= self.hi
    }

    /// First voxel and weights of pixel `u` (inside).
    #[inline]
    pub fn of(&self, u: usize) -> (i64, &[f32]) {
        let i = u - self.lo;
        (self.k0[i], &self.w[i * self.n..(i + 1) * self.n])
    }

    /// Pixels within `r` voxels (and one pixel more) of voxels `[a, b)`.
    #[inline]
    pub fn reach(&self, f: &Factor, z: usize, a: usize, run: [u32; 2]) -> (usize, usize) {
        let s = f.slice_scale(z as f64);
        let e = f.eye[a];
        let to_pix = |x: f64| f.plane_to_pixel(e + (x - e) * s, a);
        let u0 = to_pix(f64::from(run[0]) - self.r).floor() - 1.0;
        let u1 = to_pix(f64::from(run[1]) - 1.0 + self.r).ceil() + 1.0;
        (
            u0.max(self.lo as f64) as usize,
            u1.min(self.hi as f64).max(0.0) as usize,
        )
    }
}

/// What every scanline of a frame shares.
pub(crate) struct Pass<'a> {
    pub view: &'a View,
    pub factor: &'a Factor,
    pub cls: &'a Classified,
    pub clip: &'a ViewClip,
    pub x: Vec<Taps>,
    pub y: Vec<Taps>,
    pub terminate: f32,
    pub rle: bool,
    /// Shading, and the scalar stack its samples mode differentiates.
    pub shade: Option<(&'a Shader, &'a SliceStack)>,
    /// The volume of interest, in view space.
    pub voi: Option<&'a ViewVoi>,
}

/// A scanline task's reusable buffers.
#[derive(Default)]
pub(crate) struct Scratch {
    next: Vec<u32>,
    ds: Vec<f32>,
    spans: Vec<(usize, usize)>,
}

/// The next pixel at or after `u` that is not opaque (path halving).
#[inline]
fn find(next: &mut [u32], mut u: usize) -> usize {
    while next[u] as usize != u {
        let up = next[next[u] as usize];
        next[u] = up;
        u = up as usize;
    }
    u
}

/// Composites every slice, front to back, into intermediate scanline `v`.
pub(crate) fn scanline(p: &Pass, v: usize, row: &mut [[f32; 4]], sc: &mut Scratch) -> SwStats {
    let mut st = SwStats::default();
    let f = p.factor;
    let w = row.len();
    let [nx, ny, nz] = p.cls.dims;
    sc.next.clear();
    sc.next.extend(0..=w as u32);
    let (ex, ey, d) = (f.eye.x, f.eye.y, f.d);
    let yv = f.pixel_pos(v, 1);
    sc.ds.clear();
    sc.ds.extend((0..w).map(|u| {
        let xu = f.pixel_pos(u, 0);
        p.view.world_length((xu - ex) / d, (yv - ey) / d, 1.0) as f32
    }));
    let clipping = !p.clip.is_empty();
    for z in 0..nz {
        let (yt, xt) = (&p.y[z], &p.x[z]);
        if !yt.covers(v) || xt.lo > xt.hi {
            continue;
        }
        st.samples_candidate += (xt.hi - xt.lo + 1) as u64;
        if p.rle && !p.cls.slice_any(z) {
            continue;
        }
        let (k0y, wy) = yt.of(v);
        let clamp_y = |t: usize| (k0y + t as i64).clamp(0, ny as i64 - 1) as usize;
        sc.spans.clear();
        if p.rle {
            for (t, &wt) in wy.iter().enumerate() {
                if wt == 0.0 {
                    continue;
                }
                for &run in p.cls.runs(z, clamp_y(t)) {
                    let (a, b) = xt.reach(f, z, 0, run);
                    if a <= b {
                        sc.spans.push((a, b));
                    }
                }
            }
            sc.spans.sort_unstable();
        } else {
            sc.spans.push((xt.lo, xt.hi));
        }
        let ypos = yt.pos[v - yt.lo];
        let zf = z as f64;
        // Spans overlap where runs of neighbouring rows do: `done` is the
        // first pixel not yet visited in this slice.
        let mut done = 0usize;
        for i in 0..sc.spans.len() {
            let (a, b) = sc.spans[i];
            let mut u = find(&mut sc.next, a.max(done));
            while u <= b {
                let (k0x, wx) = xt.of(u);
                if clipping && !p.clip.keeps(xt.pos[u - xt.lo], ypos, zf) {
                    st.samples_clipped += 1;
                    u = find(&mut sc.next, u + 1);
                    continue;
                }
                st.samples_total += 1;
                let mut c = [0f32; 4];
                for (t, &wt) in wy.iter().enumerate() {
                    if wt == 0.0 {
                        continue;
                    }
                    let line = p.cls.row(z, clamp_y(t));
                    for (s, &ws) in wx.iter().enumerate() {
                        if ws == 0.0 {
                            continue;
                        }
                        let kx = (k0x + s as i64).clamp(0, nx as i64 - 1) as usize;
                        let q = line[kx];
                        let k = wt * ws;
                        for ch in 0..4 {
                            c[ch] += k * q[ch];
                        }
                    }
                }
                if let Some(vv) = p.voi {
                    let at = glam::DVec3::new(xt.pos[u - xt.lo], ypos, zf);
                    let f = vv.factor(at) as f32;
                    c = c.map(|x| x * f);
                }
                if c[3] > 0.0 {
                    st.samples_composited += 1;
                    let acc = &mut row[u];
                    let k = if let Some((sh, stack)) = p.shade {
                        let g = match sh.voxel_gradients() {
                            Some(gr) => gather(gr, z, [k0x, k0y], [wx, wy], [nx, ny]),
                            None => sh.gradient_bilinear(
                                stack,
                                z,
                                xt.pos[u - xt.lo] as f32,
                                ypos as f32,
                            ),
                        };
                        let inv = 1.0 / c[3];
                        let s = sh.shade_f32([c[0] * inv, c[1] * inv, c[2] * inv, c[3]], g);
                        let a = correct_opacity(s[3].min(1.0), sc.ds[u]);
                        let k = (1.0 - acc[3]) * a;
                        for ch in 0..3 {
                            acc[ch] += k * s[ch];
                        }
                        k
                    } else {
                        let a = correct_opacity(c[3].min(1.0), sc.ds[u]);
                        let k = (1.0 - acc[3]) * a;
                        let wgt = k / c[3];
                        acc[0] += wgt * c[0];
                        acc[1] += wgt * c[1];
                        acc[2] += wgt * c[2];
                        k
                    };
                    acc[3] += k;
                    if acc[3] >= p.terminate {
                        st.rays_terminated += 1;
                        sc.next[u] = u as u32 + 1;
                    }
                }
                u = find(&mut sc.next, u + 1);
            }
            done = done.max(b + 1);
        }
    }
    st
}

/// The voxel gradients of slice `z` filtered with a sample's own taps
/// (first voxels `k0`, weights `w`, voxels beyond a face reading the
/// edge), as the colour is: the gradient interpolated like the scalar.
#[inline]
fn gather(
    g: &crate::gradients::Gradients,
    z: usize,
    k0: [i64; 2],
    w: [&[f32]; 2],
    n: [usize; 2],
) -> [f32; 3] {
    let mut out = [0f32; 3];
    for (t, &wt) in w[1].iter().enumerate() {
        if wt == 0.0 {
            continue;
        }
        let ky = (k0[1] + t as i64).clamp(0, n[1] as i64 - 1) as usize;
        for (s, &ws) in w[0].iter().enumerate() {
            if ws == 0.0 {
                continue;
            }
            let kx = (k0[0] + s as i64).clamp(0, n[0] as i64 - 1) as usize;
            let k = wt * ws;
            // The gradients are padded by one voxel per side.
            let v = g.at(z, kx + 1, ky + 1);
            for (o, v) in out.iter_mut().zip(v) {
                *o += k * v;
            }
        }
    }
    out
}
