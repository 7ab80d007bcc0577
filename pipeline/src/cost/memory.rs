//! How a memory of `depth x width` maps onto block RAM or LUT-RAM.
//!
//! The choice follows yosys's `memory_libmap` (0.23): every candidate
//! mapping has a cost (block RAMs 128 per 18-kbit unit on xc7 and ECP5,
//! 64 per SB_RAM40_4K on iCE40; LUT-RAM 8 per Xilinx RAM32M/RAM64M-class
//! cell and 5 per ECP5 DPR16X4; plain flip-flops one per bit on iCE40) and
//! the cheapest wins. Within block RAM the geometry with the fewest units
//! wins (ties go to the larger primitive, fewer cells). A memory deeper
//! than one block is tiled in depth and its read data multiplexed in LUTs.

use super::target::{Resources, Target};
use serde::Serialize;

/// The ports a memory needs.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum MemPorts {
    /// One write port and one read port (simple dual port): FIFOs, the
    /// compositing buffer's read-modify-write, line buffers.
    Sdp,
    /// Port A reads or writes (the host loads tables and slices through
    /// it), port B only reads: two reads per cycle while running.
    DualRead,
    /// One write port (the host's) and two read ports at their own
    /// addresses, as the emitted sample datapath declares its tables
    /// (`hw::pipeline_rtl`): no block has three ports, so yosys keeps two
    /// simple dual-port copies, one per read, on every family.
    WriteTwoReads,
}

/// What a memory maps to.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum MemKind {
    /// Block RAM.
    Block,
    /// LUT-RAM (Xilinx SLICEM LUTs, ECP5 distributed RAM).
    LutRam,
    /// Flip-flops and multiplexers.
    Registers,
}

/// A memory's mapping and cost.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub struct MemMap {
    /// Block RAM, LUT-RAM or flip-flops.
    pub kind: MemKind,
    /// Primitive cells (RAMB18E1 + RAMB36E1 cells, DP16KD, SB_RAM40_4K,
    /// RAM64M-class cells, DPR16X4), or bits for registers.
    pub cells: u64,
    /// Resources, read multiplexers included.
    pub res: Resources,
}

/// One block-RAM geometry: `depth x width` in one primitive of `units`
/// block-RAM units (a RAMB36 is two RAMB18 units).
#[derive(Debug, Clone, Copy)]
struct Geometry {
    depth: u64,
    width: u64,
    units: u64,
}

const fn g(depth: u64, width: u64, units: u64) -> Geometry {
    Geometry {
        depth,
        width,
        units,
    }
}

/// RAMB18E1 and RAMB36E1 (7 Series Memory Resources, UG473): true dual
/// port up to 18 / 36 bits wide, simple dual port 36 / 72 bits wide.
const XC7_TDP: [Geometry; 11] = [
    g(16384, 1, 1),
    g(8192, 2, 1),
    g(4096, 4, 1),
    g(2048, 9, 1),
    g(1024, 18, 1),
    g(32768, 1, 2),
    g(16384, 2, 2),
    g(8192, 4, 2),
    g(4096, 9, 2),
    g(2048, 18, 2),
    g(1024, 36, 2),
];
const XC7_SDP_EXTRA: [Geometry; 2] = [g(512, 36, 1), g(512, 72, 2)];

/// DP16KD true dual port and PDPW16KD's 36-bit simple dual port (ECP5
/// Memory Usage Guide, TN1264).
const ECP5_TDP: [Geometry; 5] = [
    g(16384, 1, 1),
    g(8192, 2, 1),
    g(4096, 4, 1),
    g(2048, 9, 1),
    g(1024, 18, 1),
];
const ECP5_SDP_EXTRA: [Geometry; 1] = [g(512, 36, 1)];

/// SB_RAM40_4K: one read and one write port (iCE40 Memory Usage Guide).
const ICE40: [Geometry; 4] = [g(256, 16, 1), g(512, 8, 1), g(1024, 4, 1), g(2048, 2, 1)];

fn div_ceil(a: u64, b: u64) -> u64 {
    a.div_ceil(b)
}

/// Cost units of `memory_libmap` for one 18-kbit block (xc7, ECP5) or one
/// 4-kbit block (iCE40).
fn block_cost(t: Target) -> u64 {
    match t {
        Target::Xc7 | Target::Ecp5 => 128,
        Target::Ice40 => 64,
    }
}

/// Tiles of one geometry. On iCE40 the bits left over when the width is
/// not a multiple of the block width are folded (two depth tiles of one
/// bit share one 2-bit-wide block), as `memory_libmap` does.
fn tiles(t: Target, geo: Geometry, depth: u64, width: u64) -> (u64, u64) {
    let deep = div_ceil(depth, geo.depth);
    if t == Target::Ice40 {
        let full = deep * (width / geo.width);
        let rem = width % geo.width;
        let folded = if rem == 0 {
            0
        } else {
            div_ceil(deep * rem, geo.width)
        };
        (full + folded, deep)
    } else {
        (deep * div_ceil(width, geo.width), deep)
    }
}

/// The best block-RAM mapping of one copy: `(units, cells, depth tiles,
/// the geometry's width)`.
fn best_block(t: Target, depth: u64, width: u64, ports: MemPorts) -> (u64, u64, u64, u64) {
    let mut geos: Vec<Geometry> = match t {
        Target::Xc7 => XC7_TDP.to_vec(),
        Target::Ecp5 => ECP5_TDP.to_vec(),
        Target::Ice40 => ICE40.to_vec(),
    };
    if ports == MemPorts::Sdp {
        match t {
            Target::Xc7 => geos.extend(XC7_SDP_EXTRA),
            Target::Ecp5 => geos.extend(ECP5_SDP_EXTRA),
            Target::Ice40 => {}
        }
    }
    let mut best: Option<(u64, u64, u64, u64)> = None;
    for geo in geos {
        let (cells, deep) = tiles(t, geo, depth, width);
        let cand = (cells * geo.units, cells, deep, geo.width);
        best = Some(match best {
            Some(b) if (b.0, b.1, b.2) <= (cand.0, cand.1, cand.2) => b,
            _ => cand,
        });
    }
    best.unwrap_or((0, 0, 0, 1))
}

/// LUTs of a `k`-to-1 read multiplexer per data bit.
fn mux_luts(t: Target, k: u64) -> u64 {
    if k <= 1 {
        return 0;
    }
    match t {
        // A LUT6 is a 4:1 mux; MUXF7/MUXF8 combine pairs of LUTs for free.
        Target::Xc7 => div_ceil(k - 1, 3),
        // A LUT4 is a 2:1 mux with one spare input.
        Target::Ecp5 | Target::Ice40 => k - 1,
    }
}

/// Block-RAM mapping with read multiplexers; `copies` duplicates the
/// memory (iCE40 blocks have a single read port).
fn block_map(t: Target, depth: u64, width: u64, ports: MemPorts) -> MemMap {
    let copies = if t == Target::Ice40 && ports == MemPorts::DualRead {
        2
    } else {
        1
    };
    let reads = match ports {
        MemPorts::Sdp => 1,
        MemPorts::DualRead | MemPorts::WriteTwoReads => 2,
    };
    let (units, cells, deep, geo_width) = best_block(t, depth, width, ports);
    // Each read port of a depth-tiled memory needs a mux per data bit and
    // a registered copy of the tile-select address bits.
    let sel_bits = u64::from(64 - (deep.max(1) - 1).leading_zeros());
    let mux = match t {
        _ if deep <= 1 => 0,
        // yosys 0.23 decodes the tiles' write enables once (a LUT per
        // tile) beside the read muxes. Bits left over when the width is
        // not a multiple of the block's, folded two depth tiles to a block
        // (see `tiles`), cost about 20 LUT4s more for their write steering
        // and read select: measured at 4096 x 35 ... 39 (2048 x 2 tiles,
        // one and two read ports alike), whose even widths need none.
        Target::Ice40 => {
            let folded = if width.is_multiple_of(geo_width) {
                0
            } else {
                20
            };
            reads * width * mux_luts(t, deep) + deep + folded
        }
        _ => reads * (width * mux_luts(t, deep) + deep),
    };
    MemMap {
        kind: MemKind::Block,
        cells: cells * copies,
        res: Resources {
            lut: mux,
            ff: if deep > 1 { reads * sel_bits } else { 0 },
            bram: units * copies,
            ..Resources::default()
        },
    }
}

/// LUT-RAM mapping, if the family has it: `(cost, map)`.
fn lutram_map(t: Target, depth: u64, width: u64, ports: MemPorts) -> Option<(u64, MemMap)> {
    let reads = match ports {
        MemPorts::Sdp => 1,
        MemPorts::DualRead | MemPorts::WriteTwoReads => 2,
    };
    match t {
        Target::Xc7 => {
            // (depth per cell, bits per cell, LUTs per cell).
            let (cd, cw, cl) = match ports {
                // RAM32M: 32 x 6 (three 2-bit read ports used as one),
                // RAM64M: 64 x 3, both four LUTs.
                MemPorts::Sdp => {
                    if depth <= 32 {
                        (32, 6, 4)
                    } else {
                        (64, 3, 4)
                    }
                }
                // RAM32M in dual-port mode: 32 x 4; RAM64X1D: 64 x 1 in
                // two LUTs; RAM128X1D: 128 x 1 in four.
                MemPorts::DualRead | MemPorts::WriteTwoReads => {
                    if depth <= 32 {
                        (32, 4, 4)
                    } else if depth <= 64 {
                        (64, 1, 2)
                    } else {
                        (128, 1, 4)
                    }
                }
            };
            let deep = div_ceil(depth, cd);
            let cells = deep * div_ceil(width, cw);
            let mux = if deep > 1 {
                reads * (width * mux_luts(t, deep) + deep)
            } else {
                0
            };
            // Reads are asynchronous: the read register sits in the fabric.
            Some((
                cells * 8,
                MemMap {
                    kind: MemKind::LutRam,
                    cells,
                    res: Resources {
                        lut: cells * cl + mux,
                        lutram: cells * cl,
                        ff: reads * width,
                        ..Resources::default()
                    },
                },
            ))
        }
        Target::Ecp5 => {
            // TRELLIS_DPR16X4: 16 x 4, one write and one read port; a
            // second read port needs a second copy. One cell takes three
            // slices' worth (two for the RAM, one for the write port):
            // six LUT4 positions.
            let deep = div_ceil(depth, 16);
            let cells = deep * div_ceil(width, 4) * reads;
            let mux = if deep > 1 {
                reads * (width * mux_luts(t, deep) + deep)
            } else {
                0
            };
            Some((
                cells * 5,
                MemMap {
                    kind: MemKind::LutRam,
                    cells,
                    res: Resources {
                        lut: cells * 6 + mux,
                        lutram: cells * 6,
                        ff: reads * width,
                        ..Resources::default()
                    },
                },
            ))
        }
        Target::Ice40 => None,
    }
}

/// Maps a `depth x width` memory with `ports` onto `target`.
/// The synchronous reset of a memory's read-data registers, as the
/// emitted datapath declares its tables (`if (rst) q <= 0; else q <=
/// mem[a];` at every read port). DP16KD and RAMB18 reset their output
/// latch and LUT-RAM's read register is a fabric flip-flop with a reset:
/// nothing on ECP5 and xc7. SB_RAM40_4K has none, so yosys ANDs each read
/// bit with the reset (registered once for the module): a LUT4 a bit,
/// unless the memory is depth-tiled, where the reset takes the spare
/// input of the tile-select multiplexer's LUT4 (measured: a 256 x 9 table
/// 9 LUT4s, the 4096-entry tables of the default widths none).
pub fn read_reset(target: Target, depth: u64, width: u64, ports: MemPorts) -> Resources {
    let m = map_memory(target, depth, width, ports);
    if target != Target::Ice40 || m.kind != MemKind::Block {
        return Resources::default();
    }
    let reads = match ports {
        MemPorts::Sdp => 1,
        MemPorts::DualRead | MemPorts::WriteTwoReads => 2,
    };
    let one = if ports == MemPorts::WriteTwoReads {
        MemPorts::Sdp
    } else {
        ports
    };
    let (_, _, deep, _) = best_block(target, depth, width, one);
    if deep > 1 {
        Resources::default()
    } else {
        Resources::luts(reads * width)
    }
}

pub fn map_memory(target: Target, depth: u64, width: u64, ports: MemPorts) -> MemMap {
    if ports == MemPorts::WriteTwoReads {
        let one = map_memory(target, depth, width, MemPorts::Sdp);
        return MemMap {
            cells: 2 * one.cells,
            res: one.res * 2,
            ..one
        };
    }
    if depth == 0 || width == 0 {
        return MemMap {
            kind: MemKind::Registers,
            cells: 0,
            res: Resources::default(),
        };
    }
    let block = block_map(target, depth, width, ports);
    let block_cost_total = block.res.bram * block_cost(target);
    if let Some((cost, lut)) = lutram_map(target, depth, width, ports) {
        // memory_libmap keeps LUT-RAM on a tie.
        if cost <= block_cost_total {
            return lut;
        }
    }
    if target == Target::Ice40 {
        let bits = depth * width;
        if bits < block_cost_total {
            // Registers: one flip-flop per bit plus the read registers, and
            // a read mux of LUT4s per read port.
            let reads = match ports {
                MemPorts::Sdp => 1,
                MemPorts::DualRead | MemPorts::WriteTwoReads => 2,
            };
            return MemMap {
                kind: MemKind::Registers,
                cells: bits,
                res: Resources {
                    lut: reads * width * mux_luts(target, depth) + depth,
                    ff: bits + reads * width,
                    ..Resources::default()
                },
            };
        }
    }
    block
}

#[cfg(test)]
mod tests {
    use super::*;

    fn bram(t: Target, d: u64, w: u64, p: MemPorts) -> (MemKind, u64) {
        let m = map_memory(t, d, w, p);
        (m.kind, m.res.bram)
    }

    /// Mappings yosys 0.23 chose for these shapes (block units: RAMB18
    /// equivalents on xc7).
    #[test]
    fn matches_yosys_choices() {
        use MemKind::*;
        use MemPorts::*;
        // The known figure: 1K x 16 is one RAMB18E1.
        assert_eq!(bram(Target::Xc7, 1024, 16, Sdp), (Block, 1));
        assert_eq!(bram(Target::Xc7, 4096, 39, DualRead), (Block, 10));
        assert_eq!(bram(Target::Xc7, 4096, 12, Sdp), (Block, 3));
        assert_eq!(bram(Target::Xc7, 1025, 16, Sdp), (Block, 2));
        assert_eq!(bram(Target::Xc7, 513, 90, Sdp), (Block, 5));
        assert_eq!(bram(Target::Xc7, 256, 16, Sdp), (Block, 1));
        assert_eq!(bram(Target::Xc7, 128, 16, Sdp).0, LutRam);
        assert_eq!(bram(Target::Xc7, 64, 80, Sdp).0, LutRam);
        assert_eq!(bram(Target::Xc7, 128, 64, Sdp), (Block, 2));
        assert_eq!(bram(Target::Xc7, 256, 64, DualRead), (Block, 4));
        assert_eq!(bram(Target::Ice40, 1024, 16, Sdp), (Block, 4));
        assert_eq!(bram(Target::Ice40, 1024, 16, DualRead), (Block, 8));
        assert_eq!(bram(Target::Ice40, 4096, 39, Sdp), (Block, 39));
        assert_eq!(bram(Target::Ice40, 256, 35, DualRead), (Block, 6));
        assert_eq!(bram(Target::Ice40, 1025, 16, Sdp), (Block, 5));
        assert_eq!(bram(Target::Ice40, 513, 90, Sdp), (Block, 17));
        assert_eq!(bram(Target::Ice40, 8, 20, DualRead).0, Registers);
        assert_eq!(bram(Target::Ecp5, 4096, 39, DualRead), (Block, 10));
        assert_eq!(bram(Target::Ecp5, 64, 16, Sdp).0, LutRam);
        assert_eq!(bram(Target::Ecp5, 128, 16, Sdp), (Block, 1));
        // The xc7 LUT-RAM shapes: RAM64M x 27 for 64 x 80.
        assert_eq!(map_memory(Target::Xc7, 64, 80, Sdp).cells, 27);
        assert_eq!(map_memory(Target::Xc7, 16, 64, Sdp).cells, 11);
    }
}
