//! Laying a volume's voxels out as a [`SliceStack`](super::SliceStack):
//! the copy into view space, the in-place padding of a view along z, and
//! the side views' fill that gives the volume's buffer back as it goes.

use rayon::prelude::*;

use crate::volume::Voxel;

/// Copies the view-space voxels of `src` into the padded `data` (one
/// plane per padded slice) and replicates the edges into the padding.
pub(super) fn permute_into<T: Voxel>(src: &[T], data: &mut [T], g: &Permute) {
    let Permute {
        dims,
        row,
        plane,
        sx,
        ..
    } = *g;
    data.par_chunks_mut(plane)
        .enumerate()
        .skip(1)
        .take(dims[2])
        .for_each(|(zp, out)| {
            for y in 0..dims[1] {
                let line = g.source(0, y, zp - 1);
                let dst = &mut out[(y + 1) * row + 1..(y + 1) * row + 1 + dims[0]];
                if sx == 1 {
                    dst.copy_from_slice(&src[line..line + dims[0]]);
                } else {
                    for (x, d) in dst.iter_mut().enumerate() {
                        *d = src[g.source(x, y, zp - 1)];
                    }
                }
                out[(y + 1) * row] = out[(y + 1) * row + 1];
                out[(y + 1) * row + dims[0] + 1] = out[(y + 1) * row + dims[0]];
            }
            out.copy_within(row..2 * row, 0);
            out.copy_within(dims[1] * row..(dims[1] + 1) * row, (dims[1] + 1) * row);
        });
    data.copy_within(plane..2 * plane, 0);
    let last = dims[2] * plane;
    data.copy_within(last..last + plane, last + plane);
}

/// Turns the voxels `v` of `dims` (x fastest) into the padded stack of the
/// unpermuted view, in place: the buffer grows to the padded size (a
/// reallocation the allocator can do without copying), each voxel row moves
/// to its padded place, last row first (every row moves to a higher index,
/// so no row is overwritten before it moves), and the padding is filled as
/// [`permute_into`] fills it. With `flip`, the planes are then reversed.
pub(super) fn pad_in_place<T: Voxel>(mut v: Vec<T>, dims: [usize; 3], flip: bool) -> Vec<T> {
    let [nx, ny, nz] = dims;
    let (row, plane) = (nx + 2, (nx + 2) * (ny + 2));
    v.resize(plane * (nz + 2), T::default());
    for z in (0..nz).rev() {
        for y in (0..ny).rev() {
            let src = (z * ny + y) * nx;
            v.copy_within(src..src + nx, (z + 1) * plane + (y + 1) * row + 1);
        }
    }
    fill_padding(&mut v, dims);
    if flip {
        let k = nz + 2;
        for i in 0..k / 2 {
            let (head, tail) = v.split_at_mut((k - 1 - i) * plane);
            head[i * plane..(i + 1) * plane].swap_with_slice(&mut tail[..plane]);
        }
    }
    v
}

/// Fills the padding of a padded stack of `dims` whose interior is in
/// place, as [`permute_into`] fills it: each row's ends, each plane's first
/// and last rows, then the first and last planes repeat their neighbours.
fn fill_padding<T: Voxel>(v: &mut [T], [nx, ny, nz]: [usize; 3]) {
    let (row, plane) = (nx + 2, (nx + 2) * (ny + 2));
    v.par_chunks_mut(plane).skip(1).take(nz).for_each(|out| {
        for y in 1..=ny {
            out[y * row] = out[y * row + 1];
            out[y * row + nx + 1] = out[y * row + nx];
        }
        out.copy_within(row..2 * row, 0);
        out.copy_within(ny * row..(ny + 1) * row, (ny + 1) * row);
    });
    v.copy_within(plane..2 * plane, 0);
    v.copy_within(nz * plane..(nz + 1) * plane, (nz + 1) * plane);
}

/// The stack of a side view (the volume's z axis is view x when
/// `along_x`, else view y), built
/// while the volume's buffer `src` (dims `id`, x fastest) is given back:
/// the volume's z slabs are read last first, each slab's voxels written to
/// their view places, and the buffer shortened behind them. The stack's
/// pages are touched as they are written, and each slab lands in a band of
/// them (view rows, or with the volume's z as view x, rows of a transposed
/// plane that is put right afterwards), so the frame holds little more
/// than one copy of the voxels at any time instead of two.
pub(super) fn permute_consuming<T: Voxel>(
    mut src: Vec<T>,
    id: [usize; 3],
    g: &Permute,
    along_x: bool,
) -> Vec<T> {
    let (dims, row, plane) = (g.dims, g.row, g.plane);
    let slab = id[0] * id[1];
    // `along_x`: the volume's z is view x (else view y), so slab `k` holds
    // view column (else row) `k` of every plane. With z as view x, each
    // plane is first laid out transposed (view y fastest, rows of
    // `dims[1] + 2`), so that a slab fills whole rows either way.
    let trow = dims[1] + 2;
    let (width, n) = if along_x {
        (trow, dims[1])
    } else {
        (row, dims[0])
    };
    let mut data = vec![T::default(); plane * (dims[2] + 2)];
    // Shorten the buffer every few slabs: each shrink gives pages back.
    let release = (16 << 20) / (slab * std::mem::size_of::<T>()).max(1) + 1;
    for k in (0..id[2]).rev() {
        let s = &src[..];
        data.par_chunks_mut(plane)
            .enumerate()
            .skip(1)
            .take(dims[2])
            .for_each(|(zp, out)| {
                let dst = &mut out[(k + 1) * width + 1..][..n];
                for (u, d) in dst.iter_mut().enumerate() {
                    let (x, y) = if along_x { (k, u) } else { (u, k) };
                    *d = s[g.source(x, y, zp - 1)];
                }
            });
        src.truncate(k * slab);
        if k % release == 0 {
            src.shrink_to_fit();
        }
    }
    drop(src);
    if along_x {
        data.par_chunks_mut(plane)
            .skip(1)
            .take(dims[2])
            .for_each_init(
                || vec![T::default(); plane],
                |scratch, out| {
                    scratch.copy_from_slice(out);
                    for x in 0..dims[0] {
                        for y in 0..dims[1] {
                            out[(y + 1) * row + x + 1] = scratch[(x + 1) * trow + y + 1];
                        }
                    }
                },
            );
    }
    fill_padding(&mut data, dims);
    data
}

/// Where view voxels come from in the volume: the padded layout and the
/// index strides of the view axes.
#[derive(Clone, Copy)]
pub(super) struct Permute {
    pub(super) dims: [usize; 3],
    pub(super) row: usize,
    pub(super) plane: usize,
    pub(super) base0: isize,
    pub(super) sx: isize,
    pub(super) sy: isize,
    pub(super) sz: isize,
}

impl Permute {
    /// The volume index of view voxel `(x, y, z)` (unpadded view indices).
    #[inline]
    fn source(&self, x: usize, y: usize, z: usize) -> usize {
        // The view voxels lie in the volume, so the offset is non-negative.
        (self.base0 + z as isize * self.sz + y as isize * self.sy + x as isize * self.sx) as usize
    }
}
