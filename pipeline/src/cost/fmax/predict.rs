//! The delay model applied: a calibration unit's clock from its slowest
//! path, every measured unit predicted against its measurement, and the
//! plain sample datapath's clock from its schedule's stages.

use serde::Serialize;

use super::path::{fabric, module_paths, unit_path, Path};
use super::{fit, model, routing, DelayModel, Measured, MEASURED};
use crate::config::PipelineConfig;
use crate::cost::dsp::{decompose, DspLimits};
use crate::cost::units::{MulShape, Unit};
use crate::cost::Target;

/// The clock `model` predicts for a calibration unit's units on `t`: its
/// slowest path of [`module_paths`], MHz.
pub fn module_mhz(model: &DelayModel, t: Target, units: &[Unit]) -> f64 {
    1e3 / module_paths(t, units)
        .iter()
        .map(|p| model.period_ns(p))
        .fold(model.base_ns, f64::max)
}

/// The clock of a calibration unit's units on `t` by the family's fitted
/// model (`None` without one: xc7), MHz.
pub fn unit_prediction(t: Target, units: &[Unit]) -> Option<f64> {
    Some(module_mhz(&model(t)?, t, units))
}

/// The predicted against the measured clock of one calibration unit.
#[derive(Debug, Clone, Serialize)]
pub struct UnitPrediction {
    /// The measurement.
    pub measured: Measured,
    /// The slowest of its paths by the model.
    pub path: Path,
    /// The model's clock for that path, MHz.
    pub predicted_mhz: f64,
}

impl UnitPrediction {
    /// `(predicted - measured) / measured`.
    pub fn error(&self) -> f64 {
        (self.predicted_mhz - self.measured.mhz) / self.measured.mhz
    }
}

/// Every measured unit of `t` (calibration and holdout settings),
/// predicted against measured.
pub fn unit_predictions(t: Target) -> Vec<UnitPrediction> {
    let Some(model) = model(t) else {
        return Vec::new();
    };
    MEASURED
        .iter()
        .filter(|m| m.target == t)
        .filter_map(|meas| {
            let units = meas.units()?;
            let path = fit::slowest(&model, &module_paths(t, &units));
            Some(UnitPrediction {
                measured: *meas,
                path,
                predicted_mhz: 1e3 / model.period_ns(&path).max(model.base_ns),
            })
        })
        .collect()
}

/// The path through node `id` of a scheduled graph: its units, except
/// that a multiplier ends at its block's output register (the schedule
/// puts the adder it feeds in the next stage) and that adder, fused into
/// the multiplier's units, is a carry chain of its own.
pub(super) fn node_path(
    t: Target,
    g: &crate::hw::Graph,
    id: crate::hw::NodeId,
    consumers: &[Vec<crate::hw::NodeId>],
) -> Path {
    use crate::hw::Op;
    let units = crate::hw::units::node_units(g, id, consumers);
    let node = g.node(id);
    match node.op {
        Op::Mul(..) => units
            .iter()
            .map(|u| match *u {
                Unit::Mul(MulShape {
                    a,
                    a_signed,
                    b,
                    b_signed,
                    y,
                    ..
                }) => {
                    let d = decompose(&DspLimits::of(t), a, a_signed, b, b_signed, y);
                    Path {
                        blocks_reg: if d.blocks() == 0 { 0.0 } else { 1.0 },
                        ..Path::default()
                    }
                    .then(fabric(t, &d))
                }
                ref other => unit_path(t, other),
            })
            .fold(Path::default(), Path::then),
        Op::Add(..) if units.is_empty() => Path::chain(node.word.bits.saturating_sub(1)),
        _ => units
            .iter()
            .map(|u| unit_path(t, u))
            .fold(Path::default(), Path::then),
    }
}

/// The clock predicted for the PE's sample datapath as scheduled.
#[derive(Debug, Clone, Serialize)]
pub struct PePrediction {
    /// The family.
    pub target: Target,
    /// Predicted clock of the whole datapath placed, MHz: the slowest
    /// stage's period plus [`routing_ns`](Self::routing_ns).
    pub mhz: f64,
    /// The slowest stage's clock alone (the delay model of units placed
    /// alone), MHz.
    pub stage_mhz: f64,
    /// The routing a whole design adds ([`routing`]), ns; 0 where no
    /// whole design of the family was placed (iCE40).
    pub routing_ns: f64,
    /// The node ending the slowest stage (its probe name).
    pub critical: String,
    /// That stage's path.
    pub path: Path,
    /// The schedule's depth, clocks.
    pub depth: u32,
    /// The delay model that priced it.
    pub model: DelayModel,
}

/// The clock of the whole sample datapath placed on `t`: the slowest
/// stage ([`stage_prediction`]) and the routing a whole design adds
/// ([`routing::routing_ns`]). `None` for xc7 (no model).
pub fn pe_prediction(cfg: &PipelineConfig, t: Target) -> Option<PePrediction> {
    let p = stage_prediction(cfg, t)?;
    let routing_ns = routing::routing_ns(cfg, t);
    Some(PePrediction {
        mhz: 1e3 / (1e3 / p.stage_mhz + routing_ns),
        routing_ns,
        ..p
    })
}

/// The clock of [`crate::hw::sample::plain`]'s schedule on `t` (the
/// configuration's, [`crate::cost::latency::sample_schedule`]: one
/// operator a stage, or the stages `target_mhz` packs): each node's
/// arrival within its stage (operands produced in the same stage chain
/// on; a memory read or register starts a stage), the slowest arrival
/// priced by [`model`], without the routing of a whole design. `None`
/// for xc7 (no model).
pub fn stage_prediction(cfg: &PipelineConfig, t: Target) -> Option<PePrediction> {
    let model = model(t)?;
    let g = crate::hw::sample::plain(cfg);
    let s = crate::cost::latency::sample_schedule(cfg);
    let arrive = arrivals(&g, &s, t, &model);
    let best = arrive.iter().map(|a| model.period_ns(a)).enumerate().fold(
        (0usize, f64::MIN),
        |b, (i, ns)| if ns > b.1 { (i, ns) } else { b },
    );
    Some(PePrediction {
        target: t,
        mhz: 1e3 / best.1,
        stage_mhz: 1e3 / best.1,
        routing_ns: 0.0,
        critical: g.node(crate::hw::NodeId(best.0)).name.clone(),
        path: arrive[best.0],
        depth: s.depth,
        model,
    })
}

/// Each node's path within its stage of `s` (operands produced in the
/// same stage chain on; a memory read or register starts a stage).
fn arrivals(
    g: &crate::hw::Graph,
    s: &crate::hw::schedule::Schedule,
    t: Target,
    model: &DelayModel,
) -> Vec<Path> {
    use crate::hw::Op;
    let consumers = g.consumers();
    let n = g.nodes.len();
    let mut arrive = vec![Path::default(); n];
    for i in 0..n {
        let id = crate::hw::NodeId(i);
        let node = g.node(id);
        let own = node_path(t, g, id, &consumers);
        let start = match node.op {
            Op::Input | Op::Const(_) | Op::Reg(_) => Path::default(),
            Op::Read(..) => Path {
                brams: 1.0,
                ..Path::default()
            },
            // One chain per stage: the last stage's chain alone.
            Op::Isqrt(_) => Path::default(),
            op => op
                .operands()
                .iter()
                .filter(|o| s.stage[o.0] == s.stage[i])
                .map(|o| arrive[o.0])
                .fold(Path::default(), |a, b| {
                    if model.period_ns(&b) > model.period_ns(&a) {
                        b
                    } else {
                        a
                    }
                }),
        };
        arrive[i] = start.then(own);
    }
    arrive
}

/// The LUT4 levels of a tree over `inputs` (four inputs a level).
fn tree_levels(inputs: u64) -> u32 {
    let mut l = 0;
    let mut w = inputs.max(1);
    while w > 1 {
        w = w.div_ceil(4);
        l += 1;
    }
    l
}

/// The path of the sample stage's issue: the pick, in the clock before
/// issue ([`crate::hw::pe_sample_rtl`]'s control, as
/// [`crate::cost::sample_stage::control_logic`] prices its statements):
/// from the plan FIFO's head register (the block RAM reads ahead of it,
/// off the path), the head's bypass and the row's bits (two LUT levels),
/// the one-hot pick's carry chain over the slots and its
/// AND and the index's OR tree (a LUT4 level per four inputs) into the
/// pick's registers; under a round-robin mapping also the column map's
/// ray index at that index (a multiplexer tree), where under column
/// blocks the issue's clock adds `k_lo + k_idx`. The other path of the
/// issue, the buffer's address in the issue's clock ([`address_path`]),
/// starts at a register and holds no carry chain over the slots: the
/// pick is the longer (`the_pick_is_the_issues_longer_path`).
pub fn issue_path(s: &crate::hw::pe_sample_rtl::PeSampleShape) -> Path {
    let n = s.slots();
    let mx = if s.round_robin {
        Path::luts(tree_levels(n))
    } else {
        Path::default()
    };
    Path::luts(2)
        .then(Path::chain(n as u32))
        .then(Path::luts(1))
        .then(Path::luts(tree_levels(n.div_ceil(2))))
        .then(mx)
}

/// The issue's second clock's path: from the registered pick, the slot
/// (`map_sl + idx`, its compare and wrap; under a round-robin mapping the
/// column map entry's slot, read in the pick's clock) and the address's
/// last adder into the compositing buffer's read port.
pub fn address_path(s: &crate::hw::pe_sample_rtl::PeSampleShape) -> Path {
    let tb = crate::cost::inventory::addr_bits(s.slots());
    let slot = if s.round_robin {
        Path::default()
    } else {
        Path::chain(tb + 1)
            .then(Path::chain(tb + 1))
            .then(Path::luts(1))
    };
    slot.then(Path::chain(s.rays.ray_addr_bits()))
}

/// The path of the sample stage's tap address, in the datapath's tap
/// column stage: the column `x0` as the datapath's stage computes it
/// (its arrival in [`crate::cost::latency::sample_schedule`]'s stage, the
/// output's valid gate), then the PE's logic into the slice buffer's read
/// ports (`crate::hw::pe_sample_rtl`'s tap stage, as
/// [`crate::cost::sample_stage::control_logic`] prices it). Under column
/// blocks the row base less `col_lo` is a register, so an address is the
/// adder from `x0` beside the clamp's compare, then the select between
/// the sum and a clamped column's registered form. Under a round-robin
/// mapping: `x0 + 1`, its clamp into the volume (a compare chain and a
/// select), the column decoder's read and the bank row's base plus the
/// local column.
pub fn tap_path(
    cfg: &PipelineConfig,
    s: &crate::hw::pe_sample_rtl::PeSampleShape,
    t: Target,
) -> Option<Path> {
    let model = model(t)?;
    let g = crate::hw::sample::plain(cfg);
    let sch = crate::cost::latency::sample_schedule(cfg);
    let x0 = g.outputs.iter().find(|o| o.0 == "x0")?.1;
    let xb = g.word(x0).bits;
    let ab = crate::cost::inventory::addr_bits(s.bank_words());
    let pe = if s.round_robin {
        Path::luts(1)
            .then(Path::chain(xb + 1))
            .then(Path::chain(xb + 1))
            .then(Path::luts(1))
            .then(Path::luts(tree_levels(s.nx)))
            .then(Path::chain(ab))
    } else {
        Path::chain(ab.max(xb + 1)).then(Path::luts(1))
    };
    Some(arrivals(&g, &sch, t, &model)[x0.0].then(pe))
}

/// The clock `ercube cost` quotes as predicted for `geo` on `t`: the
/// sample stage's ([`sample_stage_prediction`]), or the datapath's
/// ([`pe_prediction`]) where the stage's shape is not declared. `None`
/// for xc7 (no model).
pub fn predicted_clock(
    cfg: &PipelineConfig,
    geo: &crate::cost::inventory::Geometry,
    t: Target,
) -> Option<PePrediction> {
    sample_stage_prediction(cfg, geo, t).or_else(|| pe_prediction(cfg, t))
}

/// The clock of the PE's emitted sample stage for `geo` on `t`: the
/// slowest of the datapath's slowest stage, the issue's pick
/// ([`issue_path`]) and the tap address ([`tap_path`]), these two with
/// their nets' routing across the stage ([`super::stages`]), plus the
/// routing a whole design adds. `None` for xc7 (no model) or where the
/// stage's shape is not declared.
pub fn sample_stage_prediction(
    cfg: &PipelineConfig,
    geo: &crate::cost::inventory::Geometry,
    t: Target,
) -> Option<PePrediction> {
    let dp = pe_prediction(cfg, t)?;
    let shape = crate::hw::pe_sample_rtl::PeSampleShape::new(cfg, geo).ok()?;
    // The stage's own paths, their nets routed across the whole stage.
    let (ns, path, critical) = super::stages::StagePath::ALL
        .into_iter()
        .filter_map(|k| {
            let path = k.path(cfg, &shape, t)?;
            let ns = dp.model.period_ns(&path) + super::stages::stage_routing_ns(path.luts, t, k);
            Some((ns, path, k.describe()))
        })
        .fold(None::<(f64, Path, &str)>, |b, c| match b {
            Some(b) if b.0 >= c.0 => Some(b),
            _ => Some(c),
        })?;
    if ns <= 1e3 / dp.stage_mhz {
        return Some(dp);
    }
    Some(PePrediction {
        mhz: 1e3 / (ns + dp.routing_ns),
        stage_mhz: 1e3 / ns,
        critical: critical.to_owned(),
        path,
        ..dp
    })
}
