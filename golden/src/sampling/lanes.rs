//! A row's samples taken [`LANES`] rays at a time, in frames without
//! shading or a volume of interest: plain samples (one substep: the
//! default frame), substeps and pre-integrated steps (both without a clip
//! plane; pre-integration past the first slice).
//!
//! [`RayRow::sample`] is a chain of dependent steps per ray (position,
//! bilinear tap, table lookup, opacity correction, compositing) whose
//! branches follow the data; a batch runs each step over all its lanes
//! before the next, with the opacity correction branch-free
//! ([`correct_opacity_lanes`]), so independent rays overlap instead of
//! waiting on one another's divisions and mispredicted branches. Every
//! lane computes exactly what [`RayRow::sample`] computes for its ray, in
//! the same order, so the bits do not change (`golden/tests/it/lanes.rs`
//! checks frames against the one-ray path).

use super::{composite_alpha, preint_span, Order, RayRow};
use crate::merge::Rgba;
use crate::opacity::{
    correct_opacity_lanes, segment_attenuation_lanes, segment_exact_lanes, segment_opacity_lanes,
};
use crate::preint::Colouring;
use crate::slices::{bilinear_x8, Plane};

/// Rays per batch.
pub(super) const LANES: usize = 8;

/// The batched paths.
#[derive(Clone, Copy)]
pub(super) enum Batch {
    /// One bilinear sample per crossing ([`RayRow::sample_lanes`]).
    Plain,
    /// A pre-integrated step per crossing ([`RayRow::preint_lanes`]).
    Preint,
    /// Several trilinear samples per crossing ([`RayRow::substep_lanes`]).
    Substeps,
}

impl RayRow<'_> {
    /// Which batched path, if any, this row's samples take.
    pub(super) fn batch(&self) -> Option<Batch> {
        let p = self.pass;
        if !p.lanes || p.shader.is_some() || p.voi.is_some() {
            return None;
        }
        // Slice 0's extra half step in front and a clip plane's per-ray
        // test stay on the one-ray path.
        let clipped = !p.mask.clip().is_empty();
        match p.preint {
            None if p.substeps == 1 => Some(Batch::Plain),
            None => (!clipped).then_some(Batch::Substeps),
            Some(_) => (self.z > 0 && !clipped).then_some(Batch::Preint),
        }
    }

    /// The batched path `kind` for the rays at row offsets `idx`. Each
    /// path is its own function (`inline(never)`): compiled into the row
    /// loop together, a change to one moved the others' code generation
    /// (a u32 cast in the substep path's slice position made
    /// pre-integrated frames 17 % slower); a call per batch of eight rays
    /// costs nothing measurable.
    #[inline(always)]
    pub(super) fn sample_batch(&self, kind: Batch, row: &mut [Rgba], idx: &[usize]) {
        match kind {
            Batch::Plain => self.sample_lanes(row, idx),
            Batch::Preint => self.preint_lanes(row, idx),
            Batch::Substeps => self.substep_lanes(row, idx),
        }
    }

    /// The substep path of [`RayRow::sample`] for the rays at row offsets
    /// `idx` (one to [`LANES`]): substep by substep over all the lanes,
    /// which keeps each ray's own samples in order.
    #[inline(never)]
    fn substep_lanes(&self, row: &mut [Rgba], idx: &[usize]) {
        let (view, stack, lut) = (self.pass.view, self.pass.stack, self.pass.lut);
        let (substeps, order) = (self.pass.substeps, self.pass.order);
        let clear = self.pass.clear_below;
        let (n, at) = spread(idx);
        let (mut x, mut slope_x, mut ds) = ([0f32; LANES], [0f32; LANES], [0f32; LANES]);
        for l in 0..LANES {
            let mx = self.grid.lo[0] + at[l] as i64;
            x[l] = (self.px.a + mx as f64 * self.px.t) as f32;
            slope_x[l] = ((self.grid.phi[0] + mx as f64 - view.eye.x) * self.inv) as f32;
            ds[l] = self.ds[at[l]] / substeps as f32;
        }
        for j in 0..substeps {
            // Back-to-front walks the substeps from the rear.
            let j = match order {
                Order::BackToFront => substeps - 1 - j,
                Order::FrontToBack { .. } => j,
            };
            let o = (j as f32 + 0.5) / substeps as f32 - 0.5;
            let (py, pz) = (self.y + o * self.slope_y, self.z as f32 + o);
            // A substep behind an eye less than half a slice in front of
            // slice 0: the same for every ray of the row.
            if pz + view.d as f32 <= 0.0 {
                continue;
            }
            let mut at_o = [0f32; LANES];
            for l in 0..LANES {
                at_o[l] = x[l] + o * slope_x[l];
            }
            let s = stack.trilinear_x8(&at_o, py, pz);
            // Every lane transparent: the batch skips this substep's table
            // and compositing (see `sample_lanes`).
            if s.iter().all(|&v| v * lut.per_scalar < clear) {
                continue;
            }
            let c = lut.lookup_x8(&s);
            let alpha = c.map(|c| c[3]);
            let a = correct_opacity_lanes(&alpha, &ds);
            // A transparent lane composites `a = 0`: no bit changes (see
            // `sample_lanes`).
            for l in 0..n {
                composite_alpha(&mut row[at[l]], c[l], a[l], order);
            }
        }
    }

    /// The pre-integrated path of [`RayRow::sample`] for the rays at row
    /// offsets `idx` (one to [`LANES`]): the step from the ray's scalar on
    /// this slice to its scalar on the next, through the 2D table.
    #[inline(never)]
    fn preint_lanes(&self, row: &mut [Rgba], idx: &[usize]) {
        let view = self.pass.view;
        let pt = self.pass.preint.expect("a pre-integrated pass");
        let (n, at) = spread(idx);
        let back = preint_span(self.z, view.dims[2])[1] as f32;
        let steps = self.step_scalars_x8(&at);
        // Every lane's step lies in the table's transparent corner: each
        // has zero extinction and composites nothing (`a > 0` below), so
        // the batch stops after its taps.
        let (ps, clear) = (pt.per_scalar(), pt.clear_below());
        if steps.iter().all(|&(f, b)| f * ps < clear && b * ps < clear) {
            return;
        }
        let (mut e, mut k) = ([[0f32; 4]; LANES], [[0f32; 4]; LANES]);
        let (mut tau, mut len) = ([0f32; LANES], [0f32; LANES]);
        for l in 0..LANES {
            let (sf, sb) = steps[l];
            (e[l], k[l]) = pt.lookup_with_slope(sf, sb);
            // Without a volume of interest the extinction's factor is 1.
            tau[l] = e[l][3] * 1.0;
            len[l] = self.ds[at[l]] * back;
        }
        let order: Order = self.pass.order;
        if pt.colouring() == Colouring::Exact {
            let (a, pos) = segment_exact_lanes(&tau, &len);
            for l in 0..n {
                if a[l] > 0.0 {
                    let (sf, sb) = steps[l];
                    let c = pt.layered_colour(sf, sb, &e[l], pos[l]);
                    composite_alpha(&mut row[at[l]], [c[0], c[1], c[2], 0.0], a[l], order);
                }
            }
            return;
        }
        let (a, h) = match pt.colouring() {
            Colouring::Attenuated => segment_attenuation_lanes(&tau, &len),
            _ => (segment_opacity_lanes(&tau, &len), [0.0; LANES]),
        };
        for l in 0..n {
            if a[l] > 0.0 {
                let c = pt.step_colour(&e[l], &k[l], h[l]);
                composite_alpha(&mut row[at[l]], [c[0], c[1], c[2], 0.0], a[l], order);
            }
        }
    }

    /// [`RayRow::sample`] for the rays at row offsets `idx` (one to
    /// [`LANES`] distinct offsets), composited into `row`.
    #[inline(never)]
    fn sample_lanes(&self, row: &mut [Rgba], idx: &[usize]) {
        let (n, at) = spread(idx);
        let mut x = [0f32; LANES];
        let mut ds = [0f32; LANES];
        for l in 0..LANES {
            let mx = self.grid.lo[0] + at[l] as i64;
            x[l] = (self.px.a + mx as f64 * self.px.t) as f32;
            ds[l] = self.ds[at[l]];
        }
        let s = match self.data {
            Plane::U8(p) => bilinear_x8(p, self.pass.stack.row, &x, self.y),
            Plane::U16(p) => bilinear_x8(p, self.pass.stack.row, &x, self.y),
        };
        let lut = self.pass.lut;
        // Every lane classifies to zero opacity (air, most of a head's
        // occupied blocks): each would composite `a = 0`, which changes no
        // bit (see below), so the batch stops before the table.
        if s.iter()
            .all(|&v| v * lut.per_scalar < self.pass.clear_below)
        {
            return;
        }
        let c = lut.lookup_x8(&s);
        let alpha = c.map(|c| c[3]);
        let a = correct_opacity_lanes(&alpha, &ds);
        // The one-ray path composites only opacities above zero. Here a
        // transparent lane composites `a = 0`, which leaves every channel's
        // bits as they were: `0 c + 1 C = C` back to front, `C + 0 c = C`
        // front to back, for the non-negative finite values a ray holds.
        for l in 0..n {
            composite_alpha(&mut row[at[l]], c[l], a[l], self.pass.order);
        }
    }
}

/// The batch's ray offsets `idx` (one to [`LANES`]) in all the lanes:
/// spare lanes repeat the last ray, and only the first `n` are stored.
#[inline(always)]
fn spread(idx: &[usize]) -> (usize, [usize; LANES]) {
    let n = idx.len();
    debug_assert!((1..=LANES).contains(&n));
    // A fixed-length gather, not a `copy_from_slice` of `n`: that became a
    // `memmove` call per batch, 2 % of an `er-ftb` frame.
    let at = std::array::from_fn(|l| idx[l.min(n - 1)]);
    (n, at)
}
