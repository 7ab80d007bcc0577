//! Ray-buffer operators at region boundaries: the Bartlett and box merges
//! (back-to-front) and the bilinear split (front-to-back, the merge's
//! adjoint). Buffers hold one premultiplied RGBA state per ray of a
//! [`RayGrid`], row-major; rays outside a grid's rectangle are empty.
//!
//! The pipeline's merge stage mirrors [`merge`]: same weights, same parity.

use std::sync::Mutex;

use rayon::prelude::*;

use crate::geometry::{Merge, RayGrid};

/// One ray's accumulated state: premultiplied RGB and opacity.
pub type Rgba = [f32; 4];

/// Ray buffers of finished frames, kept for later frames: a fresh
/// megabyte costs hundreds of page faults (several milliseconds a frame
/// in a virtual machine, more than a region's merge), a recycled one a
/// memset. One pool for the process, not one a thread: a frame's buffers
/// are made on whichever worker runs it and may be given back on another
/// thread (the Python module's caller drops an image numpy held).
static SPARE: Mutex<Vec<Vec<Rgba>>> = Mutex::new(Vec::new());

/// Spare buffers kept.
const MAX_SPARE: usize = 12;

/// A spare buffer with room for `n` states, as it was recycled (its
/// length kept), or a new empty one.
fn spare(n: usize) -> Vec<Rgba> {
    // A poisoned pool only means a holder panicked between two plain
    // `Vec` operations; its buffers are still whole.
    let mut s = SPARE.lock().unwrap_or_else(|e| e.into_inner());
    match s.iter().position(|b| b.capacity() >= n) {
        Some(i) => s.swap_remove(i),
        None => Vec::new(),
    }
}

/// States one task of [`zeroed`] writes (128 KiB): a
/// frame's ray buffers and image are megabytes, and one thread writing
/// them while the other waited was 6 % of an `er-ftb` frame.
const CHUNK: usize = 1 << 13;

/// A recycled (or new) buffer of `n` states whose values are left over:
/// a recycled buffer keeps its length, so only states past it are pushed.
fn reused(n: usize) -> Vec<Rgba> {
    let mut v = spare(n);
    v.truncate(n);
    v.resize(n, [0.0; 4]);
    v
}

/// `n` empty states (zeros), in a recycled buffer when one is spare,
/// written in parallel.
pub fn zeroed(n: usize) -> Vec<Rgba> {
    let mut v = reused(n);
    v.par_chunks_mut(CHUNK).for_each(|c| c.fill([0.0; 4]));
    v
}

/// Gives a buffer back for later frames.
pub fn recycle(v: Vec<Rgba>) {
    if v.capacity() == 0 {
        return;
    }
    let mut s = SPARE.lock().unwrap_or_else(|e| e.into_inner());
    if s.len() < MAX_SPARE {
        s.push(v);
    }
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
    let mut out = reused(fgrid.len());
    merge_rows(kind, |j| back[j], (bgrid, fgrid), &mut out, |o, v| *o = v);
    out
}

/// The front-to-back fold at one region boundary, in one merge: `finals`
/// (the front region's rays after its last slice) each gain the merge of
/// what the back region's rays added behind their inheritance, `result -
/// inherited`. The same operations as subtracting, [`merge`] and adding
/// buffer by buffer (IEEE addition commutes), without the three passes
/// over whole buffers between them.
pub fn fold_into(
    kind: Merge,
    (result, inherited): (&[Rgba], &[Rgba]),
    (bgrid, fgrid): (&RayGrid, &RayGrid),
    finals: &mut [Rgba],
) {
    let added = |j: usize| {
        let (r, h) = (result[j], inherited[j]);
        [r[0] - h[0], r[1] - h[1], r[2] - h[2], r[3] - h[3]]
    };
    merge_rows(kind, added, (bgrid, fgrid), finals, |o, v| {
        for c in 0..4 {
            o[c] += v[c];
        }
    });
}

/// [`merge`] of the back rays `back(j)` (row-major over `bgrid`), each
/// front ray's merged state `v` given to `put(&mut out[i], v)`; rays fed
/// by nothing (every ray, for an empty back grid) get `+0` states.
fn merge_rows(
    kind: Merge,
    back: impl Fn(usize) -> Rgba + Sync,
    (bgrid, fgrid): (&RayGrid, &RayGrid),
    out: &mut [Rgba],
    put: impl Fn(&mut Rgba, Rgba) + Sync,
) {
    let [fw, fh] = fgrid.counts();
    let [bw, bh] = bgrid.counts();
    debug_assert_eq!(out.len(), fw * fh);
    if fw == 0 || fh == 0 {
        return;
    }
    let taps = taps(kind);
    // Index of back ray `n` in a back row (or column), if inside the grid.
    let inside = |n: i64, lo: i64, len: usize| {
        let j = n - lo;
        (0..len as i64).contains(&j).then_some(j as usize)
    };
    // Pass 1, along x: for every back row, the x-merged values at front
    // columns (each written whole, so the buffer need not start zeroed).
    let mut tmp = reused(fw * bh);
    tmp.par_chunks_mut(fw).enumerate().for_each(|(r, line)| {
        for (c, out) in line.iter_mut().enumerate() {
            let m = fgrid.lo[0] + c as i64;
            let mut acc = [0.0; 4];
            for &(o, w) in taps {
                if let Some(j) = inside(2 * m + o, bgrid.lo[0], bw) {
                    madd(&mut acc, w, back(r * bw + j));
                }
            }
            *out = acc;
        }
    });
    // Pass 2, along y, row by row of the x-merged values, summed in a
    // row of scratch and then put.
    out.par_chunks_mut(fw).enumerate().for_each_init(
        || vec![[0f32; 4]; fw],
        |acc, (r, line)| {
            acc.fill([0.0; 4]);
            let m = fgrid.lo[1] + r as i64;
            for &(o, w) in taps {
                if let Some(j) = inside(2 * m + o, bgrid.lo[1], bh) {
                    for (a, v) in acc.iter_mut().zip(&tmp[j * fw..(j + 1) * fw]) {
                        madd(a, w, *v);
                    }
                }
            }
            for (o, a) in line.iter_mut().zip(acc.iter()) {
                put(o, *a);
            }
        },
    );
    recycle(tmp);
}

/// Splits the front region's rays (`front` over `fgrid`) into the back
/// region's rays over `bgrid`: back ray `2m` continues front ray `m`, back
/// ray `2m + 1` takes the mean of front rays `m` and `m + 1`, per axis
/// (bilinear interpolation; twice the transpose of the Bartlett merge).
pub fn split(front: &[Rgba], fgrid: &RayGrid, bgrid: &RayGrid) -> Vec<Rgba> {
    split_into(front, fgrid, bgrid, None)
}

/// [`split`] and a copy of its result, written in the same pass (the
/// front-to-back fold keeps what each region inherited).
pub fn split_kept(front: &[Rgba], fgrid: &RayGrid, bgrid: &RayGrid) -> (Vec<Rgba>, Vec<Rgba>) {
    let mut kept = reused(bgrid.len());
    let out = split_into(front, fgrid, bgrid, Some(&mut kept));
    (out, kept)
}

/// [`split`], copying every row it writes into `kept` too when given.
fn split_into(
    front: &[Rgba],
    fgrid: &RayGrid,
    bgrid: &RayGrid,
    kept: Option<&mut [Rgba]>,
) -> Vec<Rgba> {
    let [bw, bh] = bgrid.counts();
    let [fw, fh] = fgrid.counts();
    let parents = |n: i64| -> [(i64, f32); 2] {
        if n.rem_euclid(2) == 0 {
            [(n.div_euclid(2), 1.0), (0, 0.0)]
        } else {
            [(n.div_euclid(2), 0.5), (n.div_euclid(2) + 1, 0.5)]
        }
    };
    if bw == 0 || fw == 0 || fh == 0 {
        if let Some(k) = kept {
            k.fill([0.0; 4]);
        }
        return zeroed(bw * bh);
    }
    let mut out = reused(bw * bh);
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
    let row = |(r, line): (usize, &mut [Rgba])| {
        line.fill([0.0; 4]);
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
    };
    match kept {
        None => out.par_chunks_mut(bw).enumerate().for_each(row),
        Some(k) => out
            .par_chunks_mut(bw)
            .zip(k.par_chunks_mut(bw))
            .enumerate()
            .for_each(|(r, (line, copy))| {
                row((r, &mut *line));
                copy.copy_from_slice(line);
            }),
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

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

    /// A recycled buffer keeps its old states; `zeroed` must
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

    /// A grid over `lo..=hi` per axis (empty where `hi < lo`).
    fn rect(lo: [i64; 2], hi: [i64; 2]) -> RayGrid {
        RayGrid {
            z_ref: 1.0,
            phi: [0.0; 2],
            lo,
            hi,
            slices: 0..0,
        }
    }

    /// The merge's definition ray by ray: the x taps summed within each
    /// back row, then the rows' sums by their y taps, in tap order.
    fn merge_oracle(kind: Merge, back: &[Rgba], bg: &RayGrid, fg: &RayGrid) -> Vec<Rgba> {
        let mut out = Vec::new();
        for my in fg.lo[1]..=fg.hi[1] {
            for mx in fg.lo[0]..=fg.hi[0] {
                let mut acc = [0f32; 4];
                for &(oy, wy) in taps(kind) {
                    let ny = 2 * my + oy;
                    if ny < bg.lo[1] || ny > bg.hi[1] || bg.counts()[0] == 0 {
                        continue;
                    }
                    let mut row = [0f32; 4];
                    for &(ox, wx) in taps(kind) {
                        let nx = 2 * mx + ox;
                        if nx >= bg.lo[0] && nx <= bg.hi[0] {
                            madd(&mut row, wx, at(back, bg, nx, ny));
                        }
                    }
                    madd(&mut acc, wy, row);
                }
                out.push(acc);
            }
        }
        out
    }

    fn bits(v: &[Rgba]) -> Vec<[u32; 4]> {
        v.iter().map(|s| s.map(f32::to_bits)).collect()
    }

    fn state() -> impl Strategy<Value = Rgba> {
        prop::array::uniform4(prop_oneof![Just(0.0f32), Just(-0.0f32), -1.0f32..1.0])
    }

    proptest! {
        /// The fused operators give the bits of their definitions: the
        /// merge its ray-by-ray sum, the fold the subtract, merge and add
        /// it replaced, the kept split two copies of the split; whatever
        /// a recycled buffer held before, and for empty grids too.
        #[test]
        fn fused_operators_are_their_definitions(
            flo in prop::array::uniform2(-6i64..2),
            fext in prop::array::uniform2(-1i64..8),
            blo in prop::array::uniform2(-12i64..4),
            bext in prop::array::uniform2(-1i64..16),
            box_kind in any::<bool>(),
            seed in prop::collection::vec(state(), 1..64),
        ) {
            let kind = if box_kind { Merge::Box } else { Merge::Bartlett };
            let fg = rect(flo, [flo[0] + fext[0], flo[1] + fext[1]]);
            let bg = rect(blo, [blo[0] + bext[0], blo[1] + bext[1]]);
            let fill = |n: usize, k: usize| -> Vec<Rgba> {
                (0..n).map(|i| seed[(i * 7 + k) % seed.len()]).collect()
            };
            let (back, inh, fin) = (fill(bg.len(), 0), fill(bg.len(), 3), fill(fg.len(), 5));
            recycle(vec![[9.5; 4]; 4096]);
            prop_assert_eq!(bits(&merge(kind, &back, &bg, &fg)), bits(&merge_oracle(kind, &back, &bg, &fg)));
            let mut fused = fin.clone();
            recycle(vec![[-3.0; 4]; 4096]);
            fold_into(kind, (&back, &inh), (&bg, &fg), &mut fused);
            let diff: Vec<Rgba> = back
                .iter()
                .zip(&inh)
                .map(|(r, h)| [r[0] - h[0], r[1] - h[1], r[2] - h[2], r[3] - h[3]])
                .collect();
            let folded = merge_oracle(kind, &diff, &bg, &fg);
            let want: Vec<Rgba> = fin
                .iter()
                .zip(&folded)
                .map(|(r, f)| [r[0] + f[0], r[1] + f[1], r[2] + f[2], r[3] + f[3]])
                .collect();
            prop_assert_eq!(bits(&fused), bits(&want));
            let front = fill(fg.len(), 1);
            recycle(vec![[7.0; 4]; 4096]);
            let (out, kept) = split_kept(&front, &fg, &bg);
            let plain = split(&front, &fg, &bg);
            prop_assert_eq!(bits(&out), bits(&plain));
            prop_assert_eq!(bits(&kept), bits(&plain));
        }
    }
}
