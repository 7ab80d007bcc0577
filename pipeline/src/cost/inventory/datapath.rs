//! The sample datapath of one PE as units: the cost items of its
//! description, the sample with the configuration's units composed
//! ([`crate::hw::compose::sample`]), and of the PE's address and schedule
//! step around it ([`crate::hw::address`]); the pipeline registers the
//! composed module declares on its schedule ([`emitted`]), whose depth is
//! the datapath's latency ([`crate::cost::latency::sample_latency`]).

use super::{addr_bits, Geometry, Item};
use crate::config::PipelineConfig;
use crate::cost::units::Unit;
use serde::Serialize;

/// The sample pipeline's schedule as the inventory reports it: the
/// composed description's ([`crate::hw::schedule`], or the clock's
/// with `target_mhz`).
#[derive(Debug, Clone, Serialize)]
pub struct Schedule {
    /// Pipeline depth: clocks from the ray slot read to the accumulator
    /// write.
    pub depth: u32,
    /// Bits of the pipeline registers and delay lines the schedule adds
    /// ([`crate::hw::schedule::Schedule::register_bits`]).
    pub register_bits: u64,
}

/// Per-PE datapath: the items of its description, and the schedule.
pub(super) struct Datapath {
    pub(super) items: Vec<Item>,
    pub(super) schedule: Schedule,
}

/// The prefix of the sample stage's control items
/// ([`crate::cost::sample_stage::control_logic`]).
pub const SAMPLE_STAGE: &str = "sample stage: ";

pub(super) fn datapath(cfg: &PipelineConfig, geo: &Geometry) -> Datapath {
    let g = crate::hw::compose::sample(cfg, geo.units);
    let mut items = described_items(&g);
    if geo.units.shading() {
        items.extend(crate::cost::shading::table_item(&g));
    }
    // The PE's control around the module: the emitted sample stage's
    // statements where its shape is declared (else the described address
    // step's run compare and clamps), and the pre-integrated pass's ray
    // tests.
    let col_bits = addr_bits(geo.block() + 1);
    let address = described_items(&crate::hw::address::address(
        cfg,
        col_bits,
        geo.units.preint,
    ));
    match crate::hw::pe_sample_rtl::PeSampleShape::new(cfg, geo) {
        Ok(shape) => {
            let x0_bits = u32::from(cfg.position.bits() - cfg.position.frac()).max(1);
            items.extend(
                crate::cost::sample_stage::control_logic(&shape, x0_bits)
                    .into_iter()
                    .map(|(what, units)| {
                        Item::new("control", format!("{SAMPLE_STAGE}{what}"), 1, units)
                    }),
            );
            items.extend(
                address
                    .into_iter()
                    .filter(|it| it.name.starts_with("pre-integrated")),
            );
        }
        Err(_) => items.extend(address),
    }
    let sch = crate::cost::latency::graph_schedule(cfg, &g);
    // The composed module's registers, counted once: its items price
    // logic, multipliers and memories only.
    for it in items.iter_mut().filter(|it| in_module(it)) {
        it.registers_declared = true;
    }
    let (bits, dsp) = match emitted_graph(&g, &sch) {
        Some(e) => (e.register_bits - e.read_bits(), e.dsp_bits),
        // A rounding mode the Verilog does not emit: the schedule's own
        // registers and delay lines.
        None => (
            sch.register_bits,
            super::dsp_regs::dsp_register_bits(&g, &sch),
        ),
    };
    items.push(Item::new(
        "pipeline",
        PIPELINE_REGISTERS,
        1,
        vec![Unit::PipeReg {
            bits: bits as u32,
            dsp: dsp as u32,
        }],
    ));
    Datapath {
        items,
        schedule: Schedule {
            depth: sch.depth.max(1),
            register_bits: sch.register_bits,
        },
    }
}

/// The name of the emitted datapath's register item.
pub const PIPELINE_REGISTERS: &str =
    "pipeline registers (emitted: stages, ports carried, valid bits, outputs)";

/// The groups of the composed sample's items
/// ([`crate::hw::compose::sample`]): the plain sample's and its units'.
const MODULE_GROUPS: [&str; 10] = [
    "position",
    "interpolation",
    "classification",
    "path length",
    "opacity",
    "compositing",
    "gradient",
    "shading",
    "voi",
    "preint",
];

/// Whether an inventory item is logic of the emitted sample datapath
/// (`hw::pipeline_rtl` of [`crate::hw::compose::sample`]): not the
/// units' tables (memory items) nor the PE's address step and pass tests
/// ([`crate::hw::address`]) around it.
pub fn in_module(it: &Item) -> bool {
    MODULE_GROUPS.contains(&it.group) && !it.units.iter().any(|u| matches!(u, Unit::Mem { .. }))
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

/// The sample datapath with `geo`'s units as `ercube rtl` emits it on
/// the configuration's schedule; `None` for a configuration the Verilog
/// refuses (a rounding mode it does not emit).
pub(crate) fn emitted(cfg: &PipelineConfig, geo: &Geometry) -> Option<Emitted> {
    let g = crate::hw::compose::sample(cfg, geo.units);
    let s = crate::cost::latency::graph_schedule(cfg, &g);
    emitted_graph(&g, &s)
}

/// [`emitted`] of the composed graph `g` on its schedule `s`.
fn emitted_graph(g: &crate::hw::Graph, s: &crate::hw::schedule::Schedule) -> Option<Emitted> {
    let m = crate::hw::pipeline_rtl::emit_scheduled(g, s, crate::synth::DATAPATH).ok()?;
    Some(Emitted {
        register_bits: m.register_bits,
        tables: m.tables,
        dsp_bits: super::dsp_regs::dsp_register_bits(g, s),
    })
}

/// The cost items of a unit's description ([`crate::hw::units::items`]).
pub(crate) fn described_items(g: &crate::hw::Graph) -> Vec<Item> {
    crate::hw::units::items(g)
        .into_iter()
        .map(|it| Item::new(it.group, it.name, it.count, it.units))
        .collect()
}
