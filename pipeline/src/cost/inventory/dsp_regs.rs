//! The emitted datapath's pipeline registers a DSP48E1 takes in.
//!
//! yosys's `xilinx_dsp` packs the fabric registers around a multiplier
//! mapped to DSP48E1s into the blocks' own: the register at an operand's
//! port (AREG/BREG, duplicated into every block that reads it) and the one
//! before it when the block is its only reader (the second of A1/A2, B1/B2),
//! and for a single-block product its register (MREG) and, when the product
//! feeds one adder in the next stage, that adder's register (PREG, the
//! adder in the block's ALU). A cascade of blocks takes its operand
//! registers only. Which registers these are follows from the schedule
//! ([`crate::hw::schedule`]) as [`crate::hw::pipeline_rtl`] declares them:
//! a value read `k` stages after its own is held in `value_d<k>`.
//! Measured on the default datapath with yosys 0.23 (`synth_xilinx`):
//! docs/cost.md.

use std::collections::HashSet;

use crate::cost::dsp::{decompose, DspLimits};
use crate::cost::Target;
use crate::hw::schedule::Schedule;
use crate::hw::{Graph, NodeId, Op};

/// Bits of the registers of `g` on schedule `s` that DSP48E1s take in.
pub(crate) fn dsp_register_bits(g: &Graph, s: &Schedule) -> u64 {
    let n = g.nodes.len();
    // Every reader of a node with the stage it reads at.
    let mut readers: Vec<Vec<(usize, u32)>> = vec![Vec::new(); n];
    for (i, node) in g.nodes.iter().enumerate() {
        for o in node.op.operands() {
            readers[o.0].push((i, s.reads[i]));
        }
    }
    let outputs: HashSet<usize> = g.outputs.iter().map(|(_, id)| id.0).collect();
    let lim = DspLimits::of(Target::Xc7);
    let blocks = |i: usize| -> Option<bool> {
        let Op::Mul(a, b) = g.nodes[i].op else {
            return None;
        };
        let (wa, wb) = (g.word(a), g.word(b));
        let d = decompose(
            &lim,
            wa.bits,
            wa.signed,
            wb.bits,
            wb.signed,
            g.nodes[i].word.bits,
        );
        if d.is_single_block() {
            Some(true)
        } else if d.is_block_chain() {
            Some(false)
        } else {
            None
        }
    };
    // A register is named by its value and the stage it feeds; each is
    // taken in once.
    let mut taken: HashSet<(usize, u32)> = HashSet::new();
    // Whether only block multipliers reading at `k` read the register of
    // `o` feeding stage `k` (none later, not an output; readers at earlier
    // stages read earlier registers of its delay line).
    let only_blocks_read = |o: usize, k: u32| -> bool {
        !outputs.contains(&o)
            && readers[o]
                .iter()
                .filter(|&&(_, at)| at >= k)
                .all(|&(r, at)| at == k && blocks(r).is_some())
    };
    let is_reg = |o: usize, k: u32| -> bool {
        // A delay-line register, or a declared register of that stage
        // (table reads are the block RAM's, priced apart).
        !matches!(g.nodes[o].op, Op::Const(_) | Op::Read(..))
            && (s.stage[o] < k || matches!(g.nodes[o].op, Op::Reg(_)) && s.stage[o] == k)
    };
    for i in 0..n {
        let Some(single) = blocks(i) else {
            continue;
        };
        let Op::Mul(a, b) = g.nodes[i].op else {
            continue;
        };
        let k = s.reads[i];
        let mut ops = vec![a.0, b.0];
        ops.dedup();
        for o in ops {
            if !is_reg(o, k) || !only_blocks_read(o, k) {
                continue;
            }
            taken.insert((o, k));
            // The register before it, when this block alone reads it.
            if single && k > 0 && is_reg(o, k - 1) && readers[o].len() == 1 {
                taken.insert((o, k - 1));
            }
        }
        if !single {
            continue;
        }
        // MREG: the product's register, when the next stage alone reads it.
        let st = s.stage[i];
        let next = &readers[i];
        if outputs.contains(&i) || next.is_empty() || next.iter().any(|&(_, at)| at != st + 1) {
            continue;
        }
        taken.insert((i, st + 1));
        // PREG: the one adder reading it, its register.
        if let [(j, _)] = next.as_slice() {
            let j = *j;
            if matches!(g.nodes[j].op, Op::Add(..) | Op::Sub(..))
                && s.stage[j] == st + 1
                && !outputs.contains(&j)
                && !readers[j].is_empty()
                && readers[j].iter().all(|&(_, at)| at == st + 2)
            {
                taken.insert((j, st + 2));
            }
        }
    }
    taken
        .iter()
        .map(|&(o, _)| u64::from(g.word(NodeId(o)).bits))
        .sum()
}
