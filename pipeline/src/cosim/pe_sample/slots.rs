//! The compositing buffer's slots under a round-robin mapping (the
//! interleave, the cyclic mapping), as the migration that writes a PE's
//! column map gives them out.
//!
//! A round-robin PE holds rays from across the whole slice, several
//! blocks of them, and which ones changes from slice to slice as the
//! rays' columns drift into other PEs' blocks, so a ray's slot cannot be
//! its index modulo the slots as under column blocks. Migration gives an
//! arriving ray the lowest slot that no held ray has and that no
//! write-back still in the datapath will land in (the write-back carries
//! its address, so a slot freed by a leaving ray is reused only once its
//! last write-back has landed); a ray keeps its slot while it stays. The
//! PE's column map lists the held rays in increasing index, each with its
//! slot ([`crate::hw::pe_sample_rtl`]): the order the control issues a
//! row's planned rays in.
//!
//! Migration is not emitted: the capture runs this allocation beside the
//! model and replays its column map and the arriving rays' words.

use std::collections::HashMap;

/// Every PE's slots.
#[derive(Debug, Clone, Default)]
pub struct Slots {
    /// Per PE, the slot of each held ray.
    held: Vec<HashMap<i64, u64>>,
    /// Per PE and slot, the clock the slot's last write-back lands in.
    lands: Vec<Vec<u64>>,
    /// The slots there are (`None`: as many as needed).
    limit: Option<u64>,
    /// The most slots any PE used.
    pub peak: u64,
}

impl Slots {
    /// Slots for `pes` PEs, at most `limit` each (`None`: unbounded).
    pub fn new(pes: usize, limit: Option<u64>) -> Slots {
        Slots {
            held: vec![HashMap::new(); pes],
            lands: vec![Vec::new(); pes],
            limit,
            peak: 0,
        }
    }

    /// PE `k` holds rays `mxs` (ascending) from the middle of clock
    /// `cycle` on: rays it no longer holds free their slots, arriving
    /// ones take the lowest free slot whose write-backs have all landed
    /// by clock `cycle - 1`. Returns each held ray's slot, in `mxs`'
    /// order, or why none was free.
    pub fn hold(&mut self, k: usize, mxs: &[i64], cycle: u64) -> Result<Vec<u64>, String> {
        let keep: std::collections::HashSet<i64> = mxs.iter().copied().collect();
        self.held[k].retain(|mx, _| keep.contains(mx));
        let mut used: Vec<bool> = Vec::new();
        for &s in self.held[k].values() {
            let s = s as usize;
            if used.len() <= s {
                used.resize(s + 1, false);
            }
            used[s] = true;
        }
        let mut out = Vec::with_capacity(mxs.len());
        let mut next = 0usize;
        for &mx in mxs {
            if let Some(&s) = self.held[k].get(&mx) {
                out.push(s);
                continue;
            }
            let free = |s: usize, used: &[bool], lands: &[u64]| {
                !used.get(s).copied().unwrap_or(false) && lands.get(s).is_none_or(|&l| l < cycle)
            };
            while !free(next, &used, &self.lands[k]) {
                next += 1;
            }
            if let Some(n) = self.limit.filter(|&n| next as u64 >= n) {
                return Err(format!(
                    "PE {k} holds {} rays at clock {cycle} and finds no free slot of its {n} for ray {mx}",
                    mxs.len()
                ));
            }
            if used.len() <= next {
                used.resize(next + 1, false);
            }
            used[next] = true;
            self.held[k].insert(mx, next as u64);
            self.peak = self.peak.max(next as u64 + 1);
            out.push(next as u64);
        }
        Ok(out)
    }

    /// The slot of PE `k`'s held ray `mx`.
    pub fn slot(&self, k: usize, mx: i64) -> Option<u64> {
        self.held.get(k)?.get(&mx).copied()
    }

    /// A write-back of PE `k`'s ray `mx` lands in clock `land`.
    pub fn landed(&mut self, k: usize, mx: i64, land: u64) {
        let Some(s) = self.slot(k, mx) else { return };
        let l = &mut self.lands[k];
        if l.len() <= s as usize {
            l.resize(s as usize + 1, 0);
        }
        l[s as usize] = l[s as usize].max(land);
    }
}

#[cfg(test)]
mod tests {
    use super::Slots;

    #[test]
    fn a_freed_slot_waits_for_its_write_back() {
        let mut s = Slots::new(1, Some(4));
        assert_eq!(s.hold(0, &[3, 5], 10), Ok(vec![0, 1]));
        s.landed(0, 3, 20);
        // Ray 3 leaves; its slot's write-back lands in clock 20.
        assert_eq!(s.hold(0, &[5, 7], 15), Ok(vec![1, 2]));
        assert_eq!(s.hold(0, &[5, 7, 9], 21), Ok(vec![1, 2, 0]));
        assert!(s.hold(0, &[1, 2, 5, 7, 9], 22).is_err());
        assert_eq!(s.peak, 4);
    }
}
