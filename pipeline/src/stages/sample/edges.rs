//! A PE's edge registers while it samples: the voxel words of its edge
//! columns it drives to its neighbours for the row sampled next (the
//! scalar's right taps to the left; shading, the gradient's halo to the
//! left and its last column to the right), latched from memory when the
//! row changes, and the same words for a whole slice on the untraced path.

use crate::pe::{Pe, Ports, VoxelMem};
use crate::shading::{outer_rows, Halo};

use super::plan::RowRuns;

/// The words a PE drives on its ports while sampling a row (its edge
/// registers): its first column at the row's two voxel rows to the left
/// neighbour (the scalar's right taps), and while the array shades the
/// gradient's halo to the left and its last column's two words to the
/// right.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct EdgeWords {
    /// First column at rows `y0`, `y0 + 1`, to the left.
    pub left: [u16; 2],
    /// The gradient's words of the first two columns, to the left.
    pub halo: Halo,
    /// Last column at rows `y0`, `y0 + 1`, to the right.
    pub right: [u16; 2],
}

/// What a PE receives from its neighbours for the row it samples: the
/// right neighbour's edge voxels and halo, the left one's last column.
#[derive(Debug, Clone, Copy, Default)]
pub(crate) struct EdgeIn {
    pub(super) right: [u16; 2],
    pub(super) halo: Halo,
    pub(super) left: [u16; 2],
}

impl Pe {
    /// The words this PE's edge registers take for row `(z, y0, y1)`
    /// (clamped voxel rows), read from its memory; `shade` adds the
    /// gradient's. Counts nothing (see [`Pe::drive_edge`]).
    pub(crate) fn edge_words(&self, (z, y0, y1): (usize, usize, usize), shade: bool) -> EdgeWords {
        let mut e = EdgeWords::default();
        if self.cols.is_empty() {
            return e;
        }
        let w = self.cols.len();
        let at = |z: usize, y: usize, c: usize| self.mem.get((z * self.ny + y) * w + c);
        e.left = [at(z, y0, 0), at(z, y1, 0)];
        if shade {
            let (ylo, yhi) = outer_rows(y0, y1, self.ny);
            let (zm, zp) = (z.saturating_sub(1), (z + 1).min(self.nz - 1));
            // The second column, or the first again at the volume's edge
            // (the clamp), where a block has one column.
            let c1 = 1.min(w - 1);
            e.halo = [
                at(z, ylo, 0),
                at(z, yhi, 0),
                at(zm, y0, 0),
                at(zm, y1, 0),
                at(zp, y0, 0),
                at(zp, y1, 0),
                at(z, y0, c1),
                at(z, y1, c1),
            ];
            e.right = [at(z, y0, w - 1), at(z, y1, w - 1)];
        }
        e
    }

    /// Drives the edge registers for `next` (the row sampled next cycle),
    /// read from memory only when the row changes (the registers hold
    /// their values otherwise): 2 words, 12 while the array shades.
    #[inline]
    pub(crate) fn drive_edge(
        &mut self,
        next: Option<(usize, usize, usize)>,
        shade: bool,
    ) -> EdgeWords {
        if let Some(n) = next {
            if self.edge_latch != Some(n) && !self.cols.is_empty() {
                self.edge_value = self.edge_words(n, shade);
                self.counters.mem_reads += if shade { 12 } else { 2 };
                self.edge_latch = Some(n);
            }
        }
        self.edge_value
    }

    /// Puts the edge registers on the ports.
    pub(super) fn drive_ports(&self, out: &mut Ports, shade: bool) {
        out.left.edge = self.edge_value.left;
        if shade {
            out.left.halo = self.edge_value.halo;
            out.right.edge = self.edge_value.right;
        }
    }

    /// The edge words this PE presents during each of a slice's rows
    /// (`z` and each row's voxel rows `y0`, `y0 + 1`) that has runs (the
    /// others take no cycle, so nothing reads theirs, left default) into
    /// `out`: what its neighbours receive over the ports in that row. Reads nothing
    /// it would not drive anyway; the reads are counted by
    /// [`Pe::latch_edges`].
    pub fn edges_for(
        &self,
        z: usize,
        (rows, runs): (&[super::Row], &RowRuns),
        shade: bool,
        out: &mut Vec<EdgeWords>,
    ) {
        out.clear();
        if shade || self.cols.is_empty() {
            out.extend(rows.iter().enumerate().map(|(r, &(_, (y0, y1, _), _, _))| {
                if runs.row(r).is_empty() {
                    EdgeWords::default()
                } else {
                    self.edge_words((z, y0, y1), shade)
                }
            }));
            return;
        }
        // Without shading only the first column's two words go left (what
        // `edge_words` reads), here straight from the memory.
        let w = self.cols.len();
        let base = z * self.ny;
        fn words(
            (rows, runs): (&[super::Row], &RowRuns),
            (base, w): (usize, usize),
            read: impl Fn(usize) -> u16,
            out: &mut Vec<EdgeWords>,
        ) {
            out.extend(rows.iter().enumerate().map(|(r, &(_, (y0, y1, _), _, _))| {
                if runs.row(r).is_empty() {
                    EdgeWords::default()
                } else {
                    EdgeWords {
                        left: [read((base + y0) * w), read((base + y1) * w)],
                        ..EdgeWords::default()
                    }
                }
            }));
        }
        match &self.mem {
            VoxelMem::Words(m) => words((rows, runs), (base, w), |i| m[i], out),
            VoxelMem::Codes {
                codes,
                words: table,
            } => words(
                (rows, runs),
                (base, w),
                |i| table[usize::from(codes[i])],
                out,
            ),
        }
    }

    /// Steps the edge registers through `seq`, the rows the bus announces
    /// as "next" in order, counting the memory reads the clocked path makes.
    /// Only the last row's words are read: the registers' earlier values
    /// are overwritten unseen (the neighbours' come from
    /// [`Pe::edges_for`]).
    pub fn latch_edges(&mut self, seq: impl Iterator<Item = (usize, usize, usize)>, shade: bool) {
        if self.cols.is_empty() {
            return;
        }
        let mut latched = None;
        for n in seq {
            if self.edge_latch != Some(n) {
                self.counters.mem_reads += if shade { 12 } else { 2 };
                self.edge_latch = Some(n);
                latched = Some(n);
            }
        }
        if let Some(n) = latched {
            self.edge_value = self.edge_words(n, shade);
        }
    }
}
