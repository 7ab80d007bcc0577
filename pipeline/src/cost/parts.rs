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
/// SPRAMs).
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
                note: "",
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
    }
}
