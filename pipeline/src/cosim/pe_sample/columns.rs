//! Where the sample stage's capture puts a PE's columns, by mapping: a
//! ray's buffer address (its index modulo the slots under column blocks,
//! the slot migration gave it under a round-robin mapping:
//! [`super::slots`]), the column map the testbench writes at a slice's
//! start (`pe<K>.map`: clock, first ray index, count; under a round-robin
//! mapping also `pe<K>.cm`: clock, entry, ray index, slot for every held
//! ray in increasing index) and, under a round-robin mapping, the column
//! decoder (`pe<K>.loc`: a held voxel column's local index, a line a
//! column of the volume, 0 for the columns the PE does not hold).

use std::io::Write;

use super::{create, PeCapture};
use crate::pe::Pe;

impl PeCapture {
    /// The buffer address of PE `k`'s ray `(mx, row)`; `None` for a ray
    /// the PE holds no slot for.
    pub fn addr(&self, k: usize, mx: i64, row: usize) -> Option<u64> {
        let s = &self.shape;
        match &self.slots {
            Some(t) => Some(row as u64 * s.slots() + t.slot(k, mx)?),
            None => Some(s.ray_addr(mx, row)),
        }
    }

    /// PE `k`'s slot of ray `mx` (see [`PeCapture::addr`]).
    pub(super) fn slot_of(&self, k: usize, mx: i64) -> Option<u64> {
        match &self.slots {
            Some(t) => t.slot(k, mx),
            None => Some(self.shape.slot(mx)),
        }
    }

    /// PE `k`'s column decoder (a round-robin mapping's).
    pub(super) fn decoder(&self, k: usize, pe: &Pe) -> std::io::Result<()> {
        if self.slots.is_none() {
            return Ok(());
        }
        let mut f = create(&self.dir, &format!("pe{k}.loc"))?;
        for c in 0..self.shape.nx as usize {
            let l = pe.local.get(c).copied().filter(|&l| l != u32::MAX);
            writeln!(f, "{:x}", l.unwrap_or(0))?;
        }
        f.flush()
    }

    /// The column map PE `k` samples slice `z` with from the middle of
    /// clock `cycle` on: under column blocks its held range (false where
    /// the held columns are not one consecutive block within the slots),
    /// under a round-robin mapping every held ray in increasing index
    /// with the slot it is given.
    pub(super) fn column_map(
        &mut self,
        cycle: u64,
        (k, z): (usize, usize),
        pe: &Pe,
    ) -> std::io::Result<bool> {
        let n = pe.rays.len();
        let lo = pe.rays.front().map_or(0, |c| c.mx);
        let slots = self.shape.slots();
        if let Some(t) = &mut self.slots {
            let mxs: Vec<i64> = pe.rays.iter().map(|c| c.mx).collect();
            let given = match t.hold(k, &mxs, cycle) {
                Ok(g) => g,
                Err(e) => {
                    self.unfit(e);
                    return Ok(false);
                }
            };
            if n as u64 > slots {
                self.unfit(format!(
                    "PE {k} holds {n} columns at slice {z}, past the {slots} slots"
                ));
                return Ok(false);
            }
            self.held[k] = (0, pe.active.1);
            writeln!(self.map[k], "{cycle:x} 0 {n:x} 0")?;
            for (i, (mx, sl)) in mxs.iter().zip(&given).enumerate() {
                writeln!(self.cm[k], "{cycle:x} {i:x} {:x} {sl:x}", *mx as u64)?;
            }
            return Ok(true);
        }
        let consecutive = pe
            .rays
            .iter()
            .enumerate()
            .all(|(i, c)| c.mx == lo + i as i64);
        if n as u64 > slots || !consecutive {
            self.unfit(format!(
                "PE {k} holds {n} columns{} at slice {z}, past the declared {slots} slots",
                if consecutive {
                    ""
                } else {
                    " (not consecutive)"
                },
            ));
            return Ok(false);
        }
        self.held[k] = (lo, pe.active.1);
        // The range's first slot, as migration keeps the slots a ring.
        let sl = self.shape.slot(lo);
        writeln!(self.map[k], "{:x} {:x} {:x} {:x}", cycle, lo as u64, n, sl)?;
        Ok(true)
    }
}
