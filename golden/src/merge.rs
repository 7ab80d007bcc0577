//! Ray-buffer operators at region boundaries: the Bartlett and box merges
//! (back-to-front) and the bilinear split (front-to-back, the merge's
//! adjoint). Buffers hold one premultiplied RGBA state per ray of a
//! [`RayGrid`], row-major; rays outside a grid's rectangle are empty.
//!
//! The pipeline's merge stage mirrors [`merge`]: same weights, same parity.

use crate::geometry::{Merge, RayGrid};

/// One ray's accumulated state: premultiplied RGB and opacity.
pub type Rgba = [f32; 4];

/// Reads `buf` (over `grid`) at ray `(mx, my)`, empty outside the grid.
#[inline]
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
    let taps = taps(kind);
    // Pass 1, along x: for every back row, the x-merged values at front columns.
    let brows = bgrid.counts()[1];
    let mut tmp = vec![[0f32; 4]; fw * brows];
    for r in 0..brows {
        let my = bgrid.lo[1] + r as i64;
        for (c, out) in tmp[r * fw..(r + 1) * fw].iter_mut().enumerate() {
            let m = fgrid.lo[0] + c as i64;
            for &(o, w) in taps {
                madd(out, w, at(back, bgrid, 2 * m + o, my));
            }
        }
    }
    // Pass 2, along y.
    let tgrid = RayGrid {
        lo: [fgrid.lo[0], bgrid.lo[1]],
        hi: [fgrid.hi[0], bgrid.hi[1]],
        ..fgrid.clone()
    };
    let mut out = vec![[0f32; 4]; fw * fh];
    for r in 0..fh {
        let m = fgrid.lo[1] + r as i64;
        for c in 0..fw {
            let mx = fgrid.lo[0] + c as i64;
            let acc = &mut out[r * fw + c];
            for &(o, w) in taps {
                madd(acc, w, at(&tmp, &tgrid, mx, 2 * m + o));
            }
        }
    }
    out
}

/// Splits the front region's rays (`front` over `fgrid`) into the back
/// region's rays over `bgrid`: back ray `2m` continues front ray `m`, back
/// ray `2m + 1` takes the mean of front rays `m` and `m + 1`, per axis
/// (bilinear interpolation; twice the transpose of the Bartlett merge).
pub fn split(front: &[Rgba], fgrid: &RayGrid, bgrid: &RayGrid) -> Vec<Rgba> {
    let [bw, bh] = bgrid.counts();
    let parents = |n: i64| -> [(i64, f32); 2] {
        if n.rem_euclid(2) == 0 {
            [(n.div_euclid(2), 1.0), (0, 0.0)]
        } else {
            [(n.div_euclid(2), 0.5), (n.div_euclid(2) + 1, 0.5)]
        }
    };
    let mut out = vec![[0f32; 4]; bw * bh];
    for r in 0..bh {
        let py = parents(bgrid.lo[1] + r as i64);
        for c in 0..bw {
            let px = parents(bgrid.lo[0] + c as i64);
            let acc = &mut out[r * bw + c];
            for &(my, wy) in &py {
                if wy == 0.0 {
                    continue;
                }
                for &(mx, wx) in &px {
                    if wx != 0.0 {
                        madd(acc, wx * wy, at(front, fgrid, mx, my));
                    }
                }
            }
        }
    }
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
