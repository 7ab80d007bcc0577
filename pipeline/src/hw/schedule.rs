//! The pipelined schedule of a [`Graph`]: pipeline registers at stage
//! boundaries so that each stage is at most one multiplier or one carry
//! chain deep, and the latency that gives.
//!
//! Why that depth: the emitted compositing unit, one clock deep
//! (subtract, 18x18 multiply, add, round, saturate), closes at about
//! 64 MHz on an ECP5-25F, against the 150 MHz the cost model assumes
//! there. A multiplier block alone (with its output register) or one
//! carry chain of the datapath's widths (up to about 40 bits) plus the
//! LUT levels of a saturation select is what one clock of 150 MHz holds
//! on those parts; a multiply and its post-add then take two stages,
//! which is also where a DSP block puts its M and P registers.
//!
//! Operators and their depth: products are multipliers; sums,
//! differences, magnitude compares, rounding increments (an assignment
//! that rounds, [`crate::cost::shapes::Quantizer::round`]) are carry
//! chains; an integer square root is one carry chain per result bit, a
//! divider one per quotient bit after its saturation compare;
//! wires, multiplexers, reductions and truncating assignments (their
//! saturation select) are logic that joins whatever stage their operands
//! are in. A memory read and a declared register end a stage. Ports are
//! held registers (the row broadcast, the ray's accumulators read when
//! needed): they cost no delay line.
//!
//! Ports arrive at issue but the ray's state from the compositing buffer
//! ([`RAY_PORTS`]), which arrives [`RAY_STAGE`] clocks later: the PE
//! picks the issuing ray in the clock before issue and reads its buffer
//! word in the clock, from the registered pick, so that one clock
//! never holds both the pick's carry chain and the buffer's address
//! (`super::pe_sample_rtl`). The compositing reads them tens of stages
//! later, so the depth does not follow.

use super::{Graph, Op};
use crate::cost::shapes::Quantizer;

/// The ports carrying the ray's state from the compositing buffer: its
/// accumulators and, pre-integrated, its previous sample.
pub const RAY_PORTS: [&str; 5] = ["acc_r", "acc_g", "acc_b", "acc_a", "pre.prev"];

/// Clocks after issue at which the [`RAY_PORTS`] arrive.
pub const RAY_STAGE: u32 = 1;

/// The stage at which node `i` of `g`, a port, arrives: [`RAY_STAGE`] for
/// the [`RAY_PORTS`], else issue's (0).
pub fn port_stage(g: &Graph, i: usize) -> u32 {
    if RAY_PORTS.contains(&g.nodes[i].name.as_str()) {
        RAY_STAGE
    } else {
        0
    }
}

/// A graph's schedule.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Schedule {
    /// Per node: the stage whose logic produces it (0 from the first
    /// clock).
    pub stage: Vec<u32>,
    /// Per node: the stage at which it reads its operands (its stage, but
    /// one before for a register or a memory read, and the first of an
    /// integer square root's stages).
    pub reads: Vec<u32>,
    /// Stages from the first to the outputs' register: the latency.
    pub depth: u32,
    /// Bits of the pipeline registers the schedule adds (delay lines
    /// included: a value consumed `n` stages later is held `n` times).
    pub register_bits: u64,
}

/// Carry chains an operator adds to its stage (`None`: a multiplier).
fn chains(g: &Graph, op: Op, id: usize) -> Option<u32> {
    Some(match op {
        Op::Mul(..) => return None,
        Op::Add(..) | Op::Sub(..) | Op::Ge(..) => 1,
        Op::Quantize(x) => {
            let q = Quantizer::new(g.word(x), g.nodes[id].fmt.expect("format"));
            u32::from(q.round)
        }
        Op::ShrQuantize(x, _) => {
            // The shifted word keeps one guard bit, then rounds.
            let q = Quantizer::new(g.word(x), g.nodes[id].fmt.expect("format"));
            u32::from(q.out.frac < q.input.frac || q.quant != crate::fixed::Quant::Trn)
        }
        Op::Isqrt(_) => g.nodes[id].word.bits.max(1),
        // The saturation compare, then one chain per quotient bit.
        Op::Div(..) => g.nodes[id].word.bits + 1,
        _ => 0,
    })
}

/// Schedules `g` as soon as possible under the one-multiplier-or-one-
/// carry-chain rule.
pub fn schedule(g: &Graph) -> Schedule {
    let n = g.nodes.len();
    // Per node: its stage and whether its stage already holds a
    // multiplier or a carry chain on its path.
    let mut stage = vec![0u32; n];
    let mut heavy = vec![false; n];
    // The stage at which each node reads its operands.
    let mut reads = vec![0u32; n];
    for (i, node) in g.nodes.iter().enumerate() {
        let ops = node.op.operands();
        let s = ops.iter().map(|o| stage[o.0]).max().unwrap_or(0);
        let busy = ops.iter().any(|o| stage[o.0] == s && heavy[o.0]);
        let (st, h, r) = match node.op {
            Op::Input => (port_stage(g, i), false, 0),
            Op::Const(_) => (0, false, 0),
            Op::Read(..) | Op::Reg(_) => (s + 1, false, s),
            op => match chains(g, op, i) {
                Some(0) => (s, busy, s),
                // A multiplier or a first carry chain starts a stage when
                // this one is taken; further chains take one stage each.
                Some(k) => {
                    let s0 = s + u32::from(busy);
                    (s0 + k - 1, true, s0)
                }
                None => {
                    let s0 = s + u32::from(busy);
                    (s0, true, s0)
                }
            },
        };
        stage[i] = st;
        heavy[i] = h;
        reads[i] = r;
    }
    let (register_bits, depth) = registers_and_depth(g, &stage, &reads);
    Schedule {
        stage,
        reads,
        depth,
        register_bits,
    }
}

/// The pipeline register bits and the depth of a placement of `g`'s nodes
/// (`stage`: where each is produced; `reads`: where each reads its
/// operands): a value is held from its stage to its last reader's (ports
/// and constants are held anyway), and the outputs' register ends the
/// last stage.
pub(crate) fn registers_and_depth(g: &Graph, stage: &[u32], reads: &[u32]) -> (u64, u32) {
    let consumers = g.consumers();
    let register_bits = (0..g.nodes.len())
        .filter(|&i| !matches!(g.nodes[i].op, Op::Input | Op::Const(_)))
        .map(|i| {
            let last = consumers[i]
                .iter()
                .map(|c| reads[c.0])
                .max()
                .unwrap_or(stage[i]);
            u64::from(last.saturating_sub(stage[i])) * u64::from(g.nodes[i].word.bits)
        })
        .sum();
    let depth = g
        .outputs
        .iter()
        .map(|(_, o)| stage[o.0] + 1)
        .max()
        .unwrap_or(0);
    (register_bits, depth)
}
