//! What lies on a register-to-register path: the primitives a unit puts
//! on it ([`Path`]: carry-chain bits, LUT levels, wide-fanout nets,
//! multiplier blocks, block-RAM reads), read off the estimator's units.

use serde::Serialize;

use super::FEATURES;
use crate::cost::dsp::{decompose, DspLimits, MulNode};
use crate::cost::units::{MulShape, Unit};
use crate::cost::Target;

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
    /// [`DelayModel`](super::DelayModel)'s coefficient order.
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

    pub(super) fn then(mut self, o: Path) -> Path {
        self.carry_bits += o.carry_bits;
        self.luts += o.luts;
        self.fanout += o.fanout;
        self.blocks += o.blocks;
        self.blocks_reg += o.blocks_reg;
        self.brams += o.brams;
        self
    }

    pub(super) fn chain(bits: u32) -> Path {
        Path {
            carry_bits: f64::from(bits),
            luts: 1.0,
            ..Path::default()
        }
    }

    pub(super) fn luts(n: u32) -> Path {
        Path {
            luts: f64::from(n),
            ..Path::default()
        }
    }

    pub(super) fn fanout() -> Path {
        Path {
            fanout: 1.0,
            ..Path::default()
        }
    }
}

/// The carry chains in series after a multiplier's blocks on `t`.
pub(super) fn fabric(t: Target, node: &MulNode) -> Path {
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
            if !crate::cost::units::absorbed(t, node) {
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
        Unit::Reduce { .. } | Unit::Mux { .. } | Unit::Decode { .. } => Path::luts(1),
        // A LUT level for the lowest set bit, one to fold the index.
        Unit::Encode { .. } => Path::luts(2),
        Unit::ConstMulAdd { y, .. } => Path::chain(y),
        Unit::Shift { amount, .. } => Path::luts(amount),
        Unit::Mul(MulShape {
            a,
            a_signed,
            b,
            b_signed,
            y,
            post_add,
            registered,
            ..
        }) => {
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
        Unit::Reg { .. }
        | Unit::PipeReg { .. }
        | Unit::Delay { .. }
        | Unit::Ip { .. }
        | Unit::ReadReset { .. } => Path::default(),
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
            Unit::Mul(MulShape {
                a,
                a_signed,
                b,
                b_signed,
                y,
                post_add,
                registered,
                ..
            }) if t == Target::Ice40 && !registered => {
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
