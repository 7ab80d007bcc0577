//! The paper's sample-count formulas (Kreeger and Kaufman 1998, equations
//! 9 to 14), restated for this model's geometry so that measured counts can
//! be plotted beside them.
//!
//! View space: slices `z = 0 .. nz - 1` along the principal axis, each
//! `nx x ny` voxels (area `A = nx ny`, the paper's `N^2`), the eye a
//! distance `D` in front of slice 0 and over the slice (its `x, y` inside
//! the volume's extent, as in every benchmark view). A ray grid whose rays
//! are `t(z)` voxels apart at slice `z` samples about `A / t(z)^2` points
//! of that slice (rays outside the slice take no sample), and by similar
//! triangles `t(z) = (z + D) / (z_ref + D)` for a grid that is one voxel
//! apart on plane `z_ref`:
//!
//! - oversampling (`z_ref` = the last slice, `nz - 1`; the paper's eq. 9):
//!   `A ((nz - 1 + D) / (z + D))^2`, growing as `1/D^2` on the front slice
//!   (the paper's `O(N^4)` as the eye touches the volume); summed over the
//!   slices it is eq. 10;
//! - undersampling (`z_ref = 0`): `A (D / (z + D))^2`, at most `A` (slice
//!   0) and shrinking towards the back; summed, eq. 11;
//! - ER (region `i` spans `[b_i, b_{i+1})`, `b_i = D (2^i - 1)`, rays one
//!   voxel apart on `b_{i+1}`, which is `D 2^(i+1)` from the eye):
//!   `A (D 2^(i+1) / (z + D))^2`, which lies in `(A, 4 A]` because
//!   `D 2^i <= z + D < D 2^(i+1)`; summed, eq. 12, bounded above by
//!   `4 A nz` (eq. 13) and below by `A nz` (eq. 14).
//!
//! The paper indexes slices `0..=N` with the rear one at `N`; here the rear
//! slice is `nz - 1`. Measured counts differ from the formulas by the
//! rounding of `A / t^2` to whole rays per axis (at most one ray per axis).

use crate::cli::method::MethodArg;
use golden::geometry::Regions;

/// One of the formulas.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Model {
    /// Oversampling, eq. 9 per slice, eq. 10 in total.
    Over,
    /// Undersampling, eq. 11 in total.
    Under,
    /// ER-Perspective, eq. 12 in total.
    Er,
    /// The upper bound `4 A` per slice, eq. 13 in total.
    Upper,
    /// The lower bound `A` per slice, eq. 14 in total.
    Lower,
}

impl Model {
    /// The formulas, in table order.
    pub const ALL: [Model; 5] = [
        Model::Over,
        Model::Under,
        Model::Er,
        Model::Upper,
        Model::Lower,
    ];

    /// The formula for a method's name (`box` and `er-ftb` cast ER's rays).
    pub fn for_method(name: &str) -> Option<Model> {
        match MethodArg::of_label(name)? {
            MethodArg::Over => Some(Model::Over),
            MethodArg::Under => Some(Model::Under),
            MethodArg::Reference => None,
            _ => Some(Model::Er),
        }
    }

    /// Label in plots and tables: the paper's equation number of the total.
    pub fn label(self) -> &'static str {
        match self {
            Model::Over => "over, eq. 10",
            Model::Under => "under, eq. 11",
            Model::Er => "er, eq. 12",
            Model::Upper => "4 N^2 per slice, eq. 13",
            Model::Lower => "N^2 per slice, eq. 14",
        }
    }

    /// Samples on slice `z` for slices of `area` voxels, `nz` slices and
    /// eye distance `d`.
    pub fn per_slice(self, z: usize, area: f64, nz: usize, d: f64) -> f64 {
        let z = z as f64;
        match self {
            Model::Over => area * ((nz as f64 - 1.0 + d) / (z + d)).powi(2),
            Model::Under => area * (d / (z + d)).powi(2),
            Model::Er => {
                let far = er_far_plane(z, nz, d);
                area * (far / (z + d)).powi(2)
            }
            Model::Upper => 4.0 * area,
            Model::Lower => area,
        }
    }

    /// Samples per slice over the whole stack, front to back.
    pub fn slices(self, area: f64, nz: usize, d: f64) -> Vec<f64> {
        (0..nz).map(|z| self.per_slice(z, area, nz, d)).collect()
    }

    /// Samples in a frame (the paper's equations 10 to 14).
    pub fn total(self, area: f64, nz: usize, d: f64) -> f64 {
        self.slices(area, nz, d).iter().sum()
    }
}

/// Distance from the eye to the plane where the rays of `z`'s region are
/// one voxel apart: `D 2^(i+1)` for region `i`, from the same
/// [`Regions`] the renderers use (so the last region, whose rear plane may
/// lie behind the volume, is handled as they handle it).
fn er_far_plane(z: f64, nz: usize, d: f64) -> f64 {
    let r = Regions::new(d, nz);
    let zi = z as usize;
    let i = (0..r.count())
        .find(|&i| r.slices(i).contains(&zi))
        .unwrap_or(r.count() - 1);
    r.bounds[i + 1] + d
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn er_stays_between_the_bounds() {
        for d in [0.5, 1.0, 3.0, 17.0, 64.0, 1000.0] {
            for z in 0..256 {
                let s = Model::Er.per_slice(z, 1.0, 256, d);
                assert!(s > 1.0 - 1e-12 && s <= 4.0 + 1e-12, "d {d} z {z}: {s}");
            }
        }
    }

    #[test]
    fn paper_worked_example() {
        // N = 7, D = 3: 7 to 13 (14) samples per slice in 1D, i.e. the
        // square of 7 / t with t from 1 down to 1/2.
        let s: Vec<f64> = Model::Er.slices(49.0, 7, 3.0);
        assert!((s[0] - 49.0 * 4.0).abs() < 1e-9);
        assert!((s[2] - 49.0 * (6.0f64 / 5.0).powi(2)).abs() < 1e-9);
        assert!((s[3] - 49.0 * 4.0).abs() < 1e-9);
        // Over and under meet the grid one voxel apart at their planes.
        assert!((Model::Over.per_slice(6, 49.0, 7, 3.0) - 49.0).abs() < 1e-9);
        assert!((Model::Under.per_slice(0, 49.0, 7, 3.0) - 49.0).abs() < 1e-9);
        assert!(Model::Over.total(49.0, 7, 0.5) > 5.0 * Model::Er.total(49.0, 7, 0.5));
    }
}
