//! Eight bilinear samples of one padded plane in `f32x8` vectors: the
//! batched sampling path's taps ([`bilinear_x8`]).
//!
//! The eight cells' four taps are read by two hardware gathers where the
//! target has AVX2 (one 32-bit word per lane holds both taps of a cell's
//! row: bytes 0 and 1 of an 8-bit plane, the two halves of a 16-bit one),
//! and the cell positions, the weights and the bilinear formula run in
//! vectors. Every operation is [`super::SliceStack::bilinear`]'s, lane by
//! lane and in the same order (a conversion, subtractions, multiplies and
//! adds, no fused multiply-add), so each lane's bits are the scalar
//! form's; a batch whose cells the gathers cannot read safely (a position
//! outside the plane, a word past its end) takes the scalar form.
//! `golden/tests/it/lanes.rs` checks frames against the one-ray path.

use wide::{f32x8, i32x8};

use super::{bilinear_lanes, SliceStack};

/// A plane's scalar type as the gathers read it.
pub(crate) trait Texel: Copy + Into<f32> {
    /// The values at padded indices `i` and `i + 1` of `p` for every
    /// lane, or `None` when some lane's word is not inside `p`.
    fn pairs(p: &[Self], i: i32x8) -> Option<(f32x8, f32x8)>;
}

/// Whether every lane's 32-bit word from element `i` (of `size`-byte
/// elements) lies inside a plane of `len` elements.
#[inline(always)]
fn words_inside(i: i32x8, size: usize, len: usize) -> bool {
    let a = i.to_array();
    let (lo, hi) = a
        .iter()
        .fold((i32::MAX, i32::MIN), |(lo, hi), &v| (lo.min(v), hi.max(v)));
    // The word's last byte is byte `i size + 3`.
    lo >= 0 && (hi as usize) * size + 4 <= len * size
}

/// One 32-bit word from byte `scale i` of `base` per lane.
///
/// # Safety
/// Every lane's four bytes lie inside one allocation starting at `base`.
#[cfg(all(target_arch = "x86_64", target_feature = "avx2"))]
#[inline(always)]
unsafe fn gather_words<const SCALE: i32>(base: *const u8, i: i32x8) -> i32x8 {
    use std::arch::x86_64::{
        __m256i, _mm256_i32gather_epi32, _mm256_loadu_si256, _mm256_storeu_si256,
    };
    let idx: [i32; 8] = i.to_array();
    let mut out = [0i32; 8];
    // SAFETY: the caller's bounds; unaligned loads and stores of arrays.
    unsafe {
        let v = _mm256_loadu_si256(idx.as_ptr() as *const __m256i);
        let g = _mm256_i32gather_epi32::<SCALE>(base as *const i32, v);
        _mm256_storeu_si256(out.as_mut_ptr() as *mut __m256i, g);
    }
    i32x8::from(out)
}

/// Without AVX2: eight scalar word loads.
#[cfg(not(all(target_arch = "x86_64", target_feature = "avx2")))]
#[inline(always)]
unsafe fn gather_words<const SCALE: i32>(base: *const u8, i: i32x8) -> i32x8 {
    let idx: [i32; 8] = i.to_array();
    // SAFETY: the caller's bounds.
    i32x8::from(
        idx.map(|k| unsafe {
            (base.add(k as usize * SCALE as usize) as *const i32).read_unaligned()
        }),
    )
}

impl Texel for u8 {
    #[inline(always)]
    fn pairs(p: &[u8], i: i32x8) -> Option<(f32x8, f32x8)> {
        if !words_inside(i, 1, p.len()) {
            return None;
        }
        // SAFETY: `words_inside` checked every lane's bytes `i..i + 4`.
        let w = unsafe { gather_words::<1>(p.as_ptr(), i) };
        let m = i32x8::splat(0xff);
        let a = w & m;
        let b = (w >> 8) & m;
        Some((f32x8::from_i32x8(a), f32x8::from_i32x8(b)))
    }
}

impl Texel for u16 {
    #[inline(always)]
    fn pairs(p: &[u16], i: i32x8) -> Option<(f32x8, f32x8)> {
        if !words_inside(i, 2, p.len()) {
            return None;
        }
        // SAFETY: `words_inside` checked every lane's elements `i, i + 1`.
        let w = unsafe { gather_words::<2>(p.as_ptr() as *const u8, i) };
        let m = i32x8::splat(0xffff);
        let a = w & m;
        let b = (w >> 16) & m;
        Some((f32x8::from_i32x8(a), f32x8::from_i32x8(b)))
    }
}

/// The bilinear sample at `(x[l], y)` of padded plane `p` (row length
/// `row`) for eight lanes: [`bilinear_lanes`]'s bits.
#[inline(always)]
pub(crate) fn bilinear_x8<T: Texel>(p: &[T], row: usize, x: &[f32; 8], y: f32) -> [f32; 8] {
    // The row's cell and weight: `SliceStack::cell_of`'s arithmetic.
    let fy = y + 1.0;
    let y0 = fy as u32;
    let ty = fy - y0 as f32;
    let fx = f32x8::from(*x) + f32x8::splat(1.0);
    // Positions at or above -1 truncate as `u32` does; a lane below
    // (or not a number, or past 2^31) gives a negative index and the
    // scalar form.
    let x0 = fx.fast_trunc_int();
    let tx = fx - f32x8::from_i32x8(x0);
    let base = (y0 as usize).checked_mul(row);
    let taps = base
        .filter(|&b| b <= i32::MAX as usize && row <= i32::MAX as usize / 2)
        .filter(|_| x0.reduce_min() >= 0)
        .and_then(|b| {
            // Non-negative lanes that overflow turn negative: `pairs`
            // refuses them.
            let i = x0 + i32x8::splat(b as i32);
            let below = i + i32x8::splat(row as i32);
            Some((T::pairs(p, i)?, T::pairs(p, below)?))
        });
    let Some(((a, b), (c, d))) = taps else {
        return bilinear_lanes(p, row, x, y);
    };
    // `lerp2_values` in vectors.
    let ty = f32x8::splat(ty);
    let top = a + tx * (b - a);
    let bot = c + tx * (d - c);
    (top + ty * (bot - top)).to_array()
}

impl SliceStack {
    /// The batched path's trilinear samples at `(x[l], y, z)`:
    /// [`SliceStack::trilinear_lanes`] with [`bilinear_x8`] taps.
    #[inline(always)]
    pub(crate) fn trilinear_x8(&self, x: &[f32; 8], y: f32, z: f32) -> [f32; 8] {
        let (z0, t, _, y) = SliceStack::clamp_f32_in(self.dims, 0.0, y, z);
        let mut x = *x;
        for v in &mut x {
            *v = SliceStack::clamp_f32_in(self.dims, *v, 0.0, 0.0).2;
        }
        let (front, back) = (z0 * self.plane, (z0 + 1) * self.plane);
        let (a, b) = match &self.data {
            super::StackData::U8(d) => (
                bilinear_x8(&d[front..back], self.row, &x, y),
                bilinear_x8(&d[back..back + self.plane], self.row, &x, y),
            ),
            super::StackData::U16(d) => (
                bilinear_x8(&d[front..back], self.row, &x, y),
                bilinear_x8(&d[back..back + self.plane], self.row, &x, y),
            ),
        };
        let (a, b) = (f32x8::from(a), f32x8::from(b));
        (a + f32x8::splat(t) * (b - a)).to_array()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::tf::Lut;
    use proptest::prelude::*;

    fn bits(v: [f32; 8]) -> [u32; 8] {
        v.map(f32::to_bits)
    }

    /// A padded `row x rows` plane of pseudo-random values below `max`.
    fn plane<T: TryFrom<u32>>(row: usize, rows: usize, seed: u32, max: u32) -> Vec<T> {
        let mut v = seed | 1;
        (0..row * rows)
            .map(|_| {
                v ^= v << 13;
                v ^= v >> 17;
                v ^= v << 5;
                T::try_from(v % max).ok().expect("below max")
            })
            .collect()
    }

    proptest! {
        /// Every lane of the gathered form has the scalar form's bits,
        /// over the whole plane: its last cells (where a word would pass
        /// the end and the scalar form takes over) and positions below -1
        /// (where the scalar form extrapolates from the first cell)
        /// included.
        #[test]
        fn gathered_taps_match_the_scalar_form(
            nx in 1usize..40,
            ny in 1usize..12,
            seed in any::<u32>(),
            fx in proptest::collection::vec(-2.5f32..1.0, 8),
            fy in 0f32..1.0,
        ) {
            let (row, rows) = (nx + 2, ny + 2);
            let x: [f32; 8] = std::array::from_fn(|l| {
                let f = fx[l];
                if f < -1.0 { f } else { -1.0 + f * (nx as f32 + 1.0 - 1e-3) }
            });
            let y = -1.0 + fy * (ny as f32 + 1.0 - 1e-3);
            let p8: Vec<u8> = plane(row, rows, seed, 256);
            prop_assert_eq!(bits(bilinear_x8(&p8, row, &x, y)), bits(bilinear_lanes(&p8, row, &x, y)));
            let p16: Vec<u16> = plane(row, rows, seed, 65536);
            prop_assert_eq!(bits(bilinear_x8(&p16, row, &x, y)), bits(bilinear_lanes(&p16, row, &x, y)));
        }

        /// The vector table lookup has `Lut::lookup`'s bits for scalars
        /// inside, below and above the table.
        #[test]
        fn vector_lookup_matches_the_scalar_form(
            entries in 1u32..9,
            seed in any::<u32>(),
            s in proptest::collection::vec(-20f32..300.0, 8),
        ) {
            let n = 2usize << entries;
            let raw: Vec<u32> = plane(n, 4, seed, 1 << 20);
            let rgba = (0..n)
                .map(|i| std::array::from_fn(|k| raw[4 * i + k] as f32 / (1 << 20) as f32))
                .collect();
            let lut = Lut { rgba, per_scalar: n as f32 / 256.0 };
            let s: [f32; 8] = std::array::from_fn(|l| s[l]);
            let v = lut.lookup_x8(&s);
            for l in 0..8 {
                prop_assert_eq!(v[l].map(f32::to_bits), lut.lookup(s[l]).map(f32::to_bits));
            }
        }
    }
}
