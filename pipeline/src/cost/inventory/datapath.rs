//! The sample datapath of one PE as units, step by step after
//! `crate::datapath` (one sample a clock, fully pipelined), and its
//! as-soon-as-possible schedule: when each step starts and the delay lines
//! that carry values to later steps (see the parent module).

use super::{addr_bits, fmt_bits, Geometry, Item};
use crate::config::PipelineConfig;
use crate::cost::arch;
use crate::cost::shapes::{
    class_weight, exp_weight, table_word, MulAdd, Quantizer, Word, RAY_INDEX_BITS,
};
use crate::cost::units::{MulShape, Unit};
use serde::Serialize;

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
pub(crate) type Step<'a> = (&'a str, Vec<(&'a str, u32)>, u32);

/// Per-PE datapath: the steps of one sample, their units, and the
/// schedule.
pub(super) struct Datapath {
    pub(super) items: Vec<Item>,
    pub(super) schedule: Schedule,
}

pub(super) fn datapath(cfg: &PipelineConfig, geo: &Geometry) -> Datapath {
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

    // Interpolation, classification (a pre-integrating PE classifies
    // whole steps in its unit instead: `crate::cost::preint`), the
    // opacity correction and the compositing: derived from the plain
    // sample's description (`crate::hw::sample`).
    let described = described_items(&crate::hw::sample::plain(cfg));
    let derived = |group: &'static str| {
        described
            .iter()
            .filter(move |it| it.group == group)
            .cloned()
    };
    items.extend(derived("interpolation"));
    let cw = class_weight(cfg);
    let cw_bits = cw.map(|x| x.bits).unwrap_or(0);
    if !geo.preint {
        items.extend(derived("classification"));
    }

    // Path length: sx^2 + sy^2 + sz^2, then an integer square root into
    // `path`.
    // The emitted module squares the slice's `sz` beside the ray's `sx`
    // and the row's `sy` (`hw::sample::plain`).
    items.push(Item::new(
        "path length",
        "slope squares sx^2, sy^2, sz^2",
        3,
        vec![Unit::Mul(MulShape {
            a: pn,
            a_signed: true,
            b: pn,
            b_signed: true,
            y: 2 * pn,
            post_add: None,
            registered: true,
            operand_reg: 0,
        })],
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

    // Opacity correction (the pre-integration unit makes `p` itself) and
    // compositing.
    let ew = exp_weight(cfg);
    let lt_int = u32::from(cfg.log_transmittance.int_bits());
    items.extend(derived("opacity").filter(|it| !(geo.preint && it.name == "p = -log2(1 - a) ds")));
    items.extend(derived("compositing"));

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
    if geo.preint {
        debug_assert!(
            !(geo.shading || geo.voi),
            "pre-integration is priced without the shading unit and the VOI stage"
        );
        // The unit's datapath from its description (its `2^-p` stage is
        // the opacity correction's, priced above), the pass's ray
        // selection from the controller's broadcast.
        items.extend(crate::cost::preint::control_items(cfg));
        items.extend(
            described_items(&crate::hw::preint::preint(cfg))
                .into_iter()
                .filter(|it| it.group == "preint"),
        );
        // The unit replaces the classification and the log table's
        // product; the exp stage reads its `p`, the compositing its colour
        // and keeps the sample as the ray's next back scalar.
        let replaced = ["table position", "table", "class lerp", "log table", "p"];
        steps.retain(|st| !replaced.contains(&st.0));
        for st in steps.iter_mut().filter(|st| st.0 == "composite") {
            for dep in st.1.iter_mut().filter(|d| d.0 == "class lerp") {
                dep.0 = "preint divide";
            }
            st.1.push(("y lerp", sm));
        }
        let at = steps
            .iter()
            .position(|st| st.0 == "exp table")
            .unwrap_or(steps.len());
        steps.splice(at..at, crate::cost::preint::steps(cfg));
    }
    if geo.shading {
        // Built for one light: each further light adds a dot product
        // pair, two dividers and a power-table read per sample.
        let g = crate::hw::shading::shading(cfg, 1);
        items.extend(described_items(&g));
        items.extend(crate::cost::shading::table_item(&g));
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
        let extra = crate::cost::shading::steps(cfg, col_bits);
        steps.splice(at..at, extra);
    }
    if geo.voi {
        items.extend(described_items(&crate::hw::voi::voi(cfg)));
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
        steps.splice(at..at, crate::cost::voi::steps(cfg));
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
    match emitted(cfg, geo) {
        Some(e) => {
            // The plain datapath is the emitted module: its registers are
            // the ones the module declares on its schedule.
            for it in items.iter_mut().filter(|it| in_module(it)) {
                it.registers_declared = true;
            }
            items.push(Item::new(
                "pipeline",
                PIPELINE_REGISTERS,
                1,
                vec![Unit::PipeReg {
                    bits: (e.register_bits - e.read_bits()) as u32,
                    dsp: e.dsp_bits as u32,
                }],
            ));
        }
        None => {
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
        }
    }
    Datapath {
        items,
        schedule: Schedule {
            steps: start.into_iter().map(|(n, s, _)| (n, s)).collect(),
            depth,
            delays,
        },
    }
}

/// The name of the emitted datapath's register item.
pub const PIPELINE_REGISTERS: &str =
    "pipeline registers (emitted: stages, ports carried, valid bits, outputs)";

/// The position items the emitted module holds (`x`, `sx`); the run
/// compare and the address clamps are the PE's, outside it.
const MODULE_POSITION: [&str; 2] = ["ray x: A + m t", "slope x: b + m k"];

/// Whether an inventory item is logic of the emitted sample datapath
/// (`hw::pipeline_rtl` of [`crate::hw::sample::plain`]).
pub fn in_module(it: &Item) -> bool {
    match it.group {
        "position" => MODULE_POSITION.contains(&it.name.as_str()),
        "interpolation" | "classification" | "path length" | "opacity" | "compositing" => true,
        _ => false,
    }
}

/// What the emitted sample datapath declares: its register bits and its
/// tables.
pub(crate) struct Emitted {
    /// Every register bit the module declares
    /// ([`crate::hw::pipeline_rtl::PipelinedModule::register_bits`]).
    pub(crate) register_bits: u64,
    /// The tables, with their read ports.
    pub(crate) tables: Vec<crate::hw::pipeline_rtl::Table>,
    /// Of the register bits, those DSP48E1s take in
    /// ([`super::dsp_regs::dsp_register_bits`]).
    pub(crate) dsp_bits: u64,
}

impl Emitted {
    /// Of the register bits, the tables' read-data registers (a block RAM
    /// takes them in; the memory model charges those it does not).
    pub(crate) fn read_bits(&self) -> u64 {
        self.tables
            .iter()
            .map(|t| u64::from(t.reads) * u64::from(t.bits))
            .sum()
    }
}

/// The plain sample datapath as `ercube rtl` emits it on the
/// configuration's schedule, for a PE without the shading unit, the VOI
/// stage or the pre-integration unit (those PEs are priced by the
/// inventory's steps and delay lines); `None` too for a configuration
/// the Verilog refuses (a rounding mode it does not emit).
pub(crate) fn emitted(cfg: &PipelineConfig, geo: &Geometry) -> Option<Emitted> {
    if geo.preint || geo.shading || geo.voi {
        return None;
    }
    let g = crate::hw::sample::plain(cfg);
    let s = crate::cost::latency::sample_schedule(cfg);
    let m = crate::hw::pipeline_rtl::emit_scheduled(&g, &s, crate::synth::DATAPATH).ok()?;
    Some(Emitted {
        register_bits: m.register_bits,
        tables: m.tables,
        dsp_bits: super::dsp_regs::dsp_register_bits(&g, &s),
    })
}

/// The cost items of a unit's description ([`crate::hw::units::items`]).
pub(crate) fn described_items(g: &crate::hw::Graph) -> Vec<Item> {
    crate::hw::units::items(g)
        .into_iter()
        .map(|it| Item::new(it.group, it.name, it.count, it.units))
        .collect()
}

/// The sample datapath's scheduled depth for `cfg`'s widths: the
/// datapath part of [`super::pe_inventory`] alone (the depth depends on the widths
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

/// [`schedule_depth`] with the pre-integration unit in place of the
/// classification and the log table's product ([`crate::cost::preint`]).
pub fn preint_schedule_depth(cfg: &PipelineConfig) -> u32 {
    datapath(cfg, &Geometry::new([64, 64, 64], cfg.pes).with_preint(true))
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
