//! Empty-space structure: a min-max block grid over the volume, built once
//! per volume, and the occupancy map the transfer function makes of it,
//! rebuilt (cheaply: one table query per block) whenever the table changes.
//!
//! Block `b` on an axis covers voxels `b B ..= b B + B`: neighbouring
//! blocks overlap by one voxel, so every interpolation cell whose base
//! voxel lies in block `b` (`floor(position) / B == b`, clamped into the
//! volume) reads only voxels of block `b`, the replicated edge padding
//! included. A block is empty when the table gives zero opacity to every
//! scalar in its `[min, max]`; since linear interpolation (bilinear,
//! trilinear, and the table's own) never leaves the range of what it
//! interpolates, no sample in an empty block can be visible and skipping
//! it leaves the image bit for bit unchanged.
//!
//! [`ViewOccupancy`] re-indexes the map for one view (principal axis,
//! flip and near clip), which is what the slice-order methods and the
//! pipeline's occupancy memory query.

use glam::DVec3;
use rayon::prelude::*;

use crate::error::{input, Result};
use crate::geometry::AxisMap;
use crate::tf::Lut;
use crate::volume::{Volume, Voxel};
use crate::with_voxels;

/// Default block edge in voxels. Four, not eight: on brainsmall (a head
/// in its air) 4^3 blocks leave 28 % fewer samples than 8^3 ones for 10 %
/// less time a frame, and a checkerboard's large uniform blocks take the
/// same time either way (measured with `ercube render --volume
/// data/brainsmall.den --eye 64,64,-64 --fov 90 --block B`); the map costs 4
/// bytes a block, 1/16 of a byte a voxel.
pub const DEFAULT_BLOCK: usize = 4;

/// Block edges the structure accepts: powers of two from 2 to 64 (a power
/// of two makes a voxel's block a shift, as in the pipeline's controller).
pub fn check_block(block: usize) -> Result<()> {
    if !(block.is_power_of_two() && (2..=64).contains(&block)) {
        return Err(input(format!(
            "block size {block} must be a power of two from 2 to 64"
        )));
    }
    Ok(())
}

/// Per-block scalar minimum and maximum, index space.
#[derive(Debug, Clone, PartialEq)]
pub struct MinMax {
    /// Block edge `B` in voxels.
    pub block: usize,
    /// Blocks per index axis.
    pub counts: [usize; 3],
    /// `(min, max)` per block, x fastest.
    pub range: Vec<(u16, u16)>,
}

impl MinMax {
    /// Scans `volume` once (in parallel over z-slabs of blocks).
    pub fn new(volume: &Volume, block: usize) -> Result<MinMax> {
        check_block(block)?;
        let dims = volume.dims();
        let counts: [usize; 3] = std::array::from_fn(|k| (dims[k] - 1) / block + 1);
        let mut range = vec![(u16::MAX, 0u16); counts[0] * counts[1] * counts[2]];
        with_voxels!(volume.voxels(), data => scan_blocks(data, dims, block, counts, &mut range));
        Ok(MinMax {
            block,
            counts,
            range,
        })
    }
}

/// Each block's smallest and largest voxel (blocks share their boundary
/// voxels, as interpolation between them does).
fn scan_blocks<T: Voxel>(
    data: &[T],
    dims: [usize; 3],
    block: usize,
    counts: [usize; 3],
    range: &mut [(u16, u16)],
) {
    let (sx, sxy) = (dims[0], dims[0] * dims[1]);
    let span = |b: usize, n: usize| b * block..(b * block + block + 1).min(n);
    range
        .par_chunks_mut(counts[0] * counts[1])
        .enumerate()
        .for_each(|(bz, slab)| {
            for z in span(bz, dims[2]) {
                for by in 0..counts[1] {
                    for y in span(by, dims[1]) {
                        let line = &data[z * sxy + y * sx..z * sxy + y * sx + dims[0]];
                        for (bx, r) in slab[by * counts[0]..(by + 1) * counts[0]]
                            .iter_mut()
                            .enumerate()
                        {
                            for &v in &line[span(bx, dims[0])] {
                                r.0 = r.0.min(v.value());
                                r.1 = r.1.max(v.value());
                            }
                        }
                    }
                }
            }
        });
}

/// One bit per block: may any sample in the block be visible?
#[derive(Debug, Clone, PartialEq)]
pub struct Occupancy {
    /// Block edge `B` in voxels.
    pub block: usize,
    /// Blocks per index axis.
    pub counts: [usize; 3],
    /// Occupied flags, x fastest.
    pub bits: Vec<bool>,
}

impl Occupancy {
    /// Occupancy under the golden table `lut`.
    pub fn for_lut(mm: &MinMax, lut: &Lut) -> Occupancy {
        let visible = lut.visible_ranges();
        Occupancy::from_fn(mm, |lo, hi| visible.any(lo, hi))
    }

    /// Occupancy under any classifier: `visible(min, max)` must be true
    /// when any scalar in `[min, max]` may get a non-zero opacity.
    pub fn from_fn(mm: &MinMax, visible: impl Fn(u16, u16) -> bool) -> Occupancy {
        Occupancy {
            block: mm.block,
            counts: mm.counts,
            bits: mm.range.iter().map(|&(lo, hi)| visible(lo, hi)).collect(),
        }
    }

    /// Fraction of blocks occupied.
    pub fn fraction(&self) -> f64 {
        let n = self.bits.iter().filter(|&&b| b).count();
        n as f64 / self.bits.len().max(1) as f64
    }
}

/// A key of what a table says about visibility: its opacities and scalar
/// scaling. Two tables with one key give one occupancy map.
pub fn table_key(lut: &Lut) -> u64 {
    use std::hash::{Hash, Hasher};
    let mut h = std::collections::hash_map::DefaultHasher::new();
    lut.per_scalar.to_bits().hash(&mut h);
    lut.rgba.len().hash(&mut h);
    for e in &lut.rgba {
        e[3].to_bits().hash(&mut h);
    }
    h.finish()
}

/// Which table entries are visible, as a prefix count for `O(1)` range
/// queries over scalars.
#[derive(Debug, Clone)]
pub struct VisibleEntries {
    per_scalar: f32,
    last: usize,
    prefix: Vec<u32>,
}

impl VisibleEntries {
    /// Builds the prefix count of entries with non-zero opacity.
    pub fn new(alpha: impl Iterator<Item = f32>, per_scalar: f32) -> VisibleEntries {
        let mut prefix = vec![0u32];
        for a in alpha {
            let n = *prefix.last().expect("non-empty") + u32::from(a != 0.0);
            prefix.push(n);
        }
        VisibleEntries {
            per_scalar,
            last: prefix.len() - 2,
            prefix,
        }
    }

    /// True when some scalar in `[lo, hi]` looks up a non-zero opacity:
    /// the entries [`Lut::lookup`] interpolates for `lo` and `hi` bound the
    /// ones it uses in between, since its index is monotonic in the scalar.
    pub fn any(&self, lo: u16, hi: u16) -> bool {
        let index = |s: u16| {
            let f = (f32::from(s) * self.per_scalar).clamp(0.0, self.last as f32);
            (f as usize).min(self.last.saturating_sub(1))
        };
        let (i0, i1) = (index(lo), (index(hi) + 1).min(self.last));
        self.prefix[i1 + 1] > self.prefix[i0]
    }
}

/// The occupancy map seen from one view: block rows along the view's `x`,
/// `y` and slices along its principal axis.
#[derive(Debug, Clone, PartialEq)]
pub struct ViewOccupancy {
    /// Block edge `B` in voxels.
    pub block: usize,
    /// Blocks along view `x` and `y`.
    pub counts: [usize; 2],
    /// Index-space block slab (along the principal axis) of each slice.
    pub slab_of_slice: Vec<usize>,
    /// Occupied flags, `[slab][by]` rows of [`ViewOccupancy::words`]
    /// words, block `bx` at bit `bx % 64` of word `bx / 64` (bits past
    /// the last block clear): a row's runs are found a word at a time.
    mask: Vec<u64>,
    /// Words per block row.
    words: usize,
    /// Any occupied block per `[slab][by]`.
    row_any: Vec<bool>,
    /// Any occupied block per slab.
    slab_any: Vec<bool>,
}

impl ViewOccupancy {
    /// Re-indexes `occ` for the view space of `axes` with `nz` rendered slices.
    pub fn new(occ: &Occupancy, axes: &AxisMap, nz: usize) -> ViewOccupancy {
        let p = axes.perm;
        let counts = [occ.counts[p[0]], occ.counts[p[1]]];
        let slabs = occ.counts[p[2]];
        let words = counts[0].div_ceil(64).max(1);
        let mut mask = vec![0u64; slabs * counts[1] * words];
        for s in 0..slabs {
            for by in 0..counts[1] {
                for bx in 0..counts[0] {
                    let mut b = [0usize; 3];
                    b[p[0]] = bx;
                    b[p[1]] = by;
                    b[p[2]] = s;
                    let i = (b[2] * occ.counts[1] + b[1]) * occ.counts[0] + b[0];
                    if occ.bits[i] {
                        mask[(s * counts[1] + by) * words + bx / 64] |= 1 << (bx % 64);
                    }
                }
            }
        }
        let row_any: Vec<bool> = mask
            .chunks(words)
            .map(|r| r.iter().any(|&w| w != 0))
            .collect();
        let slab_any = row_any
            .chunks(counts[1])
            .map(|r| r.contains(&true))
            .collect();
        let slab_of_slice = (0..nz)
            .map(|z| axes.to_index(DVec3::new(0.0, 0.0, z as f64))[p[2]] as usize / occ.block)
            .collect();
        ViewOccupancy {
            block: occ.block,
            counts,
            slab_of_slice,
            mask,
            words,
            row_any,
            slab_any,
        }
    }

    /// True when slice `z` crosses an occupied block.
    #[inline]
    pub fn slice_any(&self, z: usize) -> bool {
        self.slab_any[self.slab_of_slice[z]]
    }

    /// True when any block of slab rows `by` in `rows` of slice `z` is occupied.
    #[inline]
    pub fn rows_any(&self, z: usize, rows: std::ops::RangeInclusive<usize>) -> bool {
        let s = self.slab_of_slice[z];
        rows.into_iter()
            .any(|by| self.row_any[s * self.counts[1] + by])
    }

    /// Words per block row: blocks `64 w ..` are word `w`.
    pub fn words(&self) -> usize {
        self.words
    }

    /// Word `w` of the occupied flags of slice `z`, ORed over block rows
    /// `rows` (bit `b`: block `64 w + b` is occupied in one of them).
    #[inline]
    pub fn word(&self, z: usize, rows: std::ops::RangeInclusive<usize>, w: usize) -> u64 {
        let row = self.slab_of_slice[z] * self.counts[1];
        rows.into_iter()
            .fold(0, |acc, by| acc | self.mask[(row + by) * self.words + w])
    }
}
