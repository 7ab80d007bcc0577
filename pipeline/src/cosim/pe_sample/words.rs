//! The words the sample stage's co-simulation streams carry: a sampling
//! clock's broadcast as the PE's control reads it, and the widths that
//! pack a ray's accumulators into one testbench word.

use crate::cosim::replay::masked;
use crate::stages::sample::SampleBus;

/// A sampling clock's broadcast as the PE's control reads it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct BusCycle {
    /// The clock (the frame's numbering).
    pub cycle: u64,
    /// Whether the clock samples (not the prologue).
    pub go: bool,
    /// Whether it is the row's first sampling clock.
    pub first: bool,
    /// The row in the region's buffer.
    pub row: usize,
    /// The slice.
    pub z: usize,
    /// The row's clamped voxel rows.
    pub y: (usize, usize),
    /// The row's words, raw: `a`, `t`, `b`, `k`, `row_wy`, `sy`, `sz`.
    pub words: [i64; 7],
    /// The row whose edge voxels the PEs drive: slice, voxel rows.
    pub next: Option<(usize, usize, usize)>,
    /// The row's y position (`position`), raw: the volume of interest's
    /// `voi.y` (with `z`, its `voi.z`).
    pub yp: i64,
}

impl BusCycle {
    pub(super) fn of(b: &SampleBus) -> BusCycle {
        BusCycle {
            cycle: b.now,
            go: b.cycle != usize::MAX,
            first: b.cycle == 0,
            row: b.row,
            z: b.slice.z,
            y: (b.y.0, b.y.1),
            words: [
                b.slice.a[0].raw(),
                b.slice.t[0].raw(),
                b.slope_x.0.raw(),
                b.slope_x.1.raw(),
                b.y.2.raw(),
                b.slope_yz.0.raw(),
                b.slope_yz.1.raw(),
            ],
            next: b.next,
            yp: b.yp.raw(),
        }
    }
}

/// Widths of the words the streams carry.
#[derive(Debug, Clone, Copy)]
pub struct Widths {
    /// The ray index (`slot_m`).
    pub m: u32,
    /// A colour accumulator.
    pub color: u32,
    /// The opacity accumulator.
    pub alpha: u32,
    /// A voxel.
    pub voxel: u32,
    /// A buffer address.
    pub addr: u32,
    /// Clocks from issue to the taps' line (the tap stage).
    pub tap_stage: u64,
}

impl Widths {
    /// The words of the sample stage `shape` around datapath `dp`: the ray
    /// index as wide as the datapath's `slot_m` port, the taps at its
    /// `v00` port's stage.
    pub fn of(
        shape: &crate::hw::pe_sample_rtl::PeSampleShape,
        dp: &crate::hw::pipeline_rtl::PipelinedModule,
    ) -> Widths {
        let port = |n: &str| dp.ports.iter().find(|p| p.name == n);
        Widths {
            m: port("slot_m").map_or(16, |p| p.word.bits),
            color: shape.rays.color_bits,
            alpha: shape.rays.alpha_bits,
            voxel: shape.voxel_bits,
            addr: shape.rays.ray_addr_bits(),
            tap_stage: u64::from(port("v00").map_or(0, |p| p.stage)),
        }
    }

    pub(super) fn acc(&self, i: usize) -> u32 {
        if i == 3 {
            self.alpha
        } else {
            self.color
        }
    }

    /// A buffer word packed as the module stores it (`{a, b, g, r}`).
    pub fn pack(&self, acc: &[i64; 4]) -> u128 {
        let mut w = 0u128;
        let mut at = 0;
        for (i, &v) in acc.iter().enumerate() {
            w |= masked(v, self.acc(i)) << at;
            at += self.acc(i);
        }
        w
    }

    /// The accumulators of a packed word, sign-extended where `signed`.
    pub fn unpack(&self, w: u128, signed: [bool; 2]) -> [i64; 4] {
        let mut out = [0; 4];
        let mut at = 0;
        for (i, o) in out.iter_mut().enumerate() {
            let bits = self.acc(i);
            let raw = (w >> at) & ((1u128 << bits) - 1);
            let s = if i == 3 { signed[1] } else { signed[0] };
            *o = if s && (raw >> (bits - 1)) & 1 == 1 {
                (raw as i128 - (1i128 << bits)) as i64
            } else {
                raw as i64
            };
            at += bits;
        }
        out
    }
}
