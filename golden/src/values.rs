//! The set of voxel values a volume holds ([`ValueSet`]): what its value
//! range and a transfer function's coverage of it
//! ([`crate::tf::TransferFunction::coverage`]) depend on, found in one
//! pass and kept with the volume ([`crate::volume::Volume::values`]), so a
//! process rendering one volume many times (the Python module, the C ABI)
//! reads its voxels for them once, not once a frame.

use rayon::prelude::*;

use crate::volume::{Voxel, Voxels};

/// Voxels a worker marks in one go: large enough that the per-chunk table
/// (one byte per value of the type: 64 KiB for 16-bit voxels) is cleared
/// and folded into the set far less often than voxels are read.
const CHUNK: usize = 1 << 20;

/// Which values of a voxel type occur in a volume: one bit per value.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ValueSet {
    /// Bit `v % 64` of word `v / 64` is set when value `v` occurs.
    bits: Vec<u64>,
}

impl ValueSet {
    /// The values in `voxels`, marked chunk by chunk in parallel (the
    /// union does not depend on the order, so neither does the set).
    pub fn of(voxels: &Voxels) -> ValueSet {
        match voxels {
            Voxels::U8(d) => ValueSet::marked(d, 1 << 8),
            Voxels::U16(d) => ValueSet::marked(d, 1 << 16),
        }
    }

    fn marked<T: Voxel>(d: &[T], values: usize) -> ValueSet {
        let words = values / 64;
        let bits = d
            .par_chunks(CHUNK)
            .map(|chunk| {
                // A byte a value: a store per voxel, no read-modify-write
                // chain through one word.
                let mut seen = vec![0u8; values];
                for &v in chunk {
                    seen[usize::from(v.value())] = 1;
                }
                let mut bits = vec![0u64; words];
                for (v, _) in seen.iter().enumerate().filter(|(_, &s)| s != 0) {
                    bits[v / 64] |= 1 << (v % 64);
                }
                bits
            })
            .reduce(
                || vec![0u64; words],
                |mut a, b| {
                    a.iter_mut().zip(&b).for_each(|(x, y)| *x |= y);
                    a
                },
            );
        ValueSet { bits }
    }

    /// Whether value `v` occurs.
    pub fn contains(&self, v: u16) -> bool {
        let v = usize::from(v);
        self.bits
            .get(v / 64)
            .is_some_and(|w| w >> (v % 64) & 1 == 1)
    }

    /// The values that occur, ascending.
    pub fn iter(&self) -> impl Iterator<Item = u16> + '_ {
        self.bits.iter().enumerate().flat_map(|(i, &w)| {
            (0..64)
                .filter(move |b| w >> b & 1 == 1)
                .map(move |b| (i * 64 + b) as u16)
        })
    }

    /// The smallest and largest value that occur (`None` for no voxels).
    pub fn range(&self) -> Option<(u16, u16)> {
        let lo = self.bits.iter().enumerate().find(|(_, &w)| w != 0)?;
        let hi = self.bits.iter().enumerate().rfind(|(_, &w)| w != 0)?;
        Some((
            (lo.0 * 64 + lo.1.trailing_zeros() as usize) as u16,
            (hi.0 * 64 + 63 - hi.1.leading_zeros() as usize) as u16,
        ))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    proptest! {
        /// The set is exactly the values present, whatever the type and
        /// however the voxels split into chunks.
        #[test]
        fn the_set_is_the_values_present(
            wide in any::<bool>(),
            values in proptest::collection::vec(any::<u16>(), 1..300),
            repeat in 1usize..5,
        ) {
            let data: Vec<u16> = values
                .iter()
                .map(|&v| if wide { v } else { v & 0xff })
                .cycle()
                .take(values.len() * repeat)
                .collect();
            let voxels = if wide {
                Voxels::U16(data.clone())
            } else {
                Voxels::U8(data.iter().map(|&v| v as u8).collect())
            };
            let set = ValueSet::of(&voxels);
            let mut want: Vec<u16> = data.clone();
            want.sort_unstable();
            want.dedup();
            prop_assert_eq!(set.iter().collect::<Vec<_>>(), want.clone());
            prop_assert_eq!(set.range(), Some((want[0], *want.last().unwrap())));
            for v in [0u16, 1, 255, 256, 65535] {
                prop_assert_eq!(set.contains(v), want.contains(&v));
            }
        }
    }

    #[test]
    fn chunks_of_a_large_volume_are_all_marked() {
        // Three chunks' worth, each value only in its own chunk.
        let mut d = vec![7u16; 3 * CHUNK];
        d[CHUNK + 5] = 40_000;
        d[3 * CHUNK - 1] = 3;
        let set = ValueSet::of(&Voxels::U16(d));
        assert_eq!(set.iter().collect::<Vec<_>>(), vec![3, 7, 40_000]);
        assert_eq!(set.range(), Some((3, 40_000)));
    }
}
