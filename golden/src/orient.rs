//! A volume's placement in world (patient) space, and the camera in it.
//!
//! World space is **LPS** (DICOM's and ITK's patient coordinates, in
//! millimetres): +x towards the patient's left, +y towards the back
//! (posterior), +z towards the head (superior). Loaders convert their
//! format's convention into it (NIfTI's RAS and NRRD's RAS/LAS spaces by
//! negating x and y, or y).
//!
//! [`to_world_grid`] permutes and flips the voxels, exactly (no
//! resampling), so that index axis `x`, `y`, `z` runs along the world axis
//! closest to it, in its positive direction. What is left of the
//! placement is then a translation and, for an oblique volume, a small
//! rotation (at most 45 degrees about any axis), which the [`WorldFrame`]
//! applies to the camera: rendering the volume in its own frame with the
//! camera moved rigidly into that frame is the same picture, without
//! resampling the voxels. A volume that is axis-aligned in any order
//! (permuted, flipped) has no rotation left, so the same head written in
//! different orientations by different tools gives bit-identical images.

use glam::{DMat3, DVec3};

use crate::error::{input, Result};
use crate::load::Loaded;
use crate::volume::Volume;

/// How far (per direction cosine) a volume's axes may be from the world
/// axes and still count as axis-aligned: scanners and float headers round
/// the cosines, and below this the rotation is below a thousandth of a
/// voxel across a 1000-voxel volume.
pub const ALIGNED_TOL: f64 = 1e-6;

/// Where a canonical volume (see [`to_world_grid`]) sits in world space:
/// world point `p` is volume point `rot^T (p - origin)`, volume point `q`
/// (index times spacing) is world point `origin + rot q`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WorldFrame {
    /// World position (LPS, mm) of voxel `(0, 0, 0)`'s centre.
    pub origin: DVec3,
    /// World direction of each volume axis (columns); the identity unless
    /// the volume is oblique.
    pub rot: DMat3,
}

impl WorldFrame {
    /// A world point in the volume's frame.
    pub fn point_to_volume(&self, p: DVec3) -> DVec3 {
        let d = p - self.origin;
        if self.rot == DMat3::IDENTITY {
            d
        } else {
            self.rot.transpose() * d
        }
    }

    /// A world direction in the volume's frame.
    pub fn dir_to_volume(&self, d: DVec3) -> DVec3 {
        if self.rot == DMat3::IDENTITY {
            d
        } else {
            self.rot.transpose() * d
        }
    }

    /// A volume point in world space.
    pub fn point_to_world(&self, q: DVec3) -> DVec3 {
        self.origin + self.rot * q
    }

    /// True if the volume is oblique (a rotation is left).
    pub fn is_oblique(&self) -> bool {
        self.rot != DMat3::IDENTITY
    }
}

/// The volume of `loaded` with its axes permuted and flipped onto the
/// world axes, and its frame. Fails in one line if the file gave no
/// placement, or if its axes are not orthogonal (a sheared grid, which
/// would need resampling).
pub fn to_world_grid(loaded: &Loaded) -> Result<(Volume, WorldFrame)> {
    let axes = loaded.axes.ok_or_else(|| {
        input(
            "--space world needs a file that places the volume in patient space \
             (NIfTI with a qform or sform, NRRD with space directions, MetaImage, DICOM)",
        )
    })?;
    let origin = DVec3::from_array(loaded.origin.unwrap_or([0.0; 3]));
    let a: [DVec3; 3] = axes.map(DVec3::from_array);
    for (i, j) in [(0, 1), (0, 2), (1, 2)] {
        if a[i].dot(a[j]).abs() > 1e-3 {
            return Err(input(format!(
                "the volume's axes {axes:?} are not orthogonal (a sheared grid): \
                 only rigid placements are supported"
            )));
        }
    }
    // Each index axis goes to the world axis it is closest to.
    let mut target = [0usize; 3];
    let mut flip = [false; 3];
    for k in 0..3 {
        let v = a[k].to_array();
        let b = (0..3)
            .max_by(|&i, &j| v[i].abs().total_cmp(&v[j].abs()))
            .unwrap_or(0);
        target[k] = b;
        flip[k] = v[b] < 0.0;
    }
    if target[0] == target[1] || target[0] == target[2] || target[1] == target[2] {
        return Err(input(format!(
            "the volume's axes {axes:?} are oblique by 45 degrees or more: \
             no world axis is nearest to each (resample it to an aligned grid first)"
        )));
    }
    let vol = &loaded.volume;
    let dims = vol.dims();
    let sp = vol.spacing();
    let mut new_dims = [0usize; 3];
    let mut new_sp = [0.0; 3];
    let mut cols = [DVec3::ZERO; 3];
    let mut new_origin = origin;
    for k in 0..3 {
        new_dims[target[k]] = dims[k];
        new_sp[target[k]] = sp[k];
        let dir = if flip[k] { -a[k] } else { a[k] };
        cols[target[k]] = dir;
        if flip[k] {
            new_origin += a[k] * (sp[k] * (dims[k] - 1) as f64);
        }
    }
    let aligned = (0..3).all(|b| {
        (0..3).all(|c| {
            let want = if b == c { 1.0 } else { 0.0 };
            (cols[b][c] - want).abs() <= ALIGNED_TOL
        })
    });
    let rot = if aligned {
        DMat3::IDENTITY
    } else {
        DMat3::from_cols(cols[0], cols[1], cols[2])
    };
    if rot.determinant() <= 0.0 {
        return Err(input(format!(
            "the volume's axes {axes:?} do not form a rotation after flipping"
        )));
    }
    let [nx, ny, _] = new_dims;
    let data = vol.data();
    // Old index k along axis `k` from the new index along `target[k]`.
    let mut out = vec![0u16; data.len()];
    let mut idx = [0usize; 3];
    for (n, o) in out.iter_mut().enumerate() {
        let new = [n % nx, (n / nx) % ny, n / (nx * ny)];
        for k in 0..3 {
            let t = new[target[k]];
            idx[k] = if flip[k] { dims[k] - 1 - t } else { t };
        }
        *o = data[(idx[2] * dims[1] + idx[1]) * dims[0] + idx[0]];
    }
    let volume = Volume::new(new_dims, vol.kind(), out)?
        .with_spacing(new_sp)?
        .with_units(vol.units());
    Ok((
        volume,
        WorldFrame {
            origin: new_origin,
            rot,
        },
    ))
}

/// Converts RAS (NIfTI, NRRD `right-anterior-superior`) coordinates to
/// LPS: x and y change sign.
pub fn ras_to_lps(v: [f64; 3]) -> [f64; 3] {
    [-v[0], -v[1], v[2]]
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::volume::{VoxelType, DEFAULT_MEMORY_LIMIT};

    fn loaded(axes: [[f64; 3]; 3]) -> Loaded {
        let volume = Volume::from_fn(
            [4, 3, 2],
            VoxelType::U16,
            DEFAULT_MEMORY_LIMIT,
            |x, y, z| (x + 10 * y + 100 * z) as u16,
        )
        .unwrap()
        .with_spacing([1.0, 2.0, 3.0])
        .unwrap();
        Loaded {
            volume,
            origin: Some([10.0, 20.0, 30.0]),
            axes: Some(axes),
        }
    }

    #[test]
    fn a_permuted_flipped_grid_is_moved_exactly_onto_the_world_axes() {
        // x runs towards -z (world), y towards +x, z towards -y.
        let l = loaded([[0.0, 0.0, -1.0], [1.0, 0.0, 0.0], [0.0, -1.0, 0.0]]);
        let (v, frame) = to_world_grid(&l).unwrap();
        assert_eq!(v.dims(), [3, 2, 4]);
        assert_eq!(v.spacing(), [2.0, 3.0, 1.0]);
        assert!(!frame.is_oblique());
        // Every old voxel lands where its world position says.
        let old = &l.volume;
        for z in 0..2 {
            for y in 0..3 {
                for x in 0..4 {
                    let world = DVec3::new(
                        10.0 + 2.0 * y as f64,
                        20.0 - 3.0 * z as f64,
                        30.0 - x as f64,
                    );
                    let q = frame.point_to_volume(world);
                    let s = v.spacing();
                    let (i, j, k) = (q.x / s[0], q.y / s[1], q.z / s[2]);
                    assert_eq!(
                        v.get(i as usize, j as usize, k as usize),
                        old.get(x, y, z),
                        "voxel {x},{y},{z} at {q}"
                    );
                }
            }
        }
    }

    #[test]
    fn an_oblique_grid_keeps_its_rotation_and_a_sheared_one_is_refused() {
        let (c, s) = (30f64.to_radians().cos(), 30f64.to_radians().sin());
        let l = loaded([[c, s, 0.0], [-s, c, 0.0], [0.0, 0.0, 1.0]]);
        let (v, frame) = to_world_grid(&l).unwrap();
        assert_eq!(v.data(), l.volume.data());
        assert!(frame.is_oblique());
        let q = DVec3::new(3.0, 4.0, 3.0);
        let back = frame.point_to_volume(frame.point_to_world(q));
        assert!((back - q).length() < 1e-12);
        let sheared = loaded([[1.0, 0.0, 0.0], [0.5, 0.866, 0.0], [0.0, 0.0, 1.0]]);
        let e = to_world_grid(&sheared).unwrap_err().to_string();
        assert!(e.contains("not orthogonal"), "{e}");
        let none = Loaded {
            axes: None,
            ..loaded([[1.0, 0.0, 0.0]; 3])
        };
        let e = to_world_grid(&none).unwrap_err().to_string();
        assert!(e.contains("--space world needs"), "{e}");
    }
}
