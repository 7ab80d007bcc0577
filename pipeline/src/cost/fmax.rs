//! The clock a family reaches, predicted from the depth of a stage:
//! multiplier blocks, carry chains and LUT levels on its longest
//! register-to-register path, priced by a linear delay model per family
//! fitted to units placed and routed by `ercube synth`.
//!
//! A stage's path is read off its units ([`Unit`]): an adder, subtractor,
//! incrementer or comparator is a carry chain of its width entered through
//! a LUT; a multiplexer or reduction a LUT level; a saturation clamp a LUT
//! level and a wide-fanout net (its overflow select drives every output
//! bit); a multiplier a block followed by the partial-product adders the
//! blocks do not take in and a post-adder outside the block (as
//! [`super::units`] prices them); a square-root or divider stage a carry
//! chain of the remainder's width, a LUT (the operand's conditional
//! inversion) and a wide-fanout net (the remainder's sign selecting that
//! inversion for every bit of the next stage); a memory read a block RAM.
//! On iCE40 a path through an unregistered SB_MAC16 is cut at the block:
//! nextpnr-ice40 has no timing arcs through it and times the path to its
//! inputs and the path from its output separately (the scheduled PE
//! registers every product at its block, so it has no such path).
//!
//! The period is `max(base, base + carry bit x n + LUT level x l + fanout
//! net x f + block x m + registered block x k + block RAM x r)`, the
//! coefficients a least-squares fit of the relative error (`fmax::fit`) to the
//! calibration settings of [`MEASURED`] (every unit, single-clock ones
//! included); the holdout settings check it out of sample.
//!
//! [`pe_prediction`] applies the model to [`crate::hw::schedule`]'s
//! stages of the plain sample datapath: the arrival time of each node
//! within its stage, the slowest stage setting the clock.

use serde::Serialize;

use super::dsp::{decompose, DspLimits, MulNode};
use super::units::Unit;
use super::Target;
use crate::config::PipelineConfig;

mod fit;
mod measured;
mod pipelining;
pub mod routing;

pub use fit::{fit_rows, least_squares, FEATURES};
pub use measured::{Measured, Role, Setting, MEASURED};
pub use pipelining::{clock_schedule, schedule_for, ClockSchedule, Clocked};

/// What lies on a stage's longest path.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize)]
pub struct Path {
    /// Carry-chain bits.
    pub carry_bits: f64,
    /// LUT levels (one entering each carry chain).
    pub luts: f64,
    /// Wide-fanout nets: a clamp's overflow select, a square-root or
    /// divider stage's remainder sign, each driving a whole word.
    pub fanout: f64,
    /// Multiplier blocks passed through combinationally.
    pub blocks: f64,
    /// Multiplier blocks whose product is registered at the block (its
    /// output register: a faster path than through the block).
    pub blocks_reg: f64,
    /// Block-RAM reads.
    pub brams: f64,
}

impl Path {
    /// The fit's features: a constant, then the counts in
    /// [`DelayModel`]'s coefficient order.
    pub fn features(&self) -> [f64; FEATURES] {
        [
            1.0,
            self.carry_bits,
            self.luts,
            self.fanout,
            self.blocks,
            self.blocks_reg,
            self.brams,
        ]
    }

    fn then(mut self, o: Path) -> Path {
        self.carry_bits += o.carry_bits;
        self.luts += o.luts;
        self.fanout += o.fanout;
        self.blocks += o.blocks;
        self.blocks_reg += o.blocks_reg;
        self.brams += o.brams;
        self
    }

    fn chain(bits: u32) -> Path {
        Path {
            carry_bits: f64::from(bits),
            luts: 1.0,
            ..Path::default()
        }
    }

    fn luts(n: u32) -> Path {
        Path {
            luts: f64::from(n),
            ..Path::default()
        }
    }

    fn fanout() -> Path {
        Path {
            fanout: 1.0,
            ..Path::default()
        }
    }
}

/// The carry chains in series after a multiplier's blocks on `t`.
fn fabric(t: Target, node: &MulNode) -> Path {
    match node {
        MulNode::Block { .. } | MulNode::Zero => Path::default(),
        // A soft multiplier's adder rows: one chain of the product's width.
        MulNode::Soft { a, b } => Path::chain(a + b),
        MulNode::Split { parts, shift, y } => {
            // The slices work in parallel; the slowest feeds the sum.
            let mut p = parts
                .iter()
                .map(|q| fabric(t, q))
                .fold(Path::default(), |a, b| {
                    if b.carry_bits + b.luts > a.carry_bits + a.luts {
                        b
                    } else {
                        a
                    }
                });
            if !super::units::absorbed(t, node) {
                for (i, q) in parts.iter().enumerate().skip(1) {
                    let w = y.saturating_sub(i as u32 * shift);
                    if *q != MulNode::Zero && w > 0 {
                        p = p.then(Path::chain(w));
                    }
                }
            }
            p
        }
    }
}

/// The path through one unit on `t`.
pub fn unit_path(t: Target, u: &Unit) -> Path {
    match *u {
        Unit::Add { width } | Unit::Sub { width } | Unit::Inc { width } | Unit::Cmp { width } => {
            Path::chain(width)
        }
        Unit::Sat { input, output } => {
            let excess = input.saturating_sub(output);
            Path::luts(if t == Target::Ecp5 && 1 + excess > 4 {
                2
            } else {
                1
            })
            .then(Path::fanout())
        }
        Unit::Reduce { .. } | Unit::Mux { .. } => Path::luts(1),
        Unit::Shift { amount, .. } => Path::luts(amount),
        Unit::Mul {
            a,
            a_signed,
            b,
            b_signed,
            y,
            post_add,
            registered,
            ..
        } => {
            let node = decompose(&DspLimits::of(t), a, a_signed, b, b_signed, y);
            let block = if node.blocks() == 0 { 0.0 } else { 1.0 };
            let mut p = if registered && post_add.is_none() {
                Path {
                    blocks_reg: block,
                    ..Path::default()
                }
            } else {
                Path {
                    blocks: block,
                    ..Path::default()
                }
            }
            .then(fabric(t, &node));
            if let Some(w) = post_add {
                if !(t != Target::Ecp5 && node.is_single_block()) {
                    p = p.then(Path::chain(w));
                }
            }
            p
        }
        // One stage: the remainder's sign selects the next operand's
        // conditional inversion (a LUT level of its own before the chain's,
        // see `Unit::Sqrt`'s cost) for every bit of it.
        Unit::Sqrt { root } => Path::chain(root + 2)
            .then(Path::luts(1))
            .then(Path::fanout()),
        Unit::Div { divisor, .. } => Path::chain(divisor + 1)
            .then(Path::luts(1))
            .then(Path::fanout()),
        Unit::Mem { .. } => Path {
            brams: 1.0,
            ..Path::default()
        },
        Unit::Reg { .. } | Unit::Delay { .. } | Unit::Ip { .. } | Unit::ReadReset { .. } => {
            Path::default()
        }
    }
}

/// The register-to-register paths of a calibration unit on `t`: its units
/// in order, a saturation clamp ending a lane or stage at its register
/// (the next unit starts a new path), the register-to-register hop (the
/// empty path) among them. A compare right after a divider is its cap,
/// which the divider computes beside its first stage: a path of its own.
///
/// On iCE40 nextpnr-ice40 0.4 does not time an unregistered multiplier's
/// blocks as the fabric: a product that is one SB_MAC16 (its post-adder
/// inside) is put on a constant clock, so neither the path into it nor the
/// path out of it is timed; a product split over several blocks and fabric
/// partial sums is timed up to the blocks' inputs and again from their
/// outputs, and slices the decomposition leaves in the fabric carry the
/// path through. The scheduled PE registers every product at its block.
pub fn module_paths(t: Target, units: &[Unit]) -> Vec<Path> {
    let mut done = vec![Path::default()];
    let mut open = vec![Path::default()];
    let mut after_div = false;
    for u in units {
        match *u {
            Unit::Mul {
                a,
                a_signed,
                b,
                b_signed,
                y,
                post_add,
                registered,
                ..
            } if t == Target::Ice40 && !registered => {
                let node = decompose(&DspLimits::of(t), a, a_signed, b, b_signed, y);
                let mut after = fabric(t, &node);
                if let Some(w) = post_add {
                    if !node.is_single_block() {
                        after = after.then(Path::chain(w));
                    }
                }
                let through: Vec<Path> = if node.blocks() == 0 || has_soft(&node) {
                    open.iter().map(|p| p.then(after)).collect()
                } else {
                    Vec::new()
                };
                if node.is_single_block() {
                    open = through;
                } else {
                    done.append(&mut open);
                    open = through;
                    open.push(after);
                }
            }
            Unit::Cmp { width } if after_div => done.push(Path::chain(width)),
            _ => {
                let own = unit_path(t, u);
                for p in &mut open {
                    *p = p.then(own);
                }
            }
        }
        after_div = matches!(u, Unit::Div { .. });
        if matches!(u, Unit::Sat { .. }) {
            done.append(&mut open);
            open = vec![Path::default()];
        }
    }
    done.extend(open);
    done
}

/// A decomposition with a slice left to the fabric (a soft multiplier).
fn has_soft(node: &MulNode) -> bool {
    match node {
        MulNode::Soft { .. } => true,
        MulNode::Block { .. } | MulNode::Zero => false,
        MulNode::Split { parts, .. } => parts.iter().any(has_soft),
    }
}

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

/// A family's fitted delay model, ns.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct DelayModel {
    /// The family.
    pub target: Target,
    /// Clock-to-out, setup and the routing every path has.
    pub base_ns: f64,
    /// Per carry-chain bit.
    pub carry_bit_ns: f64,
    /// Per LUT level (with its routing).
    pub lut_ns: f64,
    /// Per wide-fanout net (a select driving a whole word).
    pub fanout_ns: f64,
    /// Per multiplier block passed through.
    pub block_ns: f64,
    /// Per multiplier block ending at its output register.
    pub block_reg_ns: f64,
    /// Per block-RAM read.
    pub bram_ns: f64,
}

impl DelayModel {
    /// The period of a path, ns.
    pub fn period_ns(&self, p: &Path) -> f64 {
        self.base_ns
            + self.carry_bit_ns * p.carry_bits
            + self.lut_ns * p.luts
            + self.fanout_ns * p.fanout
            + self.block_ns * p.blocks
            + self.block_reg_ns * p.blocks_reg
            + self.bram_ns * p.brams
    }

    /// The clock of a path, MHz.
    pub fn mhz(&self, p: &Path) -> f64 {
        1e3 / self.period_ns(p)
    }
}

impl DelayModel {
    /// The model of `t` from the fit's coefficients ([`FEATURES`] of them,
    /// in [`Path::features`]'s order).
    pub fn from_coefficients(target: Target, x: [f64; FEATURES]) -> DelayModel {
        DelayModel {
            target,
            base_ns: x[0],
            carry_bit_ns: x[1],
            lut_ns: x[2],
            fanout_ns: x[3],
            block_ns: x[4],
            block_reg_ns: x[5],
            bram_ns: x[6],
        }
    }
}

/// The delay model of `t` fitted to the calibration settings of
/// [`MEASURED`] (`None` for a family without an open place and route:
/// xc7), fitted once per process.
pub fn model(t: Target) -> Option<DelayModel> {
    static FITTED: std::sync::OnceLock<[Option<DelayModel>; 3]> = std::sync::OnceLock::new();
    let fits = FITTED.get_or_init(|| Target::ALL.map(|t| fit::fit(t, Role::Calibration)));
    Target::ALL
        .iter()
        .position(|&x| x == t)
        .and_then(|i| fits[i])
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
fn node_path(
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
                Unit::Mul {
                    a,
                    a_signed,
                    b,
                    b_signed,
                    y,
                    ..
                } => {
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

#[cfg(test)]
mod tests {
    use super::*;

    /// The fitted models against every measurement, calibration and
    /// holdout (`--nocapture` prints the table docs/cost.md shows).
    #[test]
    fn every_measured_unit_is_predicted_within_15_percent() {
        let mut worst: Vec<String> = Vec::new();
        for t in [Target::Ice40, Target::Ecp5] {
            eprintln!("{t:?}: {:?}", model(t).unwrap());
            for p in unit_predictions(t) {
                let m = p.measured;
                eprintln!(
                    "| {} | {} | {:?} | {:.1} | {:.1} | {:+.1}% | {:?}",
                    m.unit,
                    m.part,
                    m.setting,
                    m.mhz,
                    p.predicted_mhz,
                    100.0 * p.error(),
                    p.path
                );
                if p.error().abs() > 0.15 {
                    worst.push(format!(
                        "{} {} {:?}: {:+.1}%",
                        m.part,
                        m.unit,
                        m.setting,
                        100.0 * p.error()
                    ));
                }
            }
        }
        assert!(worst.is_empty(), "{worst:?}");
    }

    #[test]
    fn fitted_models_are_positive_and_xc7_has_none() {
        assert!(model(Target::Xc7).is_none());
        for t in [Target::Ice40, Target::Ecp5] {
            let m = model(t).expect("a model");
            assert!(m.base_ns > 0.0, "{m:?}");
            for c in [
                m.carry_bit_ns,
                m.lut_ns,
                m.block_ns,
                m.block_reg_ns,
                m.bram_ns,
            ] {
                assert!(c >= 0.0, "{m:?}");
            }
        }
    }

    /// The schedule's stages are one multiplier or one carry chain deep:
    /// the PE's predicted clock is above every measured unit's clock of
    /// more than one chain in series (bilinear, composite).
    #[test]
    fn the_pipelined_pe_is_faster_than_the_unpipelined_units() {
        let cfg = PipelineConfig::default();
        for t in [Target::Ice40, Target::Ecp5] {
            let pe = stage_prediction(&cfg, t).expect("prediction");
            for u in ["bilinear", "composite"] {
                let meas = MEASURED
                    .iter()
                    .find(|m| m.target == t && m.unit == u && m.setting == Setting::Default)
                    .unwrap();
                assert!(pe.mhz > meas.mhz, "{t:?} {u}: {pe:?}");
            }
        }
    }
}
