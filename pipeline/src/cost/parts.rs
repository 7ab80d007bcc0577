//! Capacities of a few real parts per family, and how many PEs fit.

use super::target::{Resources, Target};
use serde::Serialize;

/// One FPGA part's capacity in the estimator's units.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub struct Part {
    /// Part name.
    pub name: &'static str,
    /// Family.
    pub target: Target,
    /// LUTs (xc7: LUT6; ECP5 and iCE40: LUT4 / logic cells).
    pub lut: u64,
    /// Flip-flops.
    pub ff: u64,
    /// Multiplier blocks.
    pub dsp: u64,
    /// Block-RAM units ([`Target::bram_name`]).
    pub bram: u64,
    /// LUTs usable as LUT-RAM (SLICEM LUTs on xc7), if limited.
    pub lutram: Option<u64>,
    /// UltraRAM blocks (URAM288: 4096 x 72 bits, two ports), which the fit
    /// gives the largest block-RAM memories when block RAM runs out
    /// ([`fit_memories`]).
    pub uram: u64,
    /// The clock the part's frame rates are quoted at, MHz: an assumption
    /// for a fully pipelined DSP datapath on a mid speed grade, not a
    /// timing result.
    pub clock_mhz: u32,
    /// Extra memory the estimator does not map to (iCE40 UltraPlus SPRAM).
    pub note: &'static str,
}

/// Parts of `target`'s family.
///
/// Figures: Xilinx 7 Series FPGAs Data Sheet: Overview (DS180), Table 2
/// (Artix-7: logic cells as 6-input LUTs, flip-flops, DSP48E1 slices,
/// 36 Kb block RAMs = two RAMB18 each, distributed RAM kbit / 64 per LUT);
/// Lattice ECP5 Family Data Sheet (FPGA-DS-02012), Table 1.1 (LUTs, 18x18
/// multipliers, EBR blocks; one flip-flop per LUT); Lattice iCE40
/// UltraPlus Family Data Sheet (FPGA-DS-02008), Table 1.1 (logic cells of
/// one LUT4 and one flip-flop, SB_MAC16 DSPs, 4-kbit EBRs, 256-kbit
/// SPRAMs). UltraScale+ (priced with the 7-series models: the same LUT6
/// and block-RAM geometries; a DSP48E2 multiplies 27 x 18 where the
/// estimate decomposes into 25 x 18 DSP48E1s, so its DSP counts are an
/// upper bound): UltraScale Architecture and Product Data Sheet: Overview
/// (DS890), Kintex UltraScale+ table (XCKU5P, XCKU15P: CLB LUTs, CLB
/// flip-flops, DSP48E2 slices, 36 Kb block RAMs, 288 Kb UltraRAMs), Zynq
/// UltraScale+ MPSoC Data Sheet: Overview (DS891), programmable-logic
/// table (XCZU7EV); the same counts appear as the "Available" column of
/// Vivado utilization reports for these parts. Clocks: 200 MHz on
/// Artix-7, 300 MHz on the UltraScale+ parts (-2 speed grade), 150 on
/// ECP5, 48 on iCE40.
pub fn parts(target: Target) -> Vec<Part> {
    match target {
        Target::Xc7 => vec![
            Part {
                name: "XC7A35T",
                target,
                lut: 20_800,
                ff: 41_600,
                dsp: 90,
                bram: 2 * 50,
                lutram: Some(400 * 1024 / 64),
                uram: 0,
                clock_mhz: 200,
                note: "",
            },
            Part {
                name: "XC7A100T",
                target,
                lut: 63_400,
                ff: 126_800,
                dsp: 240,
                bram: 2 * 135,
                lutram: Some(1_188 * 1024 / 64),
                uram: 0,
                clock_mhz: 200,
                note: "",
            },
            Part {
                name: "XC7A200T",
                target,
                lut: 134_600,
                ff: 269_200,
                dsp: 740,
                bram: 2 * 365,
                lutram: Some(2_888 * 1024 / 64),
                uram: 0,
                clock_mhz: 200,
                note: "",
            },
            // LUT-RAM: the data sheets' maximum distributed RAM (6.1,
            // 6.2, 9.8 Mb) at 64 bits per SLICEM LUT.
            Part {
                name: "XCKU5P",
                target,
                lut: 216_960,
                ff: 433_920,
                dsp: 1_824,
                bram: 2 * 480,
                lutram: Some(6_100 * 1024 / 64),
                uram: 64,
                clock_mhz: 300,
                note: "Kintex UltraScale+",
            },
            Part {
                name: "XCZU7EV",
                target,
                lut: 230_400,
                ff: 460_800,
                dsp: 1_728,
                bram: 2 * 312,
                lutram: Some(6_200 * 1024 / 64),
                uram: 96,
                clock_mhz: 300,
                note: "Zynq UltraScale+ MPSoC (programmable logic)",
            },
            Part {
                name: "XCKU15P",
                target,
                lut: 522_720,
                ff: 1_045_440,
                dsp: 1_968,
                bram: 2 * 984,
                lutram: Some(9_800 * 1024 / 64),
                uram: 128,
                clock_mhz: 300,
                note: "Kintex UltraScale+",
            },
        ],
        Target::Ecp5 => vec![Part {
            name: "LFE5U-85F",
            target,
            lut: 84_000,
            ff: 84_000,
            dsp: 156,
            bram: 208,
            lutram: None,
            uram: 0,
            clock_mhz: 150,
            note: "",
        }],
        Target::Ice40 => vec![Part {
            name: "iCE40UP5K",
            target,
            lut: 5_280,
            ff: 5_280,
            dsp: 8,
            bram: 30,
            lutram: None,
            uram: 0,
            clock_mhz: 48,
            note: "plus 4 SPRAM of 256 kbit (single port), not used by the estimate",
        }],
    }
}

/// A design's use of a part.
#[derive(Debug, Clone, Serialize)]
pub struct Fit {
    /// The part.
    pub part: &'static str,
    /// Fraction of each resource used: LUT, FF, DSP, BRAM (and LUT-RAM if
    /// limited).
    pub used: Vec<(&'static str, f64)>,
    /// Whether every resource fits.
    pub fits: bool,
    /// The most used resource.
    pub limit: &'static str,
    /// UltraRAM blocks given memories that block RAM could not hold
    /// ([`fit_memories`]); 0 on parts without UltraRAM.
    pub uram: u64,
}

/// One block-RAM memory of a design, as the UltraRAM allocation sees it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub struct MemDemand {
    /// Block-RAM units of one copy.
    pub bram: u64,
    /// URAM288 blocks of one copy: `ceil(depth / 4096) ceil(width / 72)`.
    pub uram: u64,
    /// Copies in the design (per PE times `P`, or once).
    pub copies: u64,
}

/// URAM288 blocks of a `depth x width` memory: 4096 x 72 per block,
/// cascaded in depth (UltraScale Architecture Memory Resources, UG573).
pub fn uram_blocks(depth: u64, width: u64) -> u64 {
    depth.div_ceil(4096) * width.div_ceil(72)
}

/// How `r` uses `part`, when the memories `mems` (all counted in `r.bram`)
/// may move to the part's UltraRAM: while block RAM is over capacity the
/// memory that frees the most block RAM per UltraRAM block moves, copy by
/// copy, as long as UltraRAM lasts (what a designer does with
/// `ram_style = "ultra"` on the biggest buffers).
pub fn fit_memories(part: &Part, r: &Resources, mems: &[MemDemand]) -> Fit {
    if part.uram == 0 {
        return fit(part, r);
    }
    let mut order: Vec<&MemDemand> = mems.iter().filter(|m| m.uram > 0 && m.bram > 0).collect();
    // Most block RAM saved per UltraRAM block first; ties by size, then
    // order of listing (a stable sort keeps the result deterministic).
    order.sort_by(|a, b| {
        (b.bram * a.uram)
            .cmp(&(a.bram * b.uram))
            .then(b.bram.cmp(&a.bram))
    });
    let mut bram = r.bram;
    let mut uram = 0u64;
    for m in order {
        if bram <= part.bram {
            break;
        }
        let over = bram - part.bram;
        let room = (part.uram - uram) / m.uram;
        let k = m.copies.min(room).min(over.div_ceil(m.bram));
        bram -= k * m.bram;
        uram += k * m.uram;
    }
    let moved = Resources { bram, ..*r };
    let mut f = fit(part, &moved);
    f.uram = uram;
    f.used.push(("URAM", uram as f64 / part.uram as f64));
    f
}

/// How `r` uses `part`.
pub fn fit(part: &Part, r: &Resources) -> Fit {
    let frac = |a: u64, cap: u64| {
        if cap == 0 {
            if a == 0 {
                0.0
            } else {
                f64::INFINITY
            }
        } else {
            a as f64 / cap as f64
        }
    };
    let lut_used = if part.target == Target::Ice40 {
        // iCE40 logic cells hold a LUT4 and a flip-flop each.
        r.logic_cells()
    } else {
        r.lut
    };
    let mut used = vec![
        ("LUT", frac(lut_used, part.lut)),
        ("FF", frac(r.ff, part.ff)),
        ("DSP", frac(r.dsp, part.dsp)),
        ("BRAM", frac(r.bram, part.bram)),
    ];
    if let Some(cap) = part.lutram {
        used.push(("LUTRAM", frac(r.lutram, cap)));
    }
    let fits = used.iter().all(|(_, f)| *f <= 1.0);
    let limit = used
        .iter()
        .fold(("LUT", -1.0), |a, b| if b.1 > a.1 { *b } else { a })
        .0;
    Fit {
        part: part.name,
        used,
        fits,
        limit,
        uram: 0,
    }
}
