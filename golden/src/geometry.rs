//! The one source of truth for view geometry, shared by every golden method
//! and by the pipeline's host driver: principal axis and permutation, the
//! eye distance `D`, exponential regions, and the ray grids of each region.
//!
//! **View space.** After the permutation the principal axis is `z`, the eye
//! lies in front of slice `z = 0` at `z = -D`, and slice `z` of the rendered
//! stack is at view-space `z`. Positions are voxel indices of the permuted
//! volume (`x`, `y` in a slice, `z` the slice). Voxel `k` covers
//! `[k - 1/2, k + 1/2)` on each axis; a sample counts as inside a slice when
//! its `(x, y)` lies in `[-1/2, N - 1/2]`.

use glam::DVec3;

use crate::camera::{Camera, ImagePlane, PixelRays};
use crate::error::{input, Error, Result};

/// Eyes closer than this to slice 0 (voxel units) count as on the slab.
pub const MIN_D: f64 = 1e-3;

/// How view space relates to the volume's index space.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AxisMap {
    /// View axis `k` is index axis `perm[k]`.
    pub perm: [usize; 3],
    /// Whether view `z` runs against index axis `perm[2]` (eye on its far side).
    pub flip_z: bool,
    /// The volume's dimensions in index space.
    pub index_dims: [usize; 3],
    /// First slice rendered (non-zero when the near plane clips the volume).
    pub z_first: usize,
}

impl AxisMap {
    /// View-space position of index-space point `p`.
    pub fn to_view(&self, p: DVec3) -> DVec3 {
        let a = p.to_array();
        let z = a[self.perm[2]];
        let z = if self.flip_z {
            (self.index_dims[self.perm[2]] as f64 - 1.0) - z
        } else {
            z
        };
        DVec3::new(a[self.perm[0]], a[self.perm[1]], z - self.z_first as f64)
    }

    /// View-space direction of index-space direction `d`.
    pub fn dir_to_view(&self, d: DVec3) -> DVec3 {
        let a = d.to_array();
        let z = if self.flip_z {
            -a[self.perm[2]]
        } else {
            a[self.perm[2]]
        };
        DVec3::new(a[self.perm[0]], a[self.perm[1]], z)
    }

    /// Index-space position of view-space point `v`.
    pub fn to_index(&self, v: DVec3) -> DVec3 {
        let mut a = [0.0; 3];
        a[self.perm[0]] = v.x;
        a[self.perm[1]] = v.y;
        let z = v.z + self.z_first as f64;
        a[self.perm[2]] = if self.flip_z {
            (self.index_dims[self.perm[2]] as f64 - 1.0) - z
        } else {
            z
        };
        DVec3::from_array(a)
    }

    /// `"+z"` when the view looks along +z of the volume, `"-x"` along -x, ...
    pub fn label(&self) -> String {
        let axis = ["x", "y", "z"][self.perm[2]];
        format!("{}{axis}", if self.flip_z { '-' } else { '+' })
    }
}

/// A camera placed against a volume: everything slice-order methods need.
#[derive(Debug, Clone, PartialEq)]
pub struct View {
    /// Index space to view space.
    pub axes: AxisMap,
    /// View-space dimensions `[nx, ny, nz]` of the rendered stack.
    pub dims: [usize; 3],
    /// Eye in view space; `eye.z == -d`.
    pub eye: DVec3,
    /// Distance from the eye to slice 0 along the principal axis (voxels).
    pub d: f64,
    /// World units per view-space voxel step on each view axis.
    pub spacing: [f64; 3],
    /// The camera's pixel rays in view space.
    pub rays: PixelRays,
    /// Image width and height in pixels.
    pub size: [u32; 2],
}

/// Cyclic permutations keep view space right-handed before the z flip.
const PERMS: [[usize; 3]; 3] = [[1, 2, 0], [2, 0, 1], [0, 1, 2]];

impl View {
    /// Places `camera` against a volume of `dims` voxels with `spacing`.
    ///
    /// The principal axis is the axis of the largest component of the
    /// direction from the eye to the volume centre, among the axes whose slab
    /// the eye lies outside of (all axes when the eye is inside the volume).
    /// An eye on or inside the chosen slab is clipped: only slices at least
    /// `near` voxels in front of it are rendered.
    pub fn new(dims: [usize; 3], spacing: [f64; 3], camera: &Camera, near: f64) -> Result<View> {
        if !(near.is_finite() && near > 0.0) {
            return Err(input(format!("near distance {near} must be positive")));
        }
        let eye_idx = DVec3::from_array(std::array::from_fn(|k| camera.eye[k] / spacing[k]));
        let centre = DVec3::from_array(std::array::from_fn(|k| (dims[k] as f64 - 1.0) * 0.5));
        let v = centre - eye_idx;
        let outside = |k: usize| eye_idx[k] < -MIN_D || eye_idx[k] > dims[k] as f64 - 1.0 + MIN_D;
        let pick = |only_outside: bool| {
            (0..3)
                .filter(|&k| !only_outside || outside(k))
                .max_by(|&a, &b| v[a].abs().total_cmp(&v[b].abs()).then(b.cmp(&a)))
        };
        let axis = pick(true).or_else(|| pick(false)).expect("three axes");
        let flip_z = v[axis] < 0.0;
        let mut axes = AxisMap {
            perm: PERMS[axis],
            flip_z,
            index_dims: dims,
            z_first: 0,
        };
        let nz_full = dims[axis];
        let mut d = -axes.to_view(eye_idx).z;
        if d < MIN_D {
            // Clip: the first rendered slice is the first at least `near` in front.
            let z_first = (near - d).ceil().max(0.0);
            if z_first >= nz_full as f64 {
                return Err(input(format!(
                    "the eye is at or beyond the far side of the volume along {}; nothing lies in front of it",
                    axes.label()
                )));
            }
            axes.z_first = z_first as usize;
            d += z_first;
        }
        let eye = axes.to_view(eye_idx);
        let world_rays = match camera.image_plane {
            ImagePlane::Camera => camera.pixel_rays(),
            ImagePlane::Front => {
                let front = axes.to_index(DVec3::new(0.0, 0.0, 0.0));
                let front_world = DVec3::from_array(std::array::from_fn(|k| front[k] * spacing[k]));
                let mut normal = DVec3::ZERO;
                normal[axis] = if flip_z { -1.0 } else { 1.0 };
                camera.plane_rays(front_world, normal)?
            }
        };
        let to_view_dir = |w: DVec3| {
            axes.dir_to_view(DVec3::from_array(std::array::from_fn(|k| {
                w[k] / spacing[k]
            })))
        };
        let rays = PixelRays {
            eye,
            a: to_view_dir(world_rays.a),
            b: to_view_dir(world_rays.b),
            c: to_view_dir(world_rays.c),
        };
        let p = axes.perm;
        Ok(View {
            axes,
            dims: [dims[p[0]], dims[p[1]], nz_full - axes.z_first],
            eye,
            d,
            spacing: [spacing[p[0]], spacing[p[1]], spacing[p[2]]],
            rays,
            size: [camera.width, camera.height],
        })
    }

    /// World length of a view-space displacement `(dx, dy, dz)`.
    #[inline]
    pub fn world_length(&self, dx: f64, dy: f64, dz: f64) -> f64 {
        let s = self.spacing;
        ((dx * s[0]).powi(2) + (dy * s[1]).powi(2) + (dz * s[2]).powi(2)).sqrt()
    }

    /// Exponential regions for this view.
    pub fn regions(&self) -> Regions {
        Regions::new(self.d, self.dims[2])
    }
}

/// Exponential regions: region `i` spans view `z` in `[b_i, b_{i+1})` with
/// `b_i = D (2^i - 1)`, so the eye is `D 2^i` from `b_i`; `K` is the
/// smallest count (at least 1) with `b_K >= nz - 1`.
#[derive(Debug, Clone, PartialEq)]
pub struct Regions {
    /// Eye distance `D` to slice 0.
    pub d: f64,
    /// Boundaries `b_0 = 0, ..., b_K`.
    pub bounds: Vec<f64>,
    /// Slices in the stack.
    pub nz: usize,
}

impl Regions {
    /// Regions for eye distance `d > 0` and `nz` slices.
    pub fn new(d: f64, nz: usize) -> Regions {
        assert!(d.is_finite() && d > 0.0, "D must be positive and finite");
        let last = nz.saturating_sub(1) as f64;
        let mut bounds = vec![0.0];
        let mut i = 1;
        loop {
            let b = d * ((2f64).powi(i) - 1.0);
            bounds.push(b);
            if b >= last {
                break;
            }
            i += 1;
        }
        Regions { d, bounds, nz }
    }

    /// Number of regions `K`.
    pub fn count(&self) -> usize {
        self.bounds.len() - 1
    }

    /// Slices of region `i`: integer `z` with `b_i <= z < b_{i+1}` (the last
    /// region also takes a slice exactly on `b_K`).
    pub fn slices(&self, i: usize) -> std::ops::Range<usize> {
        let lo = self.bounds[i].ceil().max(0.0) as usize;
        let hi = if i + 1 == self.count() {
            self.nz
        } else {
            (self.bounds[i + 1].ceil().max(0.0) as usize).min(self.nz)
        };
        lo.min(hi)..hi
    }
}

/// How rays of one region become the rays of the region in front.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
pub enum Merge {
    /// ER: ray `m` continues ray `2m` and takes the (1/4, 1/2, 1/4) tent
    /// of rays `2m - 1 ..= 2m + 1` on each axis.
    Bartlett,
    /// Novins-style: ray `m` starts midway between rays `2m` and `2m + 1`
    /// and takes their average on each axis.
    Box,
}

impl Merge {
    /// Rays of the front region fed by back-region rays `lo..=hi`.
    fn fed_by(self, lo: i64, hi: i64) -> (i64, i64) {
        match self {
            // 2m in [lo - 1, hi + 1]: m from ceil((lo - 1) / 2) = floor(lo / 2).
            Merge::Bartlett => (lo.div_euclid(2), (hi + 1).div_euclid(2)),
            Merge::Box => (lo.div_euclid(2), hi.div_euclid(2)),
        }
    }
    /// The back ray (half-index, `2m + offset`) that front ray `m` is centred on.
    fn offset(self) -> f64 {
        match self {
            Merge::Bartlett => 0.0,
            Merge::Box => 0.5,
        }
    }
}

/// The rays of one region: on its reference plane `z_ref` they lie on a unit
/// grid with offset `phi`; at slice `z` ray `m` is at
/// `e + (phi + m - e) (z + D) / (z_ref + D)` on each axis, i.e. `A(z) + m t(z)`.
#[derive(Debug, Clone, PartialEq)]
pub struct RayGrid {
    /// Plane where the rays are one voxel apart.
    pub z_ref: f64,
    /// Grid offset on `z_ref`, per axis (x, y).
    pub phi: [f64; 2],
    /// Lowest ray index per axis.
    pub lo: [i64; 2],
    /// Highest ray index per axis (empty when `hi < lo`).
    pub hi: [i64; 2],
    /// Slices sampled in this region (back to front order is reversed).
    pub slices: std::ops::Range<usize>,
}

/// Per-slice affine ray positions on one axis: ray `m` is at `a + m t`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Affine {
    /// Position of ray 0.
    pub a: f64,
    /// Spacing between neighbouring rays.
    pub t: f64,
}

impl RayGrid {
    /// Ray count per axis.
    pub fn counts(&self) -> [usize; 2] {
        std::array::from_fn(|k| (self.hi[k] - self.lo[k] + 1).max(0) as usize)
    }
    /// Total rays.
    pub fn len(&self) -> usize {
        self.counts()[0] * self.counts()[1]
    }
    /// True when the region has no rays.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
    /// Ray positions at view `z` on axis `k` (0 = x, 1 = y).
    #[inline]
    pub fn at(&self, eye: DVec3, d: f64, z: f64, k: usize) -> Affine {
        let t = (z + d) / (self.z_ref + d);
        Affine {
            a: eye[k] * (1.0 - t) + self.phi[k] * t,
            t,
        }
    }
    /// Ray slope `d(position)/dz` of ray `m` on axis `k`.
    #[inline]
    pub fn slope(&self, eye: DVec3, d: f64, m: i64, k: usize) -> f64 {
        (self.phi[k] + m as f64 - eye[k]) / (self.z_ref + d)
    }
}

/// Where the ray `eye + t dir` (view space, `t >= 0`) is inside the
/// volume's box `[-1/2, n - 1/2]` per axis: `(t0, t1)` with `t0 < t1`, or
/// `None` when it misses. Slab by slab, so the image-order casters (the
/// reference and the mip-map) enter and leave at the same `t`.
pub fn box_interval(eye: DVec3, dir: DVec3, dims: [usize; 3]) -> Option<(f64, f64)> {
    let (mut t0, mut t1) = (0.0f64, f64::INFINITY);
    for k in 0..3 {
        let (lo, hi) = (-0.5, dims[k] as f64 - 0.5);
        if dir[k].abs() < 1e-300 {
            if eye[k] < lo || eye[k] >= hi {
                return None;
            }
            continue;
        }
        let (a, b) = ((lo - eye[k]) / dir[k], (hi - eye[k]) / dir[k]);
        t0 = t0.max(a.min(b));
        t1 = t1.min(a.max(b));
    }
    (t0 < t1).then_some((t0, t1))
}

/// Ray indices `m` whose position `a + m t` lies in `[-1/2, n - 1/2]`.
/// Closed on both faces, so that a ray exactly on the far face is kept as
/// one exactly on the near face is (eyes on the half-voxel grid put rays on
/// both faces; a half-open interval dropped the far one and halved the
/// image's far edge).
pub fn inside(p: Affine, n: usize) -> (i64, i64) {
    let lo = ((-0.5 - p.a) / p.t).ceil();
    let hi = ((n as f64 - 0.5 - p.a) / p.t).floor();
    (clamp_index(lo), clamp_index(hi))
}

fn clamp_index(v: f64) -> i64 {
    v.clamp(-(1i64 << 52) as f64, (1i64 << 52) as f64) as i64
}

/// Which rays a slice-order method uses: its regions, their ray grids and
/// how rays merge at boundaries.
#[derive(Debug, Clone, PartialEq)]
pub struct Layout {
    /// Eye in view space.
    pub eye: DVec3,
    /// Eye distance to slice 0.
    pub d: f64,
    /// Region boundaries (one region for the baselines).
    pub bounds: Vec<f64>,
    /// Ray grid per region, front (0) to back.
    pub grids: Vec<RayGrid>,
    /// Merge between regions (`None` for single-region methods).
    pub merge: Option<Merge>,
}

/// The baseplane: region 0's rays at slice 0, a regular grid of samples.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BaseGrid {
    /// View-space `(x, y)` of sample `(0, 0)`.
    pub origin: [f64; 2],
    /// Sample spacing (same on both axes).
    pub spacing: f64,
    /// Samples per axis.
    pub counts: [usize; 2],
}

/// Most rays one region may hold (each costs 16 bytes of compositing
/// buffer): 2^28, 4 GiB, refused beyond.
pub const MAX_RAYS: u128 = 1 << 28;

impl Layout {
    /// ER-Perspective's regions and rays, with the given merge filter.
    pub fn exponential(view: &View, merge: Merge) -> Result<Layout> {
        let regions = view.regions();
        let k = regions.count();
        let mut phi = vec![[0.0; 2]; k];
        for i in (0..k - 1).rev() {
            phi[i] = std::array::from_fn(|a| {
                let e = view.eye[a];
                e + (phi[i + 1][a] + merge.offset() - e) * 0.5
            });
        }
        let grids = (0..k)
            .map(|i| RayGrid {
                z_ref: regions.bounds[i + 1],
                phi: phi[i],
                lo: [0; 2],
                hi: [-1; 2],
                slices: regions.slices(i),
            })
            .collect();
        Layout::finish(view, regions.bounds, grids, Some(merge))
    }

    /// One region of rays one voxel apart on plane `z_ref` (slice 0 for
    /// undersampling, the last slice for oversampling), no merging.
    pub fn single(view: &View, z_ref: f64) -> Result<Layout> {
        let nz = view.dims[2];
        let grids = vec![RayGrid {
            z_ref,
            phi: [0.0; 2],
            lo: [0; 2],
            hi: [-1; 2],
            slices: 0..nz,
        }];
        Layout::finish(view, vec![0.0, (nz as f64 - 1.0).max(0.0)], grids, None)
    }

    fn finish(
        view: &View,
        bounds: Vec<f64>,
        mut grids: Vec<RayGrid>,
        merge: Option<Merge>,
    ) -> Result<Layout> {
        let (eye, d) = (view.eye, view.d);
        for i in (0..grids.len()).rev() {
            let g = &grids[i];
            let mut lo = [i64::MAX; 2];
            let mut hi = [i64::MIN; 2];
            // Rays sampling the volume in this region; positions move
            // monotonically with z, so the end slices bound the union.
            if !g.slices.is_empty() {
                for z in [g.slices.start, g.slices.end - 1] {
                    for a in 0..2 {
                        let (l, h) = inside(g.at(eye, d, z as f64, a), view.dims[a]);
                        if l <= h {
                            lo[a] = lo[a].min(l);
                            hi[a] = hi[a].max(h);
                        }
                    }
                }
            }
            // Rays that receive state from the region behind.
            if let (Some(m), Some(back)) = (merge, grids.get(i + 1)) {
                if !back.is_empty() {
                    for a in 0..2 {
                        let (l, h) = m.fed_by(back.lo[a], back.hi[a]);
                        lo[a] = lo[a].min(l);
                        hi[a] = hi[a].max(h);
                    }
                }
            }
            let rays = (0..2)
                .map(|a| (hi[a] as i128 - lo[a] as i128 + 1).max(0) as u128)
                .product::<u128>();
            if rays > MAX_RAYS {
                return Err(Error::TooLarge {
                    what: format!("region {i}'s {rays} rays"),
                    bytes: rays * 16,
                    limit: (MAX_RAYS * 16) as u64,
                });
            }
            if lo[0] > hi[0] || lo[1] > hi[1] {
                lo = [0; 2];
                hi = [-1; 2];
            }
            grids[i].lo = lo;
            grids[i].hi = hi;
        }
        Ok(Layout {
            eye,
            d,
            bounds,
            grids,
            merge,
        })
    }

    /// The baseplane grid: region 0's rays at slice 0.
    pub fn baseplane(&self) -> BaseGrid {
        let g = &self.grids[0];
        let px = g.at(self.eye, self.d, 0.0, 0);
        let py = g.at(self.eye, self.d, 0.0, 1);
        BaseGrid {
            origin: [px.a + g.lo[0] as f64 * px.t, py.a + g.lo[1] as f64 * py.t],
            spacing: px.t,
            counts: g.counts(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn paper_example_boundaries() {
        let r = Regions::new(3.0, 7);
        assert_eq!(r.bounds, vec![0.0, 3.0, 9.0]);
        assert_eq!(r.slices(0), 0..3);
        assert_eq!(r.slices(1), 3..7);
    }

    #[test]
    fn bartlett_fed_by_covers_neighbours() {
        // Back rays 3..=8 feed front rays whose 2m-1..=2m+1 meets 3..=8: m = 1..=4.
        assert_eq!(Merge::Bartlett.fed_by(3, 8), (1, 4));
        assert_eq!(Merge::Bartlett.fed_by(-3, -1), (-2, 0));
        assert_eq!(Merge::Box.fed_by(3, 8), (1, 4));
        assert_eq!(Merge::Box.fed_by(-3, 0), (-2, 0));
    }
}
