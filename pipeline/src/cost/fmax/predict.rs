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
    use crate::hw::Op;
    let model = model(t)?;
    let g = crate::hw::sample::plain(cfg);
    let s = crate::cost::latency::sample_schedule(cfg);
    let consumers = g.consumers();
    let n = g.nodes.len();
    let mut arrive = vec![Path::default(); n];
    let mut best = (0usize, f64::MIN);
    for i in 0..n {
        let id = crate::hw::NodeId(i);
        let node = g.node(id);
        let own = node_path(t, &g, id, &consumers);
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
        let ns = model.period_ns(&arrive[i]);
        if ns > best.1 {
            best = (i, ns);
        }
    }
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

/// The path of the sample stage's issue in the clock before issue
/// ([`crate::hw::pe_sample_rtl`]'s control, as
/// [`crate::cost::sample_stage::control_logic`] prices its statements):
/// the plan FIFO's block-RAM read, the head's bypass and the row's bits
/// (two LUT levels), the one-hot pick's carry chain over the slots and its
/// AND, the index's OR tree (a LUT4 level per four inputs), the slot
/// (`map_sl + idx`, its compare and wrap; a multiplexer tree over the
/// column map under a round-robin mapping) and the address's last adder
/// into the compositing buffer's read port.
pub fn issue_path(s: &crate::hw::pe_sample_rtl::PeSampleShape) -> Path {
    let n = s.slots();
    let levels = |inputs: u64| {
        let mut l = 0;
        let mut w = inputs.max(1);
        while w > 1 {
            w = w.div_ceil(4);
            l += 1;
        }
        l
    };
    let tb = crate::cost::inventory::addr_bits(n);
    let slot = if s.round_robin {
        Path::luts(levels(n))
    } else {
        Path::chain(tb + 1)
            .then(Path::chain(tb + 1))
            .then(Path::luts(1))
    };
    Path {
        brams: 1.0,
        ..Path::default()
    }
    .then(Path::luts(2))
    .then(Path::chain(n as u32))
    .then(Path::luts(1))
    .then(Path::luts(levels(n.div_ceil(2))))
    .then(slot)
    .then(Path::chain(s.rays.ray_addr_bits()))
}

/// The clock of the PE's emitted sample stage for `geo` on `t`: the
/// slower of the datapath's slowest stage and the control's issue path
/// ([`issue_path`], with its nets' routing across the stage:
/// [`super::stages`]), plus the routing a whole design adds. `None` for
/// xc7 (no model) or where the stage's shape is not declared.
pub fn sample_stage_prediction(
    cfg: &PipelineConfig,
    geo: &crate::cost::inventory::Geometry,
    t: Target,
) -> Option<PePrediction> {
    let dp = pe_prediction(cfg, t)?;
    let shape = crate::hw::pe_sample_rtl::PeSampleShape::new(cfg, geo).ok()?;
    let path = issue_path(&shape);
    // The issue path's nets route across the whole stage.
    let ns = dp.model.period_ns(&path) + super::stages::issue_routing_ns(path.luts, t);
    if ns <= 1e3 / dp.stage_mhz {
        return Some(dp);
    }
    Some(PePrediction {
        mhz: 1e3 / (ns + dp.routing_ns),
        stage_mhz: 1e3 / ns,
        critical: "the sample stage's issue (plan FIFO read to the buffer's address)".to_owned(),
        path,
        ..dp
    })
}
