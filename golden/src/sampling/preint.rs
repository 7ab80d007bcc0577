//! A pre-integrated step's two scalars ([`crate::preint`]): the front one
//! where the ray crosses slice `z`, the back one where it crosses slice
//! `z + 1` (or the volume's face), each at the slice's own position, one of
//! them reused from the ray's neighbour step ([`TapCache`]).

use super::{Order, RayRow};
use crate::slices::{bilinear_x8, Plane};

/// A ray's last scalar taken where it crosses a slice, and the slice
/// (`u32::MAX`: none yet). A pre-integrated step reads the scalars at
/// slices `z` and `z + 1`; its neighbour step read one of them, at the
/// same position with the same arithmetic, so that tap is reused (back to
/// front the step's back is the previous step's front, front to back its
/// front is the previous step's back) and only the other is taken.
#[derive(Debug, Clone, Copy)]
pub(crate) struct TapCache {
    pub(crate) value: f32,
    pub(crate) slice: u32,
}

impl TapCache {
    pub(crate) const NONE: TapCache = TapCache {
        value: 0.0,
        slice: u32::MAX,
    };

    /// The scalar at slice `z` if this cache holds it, else `take()`'s.
    #[inline(always)]
    pub(crate) fn get(&self, z: usize, take: impl FnOnce() -> f32) -> f32 {
        if self.slice as usize == z {
            self.value
        } else {
            take()
        }
    }
}

impl RayRow<'_> {
    /// Ray `mx`'s scalar where it crosses slice `z + 1` (its position there
    /// clamped into the padding), or at the volume's face (`z + 1/2`) for
    /// the last slice: a pre-integrated step's back end.
    #[inline(always)]
    pub(crate) fn back_tap(&self, mx: i64, x: f32, slope_x: f32) -> f32 {
        let stack = self.pass.stack;
        let clamp = |v: f32, n: usize| v.clamp(-1.0, n as f32 - 1e-3);
        match self.back {
            Some((bx, by)) => {
                let x = (bx.a + mx as f64 * bx.t) as f32;
                stack.bilinear(self.next, clamp(x, stack.dims[0]), by)
            }
            // The face: the padding repeats the slice there.
            None => stack.bilinear(
                self.data,
                clamp(x + 0.5 * slope_x, stack.dims[0]),
                clamp(self.y + 0.5 * self.slope_y, stack.dims[1]),
            ),
        }
    }

    /// A pre-integrated step's front and back scalars for ray `mx` at `x`,
    /// reusing the tap its neighbour step took (`slot`, see [`TapCache`])
    /// and leaving there the one the next step can reuse.
    #[inline(always)]
    pub(crate) fn step_scalars(
        &self,
        mx: i64,
        (x, slope_x): (f32, f32),
        slot: Option<&mut TapCache>,
    ) -> (f32, f32) {
        let stack = self.pass.stack;
        let z = self.z;
        let own = || stack.bilinear(self.data, x, self.y);
        let back = || self.back_tap(mx, x, slope_x);
        let Some(c) = slot else {
            return (own(), back());
        };
        match self.pass.order {
            // From the rear: this step's back is the previous step's front.
            Order::BackToFront => {
                let sb = if self.back.is_some() {
                    c.get(z + 1, back)
                } else {
                    back()
                };
                let sf = own();
                *c = TapCache {
                    value: sf,
                    slice: z as u32,
                };
                (sf, sb)
            }
            // From the front: this step's front is the previous step's back.
            Order::FrontToBack { .. } => {
                let sf = c.get(z, own);
                let sb = back();
                if self.back.is_some() {
                    *c = TapCache {
                        value: sb,
                        slice: z as u32 + 1,
                    };
                }
                (sf, sb)
            }
        }
    }

    /// [`RayRow::step_scalars`] without a cache for the eight rays at row
    /// offsets `at`: both taps of every step, eight at a time
    /// ([`bilinear_x8`]), at the one-ray form's positions with its
    /// arithmetic (the front tap where the ray crosses slice `z`, the back
    /// one where it crosses slice `z + 1` or the volume's face, clamped
    /// into the padding), so the same bits as the cached taps.
    #[inline(always)]
    pub(crate) fn step_scalars_x8(&self, at: &[usize; 8]) -> [(f32, f32); 8] {
        let (view, stack) = (self.pass.view, self.pass.stack);
        let clamp = |v: f32, n: usize| v.clamp(-1.0, n as f32 - 1e-3);
        let (mut x, mut xb) = ([0f32; 8], [0f32; 8]);
        for l in 0..8 {
            let mx = self.grid.lo[0] + at[l] as i64;
            x[l] = (self.px.a + mx as f64 * self.px.t) as f32;
            xb[l] = match self.back {
                Some((bx, _)) => clamp((bx.a + mx as f64 * bx.t) as f32, stack.dims[0]),
                None => {
                    let slope_x = ((self.grid.phi[0] + mx as f64 - view.eye.x) * self.inv) as f32;
                    clamp(x[l] + 0.5 * slope_x, stack.dims[0])
                }
            };
        }
        let (plane, yb) = match self.back {
            Some((_, by)) => (self.next, by),
            None => (self.data, clamp(self.y + 0.5 * self.slope_y, stack.dims[1])),
        };
        let taps = |p: Plane, x: &[f32; 8], y: f32| match p {
            Plane::U8(p) => bilinear_x8(p, stack.row, x, y),
            Plane::U16(p) => bilinear_x8(p, stack.row, x, y),
        };
        let (f, b) = (taps(self.data, &x, self.y), taps(plane, &xb, yb));
        std::array::from_fn(|l| (f[l], b[l]))
    }
}
