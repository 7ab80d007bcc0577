//! Who holds which ray: the owner function of a slice, under the
//! sampling mapping or the column blocks the passes run on.

use crate::datapath::Datapath;
use crate::fixed::QuantStats;
use crate::host::SlicePlan;
use crate::mapping::ColumnMap;

use super::Array;

impl Array {
    /// Who holds which ray in `slice` while the array samples it, computed
    /// with `dp` (the array's datapath, borrowed apart from the array so
    /// the PEs can step).
    pub(crate) fn owners<'a>(&self, dp: &'a Datapath, slice: &'a SlicePlan) -> Owners<'a> {
        Owners {
            dp,
            slice,
            map: self.map,
        }
    }

    /// Who holds which ray on the plane of `slice` for a merge, split or
    /// fold: the column blocks' owner.
    pub(crate) fn pass_owners<'a>(&self, dp: &'a Datapath, slice: &'a SlicePlan) -> Owners<'a> {
        Owners {
            dp,
            slice,
            map: self.blocks,
        }
    }
}

/// The owner function of one slice: the PE owning the ray's base column
/// under `map`, computed with the same fixed-point position a PE uses.
pub(crate) struct Owners<'a> {
    dp: &'a Datapath,
    slice: &'a SlicePlan,
    map: ColumnMap,
}

impl Owners<'_> {
    pub(crate) fn of(&self, mx: i64) -> usize {
        let mut st = QuantStats::default();
        let s = self.slice;
        match self.dp.position(s.a[0], s.t[0], mx, &mut st) {
            Ok(x) => {
                let x0 = self.dp.address(x, &mut st).0;
                let c = x0.clamp(0, self.map.nx as i64 - 1) as usize;
                self.map.owner(c)
            }
            // A position the model cannot form cannot be sampled either;
            // park the ray at the far end.
            Err(_) => self.map.pes - 1,
        }
    }
}
