//! Scope `top.pe_K.hw`: the datapath description's nodes traced by name
//! (`--trace-nodes comp.*,class.addr1`), each as the pipelined module
//! would hold it.
//!
//! The traced graph is the sample's description for the frame
//! ([`crate::hw::compose::sample`] with the frame's units, the plain
//! sample without any), on the schedule the model's latency follows
//! ([`crate::cost::latency::graph_schedule`]). Every sample a traced PE
//! issues in a sampling cycle `t` is evaluated by [`crate::hw::eval`] on
//! the words it took ([`crate::cosim::capture::SampleIn`], the same bundle
//! a capture records) with the frame's tables and per-frame words; node
//! `n`, produced at stage `s` of the schedule, then shows that sample's
//! raw word in cycle `t + s`: the cycle in which the emitted module's wire
//! `n_<name>` carries it (its logic runs in stage `s`; a register or a
//! table read, whose stage ends at its register, shows the registered
//! word). Between samples a signal holds its last word, where the emitted
//! module's wires show whatever a bubble's zeros give (`valid_d<s>` tells
//! them apart there). The signal is named as the node with `.` as `_`
//! (`class_addr1`, the emitted wire without its `n_`), as wide as the
//! node's word, two's complement when the word is signed.
//!
//! The signals are outside the groups of `--trace-signals`: naming a node
//! is the selection. Without `--trace-nodes` none is registered, so the
//! default waveforms are unchanged. A pre-integrated frame is refused: its
//! unit is not composed into the sample's description.

use std::collections::{HashMap, VecDeque};

use waves::bitvec::prelude::{BitSlice, Lsb0};
use waves::{Sampler, ScopePath, SignalId, Tracer, WavesError};

use crate::cosim::capture::{frame_words, table_words, SampleIn};
use crate::cosim::replay::word_of;
use crate::datapath::Datapath;
use crate::fixed::QuantStats;
use crate::hw::pipeline_rtl::verilog_name;
use crate::hw::{eval::eval, Graph, NodeId, Op};
use crate::pe::Pe;

/// The scope below `top.pe_K` holding the traced nodes.
pub const SCOPE: &str = "hw";

/// Parses `--trace-nodes`' comma-separated patterns (`*` matches any run
/// of characters, dots included); an empty pattern is an error.
pub fn parse_node_patterns(text: &str) -> Result<Vec<String>, String> {
    let pats: Vec<String> = text.split(',').map(|p| p.trim().to_owned()).collect();
    if pats.iter().any(String::is_empty) {
        return Err(format!(
            "--trace-nodes {text:?}: an empty pattern (give names such as comp.*,class.addr1)"
        ));
    }
    Ok(pats)
}

/// Whether `name` matches `pat` (`*`: any run of characters).
fn glob(pat: &str, name: &str) -> bool {
    let parts: Vec<&str> = pat.split('*').collect();
    if parts.len() == 1 {
        return pat == name;
    }
    let (first, last) = (parts[0], parts[parts.len() - 1]);
    if !name.starts_with(first) || name.len() < first.len() + last.len() || !name.ends_with(last) {
        return false;
    }
    let mut rest = &name[first.len()..name.len() - last.len()];
    for mid in &parts[1..parts.len() - 1] {
        match rest.find(mid) {
            Some(i) => rest = &rest[i + mid.len()..],
            None => return false,
        }
    }
    true
}

/// The sample's description a frame with `units` (shading's lights, the
/// volume of interest; `preint`: pre-integrated) traces; a pre-integrated
/// frame is refused in one line.
pub fn description(
    cfg: &crate::config::PipelineConfig,
    units: crate::hw::compose::Units,
    preint: bool,
) -> Result<Graph, String> {
    if preint {
        return Err("--trace-nodes: a pre-integrated sample can composite two steps (back to front, slice 0's), where the trace evaluates the description once an issue; trace it without --preintegrate".into());
    }
    Ok(crate::hw::compose::sample(cfg, units))
}

/// The nodes of `g` the patterns name, in node order; a pattern naming
/// none is an error naming it.
pub fn select(g: &Graph, patterns: &[String]) -> Result<Vec<NodeId>, String> {
    if let Some(p) = patterns
        .iter()
        .find(|p| !g.nodes.iter().any(|n| glob(p, &n.name)))
    {
        let some: Vec<&str> = g.probe_names().into_iter().take(6).collect();
        return Err(format!(
            "--trace-nodes: unknown description node {p:?} (the frame's datapath has {} nodes: {}, ...; `*` traces them all)",
            g.nodes.len(),
            some.join(", ")
        ));
    }
    Ok((0..g.nodes.len())
        .filter(|&i| patterns.iter().any(|p| glob(p, &g.nodes[i].name)))
        .map(NodeId)
        .collect())
}

/// Where an input port's word comes from.
enum Source {
    /// A word of the issued bundle (the emitted port's name).
    Issue(String),
    /// A per-frame word.
    Frame(i64),
}

/// The traced nodes of a run: the description, its schedule, the frame's
/// tables, and per traced PE the recent issues' words.
pub(crate) struct NodeTrace {
    graph: Graph,
    /// The selected nodes and each one's stage.
    nodes: Vec<(NodeId, u32)>,
    /// The deepest selected stage.
    span: u32,
    /// Per input node (by probe name): its word's source.
    inputs: HashMap<String, Source>,
    /// Per memory: its words (`None`: the voxel taps).
    tables: Vec<Option<Vec<i64>>>,
    /// Per PE: each selected node's signal.
    ids: Vec<Vec<SignalId>>,
    /// Per PE: the issues of the last `span + 1` cycles and the selected
    /// nodes' words.
    recent: Vec<VecDeque<(u64, Vec<i128>)>>,
    /// The first evaluation that failed (the model's words outside the
    /// description's, which the tests rule out).
    error: Option<String>,
}

impl NodeTrace {
    /// Registers `patterns`' nodes of `dp`'s description in `p` PEs.
    pub(crate) fn new(
        tracer: &mut Tracer,
        p: usize,
        dp: &Datapath,
        patterns: &[String],
    ) -> Result<NodeTrace, WavesError> {
        let spec = |reason: String| WavesError::InvalidSpec {
            what: "description node list",
            text: patterns.join(","),
            reason,
        };
        let graph = description(&dp.cfg, dp.units(), dp.units().preint).map_err(spec)?;
        let sel = select(&graph, patterns).map_err(spec)?;
        let sch = crate::cost::latency::graph_schedule(&dp.cfg, &graph);
        let nodes: Vec<(NodeId, u32)> = sel.iter().map(|&id| (id, sch.stage[id.0])).collect();
        let span = nodes.iter().map(|n| n.1).max().unwrap_or(0);
        let frame = frame_words(dp);
        let inputs = graph
            .nodes
            .iter()
            .filter(|n| n.op == Op::Input)
            .map(|n| {
                let v = verilog_name(&n.name);
                let src = match frame.iter().find(|f| f.0 == v) {
                    Some(f) => Source::Frame(f.1),
                    None => Source::Issue(v),
                };
                (n.name.clone(), src)
            })
            .collect();
        let words = table_words(dp);
        let tables = graph
            .mems
            .iter()
            .map(|m| {
                (m.depth > 0).then(|| {
                    words
                        .iter()
                        .find(|t| t.0 == m.name)
                        .map(|t| t.1.clone())
                        .unwrap_or_default()
                })
            })
            .collect();
        let mut ids = Vec::with_capacity(p);
        for k in 0..p {
            let scope = ScopePath::pe(k as u32).child(SCOPE);
            let pe = nodes
                .iter()
                .map(|(id, _)| {
                    let n = graph.node(*id);
                    tracer.register(&scope, &verilog_name(&n.name), n.word.bits)
                })
                .collect::<Result<Vec<_>, _>>()?;
            ids.push(pe);
        }
        Ok(NodeTrace {
            graph,
            nodes,
            span,
            inputs,
            tables,
            recent: vec![VecDeque::new(); p],
            ids,
            error: None,
        })
    }

    /// The selected nodes' words for the sample that took `s`.
    fn words(&self, s: &SampleIn) -> Result<Vec<i128>, String> {
        let g = &self.graph;
        let issue = crate::cosim::capture::Issue {
            cycle: 0,
            pe: 0,
            input: *s,
            out: Default::default(),
        };
        let input = |name: &str| -> Option<i64> {
            match self.inputs.get(name)? {
                Source::Frame(w) => Some(*w),
                Source::Issue(v) => word_of(&issue, v),
            }
        };
        let read = |node: &str, m: crate::hw::MemId, addr: i128| -> Option<i64> {
            match &self.tables[m.0] {
                Some(words) => words.get(usize::try_from(addr).ok()?).copied(),
                None => {
                    let k = ["v00", "v01", "v10", "v11"]
                        .iter()
                        .position(|t| *t == node)?;
                    Some(i64::from(s.taps[k]))
                }
            }
        };
        let v = eval(g, &input, &read, &mut QuantStats::default()).map_err(|e| e.to_string())?;
        Ok(self.nodes.iter().map(|(id, _)| v[id.0]).collect())
    }

    /// Cycle `cycle` (of the sampling stage when `sampling`): evaluates
    /// the samples the traced PEs issued in it and sets every selected
    /// node to the word of the sample its stage holds.
    pub(crate) fn sample(&mut self, tracer: &mut Tracer, cycle: u64, pes: &[Pe], sampling: bool) {
        // Only an issue some traced cycle shows is evaluated.
        let shown = (0..=u64::from(self.span)).any(|s| tracer.is_active(cycle + s));
        for (k, pe) in pes.iter().enumerate() {
            let ring = &mut self.recent[k];
            while ring
                .front()
                .is_some_and(|(t, _)| t + u64::from(self.span) < cycle)
            {
                ring.pop_front();
            }
            if !(sampling && shown && pe.last.busy && self.ids[k].iter().any(|i| i.is_traced())) {
                continue;
            }
            match self.words(&pe.last.issue) {
                Ok(w) => self.recent[k].push_back((cycle, w)),
                Err(e) => {
                    self.error
                        .get_or_insert(format!("cycle {cycle}, PE {k}: {e}"));
                }
            }
        }
        let NodeTrace {
            graph,
            nodes,
            ids,
            recent,
            ..
        } = self;
        tracer.sample(cycle, |s| {
            for (pe, ring) in ids.iter().zip(recent.iter()) {
                for (j, &(id, stage)) in nodes.iter().enumerate() {
                    let at = cycle.checked_sub(u64::from(stage));
                    let Some(at) = at else { continue };
                    if let Ok(i) = ring.binary_search_by_key(&at, |e| e.0) {
                        set(s, pe[j], ring[i].1[j], graph.word(id).bits);
                    }
                }
            }
        });
    }

    /// The first evaluation that failed, if any.
    pub(crate) fn error(&self) -> Option<WavesError> {
        self.error.as_ref().map(|e| WavesError::InvalidSpec {
            what: "description node",
            text: e.clone(),
            reason: "the description does not evaluate on the model's words".into(),
        })
    }
}

/// Sets `id` to the raw word `v` over `bits` bits (two's complement).
fn set(s: &mut Sampler<'_>, id: SignalId, v: i128, bits: u32) {
    let u = v as u128;
    if bits <= 64 {
        let m = if bits == 64 {
            u64::MAX
        } else {
            (1 << bits) - 1
        };
        s.set(id, u as u64 & m);
    } else {
        let words = [u as u64, (u >> 64) as u64];
        let all = BitSlice::<u64, Lsb0>::from_slice(&words);
        s.set_bits(id, &all[..bits.min(128) as usize]);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::PipelineConfig;

    #[test]
    fn patterns_glob_and_unknown_nodes_are_refused() {
        assert!(glob("comp.*", "comp.r.p"));
        assert!(glob("*.addr1", "class.addr1"));
        assert!(glob("c*s*1", "class.addr1"));
        assert!(!glob("comp.*", "composite"));
        assert!(!glob("class.addr", "class.addr1"));
        let g = crate::hw::sample::plain(&PipelineConfig::default());
        let p = parse_node_patterns("comp.*, class.addr1").unwrap();
        let sel = select(&g, &p).unwrap();
        let names: Vec<&str> = sel.iter().map(|id| g.node(*id).name.as_str()).collect();
        assert!(names.contains(&"class.addr1") && names.contains(&"comp.r"));
        assert!(names
            .iter()
            .all(|n| n.starts_with("comp.") || *n == "class.addr1"));
        let e = select(&g, &["nope".to_owned()]).unwrap_err();
        assert!(e.contains("\"nope\"") && !e.contains('\n'), "{e}");
        assert!(parse_node_patterns("a,,b").is_err());
        let units = crate::hw::compose::Units::default();
        assert!(description(&PipelineConfig::default(), units, true).is_err());
    }
}
