//! The sample's datapath with its units composed into one description:
//! the volume-of-interest stage ([`super::voi::voi`]) and the gradient
//! and shading unit ([`super::shading::shading`]) spliced between the
//! classification and the opacity correction of
//! [`super::sample::with_units`], as the model's PE runs them
//! (`crate::stages::sample`: the classified opacity scaled by the VOI's
//! factor, then shaded). The composed graph is scheduled and emitted like
//! the plain one, and its depth is the model's write-back latency
//! ([`crate::cost::latency::sample_latency`]).
//!
//! A spliced unit keeps its nodes, memories and cost items; its ports
//! that the sample already computes are wired to it (the VOI's `x`, the
//! shading's `wx`, `wy`, the four scalar taps, the classified colour and
//! opacity), the others become ports of the composed module named
//! `voi.<port>` and `shade.<port>` (`voi_centre_x`, `shade_tx_0_0`, ...).
//! The model's shading unit is clock-gated for an invisible sample; the
//! composed one always computes, and an invisible sample's opacity is
//! zero either way (the gradient opacity scales it), so the write-back is
//! the same.
//!
//! The pre-integration unit's ports the sample does not compute are
//! `pre.prev` (the ray's previous sample, read with its accumulators),
//! `pre.step` (the sample composites a step; without it the
//! accumulators are written back as they were: a sample that only keeps
//! its scalar for the next step), `pre.lead` (the step is slice 0's half
//! step at the sample), `pre.half` (the step's path is halved: the last
//! slice's step to the volume's face) and `pre.scale` (the frame's table
//! scale). Back to front the sample is the step's front scalar and the
//! previous sample its back one; front to back the reverse, and a lead
//! step's front is the sample too (a select by `pre.lead`), as
//! `crate::stages::sample`'s pre-integrated half calls
//! [`crate::preint::PreintUnit::lookup`]. One issue composites one step:
//! the model's sample that composites two (back to front, slice 0's step
//! and then its half step) is two steps of this description.

use std::collections::HashMap;

use super::sample::{with_preint, with_units, Classified, Corrected, Sampled};
use super::Word;
use super::{Graph, MemId, Node, NodeId, Op};
use crate::config::Order;
use crate::config::PipelineConfig;

/// The units a sample's datapath carries besides the plain sample: the
/// one list of them, which the datapath, the PE's declaration and the
/// cost's [`Geometry`](crate::cost::inventory::Geometry) carry as it is
/// (its JSON keys are the cost report's: `shading`, `voi`, and `preint`
/// when set).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize)]
pub struct Units {
    /// The gradient and shading unit, built for this many lights (none
    /// without shading).
    #[serde(rename = "shading", serialize_with = "present")]
    pub lights: Option<usize>,
    /// The volume-of-interest stage.
    pub voi: bool,
    /// The pre-integration unit in the classification's and the log
    /// table's place (not with the others: golden neither shades nor
    /// weights pre-integrated steps).
    #[serde(skip_serializing_if = "std::ops::Not::not")]
    pub preint: bool,
}

impl Units {
    /// Whether the datapath is the plain sample's.
    pub fn plain(&self) -> bool {
        self.lights.is_none() && !self.voi && !self.preint
    }

    /// Whether it carries the gradient and shading unit.
    pub fn shading(&self) -> bool {
        self.lights.is_some()
    }
}

/// The units of [`Units`] with their per-frame constants, one slot each:
/// a unit's model file fills its slot from golden's input
/// ([`crate::datapath::FrameUnit`]), the datapath carries them
/// ([`crate::datapath::Datapath::loaded`]) and the PE's sample reads
/// them (`crate::stages::sample`).
#[derive(Debug, Clone, Default)]
pub struct FrameUnits {
    /// The gradient and shading unit's lights, material and tables.
    pub shade: Option<crate::shading::ShadeUnit>,
    /// The volume-of-interest stage's region and weighting.
    pub voi: Option<crate::voi::VoiUnit>,
    /// The pre-integration unit's table and scale.
    pub preint: Option<crate::preint::PreintUnit>,
}

impl FrameUnits {
    /// The units these constants are loaded for.
    pub fn units(&self) -> Units {
        Units {
            lights: self.shade.as_ref().map(|s| s.light_count()),
            voi: self.voi.is_some(),
            preint: self.preint.is_some(),
        }
    }

    /// Whether none is loaded (the plain sample).
    #[inline]
    pub fn plain(&self) -> bool {
        self.units().plain()
    }

    /// Refuses units [`sample`] does not compose together: the
    /// pre-integration unit takes the classification's place, which the
    /// shading unit and the VOI stage act on.
    pub fn check(&self) -> Result<(), crate::preint::PreintError> {
        let u = self.units();
        let other = match (u.preint, u.shading(), u.voi) {
            (true, true, _) => "shading",
            (true, false, true) => "volume of interest",
            _ => return Ok(()),
        };
        Err(crate::preint::PreintError::Unsupported(format!(
            "the pipeline's pre-integrated frames take no {other}; drop it or --preintegrate"
        )))
    }
}

/// A unit built for some count, as the JSON's flag: whether it is there.
fn present<S: serde::Serializer>(n: &Option<usize>, s: S) -> Result<S::Ok, S::Error> {
    s.serialize_bool(n.is_some())
}

/// The ports of the VOI stage the sample does not compute: the row's y
/// position and the slice index, as the composed module names them.
pub const VOI_ROW_PORTS: [&str; 2] = ["voi.y", "voi.z"];

/// The shading unit's voxel taps that are not the scalar's four, in the
/// order [`crate::cosim::capture::UnitIn::taps`] holds them.
pub const SHADE_TAPS: [&str; 16] = [
    "tx.0.0", "tx.0.3", "tx.1.0", "tx.1.3", "ty.0.0", "ty.0.1", "ty.1.0", "ty.1.1", "tz.0.0.0",
    "tz.0.0.1", "tz.0.1.0", "tz.0.1.1", "tz.1.0.0", "tz.1.0.1", "tz.1.1.0", "tz.1.1.1",
];

/// `unit`'s nodes added to `g`: its inputs named in `bind` wired to
/// those nodes, its other nodes named with `prefix` (unless their name
/// already starts with it), its memories shared by name or added, its
/// cost items merged by name. Returns the unit's outputs by name.
pub fn splice(
    g: &mut Graph,
    unit: &Graph,
    prefix: &str,
    bind: &[(&str, NodeId)],
) -> HashMap<String, NodeId> {
    let mems: Vec<MemId> = unit
        .mems
        .iter()
        .map(|m| match g.mems.iter().position(|x| x.name == m.name) {
            Some(i) => MemId(i),
            None => g.mem(&m.name, m.depth, m.fmt),
        })
        .collect();
    let items: Vec<usize> = unit
        .items
        .iter()
        .map(|it| match g.items.iter().position(|x| x.name == it.name) {
            Some(i) => i,
            None => {
                g.items.push(it.clone());
                g.items.len() - 1
            }
        })
        .collect();
    let mut map: Vec<NodeId> = Vec::with_capacity(unit.nodes.len());
    for n in &unit.nodes {
        if let (Op::Input, Some(&(_, id))) = (n.op, bind.iter().find(|b| b.0 == n.name)) {
            map.push(id);
            continue;
        }
        let m = |id: NodeId| map[id.0];
        let op = match n.op {
            Op::Input => Op::Input,
            Op::Const(c) => Op::Const(c),
            Op::Add(a, b) => Op::Add(m(a), m(b)),
            Op::Sub(a, b) => Op::Sub(m(a), m(b)),
            Op::Mul(a, b) => Op::Mul(m(a), m(b)),
            Op::Quantize(x) => Op::Quantize(m(x)),
            Op::ShrQuantize(x, s) => Op::ShrQuantize(m(x), m(s)),
            Op::Field(x, lo) => Op::Field(m(x), lo),
            Op::Ge(a, b) => Op::Ge(m(a), m(b)),
            Op::Eq(a, b) => Op::Eq(m(a), m(b)),
            Op::NonZero(x) => Op::NonZero(m(x)),
            Op::Mux { sel, f, t } => Op::Mux {
                sel: m(sel),
                f: m(f),
                t: m(t),
            },
            Op::Read(mem, a) => Op::Read(mems[mem.0], m(a)),
            Op::Reg(d) => Op::Reg(m(d)),
            Op::Isqrt(x) => Op::Isqrt(m(x)),
            Op::Div(a, b) => Op::Div(m(a), m(b)),
        };
        let name = if n.name.starts_with(prefix) {
            n.name.clone()
        } else {
            format!("{prefix}{}", n.name)
        };
        let remap = |x: Option<(usize, u32)>| x.map(|(i, c)| (items[i], c));
        debug_assert!(g.find(&name).is_none(), "{name}: probe names are unique");
        g.nodes.push(Node {
            name,
            op,
            word: n.word,
            fmt: n.fmt,
            item: remap(n.item),
            step_out: remap(n.step_out),
        });
        map.push(NodeId(g.nodes.len() - 1));
    }
    unit.outputs
        .iter()
        .map(|(name, id)| (name.clone(), map[id.0]))
        .collect()
}

/// The sample's description for `cfg` with `units`: the plain sample
/// ([`super::sample::plain`]) when there are none. With `preint` the
/// other units are left out.
pub fn sample(cfg: &PipelineConfig, units: Units) -> Graph {
    if units.preint {
        return preintegrated(cfg);
    }
    with_units(cfg, &mut |g: &mut Graph, c: &Classified| {
        let mut alpha = c.alpha;
        let mut rgb = c.rgb;
        if units.voi {
            let unit = super::voi::voi(cfg);
            let out = splice(g, &unit, "voi.", &[("x", c.x), ("class.a", alpha)]);
            alpha = out["alpha"];
        }
        if let Some(lights) = units.lights {
            let unit = super::shading::shading(cfg, lights);
            let out = splice(
                g,
                &unit,
                "shade.",
                &[
                    ("tx.0.1", c.taps[0]),
                    ("tx.0.2", c.taps[1]),
                    ("tx.1.1", c.taps[2]),
                    ("tx.1.2", c.taps[3]),
                    ("wx", c.wx),
                    ("wy", c.wy),
                    ("class.r", rgb[0]),
                    ("class.g", rgb[1]),
                    ("class.b", rgb[2]),
                    ("class.a", alpha),
                ],
            );
            rgb = [out["c_r"], out["c_g"], out["c_b"]];
            alpha = out["alpha"];
        }
        (rgb, alpha)
    })
}

/// The sample's description with the pre-integration unit spliced in the
/// classification's and the log table's place.
fn preintegrated(cfg: &PipelineConfig) -> Graph {
    let unit = super::preint::preint(cfg);
    with_preint(cfg, &mut |g: &mut Graph, s: &Sampled| {
        let bit = Word::unsigned(1, 0);
        let step = g.input_word("pre.step", bit);
        let lead = g.input_word("pre.lead", bit);
        let mut bind = vec![("lead", lead), ("len", s.ds)];
        match cfg.order {
            Order::BackToFront => bind.push(("front", s.sample)),
            Order::FrontToBack => {
                let prev = g.input("pre.prev", cfg.sample);
                let front = g.mux("pre.front_in", lead, prev, s.sample, cfg.sample.into());
                bind.extend([("front", front), ("prev", s.sample)]);
            }
        }
        let out = splice(g, &unit, "pre.", &bind);
        // A sample that composites no step leaves the accumulators as an
        // invisible one does: a select, no carry chain.
        let zero = g.constant("pre.no_step", 0, bit);
        let visible = g.mux("pre.visible_step", step, zero, out["visible"], bit);
        Corrected {
            rgb: [out["c_r"], out["c_g"], out["c_b"]],
            alpha: out["alpha"],
            visible,
        }
    })
}
