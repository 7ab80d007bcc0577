//! FPGA families the estimator maps to, and the resource vector it counts.

use serde::{Deserialize, Serialize};
use std::fmt;
use std::ops::{Add, AddAssign, Mul};
use std::str::FromStr;

/// An FPGA family: its logic element, multiplier block and block RAM.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum Target {
    /// Xilinx 7-series (Artix-7): LUT6 + CARRY4, DSP48E1 (25x18 signed),
    /// RAMB18E1 / RAMB36E1, LUT-RAM in SLICEMs. UltraScale+ parts are
    /// priced with the same models (their LUT6 and block-RAM geometries are
    /// the same; a DSP48E2's 27 x 18 multiplier needs at most as many
    /// blocks as the DSP48E1 decomposition) and list UltraRAM besides.
    #[serde(rename = "xc7")]
    Xc7,
    /// Lattice ECP5: LUT4 + CCU2C carry, MULT18X18D, DP16KD (18 kbit),
    /// distributed RAM (TRELLIS_DPR16X4).
    #[serde(rename = "ecp5")]
    Ecp5,
    /// Lattice iCE40 UltraPlus: LUT4 + SB_CARRY logic cells, SB_MAC16
    /// (16x16), SB_RAM40_4K (4 kbit, one read and one write port).
    #[serde(rename = "ice40")]
    Ice40,
}

impl Target {
    /// Every family, in report order.
    pub const ALL: [Target; 3] = [Target::Xc7, Target::Ecp5, Target::Ice40];

    /// The command-line spelling.
    pub fn name(self) -> &'static str {
        match self {
            Target::Xc7 => "xc7",
            Target::Ecp5 => "ecp5",
            Target::Ice40 => "ice40",
        }
    }

    /// A one-line description of the primitives.
    pub fn describe(self) -> &'static str {
        match self {
            Target::Xc7 => {
                "Xilinx 7-series: LUT6 + CARRY4, DSP48E1 (25x18), RAMB18E1/RAMB36E1, LUT-RAM (UltraScale+ parts priced alike, plus URAM288)"
            }
            Target::Ecp5 => "Lattice ECP5: LUT4 + CCU2C, MULT18X18D, DP16KD (18 kbit), DPR16X4",
            Target::Ice40 => {
                "Lattice iCE40 UltraPlus: LUT4 logic cells, SB_MAC16 (16x16), SB_RAM40_4K (4 kbit)"
            }
        }
    }

    /// Name of the LUT primitive counted in [`Resources::lut`].
    pub fn lut_name(self) -> &'static str {
        match self {
            Target::Xc7 => "LUT6",
            Target::Ecp5 | Target::Ice40 => "LUT4",
        }
    }

    /// Name of the multiplier block counted in [`Resources::dsp`].
    pub fn dsp_name(self) -> &'static str {
        match self {
            Target::Xc7 => "DSP48E1",
            Target::Ecp5 => "MULT18X18D",
            Target::Ice40 => "SB_MAC16",
        }
    }

    /// Name of the block-RAM unit counted in [`Resources::bram`].
    pub fn bram_name(self) -> &'static str {
        match self {
            // RAMB36E1 counts as two: every RAMB36 site splits into two
            // RAMB18s, so capacity in RAMB18 units is exact.
            Target::Xc7 => "RAMB18",
            Target::Ecp5 => "DP16KD",
            Target::Ice40 => "SB_RAM40_4K",
        }
    }

    /// Bits in one [`Resources::bram`] unit (data bits, parity included
    /// where the primitive has it).
    pub fn bram_bits(self) -> u64 {
        match self {
            Target::Xc7 | Target::Ecp5 => 18 * 1024,
            Target::Ice40 => 4 * 1024,
        }
    }
}

impl fmt::Display for Target {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for Target {
    type Err = String;

    fn from_str(s: &str) -> Result<Target, String> {
        match s.to_ascii_lowercase().as_str() {
            "xc7" | "artix7" | "7series" => Ok(Target::Xc7),
            "ecp5" => Ok(Target::Ecp5),
            "ice40" | "up5k" => Ok(Target::Ice40),
            _ => Err(format!("unknown target '{s}': expected xc7, ecp5 or ice40")),
        }
    }
}

/// Resources of one unit, one PE or the whole array, in the target's
/// primitives.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize)]
pub struct Resources {
    /// Look-up tables (LUT6 on xc7, LUT4 on ECP5 and iCE40), including
    /// those used as LUT-RAM or shift registers, and on ECP5 the two LUT4s
    /// of every CCU2C carry cell. iCE40 carry cells (SB_CARRY) sit beside
    /// the LUT4 of a logic cell and are counted in [`carry`](Self::carry)
    /// only.
    pub lut: u64,
    /// Of [`lut`](Self::lut), LUTs used as memory (LUT-RAM, SRL).
    pub lutram: u64,
    /// Flip-flops in the fabric (registers absorbed into DSP or RAM blocks
    /// are not counted).
    pub ff: u64,
    /// Multiplier blocks.
    pub dsp: u64,
    /// Block-RAM units ([`Target::bram_name`]).
    pub bram: u64,
    /// Carry primitives (CARRY4, CCU2C, SB_CARRY), for information.
    pub carry: u64,
}

impl Resources {
    /// Only LUTs.
    pub fn luts(n: u64) -> Resources {
        Resources {
            lut: n,
            ..Resources::default()
        }
    }

    /// Only flip-flops.
    pub fn ffs(n: u64) -> Resources {
        Resources {
            ff: n,
            ..Resources::default()
        }
    }

    /// iCE40 logic cells: each holds one LUT4, one carry and one flip-flop,
    /// so a design needs at least `max(LUTs, FFs)` of them (the packer pairs
    /// a flip-flop with the LUT that feeds it; this is the lower bound).
    pub fn logic_cells(&self) -> u64 {
        self.lut.max(self.ff)
    }
}

impl Add for Resources {
    type Output = Resources;

    fn add(self, o: Resources) -> Resources {
        Resources {
            lut: self.lut + o.lut,
            lutram: self.lutram + o.lutram,
            ff: self.ff + o.ff,
            dsp: self.dsp + o.dsp,
            bram: self.bram + o.bram,
            carry: self.carry + o.carry,
        }
    }
}

impl AddAssign for Resources {
    fn add_assign(&mut self, o: Resources) {
        *self = *self + o;
    }
}

impl Mul<u64> for Resources {
    type Output = Resources;

    fn mul(self, n: u64) -> Resources {
        Resources {
            lut: self.lut * n,
            lutram: self.lutram * n,
            ff: self.ff * n,
            dsp: self.dsp * n,
            bram: self.bram * n,
            carry: self.carry * n,
        }
    }
}

impl std::iter::Sum for Resources {
    fn sum<I: Iterator<Item = Resources>>(iter: I) -> Resources {
        iter.fold(Resources::default(), |a, b| a + b)
    }
}
