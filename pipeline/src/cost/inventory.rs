//! The hardware of one PE, and of the controller, as a list of units at
//! the configured widths, for a volume of given (view-space) dimensions
//! split over `P` PEs.
//!
//! The datapath follows `crate::datapath` step by step (one sample per
//! clock, fully pipelined): ray position and slope `A + m t`, address and
//! weight, bilinear interpolation, classification, path length (two
//! squares, a sum, a square root), opacity correction (log table, multiply,
//! interpolated exp table, shift, `1 - T`) and compositing, then the
//! Bartlett merge unit. Stage timing is as soon as possible, one clock per
//! unit and one per square-root bit; values that skip stages travel in
//! delay lines, whose length the schedule gives.
//!
//! Memories, sized for the worst view (what the hardware must hold, not
//! one frame's needs):
//!
//! - **slice buffer**: the PE's `W = ceil(nx / P)` columns of one slice,
//!   `W x ny` voxels, double-buffered (one slice is sampled while the next
//!   loads from external memory) and split by row parity so the four
//!   bilinear taps (rows `y0`, `y0 + 1`, columns `c0`, `c0 + 1`) are two
//!   reads of each bank;
//! - **edge column**: a copy of the block's first column, which the left
//!   neighbour reads every cycle (two rows), also double-buffered;
//! - **compositing buffer**: the accumulators of every ray the PE holds,
//!   at most `(2W + 1) (2 ny + 1)` (rays are between half a voxel and a
//!   voxel apart in every slice of their region), in two banks by ray
//!   column parity so the merge reads both new parents of a child in one
//!   cycle; children overwrite their centre parent's slot, which the y pass
//!   no longer needs;
//! - **occupancy memory**: per column slot of the compositing buffer,
//!   whether it holds a ray column and its index `m` (the model's
//!   `VecDeque` of held columns);
//! - **line buffer**: three rows of x-merged children (`W + 1` each) for
//!   the merge's y pass;
//! - **migration FIFOs**: one ray column arriving from each side;
//! - the three **tables** (classification, `-log2(1 - a)`, `2^-f`), loaded
//!   by the host between frames.
//!
//! Voxel memory (all `W x ny x nz` voxels of the PE's block) is external:
//! at 128^3 and beyond it is megabits per PE, far beyond on-chip RAM. The
//! throughput model charges its bandwidth instead.

use super::arch;
use super::memory::MemPorts;
use super::shapes::{
    accum_word, class_weight, exp_weight, table_word, Lerp, MulAdd, Quantizer, Word, RAY_INDEX_BITS,
};
use super::target::{Resources, Target};
use super::units::{total, Unit};
use crate::config::{PipelineConfig, RayBuffer};
use serde::Serialize;

/// One line of the inventory: `count` copies of a group of units.
#[derive(Debug, Clone, Serialize)]
pub struct Item {
    /// Pipeline stage or block: position, interpolation, ...
    pub group: &'static str,
    /// What the units do.
    pub name: String,
    /// Copies.
    pub count: u32,
    /// The units of one copy.
    pub units: Vec<Unit>,
}

impl Item {
    pub(super) fn new(
        group: &'static str,
        name: impl Into<String>,
        count: u32,
        units: Vec<Unit>,
    ) -> Item {
        Item {
            group,
            name: name.into(),
            count,
            units,
        }
    }

    /// Resources of all copies on `t`.
    pub fn cost(&self, t: Target) -> Resources {
        total(t, &self.units) * u64::from(self.count)
    }

    /// The widths, for the report: the memory or multiplier if there is
    /// one, a summary of delay lines, or the first unit and how many more.
    pub fn shape(&self) -> String {
        let find = |f: fn(&Unit) -> bool| self.units.iter().find(|u| f(u));
        if let Some(u) = find(|u| matches!(u, Unit::Mem { .. }))
            .or_else(|| find(|u| matches!(u, Unit::Mul { .. })))
        {
            return u.shape();
        }
        if !self.units.is_empty() && self.units.iter().all(|u| matches!(u, Unit::Delay { .. })) {
            let bit_clocks: u32 = self
                .units
                .iter()
                .map(|u| match u {
                    Unit::Delay { bits, cycles } => bits * cycles,
                    _ => 0,
                })
                .sum();
            return format!("{} lines, {bit_clocks} bit-clocks", self.units.len());
        }
        let logic: Vec<&Unit> = self
            .units
            .iter()
            .filter(|u| !matches!(u, Unit::Reg { .. }))
            .collect();
        match logic.as_slice() {
            [] => self.units.first().map(Unit::shape).unwrap_or_default(),
            [one] => one.shape(),
            [first, rest @ ..] => format!("{} +{}", first.shape(), rest.len()),
        }
    }
}

/// The array's geometry: view-space volume dimensions, PE count and the
/// view's regions.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub struct Geometry {
    /// View-space dimensions `[nx, ny, nz]` (x across the PEs, z along
    /// the principal axis).
    pub dims: [usize; 3],
    /// PEs.
    pub pes: u16,
    /// Exponential regions `K` of the view (front to back keeps the final
    /// states of `K - 1` boundaries for the fold).
    pub regions: u32,
    /// The PEs carry the gradient and shading unit ([`super::shading`]).
    #[serde(default)]
    pub shading: bool,
    /// The PEs carry the volume-of-interest stage ([`super::voi`]).
    #[serde(default)]
    pub voi: bool,
}

impl Geometry {
    /// The geometry of `pes` PEs for a volume of `dims` seen from half its
    /// depth in front (the eye the report's tables assume).
    pub fn new(dims: [usize; 3], pes: u16) -> Geometry {
        let d = (dims[2] as f64 / 2.0).max(golden::geometry::MIN_D);
        Geometry {
            dims,
            pes,
            regions: golden::geometry::Regions::new(d, dims[2]).count() as u32,
            shading: false,
            voi: false,
        }
    }

    /// This geometry with (or without) the gradient and shading unit.
    pub fn with_shading(self, shading: bool) -> Geometry {
        Geometry { shading, ..self }
    }

    /// This geometry with (or without) the volume-of-interest stage.
    pub fn with_voi(self, voi: bool) -> Geometry {
        Geometry { voi, ..self }
    }

    /// Columns per PE, `W = ceil(nx / P)`.
    pub fn block(&self) -> u64 {
        (self.dims[0] as u64).div_ceil(u64::from(self.pes.max(1)))
    }

    /// Rays a PE may hold: `(2W + 1) (2 ny + 1)`.
    pub fn rays_per_pe(&self) -> u64 {
        (2 * self.block() + 1) * (2 * self.dims[1] as u64 + 1)
    }
}

/// `ceil(log2(n))`, at least 1.
pub fn addr_bits(n: u64) -> u32 {
    (64 - n.saturating_sub(1).leading_zeros()).max(1)
}

fn fmt_bits(f: crate::fixed::Format) -> u32 {
    u32::from(f.bits())
}

/// An ASAP schedule of the sample pipeline: when each step starts, and
/// the delay lines that bring values to later steps.
#[derive(Debug, Clone, Serialize)]
pub struct Schedule {
    /// Clock at which each step starts, in pipeline order.
    pub steps: Vec<(String, u32)>,
    /// Pipeline depth: clocks from the ray slot read to the accumulator
    /// write.
    pub depth: u32,
    /// Delay lines: `(value, bits, clocks)`.
    pub delays: Vec<(String, u32, u32)>,
}

/// One pipeline step: its name, the steps it needs with the bits each
/// brings, and its latency in clocks.
pub(super) type Step<'a> = (&'a str, Vec<(&'a str, u32)>, u32);

/// Per-PE datapath: the steps of one sample, their units, and the
/// schedule.
struct Datapath {
    items: Vec<Item>,
    schedule: Schedule,
}

fn datapath(cfg: &PipelineConfig, geo: &Geometry) -> Datapath {
    let pos = Word::from(cfg.position);
    let step = Word::from(cfg.step);
    let m = Word::signed(RAY_INDEX_BITS, 0);
    let (pn, v, wt, sm) = (
        fmt_bits(cfg.position),
        fmt_bits(cfg.voxel),
        fmt_bits(cfg.weight),
        fmt_bits(cfg.sample),
    );
    let (c, al, pa, lt, oc) = (
        fmt_bits(cfg.color),
        fmt_bits(cfg.alpha),
        fmt_bits(cfg.path),
        fmt_bits(cfg.log_transmittance),
        fmt_bits(cfg.opacity_corr),
    );
    let w = geo.block();
    let col_bits = addr_bits(w + 1);
    let slot_bits = addr_bits(arch::slots(cfg, geo));
    let int_bits = pos.int_bits().max(1) as u32;
    let e = u32::from(cfg.exp_table_bits);
    let entry_bits = addr_bits(u64::from(cfg.table_entries));

    let mut items = Vec::new();
    // Position and slope of the ray on x: the same multiply-add shape.
    let xpos = MulAdd::new(pos, m, step, cfg.position);
    let mut u = xpos.units();
    u.push(Unit::Reg { bits: pn });
    items.push(Item::new("position", "ray x: A + m t", 1, u.clone()));
    items.push(Item::new("position", "slope x: b + m k", 1, u));
    // The row's schedule: is the held ray's index inside the broadcast run
    // (empty-space skipping), and is its termination flag clear.
    items.push(Item::new(
        "position",
        "schedule: ray index in run",
        1,
        vec![
            Unit::Cmp {
                width: RAY_INDEX_BITS,
            },
            Unit::Cmp {
                width: RAY_INDEX_BITS,
            },
        ],
    ));
    // Address: floor(x) clamped into the volume (two compares and a mux
    // per tap), the right tap one column on, the local column in the
    // block, whether it is the neighbour's edge column; the weight is the
    // position's top fraction wires.
    let mut u = vec![
        Unit::Cmp { width: int_bits },
        Unit::Cmp { width: int_bits },
        Unit::Inc { width: int_bits },
        Unit::Mux {
            width: col_bits,
            inputs: 3,
        },
        Unit::Mux {
            width: col_bits,
            inputs: 3,
        },
        Unit::Sub { width: col_bits },
        Unit::Cmp { width: col_bits },
    ];
    let weight_q = Quantizer::new(
        Word::unsigned(
            u32::from(cfg.position.frac()),
            i32::from(cfg.position.frac()),
        ),
        cfg.weight,
    );
    u.extend(weight_q.units());
    u.push(Unit::Reg {
        bits: 2 * col_bits + wt + 1,
    });
    items.push(Item::new("position", "address and weight", 1, u));

    // Bilinear interpolation.
    let lx = Lerp::new(
        cfg.voxel.into(),
        Some(cfg.voxel.into()),
        cfg.weight.into(),
        cfg.sample,
    );
    let ly = Lerp::new(
        cfg.sample.into(),
        Some(cfg.sample.into()),
        cfg.weight.into(),
        cfg.sample,
    );
    let mut u = lx.units();
    u.push(Unit::Reg { bits: sm });
    items.push(Item::new("interpolation", "x lerp (rows y0, y0+1)", 2, u));
    // The y weight is the PE's copy of the row broadcast, feeding only
    // the multiplier.
    let mut u = ly.units_with_weight_register();
    u.push(Unit::Reg { bits: sm });
    items.push(Item::new("interpolation", "y lerp", 1, u));

    // Classification.
    let cw = class_weight(cfg);
    let cw_bits = cw.map(|x| x.bits).unwrap_or(0);
    let sample_int = u32::from(cfg.sample.int_bits());
    let mut u = vec![
        Unit::Cmp {
            width: sample_int.max(entry_bits),
        },
        Unit::Inc { width: entry_bits },
        Unit::Mux {
            width: entry_bits,
            inputs: 2,
        },
    ];
    u.push(Unit::Reg {
        bits: 2 * entry_bits + cw_bits,
    });
    items.push(Item::new("classification", "table position", 1, u));
    if let Some(cw) = cw {
        let lc = Lerp::new(cfg.color.into(), Some(cfg.color.into()), cw, cfg.color);
        let la = Lerp::new(cfg.alpha.into(), Some(cfg.alpha.into()), cw, cfg.alpha);
        let mut u = lc.units();
        u.push(Unit::Reg { bits: c });
        items.push(Item::new("classification", "colour lerp (R, G, B)", 3, u));
        let mut u = la.units();
        u.push(Unit::Reg { bits: al });
        items.push(Item::new("classification", "opacity lerp", 1, u));
    } else {
        items.push(Item::new(
            "classification",
            "entry register (no interpolation)",
            1,
            vec![Unit::Reg { bits: 3 * c + al }],
        ));
    }
    items.push(Item::new(
        "classification",
        "opacity != 0",
        1,
        vec![Unit::Reduce { width: al }, Unit::Reg { bits: 1 }],
    ));

    // Path length: sx^2 + sy^2 + sz^2 (sz^2 is a region constant from the
    // controller), then an integer square root into `path`.
    items.push(Item::new(
        "path length",
        "slope squares sx^2, sy^2",
        2,
        vec![Unit::Mul {
            a: pn,
            a_signed: true,
            b: pn,
            b_signed: true,
            y: 2 * pn,
            post_add: None,
            registered: true,
            operand_reg: 0,
        }],
    ));
    let sum_bits = 2 * pn + 2;
    items.push(Item::new(
        "path length",
        "sum of squares",
        1,
        vec![
            Unit::Add { width: 2 * pn },
            Unit::Add { width: 2 * pn + 1 },
            Unit::Reg { bits: sum_bits },
        ],
    ));
    let pf = i32::from(cfg.path.frac());
    let shift = 2 * pf - 2 * i32::from(cfg.position.frac());
    let radicand = (sum_bits as i32 + shift).max(2) as u32;
    let full_root = radicand.div_ceil(2);
    let root = full_root.min(pa);
    let mut u = vec![Unit::Sqrt { root }];
    if full_root > pa {
        // Radicands of 2^(2 pa) and up saturate instead of widening the root.
        u.push(Unit::Reduce {
            width: radicand - 2 * pa,
        });
        u.push(Unit::Mux {
            width: pa,
            inputs: 2,
        });
    }
    u.push(Unit::Reg { bits: pa });
    items.push(Item::new("path length", "square root", 1, u));

    // Opacity correction.
    let lp = Quantizer::new(
        Word::unsigned(lt + pa, i32::from(cfg.log_transmittance.frac()) + pf),
        cfg.log_transmittance,
    );
    let mut u = vec![Unit::Mul {
        a: lt,
        a_signed: false,
        b: pa,
        b_signed: false,
        y: lt + pa,
        post_add: None,
        registered: false,
        operand_reg: 0,
    }];
    u.extend(lp.units());
    u.push(Unit::Inc { width: e });
    u.push(Unit::Reg { bits: lt });
    items.push(Item::new("opacity", "p = -log2(1 - a) ds", 1, u));
    let ew = exp_weight(cfg);
    if let Some(ew) = ew {
        let le = Lerp::new(
            cfg.opacity_corr.into(),
            Some(cfg.opacity_corr.into()),
            ew,
            cfg.opacity_corr,
        );
        let mut u = le.units();
        u.push(Unit::Reg { bits: oc });
        items.push(Item::new("opacity", "exp lerp 2^-frac(p)", 1, u));
    }
    let lt_int = u32::from(cfg.log_transmittance.int_bits());
    let amount = lt_int.min(addr_bits(u64::from(oc) + 1));
    let sq = Quantizer::new(
        Word::unsigned(oc + 1, i32::from(cfg.opacity_corr.frac()) + 1),
        cfg.opacity_corr,
    );
    let mut u = vec![
        Unit::Shift {
            width: oc + 1,
            amount,
        },
        Unit::Cmp { width: lt_int },
    ];
    u.extend(sq.units());
    u.push(Unit::Reg { bits: oc });
    items.push(Item::new("opacity", "T = 2^-frac >> int(p)", 1, u));
    let om = Quantizer::new(
        Word::signed(oc + 1, i32::from(cfg.opacity_corr.frac())),
        cfg.opacity_corr,
    );
    let mut u = vec![Unit::Sub { width: oc }];
    u.extend(om.units());
    u.push(Unit::Reg { bits: oc });
    items.push(Item::new("opacity", "a' = 1 - T", 1, u));

    // Compositing: C + a (c - C) per colour, A + a (1 - A); the result is
    // written straight into the compositing buffer.
    let lcomp = Lerp::new(
        cfg.accum_color.into(),
        Some(cfg.color.into()),
        cfg.opacity_corr.into(),
        cfg.accum_color,
    );
    let lalpha = Lerp::new(
        cfg.accum_alpha.into(),
        None,
        cfg.opacity_corr.into(),
        cfg.accum_alpha,
    );
    items.push(Item::new(
        "compositing",
        "colour: C + a (c - C)",
        3,
        lcomp.units(),
    ));
    items.push(Item::new(
        "compositing",
        "opacity: A + a (1 - A)",
        1,
        lalpha.units(),
    ));

    // Schedule: (step, dependencies with the bits each brings, latency).
    let root_lat = root.max(1);
    let mut steps: Vec<Step> = vec![
        ("slot", vec![], 1),
        ("x", vec![("slot", RAY_INDEX_BITS)], 1),
        ("sx", vec![("slot", RAY_INDEX_BITS)], 1),
        ("address", vec![("x", pn)], 1),
        ("voxels", vec![("address", 2 * col_bits)], 1),
        ("x lerp", vec![("voxels", 4 * v), ("address", wt)], 1),
        ("y lerp", vec![("x lerp", 2 * sm)], 1),
        ("table position", vec![("y lerp", sm)], 1),
        ("table", vec![("table position", 2 * entry_bits)], 1),
        (
            "class lerp",
            vec![("table", 2 * table_word(cfg)), ("table position", cw_bits)],
            1,
        ),
        ("log table", vec![("class lerp", al)], 1),
        ("squares", vec![("sx", pn)], 1),
        ("sum", vec![("squares", 4 * pn)], 1),
        ("sqrt", vec![("sum", sum_bits)], root_lat),
        ("p", vec![("log table", lt), ("sqrt", pa)], 1),
        ("exp table", vec![("p", e)], 1),
        (
            "exp lerp",
            vec![
                ("exp table", 2 * oc),
                ("p", ew.map(|x| x.bits).unwrap_or(0)),
            ],
            1,
        ),
        ("shift", vec![("exp lerp", oc), ("p", lt_int)], 1),
        ("1 - T", vec![("shift", oc)], 1),
        (
            "composite",
            vec![
                ("1 - T", oc),
                ("class lerp", 3 * c + 1),
                ("slot", slot_bits),
            ],
            1,
        ),
    ];
    if geo.shading {
        items.extend(super::shading::items(cfg));
        // The opacity correction reads the gradient-modulated opacity and
        // the compositing the shaded colour.
        for st in steps.iter_mut() {
            for dep in st.1.iter_mut() {
                if st.0 == "log table" && dep.0 == "class lerp" {
                    dep.0 = "gradient opacity";
                }
                if st.0 == "composite" && dep.0 == "class lerp" {
                    dep.0 = "shade";
                }
            }
        }
        let at = steps
            .iter()
            .position(|st| st.0 == "log table")
            .unwrap_or(steps.len());
        let extra = super::shading::steps(cfg, col_bits);
        steps.splice(at..at, extra);
    }
    if geo.voi {
        items.extend(super::voi::items(cfg));
        // Golden scales the classified opacity before the shading's
        // gradient opacity and the correction: whichever read it reads
        // the scaled one.
        let reader = if geo.shading {
            "gradient opacity"
        } else {
            "log table"
        };
        for st in steps.iter_mut().filter(|st| st.0 == reader) {
            for dep in st.1.iter_mut().filter(|d| d.0 == "class lerp") {
                dep.0 = "voi opacity";
            }
        }
        let at = steps
            .iter()
            .position(|st| st.0 == "class lerp")
            .map_or(steps.len(), |i| i + 1);
        steps.splice(at..at, super::voi::steps(cfg));
    }
    let mut start: Vec<(String, u32, u32)> = Vec::new(); // name, start, ready
    let mut delays = Vec::new();
    for (name, deps, lat) in &steps {
        let s = deps
            .iter()
            .filter_map(|(d, _)| start.iter().find(|x| x.0 == *d).map(|x| x.2))
            .max()
            .unwrap_or(0);
        for (d, bits) in deps {
            if let Some(p) = start.iter().find(|x| x.0 == *d) {
                let gap = s - p.2;
                if gap > 0 && *bits > 0 {
                    delays.push((format!("{d} -> {name}"), *bits, gap));
                }
            }
        }
        start.push(((*name).to_owned(), s, s + lat));
    }
    let depth = start.last().map(|x| x.2).unwrap_or(0);
    let delay_units: Vec<Unit> = delays
        .iter()
        .map(|(_, bits, cycles)| Unit::Delay {
            bits: *bits,
            cycles: *cycles,
        })
        .collect();
    items.push(Item::new(
        "pipeline",
        "delay lines (schedule)",
        1,
        delay_units,
    ));
    Datapath {
        items,
        schedule: Schedule {
            steps: start.into_iter().map(|(n, s, _)| (n, s)).collect(),
            depth,
            delays,
        },
    }
}

/// The sample datapath's scheduled depth for `cfg`'s widths: the
/// datapath part of [`pe_inventory`] alone (the depth depends on the widths
/// only, so any geometry gives the same).
pub fn schedule_depth(cfg: &PipelineConfig) -> u32 {
    datapath(cfg, &Geometry::new([64, 64, 64], cfg.pes))
        .schedule
        .depth
}

/// [`schedule_depth`] with the gradient and shading unit (`shading`)
/// and the volume-of-interest stage (`voi`).
pub fn unit_schedule_depth(cfg: &PipelineConfig, (shading, voi): (bool, bool)) -> u32 {
    datapath(
        cfg,
        &Geometry::new([64, 64, 64], cfg.pes)
            .with_shading(shading)
            .with_voi(voi),
    )
    .schedule
    .depth
}

/// [`schedule_depth`] with the gradient and shading unit.
pub fn shaded_schedule_depth(cfg: &PipelineConfig) -> u32 {
    datapath(
        cfg,
        &Geometry::new([64, 64, 64], cfg.pes).with_shading(true),
    )
    .schedule
    .depth
}

/// The PE's memories.
fn memories(cfg: &PipelineConfig, geo: &Geometry) -> Vec<Item> {
    let [_, ny, _] = geo.dims;
    let ny = ny as u64;
    let w = geo.block();
    let v = fmt_bits(cfg.voxel);
    let acc = accum_word(cfg);
    let row_bits = addr_bits(2 * ny + 2);
    let mem = |depth: u64, width: u32, ports: MemPorts| Unit::Mem {
        depth,
        width,
        ports,
    };
    let half_rows = ny.div_ceil(2);
    // Round-robin mappings store each block with its apron and read no
    // neighbour: no edge-column copies.
    let round_robin = arch::round_robin_width(cfg).is_some();
    let stored = arch::stored_columns(cfg, geo);
    let buffers = if geo.shading {
        super::shading::memories(cfg, geo, stored, !round_robin)
    } else {
        let mut b = vec![Item::new(
            "memories",
            "slice buffer (2 slices x 2 row banks)",
            4,
            vec![mem(stored * half_rows, v, MemPorts::DualRead)],
        )];
        if !round_robin {
            b.push(Item::new(
                "memories",
                "edge column (2 slices x 2 row banks)",
                4,
                vec![mem(half_rows, v, MemPorts::Sdp)],
            ));
        }
        b
    };
    let mut items = buffers;
    items.extend(vec![
        Item::new(
            "memories",
            "classification table",
            1,
            vec![mem(
                u64::from(cfg.table_entries),
                table_word(cfg),
                MemPorts::DualRead,
            )],
        ),
        Item::new(
            "memories",
            "-log2(1 - a) table",
            1,
            vec![mem(
                1u64 << cfg.alpha.bits(),
                fmt_bits(cfg.log_transmittance),
                MemPorts::Sdp,
            )],
        ),
        Item::new(
            "memories",
            "2^-f table",
            1,
            vec![mem(
                (1u64 << cfg.exp_table_bits) + 1,
                fmt_bits(cfg.opacity_corr),
                MemPorts::DualRead,
            )],
        ),
    ]);
    let rays = arch::rays_per_pe(cfg, geo);
    let row = arch::rays_per_row(cfg, geo);
    if cfg.ray_buffer == RayBuffer::External {
        // Every ray's state lives in DDR; the PE keeps the row it samples
        // and the rows the controller reads ahead (and writes back).
        let rows = arch::row_buffers(cfg);
        items.push(Item::new(
            "memories",
            format!("row buffers ({rows} rows x 2 column banks; rays in DDR)"),
            2,
            vec![mem(
                (rows * row).div_ceil(2),
                arch::ray_bits(cfg),
                MemPorts::Sdp,
            )],
        ));
    } else {
        items.push(Item::new(
            "memories",
            "compositing buffer (2 column banks)",
            2,
            vec![mem(rays.div_ceil(2), acc, MemPorts::Sdp)],
        ));
    }
    items.extend(vec![
        Item::new(
            "memories",
            "column map (slot -> ray column)",
            1,
            vec![mem(row, RAY_INDEX_BITS + 1, MemPorts::Sdp)],
        ),
        Item::new(
            "memories",
            "merge line buffer (3 rows)",
            3,
            vec![mem(w + 1, 4 * fmt_bits(cfg.merge), MemPorts::Sdp)],
        ),
        Item::new(
            "memories",
            "migration FIFO (one column per side)",
            2,
            vec![mem(
                2 * ny + 1,
                acc + RAY_INDEX_BITS + row_bits,
                MemPorts::Sdp,
            )],
        ),
    ]);
    if cfg.order == crate::config::Order::FrontToBack && cfg.ray_buffer == RayBuffer::OnChip {
        // Each ray also carries what it inherited at the split and its
        // termination flag; each PE keeps its rays' final states at every
        // split for the fold, about `(W + 1)(ny + 1)` per boundary. With
        // an external buffer both live in DDR (the row buffer carries the
        // inherited state and the flag: `arch::ray_bits`).
        items.push(Item::new(
            "memories",
            "inherited state + termination flag (front to back)",
            2,
            vec![mem(rays.div_ceil(2), acc + 1, MemPorts::Sdp)],
        ));
        items.push(Item::new(
            "memories",
            "kept final states, K - 1 boundaries (front to back)",
            1,
            vec![mem(
                (w + 1) * (ny + 1) * u64::from(geo.regions.saturating_sub(1)),
                acc,
                MemPorts::Sdp,
            )],
        ));
    }
    items.retain(|i| {
        !i.units
            .iter()
            .any(|u| matches!(u, Unit::Mem { depth: 0, .. }))
    });
    items
}

/// The merge unit: the x pass (a tent of three parents into `merge`) and
/// the y pass (a tent of three line-buffer rows back into the
/// accumulators), one child per clock.
fn merge_unit(cfg: &PipelineConfig) -> Vec<Item> {
    let acc_c = fmt_bits(cfg.accum_color);
    let acc_a = fmt_bits(cfg.accum_alpha);
    let mb = fmt_bits(cfg.merge);
    let tent = |from: crate::fixed::Format, to: crate::fixed::Format| {
        let fb = u32::from(from.bits());
        let q = Quantizer::new(Word::unsigned(fb + 2, i32::from(from.frac()) + 2), to);
        let mut u = vec![Unit::Add { width: fb }, Unit::Add { width: fb + 1 }];
        u.extend(q.units());
        u
    };
    let mut x = Vec::new();
    for _ in 0..3 {
        x.extend(tent(cfg.accum_color, cfg.merge));
    }
    x.extend(tent(cfg.accum_alpha, cfg.merge));
    x.push(Unit::Reg { bits: 4 * mb });
    // The previous child's right parent is the next child's left one.
    x.push(Unit::Reg {
        bits: 3 * acc_c + acc_a,
    });
    let mut y = Vec::new();
    for _ in 0..3 {
        y.extend(tent(cfg.merge, cfg.accum_color));
    }
    y.extend(tent(cfg.merge, cfg.accum_alpha));
    y.push(Unit::Reg {
        bits: 3 * acc_c + acc_a,
    });
    vec![
        Item::new("merge", "x pass (R, G, B, A tents)", 1, x),
        Item::new("merge", "y pass (R, G, B, A tents)", 1, y),
    ]
}

/// Ports to the neighbours, the PE's copy of the broadcast bus, and the
/// PE's counters.
fn links(cfg: &PipelineConfig, geo: &Geometry) -> Vec<Item> {
    let acc = accum_word(cfg);
    let ny = geo.dims[1] as u64;
    let row_bits = addr_bits(2 * ny + 2);
    let pn = fmt_bits(cfg.position);
    let s = fmt_bits(cfg.step);
    let col_bits = addr_bits(geo.block() + 1);
    let slot_bits = addr_bits(arch::slots(cfg, geo));
    let mut items = vec![
        Item::new(
            "links",
            "ray ports (left, right): accumulators, m, row, valid",
            2,
            vec![Unit::Reg {
                bits: acc + RAY_INDEX_BITS + row_bits + 1,
            }],
        ),
        Item::new(
            "links",
            "merge edge-ray ports (left, right)",
            2,
            vec![Unit::Reg { bits: acc }],
        ),
        Item::new(
            "links",
            "broadcast copy: A, t, b, k, sy, sz^2, rows",
            1,
            vec![Unit::Reg {
                bits: 3 * pn + 2 * s + 2 * pn + 2 * row_bits,
            }],
        ),
        Item::new(
            "control",
            "counters: column, row, slot",
            1,
            vec![
                Unit::Inc { width: col_bits },
                Unit::Inc { width: row_bits },
                Unit::Inc { width: slot_bits },
                Unit::Cmp { width: col_bits },
                Unit::Cmp { width: row_bits },
                Unit::Reg {
                    bits: col_bits + row_bits + slot_bits,
                },
            ],
        ),
    ];
    if arch::round_robin_width(cfg).is_none() {
        // Column blocks read the right neighbour's first column while
        // sampling (round-robin blocks carry their aprons instead).
        items.insert(
            1,
            Item::new(
                "links",
                "edge voxel port (two rows)",
                1,
                vec![Unit::Reg {
                    bits: 2 * fmt_bits(cfg.voxel),
                }],
            ),
        );
        if geo.shading {
            items.push(super::shading::link(cfg));
        }
    }
    items.extend(arch::owner_logic(cfg));
    items.extend(arch::lane_ports(cfg, geo));
    items.extend(arch::valid_bits(cfg, geo));
    items
}

/// Everything in one PE.
#[derive(Debug, Clone, Serialize)]
pub struct PeInventory {
    /// The geometry it was sized for.
    pub geometry: Geometry,
    /// Units, memories and registers.
    pub items: Vec<Item>,
    /// The sample pipeline's schedule.
    pub schedule: Schedule,
    /// Bits of external voxel memory behind this PE: `W x ny x nz` voxels.
    pub voxel_memory_bits: u64,
}

impl PeInventory {
    /// One PE's resources on `t`.
    pub fn cost(&self, t: Target) -> Resources {
        self.items.iter().map(|i| i.cost(t)).sum()
    }
}

/// The PE for `cfg` in an array of `geo`.
pub fn pe_inventory(cfg: &PipelineConfig, geo: &Geometry) -> PeInventory {
    let dp = datapath(cfg, geo);
    let mut items = dp.items;
    items.extend(merge_unit(cfg));
    items.extend(memories(cfg, geo));
    items.extend(links(cfg, geo));
    let [_, ny, nz] = geo.dims;
    PeInventory {
        geometry: *geo,
        items,
        schedule: dp.schedule,
        voxel_memory_bits: arch::stored_columns(cfg, geo)
            * ny as u64
            * nz as u64
            * u64::from(cfg.voxel.bits()),
    }
}

/// The controller, once per array: per row it computes the y position,
/// address, weight and slope the PEs share, and it holds the broadcast
/// registers. The host computes the per-slice and per-region constants.
pub fn controller_inventory(cfg: &PipelineConfig, geo: &Geometry) -> Vec<Item> {
    let pos = Word::from(cfg.position);
    let m = Word::signed(RAY_INDEX_BITS, 0);
    let ypos = MulAdd::new(pos, m, cfg.step.into(), cfg.position);
    let pn = fmt_bits(cfg.position);
    let s = fmt_bits(cfg.step);
    let row_bits = addr_bits(2 * geo.dims[1] as u64 + 2);
    let int_bits = pos.int_bits().max(1) as u32;
    let mut u = ypos.units();
    u.push(Unit::Reg { bits: pn });
    let mut addr = vec![
        Unit::Cmp { width: int_bits },
        Unit::Cmp { width: int_bits },
        Unit::Inc { width: int_bits },
    ];
    let weight_q = Quantizer::new(
        Word::unsigned(
            u32::from(cfg.position.frac()),
            i32::from(cfg.position.frac()),
        ),
        cfg.weight,
    );
    addr.extend(weight_q.units());
    addr.push(Unit::Reg {
        bits: 2 * row_bits + fmt_bits(cfg.weight),
    });
    // Empty-space skipping: one bit per block of the volume, and the row's
    // runs (a block edge's ray index, `(x_edge - A) / t`, as a multiply by
    // the host's `1 / t`, one edge per cycle while the previous row
    // samples).
    let b = u64::from(cfg.occupancy_block);
    let blocks: u64 = geo
        .dims
        .iter()
        .map(|&n| (n as u64).saturating_sub(1) / b + 1)
        .product();
    let runs = MulAdd::new(pos, pos, cfg.step.into(), cfg.position);
    let mut run_units = runs.units();
    run_units.push(Unit::Reg {
        bits: 2 * RAY_INDEX_BITS,
    });
    let mut items = vec![
        Item::new(
            "controller",
            "occupancy memory (1 bit per block)",
            1,
            vec![Unit::Mem {
                depth: blocks,
                width: 1,
                ports: MemPorts::Sdp,
            }],
        ),
        Item::new(
            "controller",
            "row runs: block edge to ray index",
            1,
            run_units,
        ),
        Item::new("controller", "row y: A + m t", 1, u.clone()),
        Item::new("controller", "row slope y: b + m k", 1, u),
        Item::new("controller", "row address and weight", 1, addr),
        Item::new(
            "controller",
            "broadcast registers: A, t, b, k, sz^2 (x and y)",
            1,
            vec![Unit::Reg {
                bits: 4 * pn + 4 * s + 2 * pn,
            }],
        ),
    ];
    items.extend(arch::wrap_link(cfg, geo));
    items.extend(arch::memory_controller(cfg));
    items
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn default_pe_on_xc7() {
        let cfg = PipelineConfig::default();
        let geo = Geometry::new([128, 128, 128], 16);
        let pe = pe_inventory(&cfg, &geo);
        let r = pe.cost(Target::Xc7);
        // 2 + 2 (ray and slope), 3 (bilinear), 4 (classification),
        // 2 x 4 (squares), 1 (log x path), 1 (exp lerp), 4 (compositing).
        assert_eq!(r.dsp, 25);
        assert!(r.bram > 0 && r.lut > 0 && r.ff > 0);
        assert!(pe.schedule.depth > 20, "{:?}", pe.schedule);
        assert_eq!(pe.voxel_memory_bits, 8 * 128 * 128 * 12);
    }
}
