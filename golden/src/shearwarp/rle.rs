//! Lacroute's classified volume with its run-length encoding: every voxel
//! of the permuted stack classified once (pre-classification, as
//! shear-warp does: the resampling filters classified colour and
//! opacity), and per voxel scanline the runs of voxels with non-zero
//! opacity, so the compositing visits only the intermediate pixels a
//! non-transparent voxel can reach.
//!
//! **Layout.** Voxels are `(a r, a g, a b, a)` (colour premultiplied by
//! the table's opacity per unit length, as the pre-classified mip-map's
//! level 0: filtering a bright voxel beside an empty one does not bleed
//! the empty one's colour), x fastest, slice by slice of the view's
//! stack. Lacroute stores one encoding per principal axis; here the
//! encoding belongs to the permuted stack, which
//! [`crate::render::Prepared`] already shares between the views of one
//! principal axis, and it is cached there by
//! [`crate::mipmap::classification_key`] like the mip-map: built once
//! per volume, axis and table. The dense voxels stay beside the runs so a
//! resampling tap is one read (the runs are the skip structure, not the
//! storage; a transparent voxel's four zeros are what skipping it adds).

use rayon::prelude::*;

use crate::error::{Error, Result};
use crate::slices::SliceStack;
use crate::tf::Lut;

/// Memory the classified volume may take (bytes).
pub const CLASSIFIED_LIMIT: u64 = 4 << 30;

/// A classified, run-length encoded stack.
#[derive(Debug, Clone, PartialEq)]
pub struct Classified {
    /// View-space dimensions `[nx, ny, nz]`.
    pub dims: [usize; 3],
    /// Classified voxels, `nz` slices of `ny` rows of `nx`.
    pub voxels: Vec<[f32; 4]>,
    /// Runs of scanline `z ny + y` are `runs[starts[z ny + y]..starts[z ny + y + 1]]`.
    starts: Vec<u32>,
    /// Non-transparent runs `[x0, x1)`, in increasing `x` per scanline.
    runs: Vec<[u32; 2]>,
}

impl Classified {
    /// Classifies `stack` with `lut` and encodes its runs.
    pub fn build(stack: &SliceStack, lut: &Lut) -> Result<Classified> {
        let dims = stack.dims;
        let [nx, ny, nz] = dims;
        let count = nx as u128 * ny as u128 * nz as u128;
        let bytes = count * (16 + 8);
        if bytes > CLASSIFIED_LIMIT as u128 || nx > u32::MAX as usize {
            return Err(Error::TooLarge {
                what: "the shear-warp classified volume".into(),
                bytes,
                limit: CLASSIFIED_LIMIT,
            });
        }
        let mut voxels = vec![[0f32; 4]; nx * ny * nz];
        let per_row: Vec<Vec<[u32; 2]>> = voxels
            .par_chunks_mut(nx.max(1))
            .enumerate()
            .map(|(r, out)| {
                let (z, y) = (r / ny, r % ny);
                let line = stack.slice(z);
                let line = line.values((y + 1) * stack.row + 1, nx);
                let mut runs = Vec::new();
                let mut open: Option<u32> = None;
                for (x, (o, v)) in out.iter_mut().zip(line).enumerate() {
                    let c = lut.lookup(v);
                    *o = [c[3] * c[0], c[3] * c[1], c[3] * c[2], c[3]];
                    match (c[3] > 0.0, open) {
                        (true, None) => open = Some(x as u32),
                        (false, Some(a)) => {
                            runs.push([a, x as u32]);
                            open = None;
                        }
                        _ => {}
                    }
                }
                if let Some(a) = open {
                    runs.push([a, nx as u32]);
                }
                runs
            })
            .collect();
        let mut starts = Vec::with_capacity(per_row.len() + 1);
        let mut runs = Vec::new();
        starts.push(0);
        for r in per_row {
            runs.extend_from_slice(&r);
            if runs.len() > u32::MAX as usize {
                return Err(Error::TooLarge {
                    what: "the shear-warp run list".into(),
                    bytes: runs.len() as u128 * 8,
                    limit: u32::MAX as u64,
                });
            }
            starts.push(runs.len() as u32);
        }
        Ok(Classified {
            dims,
            voxels,
            starts,
            runs,
        })
    }

    /// The non-transparent runs `[x0, x1)` of scanline `y` of slice `z`.
    #[inline]
    pub fn runs(&self, z: usize, y: usize) -> &[[u32; 2]] {
        let r = z * self.dims[1] + y;
        &self.runs[self.starts[r] as usize..self.starts[r + 1] as usize]
    }

    /// Whether slice `z` holds any non-transparent voxel.
    #[inline]
    pub fn slice_any(&self, z: usize) -> bool {
        let ny = self.dims[1];
        self.starts[z * ny] != self.starts[(z + 1) * ny]
    }

    /// Scanline `y` of slice `z`.
    #[inline]
    pub fn row(&self, z: usize, y: usize) -> &[[f32; 4]] {
        let nx = self.dims[0];
        &self.voxels[(z * self.dims[1] + y) * nx..][..nx]
    }

    /// Number of runs (a measure of how well the volume encodes).
    pub fn run_count(&self) -> usize {
        self.runs.len()
    }

    /// Fraction of voxels with non-zero opacity.
    pub fn occupied_fraction(&self) -> f64 {
        let n: u64 = self.runs.iter().map(|r| u64::from(r[1] - r[0])).sum();
        n as f64 / self.voxels.len().max(1) as f64
    }
}
