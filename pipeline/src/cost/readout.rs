//! The PE's readout stage as cost units: what `ercube synth --readout`
//! estimates for `ercube_pe_readout` ([`crate::hw::readout_rtl`]).
//!
//! Every unit follows a statement of the emitted module at the widths and
//! depths of its [`ReadoutShape`] (the same shape the Verilog is written
//! from): the memories at their declared depths, the registers the shape
//! counts ([`ReadoutShape::register_bits`]) less the read registers the
//! block RAMs take in, and the logic between them.

use super::memory::MemPorts;
use super::units::Unit;
use crate::cost::shapes::RAY_INDEX_BITS;
use crate::hw::readout_rtl::ReadoutShape;

/// The units of one PE's readout module of shape `s`.
pub fn readout_units(s: &ReadoutShape) -> Vec<Unit> {
    let n = s.map_depth as u32;
    let (rb, sb, lab) = (s.row_bits(), s.slot_bits(), s.ray_addr_bits());
    let w = s.buffer_width;
    let mem = |depth: u64, width: u32| Unit::Mem {
        depth,
        width,
        ports: MemPorts::Sdp,
    };
    // The two banks and the column map, each a host write port and a read
    // port; with `pass_skip_empty` also a valid word a row.
    let mut u = vec![
        mem(s.bank_depth, w),
        mem(s.bank_depth, w),
        mem(s.map_depth, s.map_width),
    ];
    // Their read registers (`q0`, `q1`, `mq`; `vq` reading the valid
    // words) are the blocks' own. Their synchronous reset costs no LUT
    // here (unlike the datapath's tables, `cost::memory::read_reset`):
    // every read bit reaches the host port through `host_valid`, which
    // the reset already clears, so yosys drops the reset's AND.
    let mut read_bits = 2 * u64::from(w) + u64::from(s.map_width);
    if s.sparse {
        u.push(mem(s.max_rows, n));
        read_bits += u64::from(n);
    }
    u.push(Unit::Reg {
        bits: (s.register_bits() - read_bits) as u32,
    });
    // Without the valid words, `vq` is the thermometer of `ncols`.
    if !s.sparse {
        u.push(Unit::Decode { width: n });
    }
    u.extend([
        // The row in hand: `bits` (the row worked or the arriving valid
        // word, else zero) and `row_now`.
        Unit::Mux {
            width: n,
            inputs: 2,
        },
        Unit::Mux {
            width: rb,
            inputs: 2,
        },
        // `rest = bits & (bits - 1)`, `pick = bits != 0`, `row_end = rest
        // == 0`: the decrement's chain and two reductions; the AND is not
        // charged (in the synthesized module the three take fewer LUTs
        // than the decrement and reductions alone: 38 LUT4s at 26 bits).
        Unit::Inc { width: n },
        Unit::Reduce { width: n },
        Unit::Reduce { width: n },
        // `col = lowest(bits)`.
        Unit::Encode { width: n },
        // `addr = row_now * slots + col`.
        Unit::ConstMulAdd {
            a: rb,
            k: s.map_depth,
            y: lab,
        },
        // `next_row`, `next_row != rows`, the counts' zero tests and
        // `v_addr`.
        Unit::Inc { width: rb },
        Unit::Cmp { width: rb },
        Unit::Reduce { width: sb },
        Unit::Reduce { width: rb },
        Unit::Mux {
            width: rb,
            inputs: 2,
        },
        // The host port: the bank's word selected and every field masked
        // by `host_valid`, a LUT a bit.
        Unit::Mux {
            width: w + RAY_INDEX_BITS + rb,
            inputs: 2,
        },
    ]);
    u
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::PipelineConfig;
    use crate::cost::inventory::Geometry;
    use crate::cost::units::total;
    use crate::cost::Target;

    /// The registers priced are the module's declared ones less the read
    /// registers the blocks take in; the memories hold the declared bits.
    #[test]
    fn readout_units_follow_the_shape() {
        let cfg = PipelineConfig {
            pes: 2,
            ..PipelineConfig::default()
        };
        let s = ReadoutShape::new(&cfg, &Geometry::new([16, 16, 16], 2)).unwrap();
        let u = readout_units(&s);
        let ff: u64 = u
            .iter()
            .filter(|x| matches!(x, Unit::Reg { .. }))
            .map(|x| x.cost(Target::Xc7).ff)
            .sum();
        assert_eq!(
            ff,
            s.register_bits() - 2 * u64::from(s.buffer_width) - u64::from(s.map_width)
        );
        let bits: u64 = u
            .iter()
            .filter_map(|x| match *x {
                Unit::Mem { depth, width, .. } => Some(depth * u64::from(width)),
                _ => None,
            })
            .sum();
        assert_eq!(bits, s.memory_bits());
        assert!(total(Target::Ice40, &u).bram > 0);
    }
}
