//! Verilog-2005 text of a cut of a [`Graph`]: the nodes between named
//! ports and named outputs, each operator as one expression at its wired
//! width, every assignment emitted by [`crate::rtl`]'s quantiser (`TRN`
//! or `RND`, and the overflow modes). Registers are the declared ones
//! ([`Op::Reg`]), the step registers of the model's schedule
//! ([`super::Node::step_out`]) inside the cut and the outputs, so the
//! module is the unit the cost items price.
//!
//! Not emitted yet (refused with [`RtlError::Unsupported`]): memory reads
//! and ports inside the cut (they must be the cut's ports) and the integer
//! square root.

use super::{Graph, NodeId, Op, Word};
use crate::cost::shapes::Quantizer;
use crate::rtl::{module, quantize, range, shl, Body, RtlError};

/// A node's wire.
fn wire(g: &Graph, id: NodeId) -> String {
    format!("n_{}", g.node(id).name.replace('.', "_"))
}

/// `x` (of word `w`) shifted up `k` bits, as a signed expression.
fn signed_at(x: &str, w: Word, k: i32) -> String {
    let e = shl(x, k);
    if w.signed {
        format!("$signed({e})")
    } else {
        format!("$signed({{1'b0, {e}}})")
    }
}

/// Emits node `id` of `g` as the combinational wire `v` (its operands
/// read through `get`): every operator but a port, a register, a memory
/// read and a square root, which are not logic of one stage (`Ok(false)`,
/// nothing emitted).
pub(crate) fn comb(
    b: &mut Body,
    g: &Graph,
    id: NodeId,
    v: &str,
    get: &dyn Fn(NodeId) -> String,
) -> Result<bool, RtlError> {
    let n = g.node(id);
    let w = n.word;
    let decl = format!(
        "wire {}{} {v}",
        if w.signed { "signed " } else { "" },
        range(w.bits)
    );
    match n.op {
        Op::Const(c) => {
            if c < 0 {
                return Err(RtlError::Unsupported(format!(
                    "negative constant {}",
                    n.name
                )));
            }
            b.line(&format!("{decl} = {}'d{c};", w.bits));
        }
        Op::Add(x, y) | Op::Sub(x, y) => {
            let op = if matches!(n.op, Op::Add(..)) {
                "+"
            } else {
                "-"
            };
            let (wx, wy) = (g.word(x), g.word(y));
            if w.signed {
                b.line(&format!(
                    "{decl} = {} {op} {};",
                    signed_at(&get(x), wx, w.frac - wx.frac),
                    signed_at(&get(y), wy, w.frac - wy.frac)
                ));
            } else {
                b.line(&format!(
                    "{decl} = {} {op} {};",
                    shl(&get(x), w.frac - wx.frac),
                    shl(&get(y), w.frac - wy.frac)
                ));
            }
        }
        Op::Mul(x, y) => {
            let (wx, wy) = (g.word(x), g.word(y));
            if w.signed {
                b.line(&format!(
                    "{decl} = {} * {};",
                    signed_at(&get(x), wx, 0),
                    signed_at(&get(y), wy, 0)
                ));
            } else {
                b.line(&format!("{decl} = {} * {};", get(x), get(y)));
            }
        }
        Op::Quantize(x) => {
            let q = Quantizer::new(g.word(x), n.fmt.expect("format"));
            let y = quantize(b, &get(x), &q)?;
            b.line(&format!("{decl} = {y};"));
        }
        Op::ShrQuantize(x, s) => {
            // One guard bit below the word, shifted, then assigned:
            // for TRN and RND the guard bit is all the rounding reads.
            let wx = g.word(x);
            let gw = Word::unsigned(wx.bits + 1, wx.frac + 1);
            let gv = format!("{v}_g");
            b.line(&format!(
                "wire {} {gv} = {{{}, 1'b0}} >> {};",
                range(gw.bits),
                get(x),
                get(s)
            ));
            let q = Quantizer::new(gw, n.fmt.expect("format"));
            let y = quantize(b, &gv, &q)?;
            b.line(&format!("{decl} = {y};"));
        }
        Op::Field(x, lo) => {
            let wx = g.word(x);
            // A part-select of a concatenation is not Verilog-2005: the
            // shifted word gets its own wire.
            let src = if lo < 0 {
                let sh = format!("{v}_sh");
                b.line(&format!(
                    "wire {} {sh} = {};",
                    range(wx.bits + (-lo) as u32),
                    shl(&get(x), -lo)
                ));
                sh
            } else {
                get(x)
            };
            let (lo, width) = if lo < 0 {
                (0, wx.bits + (-lo) as u32)
            } else {
                (lo as u32, wx.bits)
            };
            let hi = lo + w.bits - 1;
            if hi < width {
                b.line(&format!("{decl} = {src}[{hi}:{lo}];"));
            } else {
                b.line(&format!(
                    "{decl} = {{{}'b0, {src}[{}:{lo}]}};",
                    hi + 1 - width,
                    width - 1
                ));
            }
        }
        Op::Ge(x, y) | Op::Eq(x, y) => {
            let op = if matches!(n.op, Op::Ge(..)) {
                ">="
            } else {
                "=="
            };
            let (wx, wy) = (g.word(x), g.word(y));
            let f = wx.frac.max(wy.frac);
            b.line(&format!(
                "{decl} = {} {op} {};",
                signed_at(&get(x), wx, f - wx.frac),
                signed_at(&get(y), wy, f - wy.frac)
            ));
        }
        Op::NonZero(x) => b.line(&format!("{decl} = |{};", get(x))),
        Op::Mux { sel, f, t } => {
            let (wf, wt) = (g.word(f), g.word(t));
            b.line(&format!(
                "{decl} = {} ? {} : {};",
                get(sel),
                shl(&get(t), w.frac - wt.frac),
                shl(&get(f), w.frac - wf.frac)
            ));
        }
        _ => return Ok(false),
    }
    Ok(true)
}

/// The body, registers and outputs of the cut of `g` from `ports` to
/// `outputs` (each `(Verilog name, node)`).
pub struct Cut {
    /// The logic.
    pub(crate) body: Body,
    /// Registers: name, bits, source.
    pub regs: Vec<(String, u32, String)>,
    /// Registered outputs: name, bits, source.
    pub outputs: Vec<(String, u32, String)>,
    /// Ports: name and word.
    pub ports: Vec<(String, Word)>,
}

/// Emits the cut of `g` from `ports` to `outputs`.
pub fn cut(
    g: &Graph,
    ports: &[(&str, NodeId)],
    outputs: &[(&str, NodeId)],
) -> Result<Cut, RtlError> {
    let outs: Vec<NodeId> = outputs.iter().map(|o| o.1).collect();
    let cut_ids: Vec<NodeId> = ports.iter().map(|p| p.1).collect();
    let cone = g.cone(&outs, &cut_ids);
    // What a consumer reads for each node: a port, a wire or a register.
    let mut name: Vec<Option<String>> = vec![None; g.nodes.len()];
    for (p, id) in ports {
        name[id.0] = Some((*p).to_owned());
    }
    let mut b = Body::new();
    let mut regs = Vec::new();
    for &id in &cone {
        if name[id.0].is_some() {
            continue;
        }
        let n = g.node(id);
        let w = n.word;
        let v = wire(g, id);
        let get = |o: NodeId| name[o.0].clone().expect("operands come first");
        match n.op {
            Op::Reg(d) => {
                regs.push((v.clone(), w.bits, get(d)));
                name[id.0] = Some(v);
                continue;
            }
            Op::Input | Op::Read(..) | Op::Isqrt(_) | Op::Div(..) => {
                return Err(RtlError::Unsupported(format!(
                    "{} inside a cut ({})",
                    match n.op {
                        Op::Isqrt(_) => "an integer square root",
                        Op::Div(..) => "a divider",
                        Op::Read(..) => "a memory read",
                        _ => "a port",
                    },
                    n.name
                )))
            }
            _ => {
                comb(&mut b, g, id, &v, &get)?;
            }
        }
        // A step register inside the cut: its readers read the register.
        if n.step_out.is_some() && !outs.contains(&id) {
            let r = format!("{v}_r");
            regs.push((r.clone(), w.bits, v));
            name[id.0] = Some(r);
        } else {
            name[id.0] = Some(v);
        }
    }
    let outputs = outputs
        .iter()
        .map(|(o, id)| {
            let src = name[id.0].clone().expect("an output is in the cone");
            ((*o).to_owned(), g.word(*id).bits, src)
        })
        .collect();
    let ports = ports
        .iter()
        .map(|(p, id)| ((*p).to_owned(), g.word(*id)))
        .collect();
    Ok(Cut {
        body: b,
        regs,
        outputs,
        ports,
    })
}

/// The cut as a module named `name` with a clock and registered outputs.
pub fn cut_module(name: &str, comment: &str, c: &Cut) -> String {
    let ports: Vec<(&str, Word)> = c.ports.iter().map(|(n, w)| (n.as_str(), *w)).collect();
    module(name, comment, &ports, &c.regs, &c.outputs, &c.body)
}
