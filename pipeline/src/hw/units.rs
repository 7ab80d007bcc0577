//! The cost inventory's units of a [`Graph`], item by item: each node's
//! operator priced as the estimator's [`Unit`] of its words, and the
//! registers the model's schedule puts at the end of each step
//! ([`super::Node::step_out`]).
//!
//! A multiplier whose product feeds one adder and nothing else takes the
//! adder in (`post_add`, a DSP block's post-adder); the low bits of the
//! sum that come from the product alone (the other operand shifted up)
//! are not on the adder. An add of the constant 1 is an incrementer.

use super::{Graph, NodeId, Op, Word};
use crate::cost::inventory::addr_bits;
use crate::cost::shapes::Quantizer;
use crate::cost::units::{MulShape, Unit};

/// One cost item of a graph: group, name, copies and one copy's units.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ItemUnits {
    /// Pipeline stage or block.
    pub group: &'static str,
    /// What the units do.
    pub name: String,
    /// Copies described.
    pub count: u32,
    /// One copy's units.
    pub units: Vec<Unit>,
}

/// Whether `id` is the constant 1 at fraction 0.
fn is_one(g: &Graph, id: NodeId) -> bool {
    g.node(id).op == Op::Const(1) && g.word(id).frac == 0
}

/// The units of node `id` (none for wires, ports, memory reads and
/// registers, which are priced elsewhere or by [`items`]).
pub fn node_units(g: &Graph, id: NodeId, consumers: &[Vec<NodeId>]) -> Vec<Unit> {
    let n = g.node(id);
    let w = n.word;
    // The adder a product feeds alone, if any.
    let fused_into = |m: NodeId| -> Option<NodeId> {
        let c = &consumers[m.0];
        (matches!(g.node(m).op, Op::Mul(..))
            && c.len() == 1
            && matches!(g.node(c[0]).op, Op::Add(..)))
        .then_some(c[0])
    };
    match n.op {
        Op::Sub(..) => vec![Unit::Sub { width: w.bits - 1 }],
        Op::Add(a, b) => {
            if fused_into(a) == Some(id) || fused_into(b) == Some(id) {
                vec![]
            } else if is_one(g, a) || is_one(g, b) {
                let x = if is_one(g, a) { b } else { a };
                vec![Unit::Inc {
                    width: g.word(x).bits,
                }]
            } else {
                vec![Unit::Add { width: w.bits - 1 }]
            }
        }
        Op::Mul(a, b) => {
            let post_add = fused_into(id).map(|s| {
                let Op::Add(x, y) = g.node(s).op else {
                    unreachable!("fused into an adder")
                };
                let other = if x == id { y } else { x };
                let sw = g.word(s);
                sw.bits - (sw.frac - g.word(other).frac).max(0) as u32
            });
            // A register feeding this operand alone: the block's input
            // register can hold it.
            let operand_reg = [a, b]
                .iter()
                .filter(|&&o| matches!(g.node(o).op, Op::Reg(_)) && consumers[o.0] == [id])
                .map(|&o| g.word(o).bits)
                .sum();
            let (wa, wb) = (g.word(a), g.word(b));
            vec![Unit::Mul(MulShape {
                a: wa.bits,
                a_signed: wa.signed,
                b: wb.bits,
                b_signed: wb.signed,
                y: w.bits,
                post_add,
                registered: false,
                operand_reg,
            })]
        }
        Op::Quantize(x) => Quantizer::new(g.word(x), n.fmt.expect("format")).units(),
        Op::ShrQuantize(x, s) => {
            // The shifter keeps one bit below the result (the rounding
            // bit); the count's compare zeroes a word shifted out.
            let xw = g.word(x);
            let sb = g.word(s).bits;
            let mut u = vec![
                Unit::Shift {
                    width: xw.bits + 1,
                    amount: sb.min(addr_bits(u64::from(xw.bits) + 1)),
                },
                Unit::Cmp { width: sb },
            ];
            let guard = Word::unsigned(xw.bits + 1, xw.frac + 1);
            u.extend(Quantizer::new(guard, n.fmt.expect("format")).units());
            u
        }
        Op::Ge(a, b) | Op::Eq(a, b) => vec![Unit::Cmp {
            width: g.word(a).bits.max(g.word(b).bits),
        }],
        Op::Mux { .. } => vec![Unit::Mux {
            width: w.bits,
            inputs: 2,
        }],
        Op::NonZero(x) => vec![Unit::Reduce {
            width: g.word(x).bits,
        }],
        Op::Isqrt(_) => vec![Unit::Sqrt { root: w.bits }],
        Op::Div(_, d) => vec![Unit::Div {
            quotient: w.bits,
            divisor: g.word(d).bits,
        }],
        Op::Input | Op::Const(_) | Op::Field(..) | Op::Read(..) | Op::Reg(_) => vec![],
    }
}

/// The graph's cost items, in the order they were described: one copy's
/// units (its operators in node order, then one register of its step
/// outputs' bits) and the number of copies.
pub fn items(g: &Graph) -> Vec<ItemUnits> {
    let consumers = g.consumers();
    g.items
        .iter()
        .enumerate()
        .map(|(i, it)| {
            let mine = |copy: Option<u32>| {
                g.nodes.iter().enumerate().filter(move |(_, n)| {
                    n.item
                        .is_some_and(|(j, c)| j == i && copy.is_none_or(|k| k == c))
                })
            };
            let count = mine(None)
                .map(|(_, n)| n.item.map_or(0, |x| x.1) + 1)
                .max()
                .unwrap_or(0);
            let mut units: Vec<Unit> = mine(Some(0))
                .flat_map(|(id, _)| node_units(g, NodeId(id), &consumers))
                .collect();
            // Step outputs of the copy, wherever they were built.
            let reg: u32 = g
                .nodes
                .iter()
                .filter(|n| n.step_out == Some((i, 0)))
                .map(|n| n.word.bits)
                .sum();
            if reg > 0 {
                units.push(Unit::Reg { bits: reg });
            }
            ItemUnits {
                group: it.group,
                name: it.name.clone(),
                count,
                units,
            }
        })
        .collect()
}
