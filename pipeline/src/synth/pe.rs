//! The PE's sample stage as one design for `ercube synth --pe`: the
//! emitted `ercube_pe_sample` (its control, voxel memory, compositing
//! buffer, column map, row plan with its plan port, termination bits)
//! around the pipelined sample datapath (`ercube_sample`, its tables
//! included), at the depths the PE declares for a view-space volume.
//!
//! It is what `ercube rtl` emits of the PE, not the whole PE: the
//! migration's link FIFOs and ports, the merge, split and fold with their
//! line buffer, and the readout's state machine (placed alone by
//! `--readout`) are not in it. Its estimate is `ercube cost`'s PE
//! inventory restricted to the items the module holds
//! ([`sample_stage_item`]), so the report compares like with like.

use super::DATAPATH;
use crate::config::PipelineConfig;
use crate::cost::inventory::{pe_inventory, Geometry, Item};
use crate::cost::{Resources, Target};
use crate::hw::pe_sample_rtl::{emit, PeSampleShape, MODULE};
use crate::rtl::CalibrationModule;

/// The inventory's memories the sample stage declares.
const MEMORIES: [&str; 5] = [
    "slice buffer",
    "edge column",
    "compositing buffer",
    "column map",
    "row plan",
];

/// The inventory's registers and control the sample stage declares.
const CONTROL: [&str; 5] = [
    crate::cost::inventory::SAMPLE_STAGE,
    "active columns",
    "row plan:",
    "edge register",
    "counters",
];

/// Whether `it` is held by the emitted sample stage: the datapath
/// ([`super::datapath_item`]), the PE's voxel and ray memories the stage
/// reads and writes, its run compare and address clamps, and its control
/// registers and counters. Not the merge, the link FIFOs, the ports, the
/// broadcast's copy (the stage takes the broadcast on its `bc_*` ports)
/// or the readout's registers.
pub fn sample_stage_item(it: &Item) -> bool {
    let named = |list: &[&str]| list.iter().any(|n| it.name.starts_with(n));
    super::datapath_item(it)
        || (it.group == "memories" && named(&MEMORIES))
        || (matches!(it.group, "address" | "registers" | "control") && named(&CONTROL))
}

/// The geometry the stage is declared for: `dims` over `cfg.pes` PEs.
fn geometry(cfg: &PipelineConfig, dims: [usize; 3]) -> Geometry {
    Geometry::new(dims, cfg.pes.max(1))
}

/// The estimate of the sample stage on `t`: the [`sample_stage_item`]s of
/// the PE's inventory for `dims` over `cfg.pes` PEs, with the control's
/// registers as the emitted module declares them (its delay lines, the
/// write-back address line, the plan FIFO's pointers) in place of the
/// PE's declared control registers, less the read registers its block
/// RAMs take in (the compositing buffer's two words, the four taps).
pub fn estimate(cfg: &PipelineConfig, dims: [usize; 3], t: Target) -> Resources {
    let inventory = pe_inventory(cfg, &geometry(cfg, dims));
    // Under column blocks a held column's slot is its index modulo the
    // slots: the stage keeps no column map (the readout's is its own).
    let blocks = !crate::mapping::ColumnMap::of(cfg, dims[0]).round_robin();
    let held = inventory
        .items
        .iter()
        .filter(|it| sample_stage_item(it) && !(blocks && it.name.starts_with("column map")));
    match emitted(cfg, dims) {
        Ok((shape, r, _)) => {
            let absorbed = 2 * u64::from(shape.rays.buffer_width) + 4 * u64::from(shape.voxel_bits);
            held.filter(|it| it.group != "registers")
                .map(|it| it.cost(t))
                .sum::<Resources>()
                + Resources::ffs(r.register_bits.saturating_sub(absorbed))
        }
        // No emitted stage: the PE's declared registers.
        Err(_) => held.map(|it| it.cost(t)).sum(),
    }
}

/// The predicted clock of the stage for `dims` over `cfg.pes` PEs on
/// `t`: the slowest of its datapath's slowest stage and its own paths,
/// the issue's pick and the tap address
/// ([`crate::cost::fmax::sample_stage_prediction`]).
pub fn predicted_mhz(cfg: &PipelineConfig, dims: [usize; 3], t: Target) -> Option<f64> {
    crate::cost::fmax::sample_stage_prediction(cfg, &geometry(cfg, dims), t).map(|p| p.mhz)
}

/// The emitted stage for `dims` over `cfg.pes` PEs: its shape, the
/// datapath module it instantiates and its own text.
fn emitted(
    cfg: &PipelineConfig,
    dims: [usize; 3],
) -> Result<
    (
        PeSampleShape,
        crate::hw::pe_sample_rtl::PeSampleRtl,
        crate::hw::pipeline_rtl::PipelinedModule,
    ),
    String,
> {
    let shape = PeSampleShape::new(cfg, &geometry(cfg, dims))?;
    let g = crate::hw::sample::plain(cfg);
    let s = crate::cost::latency::sample_schedule(cfg);
    let dp =
        crate::hw::pipeline_rtl::emit_scheduled(&g, &s, DATAPATH).map_err(|e| e.to_string())?;
    let r = emit(&shape, &dp)?;
    Ok((shape, r, dp))
}

/// The PE's sample stage for a view-space volume of `dims` over
/// `cfg.pes` PEs, with the datapath it instantiates, as one Verilog text
/// (module [`MODULE`]); its estimate is [`estimate`] (the `units` are
/// left empty, as for the datapath).
pub fn sample_stage(cfg: &PipelineConfig, dims: [usize; 3]) -> Result<CalibrationModule, String> {
    let (shape, r, dp) = emitted(cfg, dims)?;
    Ok(CalibrationModule {
        name: MODULE.to_owned(),
        description: format!(
            "the PE's sample stage for a {}x{}x{} volume over {} PEs ({} memory bits, {} control register bits, the datapath {} clocks); not the migration, merge, split, fold or readout",
            dims[0],
            dims[1],
            dims[2],
            cfg.pes.max(1),
            shape.memory_bits(),
            r.register_bits,
            dp.depth
        ),
        verilog: format!("{}\n{}", dp.verilog, r.verilog),
        units: Vec::new(),
    })
}

#[cfg(test)]
mod tests {
    use crate::cost::fmax::{pe_prediction, sample_stage_prediction};

    /// The stage's clock is at most its datapath's, and falls as the
    /// volume lengthens the stage's own paths (the issue's carry chain
    /// over the slots, the tap address's adders), which set it at 64^3.
    #[test]
    fn the_issue_path_bounds_the_stages_clock() {
        let cfg = PipelineConfig {
            pes: 2,
            ..PipelineConfig::default()
        };
        for t in [Target::Ecp5, Target::Ice40] {
            let dp = pe_prediction(&cfg, t).unwrap().mhz;
            let small = predicted_mhz(&cfg, [16, 16, 16], t).unwrap();
            let big = predicted_mhz(&cfg, [64, 64, 64], t).unwrap();
            eprintln!("{t:?}: datapath {dp:.1} MHz, 16^3 stage {small:.1}, 64^3 stage {big:.1}");
            assert!(small <= dp + 1e-9 && big <= small, "{dp} {small} {big}");
            let p = sample_stage_prediction(&cfg, &geometry(&cfg, [64, 64, 64]), t).unwrap();
            assert!(p.critical.starts_with("the sample stage's"), "{p:?}");
        }
    }

    use super::*;

    /// The issue's two clocks: the pick (from the plan's head register through
    /// the carry chain over the slots) is predicted slower than the
    /// buffer's address (from the registered pick), over volumes, PEs and
    /// mappings, so the pick is the path the stage's clock quotes.
    #[test]
    fn the_pick_is_the_issues_longer_path() {
        use crate::config::Mapping;
        use crate::cost::fmax::{address_path, issue_path, model};
        let mut checked = 0;
        for mapping in Mapping::ALL {
            for pes in [1u16, 2, 4, 16] {
                for n in [16, 32, 64, 128] {
                    let cfg = PipelineConfig {
                        pes,
                        mapping,
                        ..PipelineConfig::default()
                    };
                    let Ok(s) = PeSampleShape::new(&cfg, &geometry(&cfg, [n, n, n])) else {
                        continue;
                    };
                    for t in [Target::Ecp5, Target::Ice40] {
                        let m = model(t).unwrap();
                        let (pick, addr) =
                            (m.period_ns(&issue_path(&s)), m.period_ns(&address_path(&s)));
                        assert!(
                            pick > addr,
                            "{mapping:?}, {pes} PEs, {n}^3, {t:?}: pick {pick:.2} ns, address {addr:.2} ns"
                        );
                        checked += 1;
                    }
                }
            }
        }
        assert!(checked >= 48, "{checked} shapes");
    }

    #[test]
    fn the_sample_stage_holds_its_memories_and_not_the_merge() {
        let cfg = PipelineConfig::default();
        let inv = pe_inventory(&cfg, &geometry(&cfg, [32, 32, 32]));
        let held: Vec<String> = inv
            .items
            .iter()
            .filter(|it| sample_stage_item(it))
            .map(|it| format!("{}: {}", it.group, it.name))
            .collect();
        for m in MEMORIES {
            assert!(held.iter().any(|h| h.contains(m)), "{m} not held: {held:?}");
        }
        assert!(
            !held.iter().any(|h| h.starts_with("merge")
                || h.contains("link FIFO")
                || h.contains("readout")),
            "{held:?}"
        );
        for c in CONTROL {
            assert!(held.iter().any(|h| h.contains(c)), "{c} not held: {held:?}");
        }
        let m = sample_stage(&cfg, [32, 32, 32]).unwrap();
        assert!(
            m.verilog.contains(&format!("module {MODULE}"))
                && m.verilog.contains(&format!("module {DATAPATH}"))
        );
    }
}
