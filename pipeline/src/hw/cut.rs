//! Cuts of a datapath description: the named cuts' port lists
//! ([`spec`], what [`super::unit::Unit`] and [`crate::rtl`]'s calibration
//! modules are cut with), the cone of a cut's outputs made a graph of its
//! own (`subgraph`), and the registers on a cut's paths
//! (`cut_latency`).

use super::sample::class_names;
use super::unit::UnitError;
use super::{Graph, Node, NodeId, Op};

/// A cut's port list: `(Verilog port, node)` pairs and `(Verilog output,
/// node)` pairs.
pub struct Spec {
    /// Ports.
    pub ports: Vec<(&'static str, &'static str)>,
    /// Registered outputs.
    pub outputs: Vec<(&'static str, &'static str)>,
}

/// The port list of the cut `name` of `g` (a plain sample's description),
/// if `name` is a cut.
pub fn spec(g: &Graph, name: &str) -> Option<Spec> {
    match name {
        // Two stages: the x lerps of the two voxel rows, registered with
        // the y weight, then the y lerp.
        "bilinear" => Some(Spec {
            ports: vec![
                ("v00", "v00"),
                ("v01", "v01"),
                ("v10", "v10"),
                ("v11", "v11"),
                ("wx", "wx"),
                ("wy", "row.wy"),
            ],
            outputs: vec![("y", "sample")],
        }),
        // One sample into a ray's accumulators, in the graph's order.
        "composite" => {
            let c = class_names(g);
            Some(Spec {
                ports: vec![
                    ("acc_r", "acc_r"),
                    ("acc_g", "acc_g"),
                    ("acc_b", "acc_b"),
                    ("acc_a", "acc_a"),
                    ("c_r", c[0]),
                    ("c_g", c[1]),
                    ("c_b", c[2]),
                    ("a", "corrected"),
                ],
                outputs: vec![
                    ("y_r", "comp.r"),
                    ("y_g", "comp.g"),
                    ("y_b", "comp.b"),
                    ("y_a", "comp.a"),
                ],
            })
        }
        _ => None,
    }
}

/// `op` with its operands renamed by `m`.
fn remap(op: Op, m: &dyn Fn(NodeId) -> NodeId) -> Op {
    match op {
        Op::Input | Op::Const(_) => op,
        Op::Add(a, b) => Op::Add(m(a), m(b)),
        Op::Sub(a, b) => Op::Sub(m(a), m(b)),
        Op::Mul(a, b) => Op::Mul(m(a), m(b)),
        Op::Ge(a, b) => Op::Ge(m(a), m(b)),
        Op::Eq(a, b) => Op::Eq(m(a), m(b)),
        Op::ShrQuantize(a, b) => Op::ShrQuantize(m(a), m(b)),
        Op::Quantize(x) => Op::Quantize(m(x)),
        Op::Field(x, lo) => Op::Field(m(x), lo),
        Op::NonZero(x) => Op::NonZero(m(x)),
        Op::Reg(x) => Op::Reg(m(x)),
        Op::Isqrt(x) => Op::Isqrt(m(x)),
        Op::Div(a, b) => Op::Div(m(a), m(b)),
        Op::Read(mem, a) => Op::Read(mem, m(a)),
        Op::Mux { sel, f, t } => Op::Mux {
            sel: m(sel),
            f: m(f),
            t: m(t),
        },
    }
}

/// The cone of `outputs` in `g`, stopping at `ports`, which become
/// inputs: returns the graph and each port's and output's new node.
pub(crate) fn subgraph(
    g: &Graph,
    ports: &[NodeId],
    outputs: &[(String, NodeId)],
) -> (Graph, Vec<NodeId>, Vec<NodeId>) {
    let outs: Vec<NodeId> = outputs.iter().map(|o| o.1).collect();
    let cone = g.cone(&outs, ports);
    let mut new = vec![None; g.nodes.len()];
    let mut s = Graph {
        mems: g.mems.clone(),
        items: g.items.clone(),
        ..Graph::default()
    };
    for &id in &cone {
        let n = g.node(id);
        let op = if ports.contains(&id) {
            Op::Input
        } else {
            remap(n.op, &|o: NodeId| new[o.0].expect("operands come first"))
        };
        s.nodes.push(Node { op, ..n.clone() });
        new[id.0] = Some(NodeId(s.nodes.len() - 1));
    }
    let at = |id: &NodeId| new[id.0].expect("in the cone");
    for (name, id) in outputs {
        s.outputs.push((name.clone(), at(id)));
    }
    (
        s,
        ports.iter().map(at).collect(),
        outs.iter().map(at).collect(),
    )
}

/// The registers on every path of the cut from `ports` to `outputs` as
/// [`super::verilog::cut`] emits it (declared registers, step registers
/// inside, the output register), or why the paths differ.
pub(crate) fn cut_latency(
    g: &Graph,
    ports: &[NodeId],
    outputs: &[NodeId],
) -> Result<u32, UnitError> {
    let cone = g.cone(outputs, ports);
    // Per node: the registers between the ports and its value (None for a
    // constant, which every stage has).
    let mut at: Vec<Option<u32>> = vec![None; g.nodes.len()];
    for &id in &cone {
        let n = g.node(id);
        if ports.contains(&id) {
            at[id.0] = Some(0);
            continue;
        }
        let mut d = None;
        for o in n.op.operands() {
            match (d, at[o.0]) {
                (Some(a), Some(b)) if a != b => {
                    return Err(UnitError::Argument(format!(
                        "{}: operands arrive after {a} and {b} registers; the cut is not a balanced pipeline",
                        n.name
                    )))
                }
                (None, b) => d = b,
                _ => {}
            }
        }
        let registered =
            matches!(n.op, Op::Reg(_)) || (n.step_out.is_some() && !outputs.contains(&id));
        at[id.0] = d.map(|d| d + u32::from(registered));
    }
    let mut lat = None;
    for o in outputs {
        let d = at[o.0].unwrap_or(0) + 1;
        if lat.is_some_and(|l| l != d) {
            return Err(UnitError::Argument(
                "the cut's outputs have different latencies".into(),
            ));
        }
        lat = Some(d);
    }
    Ok(lat.unwrap_or(0))
}
