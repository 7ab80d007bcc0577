//! A small hardware description layer: the PE's datapath written once, as
//! a graph of fixed-width operators, from which the model's checks, the
//! cost inventory, the probe names and the Verilog all derive.
//!
//! A [`Graph`] is built once per configuration (for instance
//! [`sample::plain`] from a [`PipelineConfig`](crate::config::PipelineConfig));
//! the units beside the plain sample are graphs of their own:
//! [`shading::shading`], [`voi::voi`], [`preint::preint`] and the merge's
//! [`tents::tents`].
//! Every node is one operator on wired words ([`Word`]: width, fraction
//! bits, signedness); the operators are full precision, as in
//! [`crate::fixed`], and only a [`Op::Quantize`] (or [`Op::ShrQuantize`],
//! [`Op::Isqrt`]) assigns into a declared [`Format`] with its rounding and
//! overflow (a divider, [`Op::Div`], truncates and saturates onto its
//! word). Nodes are created in dependency order, so the node list is a
//! topological order and every consumer is one pass over it:
//!
//! - [`eval`]: the bit-exact evaluator (each node's raw word);
//! - [`units`]: the cost inventory's units, item by item;
//! - [`schedule`]: the pipelined schedule (at most one multiplier or one
//!   carry chain per stage) and the latency it gives;
//! - [`verilog`]: Verilog-2005 text of a cut of the graph;
//! - [`pipeline_rtl`]: the whole graph as one pipelined module on that
//!   schedule, which [`testbench`] and [`sim`] stream samples through;
//! - [`unit`](mod@unit): the whole sample or a named cut as a verification model
//!   (ports, outputs, latency, one sample's words), cut from the graph by
//!   [`cut`];
//! - the probe names are the nodes' names ([`Graph::probe_names`]).

pub mod address;
pub mod compose;
pub mod cut;
mod div_rtl;
pub mod eval;
mod isqrt_rtl;
pub mod merge_rtl;
mod pe_carry_rtl;
mod pe_columns_rtl;
mod pe_plan_rtl;
pub mod pe_sample_rtl;
mod pe_sample_shape;
mod pe_taps_rtl;
mod pe_term_rtl;
pub mod pe_units_rtl;
pub mod pipeline_rtl;
pub mod preint;
pub mod readout_rtl;
pub mod sample;
pub mod schedule;
pub mod shading;
pub mod sim;
pub mod split_rtl;
pub mod state;
pub mod tents;
pub mod testbench;
pub mod unit;
pub mod units;
pub mod verilog;
pub mod voi;

#[cfg(test)]
pub(crate) mod tests;
#[cfg(test)]
mod unit_tests;
#[cfg(test)]
mod units_tests;

pub use crate::cost::shapes::Word;
use crate::fixed::Format;

/// A node of a [`Graph`], by position.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct NodeId(pub usize);

/// A memory of a [`Graph`], by position.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct MemId(pub usize);

/// One operator. Operand words are aligned to the result's fraction bits
/// where the operator adds, subtracts or compares; a product's fraction is
/// the sum of its operands'.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Op {
    /// A port: a word the PE receives (a broadcast register, a memory word
    /// read elsewhere), in the node's declared format.
    Input,
    /// A constant raw word at the node's word.
    Const(i128),
    /// `a + b`, exact.
    Add(NodeId, NodeId),
    /// `a - b`, exact.
    Sub(NodeId, NodeId),
    /// `a b`, exact.
    Mul(NodeId, NodeId),
    /// Assignment into the node's format: its rounding, then its overflow.
    Quantize(NodeId),
    /// `x 2^-n` assigned into the node's format (a barrel shift right by
    /// the unsigned word `n`, then the assignment); zero for `n >= 64`.
    ShrQuantize(NodeId, NodeId),
    /// Bits `lo ..` of `x`'s raw word, as many as the node's word has:
    /// wires (an integer part, a fraction, an index); a negative `lo`
    /// puts `-lo` zero bits below `x`.
    Field(NodeId, i32),
    /// `a >= b` (one bit), after alignment.
    Ge(NodeId, NodeId),
    /// `a == b` (one bit), after alignment.
    Eq(NodeId, NodeId),
    /// Whether any bit of `x` is set (one bit).
    NonZero(NodeId),
    /// `sel ? t : f`.
    Mux {
        /// The one-bit select.
        sel: NodeId,
        /// Chosen when `sel` is 0.
        f: NodeId,
        /// Chosen when `sel` is 1.
        t: NodeId,
    },
    /// A synchronous read of a memory at an address (the word arrives one
    /// clock after the address).
    Read(MemId, NodeId),
    /// A declared register: reset to zero, loaded from `d` when enabled.
    Reg(NodeId),
    /// `floor(sqrt(x))` onto the node's format's grid, as
    /// [`crate::datapath::isqrt_into`]: one add/subtract stage per result
    /// bit (non-restoring).
    Isqrt(NodeId),
    /// `floor(num / den)` onto the node's (unsigned) word's grid, as a
    /// restoring divider gives it: both operands non-negative, the exact
    /// quotient truncated, saturated at the word's largest value (a zero
    /// divisor gives that value too); one subtract-and-select stage per
    /// quotient bit.
    Div(NodeId, NodeId),
}

impl Op {
    /// The operator's operands.
    pub fn operands(&self) -> Vec<NodeId> {
        match *self {
            Op::Input | Op::Const(_) => vec![],
            Op::Add(a, b)
            | Op::Sub(a, b)
            | Op::Mul(a, b)
            | Op::Ge(a, b)
            | Op::Eq(a, b)
            | Op::Div(a, b) => {
                vec![a, b]
            }
            Op::ShrQuantize(a, b) => vec![a, b],
            Op::Quantize(x) | Op::Field(x, _) | Op::NonZero(x) | Op::Reg(x) | Op::Isqrt(x) => {
                vec![x]
            }
            Op::Read(_, a) => vec![a],
            Op::Mux { sel, f, t } => vec![sel, f, t],
        }
    }
}

/// A cost item: a block of the datapath as the inventory lists it.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Item {
    /// Pipeline stage or block (`interpolation`, `opacity`, ...).
    pub group: &'static str,
    /// What the units do.
    pub name: String,
}

/// One node: its probe name, operator, wired word and declared format.
#[derive(Debug, Clone)]
pub struct Node {
    /// Probe name, unique in the graph (`bilinear.top`, ...).
    pub name: String,
    /// The operator.
    pub op: Op,
    /// The wired word.
    pub word: Word,
    /// The declared format of an input, an assignment or a register.
    pub fmt: Option<Format>,
    /// The cost item and copy this node belongs to.
    pub item: Option<(usize, u32)>,
    /// Registered at the end of its step in the model's schedule
    /// ([`crate::cost::inventory`]'s steps), the register priced in this
    /// cost item and copy.
    pub step_out: Option<(usize, u32)>,
}

/// A memory: depth and word, in a declared format.
#[derive(Debug, Clone)]
pub struct Mem {
    /// Name (`class_table`, ...).
    pub name: String,
    /// Words.
    pub depth: u64,
    /// The stored format.
    pub fmt: Format,
}

/// A datapath: nodes in dependency order, memories, cost items and named
/// outputs.
#[derive(Debug, Clone, Default)]
pub struct Graph {
    /// Nodes, each after its operands.
    pub nodes: Vec<Node>,
    /// Memories read by [`Op::Read`].
    pub mems: Vec<Mem>,
    /// Cost items, in inventory order.
    pub items: Vec<Item>,
    /// Named outputs.
    pub outputs: Vec<(String, NodeId)>,
    /// The item (and copy) new nodes join.
    current: Option<(usize, u32)>,
}

/// A word holding every value of both `a` and `b` aligned to `frac`
/// bits, plus `extra` bits (a carry), signed if either is or `signed`.
pub fn joint(a: Word, b: Word, frac: i32, extra: u32, signed: bool) -> Word {
    let s = a.signed || b.signed || signed;
    // Magnitude bits of each aligned, plus a sign bit for an unsigned
    // operand in a signed result.
    let need = |w: Word| w.bits as i32 + (frac - w.frac) + i32::from(s && !w.signed);
    Word {
        bits: (need(a).max(need(b)).max(1) as u32) + extra,
        frac,
        signed: s,
    }
}

impl Graph {
    /// An empty graph.
    pub fn new() -> Graph {
        Graph::default()
    }

    /// New nodes join cost item `group`/`name`, copy `copy` (the item is
    /// listed once, with as many copies as are described).
    pub fn item(&mut self, group: &'static str, name: &str, copy: u32) {
        let i = match self.items.iter().position(|it| it.name == name) {
            Some(i) => i,
            None => {
                self.items.push(Item {
                    group,
                    name: name.to_owned(),
                });
                self.items.len() - 1
            }
        };
        self.current = Some((i, copy));
    }

    /// New nodes join no cost item (their units are priced elsewhere).
    pub fn no_item(&mut self) {
        self.current = None;
    }

    /// The node `id`.
    pub fn node(&self, id: NodeId) -> &Node {
        &self.nodes[id.0]
    }

    /// The wired word of `id`.
    pub fn word(&self, id: NodeId) -> Word {
        self.nodes[id.0].word
    }

    /// Adds a node.
    pub fn push(&mut self, name: &str, op: Op, word: Word, fmt: Option<Format>) -> NodeId {
        debug_assert!(
            op.operands().iter().all(|o| o.0 < self.nodes.len()),
            "{name}: operands come first"
        );
        debug_assert!(
            self.nodes.iter().all(|n| n.name != name),
            "{name}: probe names are unique"
        );
        self.nodes.push(Node {
            name: name.to_owned(),
            op,
            word,
            fmt,
            item: self.current,
            step_out: None,
        });
        NodeId(self.nodes.len() - 1)
    }

    /// The node by probe name.
    pub fn find(&self, name: &str) -> Option<NodeId> {
        self.nodes.iter().position(|n| n.name == name).map(NodeId)
    }

    /// Every probe name, in node order.
    pub fn probe_names(&self) -> Vec<&str> {
        self.nodes.iter().map(|n| n.name.as_str()).collect()
    }

    /// Marks `id` as registered at the end of its step in the model's
    /// schedule, the register priced in the current cost item.
    pub fn step_out(&mut self, id: NodeId) -> NodeId {
        debug_assert!(self.current.is_some(), "a step register belongs to an item");
        self.nodes[id.0].step_out = self.current;
        id
    }

    /// Names `id` as an output.
    pub fn output(&mut self, name: &str, id: NodeId) {
        self.outputs.push((name.to_owned(), id));
    }

    /// An input port in format `f`.
    pub fn input(&mut self, name: &str, f: Format) -> NodeId {
        self.push(name, Op::Input, f.into(), Some(f))
    }

    /// An input port of a plain word (a ray index, an address).
    pub fn input_word(&mut self, name: &str, w: Word) -> NodeId {
        self.push(name, Op::Input, w, None)
    }

    /// A constant `raw 2^-w.frac`.
    pub fn constant(&mut self, name: &str, raw: i128, w: Word) -> NodeId {
        self.push(name, Op::Const(raw), w, None)
    }

    /// `a + b` in `w`.
    pub fn add(&mut self, name: &str, a: NodeId, b: NodeId, w: Word) -> NodeId {
        self.push(name, Op::Add(a, b), w, None)
    }

    /// `a - b` in `w`.
    pub fn sub(&mut self, name: &str, a: NodeId, b: NodeId, w: Word) -> NodeId {
        self.push(name, Op::Sub(a, b), w, None)
    }

    /// `a b` in `w` (its fraction is the operands' sum).
    pub fn mul(&mut self, name: &str, a: NodeId, b: NodeId, w: Word) -> NodeId {
        debug_assert_eq!(w.frac, self.word(a).frac + self.word(b).frac, "{name}");
        self.push(name, Op::Mul(a, b), w, None)
    }

    /// `a b` in the narrowest word holding every product.
    pub fn mul_exact(&mut self, name: &str, a: NodeId, b: NodeId) -> NodeId {
        let (x, y) = (self.word(a), self.word(b));
        let w = Word {
            bits: x.bits + y.bits,
            frac: x.frac + y.frac,
            signed: x.signed || y.signed,
        };
        self.mul(name, a, b, w)
    }

    /// `x` assigned into `f`.
    pub fn quantize(&mut self, name: &str, x: NodeId, f: Format) -> NodeId {
        self.push(name, Op::Quantize(x), f.into(), Some(f))
    }

    /// Bits `lo ..` of `x`'s raw word as `w`.
    pub fn field(&mut self, name: &str, x: NodeId, lo: i32, w: Word) -> NodeId {
        self.push(name, Op::Field(x, lo), w, None)
    }

    /// A declared register of `d`.
    pub fn reg(&mut self, name: &str, d: NodeId) -> NodeId {
        let (w, f) = (self.word(d), self.node(d).fmt);
        self.push(name, Op::Reg(d), w, f)
    }

    /// A memory of `depth` words of `fmt`.
    pub fn mem(&mut self, name: &str, depth: u64, fmt: Format) -> MemId {
        self.mems.push(Mem {
            name: name.to_owned(),
            depth,
            fmt,
        });
        MemId(self.mems.len() - 1)
    }

    /// A read of `m` at `addr`.
    pub fn read(&mut self, name: &str, m: MemId, addr: NodeId) -> NodeId {
        let f = self.mems[m.0].fmt;
        self.push(name, Op::Read(m, addr), f.into(), Some(f))
    }

    /// `a >= b` (one bit).
    pub fn ge(&mut self, name: &str, a: NodeId, b: NodeId) -> NodeId {
        self.push(name, Op::Ge(a, b), Word::unsigned(1, 0), None)
    }

    /// Whether any bit of `x` is set (one bit).
    pub fn nonzero(&mut self, name: &str, x: NodeId) -> NodeId {
        self.push(name, Op::NonZero(x), Word::unsigned(1, 0), None)
    }

    /// `sel ? t : f` in `w`.
    pub fn mux(&mut self, name: &str, sel: NodeId, f: NodeId, t: NodeId, w: Word) -> NodeId {
        self.push(name, Op::Mux { sel, f, t }, w, None)
    }

    /// `sel ? t : f` in the narrowest word holding both.
    pub fn select(&mut self, name: &str, sel: NodeId, f: NodeId, t: NodeId) -> NodeId {
        let (wf, wt) = (self.word(f), self.word(t));
        let w = joint(wf, wt, wf.frac.max(wt.frac), 0, false);
        self.mux(name, sel, f, t, w)
    }

    /// The smaller of `a` and `b`: a compare (`name.ge`) and a select.
    pub fn min(&mut self, name: &str, a: NodeId, b: NodeId) -> NodeId {
        let ge = self.ge(&format!("{name}.ge"), a, b);
        self.select(name, ge, a, b)
    }

    /// The larger of `a` and `b`: a compare (`name.ge`) and a select.
    pub fn max(&mut self, name: &str, a: NodeId, b: NodeId) -> NodeId {
        let ge = self.ge(&format!("{name}.ge"), b, a);
        self.select(name, ge, a, b)
    }

    /// `a + b` (`sub`: `a - b`) in the narrowest word holding every
    /// result.
    pub fn sum(&mut self, name: &str, a: NodeId, b: NodeId, sub: bool) -> NodeId {
        let (wa, wb) = (self.word(a), self.word(b));
        let w = joint(wa, wb, wa.frac.max(wb.frac), 1, sub);
        if sub {
            self.sub(name, a, b, w)
        } else {
            self.add(name, a, b, w)
        }
    }

    /// `num / den` truncated onto `w`'s grid, saturated ([`Op::Div`]).
    pub fn div(&mut self, name: &str, num: NodeId, den: NodeId, w: Word) -> NodeId {
        debug_assert!(!w.signed, "{name}: a quotient is unsigned");
        self.push(name, Op::Div(num, den), w, None)
    }

    /// `a + w (b - a)` assigned into `out` (`b = None`: the constant 1.0),
    /// sized by [`crate::cost::shapes::Lerp`]: the difference, the
    /// multiply, the sum and the assignment, named `name.d`, `.p`, `.s`
    /// and `name`.
    pub fn lerp(
        &mut self,
        name: &str,
        a: NodeId,
        b: Option<NodeId>,
        w: NodeId,
        out: Format,
    ) -> NodeId {
        let l = crate::cost::shapes::Lerp::new(
            self.word(a),
            b.map(|b| self.word(b)),
            self.word(w),
            out,
        );
        let b = match b {
            Some(b) => b,
            None => {
                let f = l.a.frac.max(0);
                let one = Word::unsigned(f as u32 + 1, f);
                self.constant(&format!("{name}.one"), 1 << f, one)
            }
        };
        let d = self.sub(&format!("{name}.d"), b, a, l.d);
        let p = self.mul(&format!("{name}.p"), w, d, l.p);
        let s = self.add(&format!("{name}.s"), a, p, l.s);
        self.quantize(name, s, out)
    }

    /// The nodes each node feeds, by node.
    pub fn consumers(&self) -> Vec<Vec<NodeId>> {
        let mut c = vec![Vec::new(); self.nodes.len()];
        for (i, n) in self.nodes.iter().enumerate() {
            for o in n.op.operands() {
                c[o.0].push(NodeId(i));
            }
        }
        c
    }

    /// The nodes `outputs` depend on, stopping at `cut` (which are then
    /// the ports), in node order.
    pub fn cone(&self, outputs: &[NodeId], cut: &[NodeId]) -> Vec<NodeId> {
        let mut keep = vec![false; self.nodes.len()];
        let mut stack: Vec<NodeId> = outputs.to_vec();
        while let Some(n) = stack.pop() {
            if std::mem::replace(&mut keep[n.0], true) || cut.contains(&n) {
                continue;
            }
            stack.extend(self.nodes[n.0].op.operands());
        }
        (0..self.nodes.len())
            .filter(|&i| keep[i])
            .map(NodeId)
            .collect()
    }
}
