//! Ray-buffer operators at region boundaries: the Bartlett and box merges
//! (back-to-front) and the bilinear split (front-to-back, the merge's
//! adjoint). Buffers hold one premultiplied RGBA state per ray of a
//! [`RayGrid`], row-major; rays outside a grid's rectangle are empty.
//!
//! The pipeline's merge stage mirrors [`merge`]: same weights, same parity.

use std::cell::RefCell;

use rayon::prelude::*;

use crate::geometry::{Merge, RayGrid};

/// One ray's accumulated state: premultiplied RGB and opacity.
pub type Rgba = [f32; 4];

thread_local! {
    /// Ray buffers of finished frames, kept for later frames on this
    /// thread: a fresh megabyte costs hundreds of page faults (several
    /// milliseconds a frame in a virtual machine, more than a region's
    /// merge), a recycled one a memset.
    static SPARE: RefCell<Vec<Vec<Rgba>>> = const { RefCell::new(Vec::new()) };
}

/// Spare buffers kept per thread.
const MAX_SPARE: usize = 12;

/// A spare buffer of this thread with room for `n` states, as it was
/// recycled (its length kept), or a new empty one.
fn spare(n: usize) -> Vec<Rgba> {
    SPARE
        .with(|s| {
            let mut s = s.borrow_mut();
            let i = s.iter().position(|b| b.capacity() >= n)?;
            Some(s.swap_remove(i))
        })
        .unwrap_or_default()
}

/// States one task of [`zeroed`] or [`copied`] writes (128 KiB): a
/// frame's ray buffers and image are megabytes, and one thread writing
/// them while the other waited was 6 % of an `er-ftb` frame.
const CHUNK: usize = 1 << 13;

/// A recycled (or new) buffer of `n` states whose values are left over:
/// a recycled buffer keeps its length, so only states past it are pushed.
fn sized(n: usize) -> Vec<Rgba> {
    let mut v = spare(n);
    v.truncate(n);
    v.resize(n, [0.0; 4]);
    v
}

/// `n` empty states (zeros), in a recycled buffer when one is spare,
/// written in parallel.
pub fn zeroed(n: usize) -> Vec<Rgba> {
    let mut v = sized(n);
    v.par_chunks_mut(CHUNK).for_each(|c| c.fill([0.0; 4]));
    v
}

/// A copy of `src`, in a recycled buffer when one is spare, written in
/// parallel.
pub fn copied(src: &[Rgba]) -> Vec<Rgba> {
    let mut v = sized(src.len());
    v.par_chunks_mut(CHUNK)
        .zip(src.par_chunks(CHUNK))
        .for_each(|(d, s)| d.copy_from_slice(s));
    v
}

/// Gives a buffer back for later frames on this thread.
pub fn recycle(v: Vec<Rgba>) {
    if v.capacity() == 0 {
        return;
    }
    SPARE.with(|s| {
        let mut s = s.borrow_mut();
        if s.len() < MAX_SPARE {
            s.push(v);
        }
    });
}

/// Reads `buf` (over `grid`) at ray `(mx, my)`, empty outside the grid.
#[cfg(test)]
fn at(buf: &[Rgba], grid: &RayGrid, mx: i64, my: i64) -> Rgba {
    if mx < grid.lo[0] || mx > grid.hi[0] || my < grid.lo[1] || my > grid.hi[1] {
        return [0.0; 4];
    }
    let w = grid.counts()[0];
    buf[(my - grid.lo[1]) as usize * w + (mx - grid.lo[0]) as usize]
}

#[inline]
fn madd(acc: &mut Rgba, w: f32, v: Rgba) {
    for c in 0..4 {
        acc[c] += w * v[c];
    }
}

/// Taps of a merge: which back rays (relative to `2m`) feed front ray `m`
/// on one axis, and with what weight.
fn taps(kind: Merge) -> &'static [(i64, f32)] {
    match kind {
        Merge::Bartlett => &[(-1, 0.25), (0, 0.5), (1, 0.25)],
        Merge::Box => &[(0, 0.5), (1, 0.5)],
    }
}

/// Merges the back region's rays (`back` over `bgrid`) into the front
/// region's rays over `fgrid`: separable, per axis front ray `m` takes the
/// taps around back ray `2m` (Bartlett: `(1/4, 1/2, 1/4)` on `2m-1..=2m+1`;
/// box: `(1/2, 1/2)` on `2m, 2m+1`). Front rays fed by nothing start empty,
/// which is how empty rays are added at the edges.
pub fn merge(kind: Merge, back: &[Rgba], bgrid: &RayGrid, fgrid: &RayGrid) -> Vec<Rgba> {
    let [fw, fh] = fgrid.counts();
    let [bw, bh] = bgrid.counts();
    let taps = taps(kind);
    let mut out = zeroed(fw * fh);
    if fw == 0 || fh == 0 || bw == 0 || bh == 0 {
        return out;
    }
    // Index of back ray `n` in a back row (or column), if inside the grid.
    let inside = |n: i64, lo: i64, len: usize| {
        let j = n - lo;
        (0..len as i64).contains(&j).then_some(j as usize)
    };
    // Pass 1, along x: for every back row, the x-merged values at front columns.
    let mut tmp = zeroed(fw * bh);
    tmp.par_chunks_mut(fw)
        .zip(back.par_chunks(bw))
        .for_each(|(line, src)| {
            for (c, acc) in line.iter_mut().enumerate() {
                let m = fgrid.lo[0] + c as i64;
                for &(o, w) in taps {
                    if let Some(j) = inside(2 * m + o, bgrid.lo[0], bw) {
                        madd(acc, w, src[j]);
                    }
                }
            }
        });
    // Pass 2, along y, row by row of the x-merged values.
    out.par_chunks_mut(fw).enumerate().for_each(|(r, line)| {
        let m = fgrid.lo[1] + r as i64;
        for &(o, w) in taps {
            if let Some(j) = inside(2 * m + o, bgrid.lo[1], bh) {
                for (acc, v) in line.iter_mut().zip(&tmp[j * fw..(j + 1) * fw]) {
                    madd(acc, w, *v);
                }
            }
        }
    });
    recycle(tmp);
    out
}

/// Splits the front region's rays (`front` over `fgrid`) into the back
/// region's rays over `bgrid`: back ray `2m` continues front ray `m`, back
/// ray `2m + 1` takes the mean of front rays `m` and `m + 1`, per axis
/// (bilinear interpolation; twice the transpose of the Bartlett merge).
pub fn split(front: &[Rgba], fgrid: &RayGrid, bgrid: &RayGrid) -> Vec<Rgba> {
    let [bw, bh] = bgrid.counts();
    let [fw, fh] = fgrid.counts();
    let parents = |n: i64| -> [(i64, f32); 2] {
        if n.rem_euclid(2) == 0 {
            [(n.div_euclid(2), 1.0), (0, 0.0)]
        } else {
            [(n.div_euclid(2), 0.5), (n.div_euclid(2) + 1, 0.5)]
        }
    };
    let mut out = zeroed(bw * bh);
    if bw == 0 || fw == 0 || fh == 0 {
        return out;
    }
    // Each back column's parents as indices into a front row.
    let cols: Vec<[(usize, f32); 2]> = (0..bw)
        .map(|c| {
            parents(bgrid.lo[0] + c as i64).map(|(m, w)| {
                let j = m - fgrid.lo[0];
                if w != 0.0 && (0..fw as i64).contains(&j) {
                    (j as usize, w)
                } else {
                    (0, 0.0)
                }
            })
        })
        .collect();
    out.par_chunks_mut(bw).enumerate().for_each(|(r, line)| {
        for (my, wy) in parents(bgrid.lo[1] + r as i64) {
            let j = my - fgrid.lo[1];
            if wy == 0.0 || !(0..fh as i64).contains(&j) {
                continue;
            }
            let src = &front[j as usize * fw..(j as usize + 1) * fw];
            for (acc, px) in line.iter_mut().zip(&cols) {
                for &(i, wx) in px {
                    if wx != 0.0 {
                        madd(acc, wx * wy, src[i]);
                    }
                }
            }
        }
    });
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn grid(lo: i64, hi: i64) -> RayGrid {
        RayGrid {
            z_ref: 1.0,
            phi: [0.0; 2],
            lo: [lo, lo],
            hi: [hi, hi],
            slices: 0..0,
        }
    }

    /// A buffer over `g` that is 1 on column `n` (constant along y, so the
    /// y pass of a merge leaves interior rows at 1).
    fn column(g: &RayGrid, n: i64) -> Vec<Rgba> {
        let w = g.counts()[0];
        let mut buf = vec![[0f32; 4]; g.len()];
        for r in 0..g.counts()[1] {
            buf[r * w + (n - g.lo[0]) as usize] = [1.0; 4];
        }
        buf
    }

    /// A recycled buffer keeps its old states; `zeroed` and `copied` must
    /// overwrite every one of them, in every chunk, whatever the lengths.
    #[test]
    fn recycled_buffers_are_overwritten() {
        for (old, n) in [(50_000, 20_000), (20_000, 50_000), (9_000, 8_193), (100, 7)] {
            recycle(vec![[1.5; 4]; old]);
            let z = zeroed(n);
            assert_eq!(z.len(), n);
            assert!(
                z.iter().all(|s| s.iter().all(|c| c.to_bits() == 0)),
                "{old} {n}"
            );
            drop(z);
            recycle(vec![[2.5; 4]; old]);
            let src: Vec<Rgba> = (0..n).map(|i| [i as f32, 1.0, 2.0, 3.0]).collect();
            let c = copied(&src);
            assert_eq!(c, src, "{old} {n}");
        }
    }

    /// Output ray 0's weight for an impulse at each input ray after two
    /// merges: the paper's cascade `1 2 3 4 3 2 1 / 16`.
    #[test]
    fn two_bartlett_merges_cascade() {
        let (g0, g1, g2) = (grid(-8, 8), grid(-4, 4), grid(-2, 2));
        let mut weights = Vec::new();
        for n in -4..=4 {
            let buf = column(&g0, n);
            let b1 = merge(Merge::Bartlett, &buf, &g0, &g1);
            let b2 = merge(Merge::Bartlett, &b1, &g1, &g2);
            weights.push(at(&b2, &g2, 0, 0)[0] * 16.0);
        }
        assert_eq!(weights, vec![0.0, 1.0, 2.0, 3.0, 4.0, 3.0, 2.0, 1.0, 0.0]);
    }

    #[test]
    fn split_is_twice_the_merge_transpose() {
        let (gb, gf) = (grid(-6, 6), grid(-3, 3));
        for n in -6..=6 {
            for m in -3..=3 {
                let s = at(&split(&column(&gf, m), &gf, &gb), &gb, n, 0)[0];
                let bb = column(&gb, n);
                let mm = at(&merge(Merge::Bartlett, &bb, &gb, &gf), &gf, m, 0)[0];
                assert_eq!(s, 2.0 * mm, "n {n} m {m}");
            }
        }
    }
}
