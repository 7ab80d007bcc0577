//! The control of the PE's sample stage as cost units: the logic of
//! `ercube_pe_sample` ([`crate::hw::pe_sample_rtl`]) around its datapath
//! and memories, statement by statement.
//!
//! Every unit follows a statement of the emitted module (or of its
//! helpers `pe_plan_rtl`, `pe_columns_rtl`, `pe_taps_rtl`, `pe_term_rtl`) at the widths
//! and depths of the [`PeSampleShape`] the Verilog is written from: the
//! plan port's comparators and FIFO, the one-hot pick, index,
//! slot and buffer address, the accumulators' forwarding, the taps'
//! clamps, addresses and selects, the edge register's reads, the voxel
//! load's addresses and, front to back, the termination bits. The
//! memories are the PE's declared state and the registers its declared
//! registers, both charged by the inventory; the datapath is charged
//! from its own description.

use crate::cost::inventory::addr_bits;
use crate::cost::units::Unit;
use crate::hw::pe_sample_rtl::PeSampleShape;

/// The control's logic in `s`, whose datapath shows the tap column as an
/// `x0_bits`-bit word: `(statement, units)`, in the module's order.
pub fn control_logic(s: &PeSampleShape, x0_bits: u32) -> Vec<(&'static str, Vec<Unit>)> {
    let n = s.slots() as u32;
    let r = &s.rays;
    let ib = s.index_bits;
    let tb = addr_bits(s.slots());
    let pb = addr_bits(r.max_rows);
    let (ab, rb, yb, cb) = (r.ray_addr_bits(), r.row_bits(), s.row_bits(), s.col_bits());
    let v = s.voxel_bits;
    let bw = r.buffer_width;
    let sbw = addr_bits(s.bank_words());
    let ebw = addr_bits(2 * s.half_rows);
    let lb = addr_bits(s.stored);
    let mux = |width: u32, inputs: u32| Unit::Mux { width, inputs };
    let mut out: Vec<(&'static str, Vec<Unit>)> = Vec::new();
    if s.round_robin {
        out.push((
            "plan port: each column map entry's ray against the run, the entry held",
            vec![Unit::Cmp { width: ib }; 2 * n as usize]
                .into_iter()
                .chain([Unit::Decode { width: n }, mux(n, 3)])
                .collect(),
        ));
    } else {
        out.push((
            "plan port: the run moved to the held range, its ends as thermometer codes",
            vec![
                Unit::Sub { width: ib + 1 },
                Unit::Sub { width: ib + 1 },
                Unit::Cmp { width: ib + 1 },
                Unit::Cmp { width: ib + 1 },
                Unit::Decode { width: n },
                Unit::Decode { width: n },
                Unit::Decode { width: n },
                mux(n, 3),
            ],
        ));
    }
    out.extend([
        (
            "plan port: the row's word (pl_acc OR the run's bits)",
            vec![mux(n, 2)],
        ),
        (
            "plan FIFO: tail and head pointers, the entry written, the head and the entry after it",
            vec![
                Unit::Inc { width: pb },
                Unit::Inc { width: pb },
                Unit::Inc { width: pb },
                Unit::Reduce { width: pb },
                Unit::Reduce { width: pb },
                Unit::Reduce { width: pb },
                mux(pb, 3),
                mux(pb, 3),
                mux(pb, 2),
            ],
        ),
        (
            "plan FIFO: the head's word and the memory's read ahead, each with its write bypass",
            vec![
                Unit::Cmp { width: pb },
                Unit::Cmp { width: pb },
                mux(n, 2),
                mux(n, 2),
            ],
        ),
        (
            "plan FIFO: the head's register, the entry after it taken at a row's first clock",
            vec![mux(n, 2)],
        ),
        (
            "issue: the row's bits (the head's word or those left)",
            vec![mux(n, if s.termination.is_some() { 3 } else { 2 })],
        ),
        (
            "issue: the lowest bit one-hot (bits & -bits), the bits left",
            vec![Unit::Inc { width: n }, mux(n, 2), mux(n, 2)],
        ),
        (
            "issue: the lowest bit's index (an OR tree an index bit), any bit left",
            std::iter::repeat_n(
                Unit::Reduce {
                    width: n.div_ceil(2),
                },
                tb as usize,
            )
            .chain([Unit::Reduce { width: n }])
            .collect(),
        ),
    ]);
    if s.round_robin {
        out.push((
            "issue: the ray and its slot from the column map entry",
            vec![mux(ib + tb, n)],
        ));
    } else {
        out.push((
            "issue: the ray map_lo + idx (added at issue), its slot map_sl + idx wrapped",
            vec![
                Unit::Add { width: ib },
                Unit::Add { width: tb + 1 },
                Unit::Cmp { width: tb + 1 },
                Unit::Sub { width: tb + 1 },
                mux(tb, 2),
            ],
        ));
    }
    out.extend([
        (
            "issue: the buffer word row * slots + slot",
            times_plus(s.slots(), ab),
        ),
        (
            "accumulators: a write-back forwarded, bank select",
            vec![Unit::Cmp { width: ab }, mux(bw, 3)],
        ),
    ]);
    let rows = [
        mux(yb, 2),
        mux(yb, 2),
        Unit::Add { width: sbw },
        Unit::Add { width: sbw },
    ]
    .into_iter()
    .chain(times_plus(s.stored, sbw))
    .chain(times_plus(s.stored, sbw));
    if s.round_robin {
        out.extend([
            (
                "taps: x0 and x0 + 1 clamped into the volume",
                vec![
                    Unit::Inc { width: x0_bits },
                    Unit::Cmp { width: x0_bits },
                    Unit::Cmp { width: x0_bits },
                    Unit::Cmp { width: x0_bits },
                    Unit::Cmp { width: x0_bits },
                    mux(cb, 3),
                    mux(cb, 3),
                ],
            ),
            (
                "taps: the local columns through the column decoder",
                vec![mux(lb, s.nx as u32), mux(lb, s.nx as u32)],
            ),
            (
                "taps: the row banks' rows and the four read addresses",
                rows.chain([Unit::Add { width: sbw }; 4]).collect(),
            ),
        ]);
    } else {
        out.extend([
            (
                "taps: a clock ahead, the row banks' rows and bases less col_lo, + 1, + nx_last",
                rows.chain([
                    Unit::Sub { width: sbw },
                    Unit::Sub { width: sbw },
                    Unit::Inc { width: sbw },
                    Unit::Inc { width: sbw },
                    Unit::Add { width: sbw },
                    Unit::Add { width: sbw },
                ])
                .collect(),
            ),
            (
                "taps: the clamp's compares, each address a sum with x0 or a clamped form",
                [Unit::Cmp { width: x0_bits }; 3]
                    .into_iter()
                    .chain([Unit::Add { width: sbw }; 4])
                    .chain([mux(sbw, 3); 4])
                    .collect(),
            ),
            (
                "taps: the right tap held (x0 + 1 clamped, below col_end: x0 against col_end - 1)",
                vec![
                    Unit::Sub { width: cb + 1 },
                    Unit::Cmp {
                        width: x0_bits.max(cb + 1),
                    },
                    Unit::Cmp { width: cb + 1 },
                    mux(1, 3),
                ],
            ),
        ]);
    }
    out.extend([
        (
            "taps: each tap's row bank or the neighbour's edge word",
            vec![mux(v, 2), mux(v, 2), mux(v, 3), mux(v, 3)],
        ),
        (
            "edge register: its rows' addresses, the words driven",
            vec![
                mux(yb, 2),
                mux(yb, 2),
                Unit::Add { width: ebw },
                Unit::Add { width: ebw },
                mux(v, 2),
                mux(v, 2),
            ],
        ),
        (
            "voxel load: the slice buffer's and the edge column's words",
            [Unit::Add { width: sbw }]
                .into_iter()
                .chain(times_plus(s.stored, sbw))
                .chain([Unit::Add { width: ebw }, Unit::Reduce { width: lb }])
                .collect(),
        ),
    ]);
    if s.termination.is_some() {
        let aw = r.alpha_bits;
        out.push((
            "termination: the threshold, the write's bit, the read forwarded",
            vec![
                Unit::Cmp { width: aw },
                Unit::Decode { width: n },
                Unit::Cmp { width: rb },
                Unit::Decode { width: n },
                mux(n, 2),
            ],
        ));
        out.push((
            "termination: the row's bits from slots to plan order",
            if s.round_robin {
                vec![mux(n, n)]
            } else {
                vec![Unit::Shift {
                    width: n,
                    amount: tb,
                }]
            },
        ));
    }
    out
}

/// `x * k + c` into `y` bits as the Verilog writes it
/// ([`crate::hw::pe_sample_rtl`]'s shifted sums): an adder a further set
/// bit of `k`, and the `+ c`.
fn times_plus(k: u64, y: u32) -> Vec<Unit> {
    vec![Unit::Add { width: y }; k.count_ones().max(1) as usize]
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::{Order, PipelineConfig};
    use crate::cost::inventory::Geometry;
    use crate::cost::units::total;
    use crate::cost::Target;

    fn shape(cfg: &PipelineConfig) -> PeSampleShape {
        PeSampleShape::new(cfg, &Geometry::new([16, 16, 16], 2)).unwrap()
    }

    /// The logic grows with the column map's slots, and front to back with
    /// termination adds the termination bits' statements.
    #[test]
    fn the_control_follows_the_shape() {
        let cfg = PipelineConfig {
            pes: 2,
            ..PipelineConfig::default()
        };
        let s = shape(&cfg);
        let lut = |s: &PeSampleShape| -> u64 {
            let u: Vec<Unit> = control_logic(s, 12)
                .into_iter()
                .flat_map(|(_, u)| u)
                .collect();
            total(Target::Ice40, &u).lut
        };
        let wide = s.with_slots(2 * s.slots());
        assert!(lut(&wide) > lut(&s), "{} vs {}", lut(&wide), lut(&s));
        let ftb = PipelineConfig {
            order: Order::FrontToBack,
            terminate: 0.9,
            ..cfg
        };
        let t = shape(&ftb);
        assert!(t.termination.is_some());
        let names: Vec<&str> = control_logic(&t, 12).into_iter().map(|(n, _)| n).collect();
        assert!(
            names.iter().any(|n| n.starts_with("termination")),
            "{names:?}"
        );
        assert!(!control_logic(&s, 12)
            .iter()
            .any(|(n, _)| n.starts_with("termination")));
    }
}
