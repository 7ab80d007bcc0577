//! The 3D mip-map (hyperpyramid) of Levoy and Whitaker's gaze-directed
//! volume rendering: the classified volume at full resolution and at every
//! binary fraction of it, for ray casting whose samples grow with distance
//! ([`crate::mipcast`]).
//!
//! **Two classifications** ([`Classify`]). **Pre-classified** (the
//! paper's): level 0 holds each voxel's classified colour and
//! opacity, as the paper stores its viewpoint-independent shading
//! components: `(a r, a g, a b, a)` with `a` the table's opacity per unit
//! length and the colour premultiplied by it (opacity-weighted colour), so
//! that filtering a bright voxel beside an empty one does not bleed the
//! empty voxel's colour into the result. The pyramid therefore depends on
//! the whole table, and [`crate::render::Prepared`] caches it by
//! [`classification_key`] (colours and opacities), as it caches the
//! occupancy map by its opacities. **Post-classified** (the default,
//! chosen by measurement: lower error on every view measured): the levels hold
//! the scalar (and, for skipping, the minimum and maximum of the base
//! voxels under each level voxel); a sample interpolates the scalar and
//! then classifies it, as the reference and the slice-order methods do.
//! Level 0 then matches the reference's sampling exactly, but a coarse
//! level classifies a mean scalar, which on two-material data is a third
//! material (the checkerboard's air-floor mean is the wall's value). The
//! scalar pyramid does not depend on the table.
//!
//! **Shading, pre-classified** ([`MipMap::build_shaded`]): level 0 holds
//! each voxel's shaded, opacity-weighted colour, Blinn-Phong
//! ([`crate::shading::Shader::shade`]) of its classified colour with its
//! voxel gradient ([`crate::gradients::Gradients`], central differences)
//! and the frame's lights, as the paper stores its shading in the
//! pyramid. The view direction is the golden shader's own: one direction
//! for the whole volume, from its centre to the eye (the half vectors of
//! [`crate::shading::Lighting`]), which is the paper's viewpoint-independent
//! approximation within a frame and is exactly what every other method
//! shades with. The pyramid then depends on the eye's direction (and the
//! lights, material, fade and gradient opacity): it is cached by a key of
//! them with the table's ([`shading_key`]) and rebuilt when they change.
//!
//! **Filter.** Each level is half the resolution of the one below
//! (`ceil(n / 2)` per axis, down to one voxel): the paper's 2x2x2 box, the
//! mean of the eight children, summed pairwise so that a constant volume
//! stays exactly constant at every level. A child index beyond an odd edge
//! reads the edge voxel (replicate padding, as every method reads beyond
//! the volume). Level `l`'s voxel `i` covers base voxels `2^l i ..
//! 2^l (i + 1) - 1`, so its centre is at base position
//! `2^l (i + 1/2) - 1/2`.
//!
//! **Occupancy octree.** Pre-classified: opacities are non-negative, so a level voxel's
//! mean is zero exactly when all eight children are: the opacity channel is
//! an octree of empty space (the paper's remark). A mean that would
//! underflow to zero from a non-zero sum is stored as the smallest positive
//! `f32` instead (a change below `1e-44`), which keeps the property exact.
//! [`Level::cell_empty`] asks it of the eight voxels one trilinear sample
//! reads. Post-classified: a cell is empty when the table gives zero
//! opacity to every scalar between the least minimum and the greatest
//! maximum of its eight voxels (widened by one scalar unit against the
//! rounding of means), an `O(1)` query ([`VisibleEntries`]); a parent's
//! range holds its children's. Either way, the nesting of the cells read
//! across levels is what makes [`crate::mipcast`]'s skipping exact.

use std::hash::{Hash, Hasher};

use rayon::prelude::*;

use crate::error::{input, Error, Result};
use crate::geometry::View;
use crate::gradients::Gradients;
use crate::occupancy::VisibleEntries;
use crate::shading::{Lighting, Shade, Shader};
use crate::slices::SliceStack;
use crate::tf::Lut;

/// Memory the pyramid may take (bytes).
pub const MIPMAP_LIMIT: u64 = 4 << 30;

/// What the pyramid stores and when a sample is classified.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub enum Classify {
    /// Classified colour and opacity, filtered (the paper's).
    Pre,
    /// The scalar, filtered; each sample is classified (the default: on
    /// every view measured its error against the reference is lower,
    /// docs/golden.md).
    #[default]
    Post,
}

impl Classify {
    /// Name on the command line.
    pub fn name(self) -> &'static str {
        match self {
            Classify::Pre => "pre",
            Classify::Post => "post",
        }
    }
}

impl std::str::FromStr for Classify {
    type Err = Error;
    fn from_str(s: &str) -> Result<Classify> {
        match s {
            "pre" => Ok(Classify::Pre),
            "post" => Ok(Classify::Post),
            _ => Err(input(format!(
                "mip-map classification '{s}' must be pre or post"
            ))),
        }
    }
}

/// One level of the pyramid, x fastest: per voxel `(a r, a g, a b, a)`
/// pre-classified, `(scalar, min, max, 0)` post-classified.
#[derive(Debug, Clone, PartialEq)]
pub struct Level {
    /// Voxels per axis.
    pub dims: [usize; 3],
    /// The four channels per voxel.
    pub data: Vec<[f32; 4]>,
    /// Base positions per level position: `2^-l`.
    pub scale: f64,
}

/// The interpolation cell on one axis at level coordinate `q`: the two
/// voxels read and the weight of the second. Clamping `q` into the level
/// is replicate padding; the cell is constant while `floor(q)` is.
#[inline]
fn cell(q: f64, n: usize) -> (usize, usize, f32) {
    let q = q.clamp(0.0, (n - 1) as f64);
    let i0 = q as usize;
    let i1 = (i0 + 1).min(n - 1);
    (i0, i1, (q - i0 as f64) as f32)
}

impl Level {
    /// Level coordinate of base (view-space) position `p` on each axis.
    #[inline]
    pub fn coord(&self, p: [f64; 3]) -> [f64; 3] {
        p.map(|v| (v + 0.5) * self.scale - 0.5)
    }

    /// The interpolation cell of base position `p`: per axis the two
    /// voxel indices and the weight of the second.
    #[inline]
    fn cells(&self, p: [f64; 3]) -> [(usize, usize, f32); 3] {
        let q = self.coord(p);
        std::array::from_fn(|k| cell(q[k], self.dims[k]))
    }

    #[inline]
    fn at(&self, x: usize, y: usize, z: usize) -> [f32; 4] {
        self.data[(z * self.dims[1] + y) * self.dims[0] + x]
    }

    /// Trilinear interpolation of channel 0 (the post-classified scalar)
    /// at base position `p`.
    #[inline]
    pub fn scalar(&self, p: [f64; 3]) -> f32 {
        let [(x0, x1, tx), (y0, y1, ty), (z0, z1, tz)] = self.cells(p);
        let lerp = |a: f32, b: f32, t: f32| a + t * (b - a);
        let plane = |z: usize| {
            let top = lerp(self.at(x0, y0, z)[0], self.at(x1, y0, z)[0], tx);
            let bot = lerp(self.at(x0, y1, z)[0], self.at(x1, y1, z)[0], tx);
            lerp(top, bot, ty)
        };
        lerp(plane(z0), plane(z1), tz)
    }

    /// Trilinear interpolation at base position `p`.
    #[inline]
    pub fn trilinear(&self, p: [f64; 3]) -> [f32; 4] {
        let [(x0, x1, tx), (y0, y1, ty), (z0, z1, tz)] = self.cells(p);
        let lerp = |a: [f32; 4], b: [f32; 4], t: f32| -> [f32; 4] {
            std::array::from_fn(|c| a[c] + t * (b[c] - a[c]))
        };
        let plane = |z: usize| {
            let top = lerp(self.at(x0, y0, z), self.at(x1, y0, z), tx);
            let bot = lerp(self.at(x0, y1, z), self.at(x1, y1, z), tx);
            lerp(top, bot, ty)
        };
        lerp(plane(z0), plane(z1), tz)
    }

    /// True when every voxel a [`Level::trilinear`] sample at `p` reads
    /// has zero opacity (the sample is then exactly transparent: linear
    /// interpolation of non-negative values with one of them non-zero is
    /// the only way to get a non-zero result).
    #[inline]
    pub fn cell_empty(&self, p: [f64; 3]) -> bool {
        let [(x0, x1, _), (y0, y1, _), (z0, z1, _)] = self.cells(p);
        [z0, z1].iter().all(|&z| {
            [y0, y1]
                .iter()
                .all(|&y| self.at(x0, y, z)[3] == 0.0 && self.at(x1, y, z)[3] == 0.0)
        })
    }

    /// Post-classified: true when `visible` sees no scalar between the
    /// least minimum and the greatest maximum of the voxels a sample at
    /// `p` reads.
    #[inline]
    pub fn cell_invisible(&self, p: [f64; 3], visible: &VisibleEntries) -> bool {
        let [(x0, x1, _), (y0, y1, _), (z0, z1, _)] = self.cells(p);
        let (mut lo, mut hi) = (f32::INFINITY, f32::NEG_INFINITY);
        for z in [z0, z1] {
            for y in [y0, y1] {
                for x in [x0, x1] {
                    let v = self.at(x, y, z);
                    lo = lo.min(v[1]);
                    hi = hi.max(v[2]);
                }
            }
        }
        // Minima and maxima are voxel values (integers); one unit either
        // side covers a mean or an interpolation rounded past them.
        let lo = (lo - 1.0).max(0.0) as u16;
        let hi = (hi + 1.0).min(f32::from(u16::MAX)) as u16;
        !visible.any(lo, hi)
    }

    /// The box of base positions sharing `p`'s interpolation cell
    /// (`floor` of the level coordinate constant), per axis `[lo, hi)`.
    pub fn cell_box(&self, p: [f64; 3]) -> [[f64; 2]; 3] {
        let q = self.coord(p);
        let inv = 1.0 / self.scale;
        std::array::from_fn(|k| {
            let i = q[k].floor();
            [(i + 0.5) * inv - 0.5, (i + 1.5) * inv - 0.5]
        })
    }

    /// The next coarser level: the 2x2x2 box mean (post-classified, the
    /// minimum and maximum in channels 1 and 2).
    fn halve(&self, classify: Classify) -> Level {
        let n = self.dims;
        let dims = n.map(|v| v.div_ceil(2));
        let mut data = vec![[0f32; 4]; dims[0] * dims[1] * dims[2]];
        data.par_chunks_mut(dims[0] * dims[1])
            .enumerate()
            .for_each(|(z, slab)| {
                let zs = [2 * z, (2 * z + 1).min(n[2] - 1)];
                for y in 0..dims[1] {
                    let ys = [2 * y, (2 * y + 1).min(n[1] - 1)];
                    for x in 0..dims[0] {
                        let xs = [2 * x, (2 * x + 1).min(n[0] - 1)];
                        let v = |dx: usize, dy: usize, dz: usize| self.at(xs[dx], ys[dy], zs[dz]);
                        slab[y * dims[0] + x] = std::array::from_fn(|c| {
                            let all = || (0..8).map(|i| v(i & 1, (i >> 1) & 1, i >> 2)[c]);
                            match (classify, c) {
                                (Classify::Post, 1) => return all().fold(f32::INFINITY, f32::min),
                                (Classify::Post, 2) => {
                                    return all().fold(f32::NEG_INFINITY, f32::max)
                                }
                                _ => {}
                            }
                            // Pairwise: a constant stays exact (2c, 4c, 8c).
                            let pair = |dy, dz| v(0, dy, dz)[c] + v(1, dy, dz)[c];
                            let sum = (pair(0, 0) + pair(1, 0)) + (pair(0, 1) + pair(1, 1));
                            let mean = sum * 0.125;
                            if c == 3 && mean == 0.0 && sum > 0.0 {
                                f32::from_bits(1)
                            } else {
                                mean
                            }
                        });
                    }
                }
            });
        Level {
            dims,
            data,
            scale: self.scale * 0.5,
        }
    }
}

/// The pyramid: level 0 at full resolution up to a single voxel.
#[derive(Debug, Clone, PartialEq)]
pub struct MipMap {
    /// What the levels hold.
    pub classify: Classify,
    /// Levels, finest first.
    pub levels: Vec<Level>,
    /// The [`shading_key`] of the shading level 0 holds (pre-classified
    /// shaded pyramids only).
    pub shading: Option<u64>,
}

impl MipMap {
    /// Classifies every voxel of `stack` with `lut` (pre-classified; a
    /// post-classified pyramid ignores `lut`) and filters it down.
    pub fn build(stack: &SliceStack, lut: &Lut, classify: Classify) -> Result<MipMap> {
        MipMap::build_with(stack, lut, classify, None)
    }

    /// A pre-classified pyramid of shaded voxels: each voxel's classified
    /// colour shaded by `shader` with its gradient from `grads` (the
    /// stack's central differences), then opacity-weighted; `key` is
    /// [`shading_key`] of the shading, kept in [`MipMap::shading`].
    pub fn build_shaded(
        stack: &SliceStack,
        grads: &Gradients,
        lut: &Lut,
        shader: &Shader,
        key: u64,
    ) -> Result<MipMap> {
        let mut m = MipMap::build_with(stack, lut, Classify::Pre, Some((grads, shader)))?;
        m.shading = Some(key);
        Ok(m)
    }

    fn build_with(
        stack: &SliceStack,
        lut: &Lut,
        classify: Classify,
        shading: Option<(&Gradients, &Shader)>,
    ) -> Result<MipMap> {
        let dims = stack.dims;
        check_size(dims)?;
        let mut base = vec![[0f32; 4]; dims[0] * dims[1] * dims[2]];
        base.par_chunks_mut(dims[0] * dims[1])
            .enumerate()
            .for_each(|(z, slab)| {
                let s = stack.slice(z);
                for y in 0..dims[1] {
                    let start = (y + 1) * stack.row + 1;
                    let line = s.values(start, dims[0]);
                    for (x, (out, v)) in slab[y * dims[0]..][..dims[0]]
                        .iter_mut()
                        .zip(line)
                        .enumerate()
                    {
                        *out = match classify {
                            Classify::Pre => {
                                let mut c = lut.lookup(v);
                                if let (Some((g, sh)), true) = (shading, c[3] > 0.0) {
                                    // The gradients are padded by one voxel per side.
                                    c = sh.shade_f32(c, g.at(z, x + 1, y + 1));
                                }
                                [c[3] * c[0], c[3] * c[1], c[3] * c[2], c[3]]
                            }
                            Classify::Post => [v, v, v, 0.0],
                        };
                    }
                }
            });
        MipMap::from_base(dims, base, classify)
    }

    /// The pyramid over a given level 0 (per voxel `(a r, a g, a b, a)`,
    /// opacities non-negative, or `(scalar, scalar, scalar, 0)`; x
    /// fastest).
    pub fn from_base(dims: [usize; 3], data: Vec<[f32; 4]>, classify: Classify) -> Result<MipMap> {
        check_size(dims)?;
        if data.len() != dims[0] * dims[1] * dims[2] {
            return Err(input(format!(
                "mip-map base of {} voxels does not match dims {dims:?}",
                data.len()
            )));
        }
        let mut levels = vec![Level {
            dims,
            data,
            scale: 1.0,
        }];
        while levels.last().is_some_and(|l| l.dims.iter().any(|&n| n > 1)) {
            let next = levels.last().expect("a level").halve(classify);
            levels.push(next);
        }
        Ok(MipMap {
            classify,
            levels,
            shading: None,
        })
    }

    /// Index of the coarsest level.
    pub fn top(&self) -> usize {
        self.levels.len() - 1
    }

    /// Voxels over all levels.
    pub fn voxels(&self) -> usize {
        self.levels.iter().map(|l| l.data.len()).sum()
    }
}

/// Refuses a pyramid over [`MIPMAP_LIMIT`] (all levels: at most 8/7 of
/// level 0, 16 bytes a voxel) or over an empty volume.
fn check_size(dims: [usize; 3]) -> Result<()> {
    let base = dims.iter().map(|&n| n as u128).product::<u128>();
    let bytes = base * 16 * 8 / 7;
    if base == 0 || bytes > MIPMAP_LIMIT as u128 {
        return Err(Error::TooLarge {
            what: "the 3D mip-map".into(),
            bytes,
            limit: MIPMAP_LIMIT,
        });
    }
    Ok(())
}

/// A key of everything a pre-classified pyramid depends on in a table:
/// every entry's colour and opacity and the scalar scaling. Two tables
/// with one key give one pyramid.
pub fn classification_key(lut: &Lut) -> u64 {
    let mut h = std::collections::hash_map::DefaultHasher::new();
    lut.per_scalar.to_bits().hash(&mut h);
    lut.rgba.len().hash(&mut h);
    for e in &lut.rgba {
        e.map(f32::to_bits).hash(&mut h);
    }
    h.finish()
}

/// A key of everything a pre-classified shaded pyramid depends on besides
/// the table: the lights and half vectors in `view`'s space (so the eye's
/// direction from the volume's centre), the material, the normal fade and
/// the gradient opacity.
pub fn shading_key(view: &View, shade: &Shade) -> u64 {
    let mut h = std::collections::hash_map::DefaultHasher::new();
    let lit = Lighting::new(view, shade);
    for v in lit.lights.iter().chain(&lit.halves) {
        v.map(f64::to_bits).hash(&mut h);
    }
    let m = shade.material;
    [
        m.ambient,
        m.diffuse,
        m.specular,
        m.shininess,
        shade.normal_fade,
        shade.gradient_opacity,
    ]
    .map(f64::to_bits)
    .hash(&mut h);
    h.finish()
}
