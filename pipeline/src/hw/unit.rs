//! A unit of the datapath as a verification model: the whole plain
//! sample ([`super::sample::plain`]) or a named cut of it (`bilinear`,
//! `composite`), with its ports, outputs, latency and memories, evaluated
//! one sample at a time by [`super::eval`]. The C ABI's `ErcubeDatapath`,
//! the SystemVerilog DPI-C package and the Python module's `Datapath` are
//! this type behind their boundaries, so a testbench's expected words are
//! the description's, which `hw::tests` proves equal to
//! [`crate::datapath::Datapath`]'s.
//!
//! Ports are named as the Verilog the description emits names them: a
//! cut's by its port list ([`spec`], also what [`crate::rtl`]'s
//! calibration modules are cut with); the whole sample's by its input
//! nodes' names with `.` made `_` (`slot_m`, `row_wy`), plus the four
//! voxel taps `v00`..`v11` (reads of the voxel memory, whose addressing is
//! outside the description). Outputs are the cut's or the graph's named
//! outputs.
//!
//! Latency: a cut is emitted with the model's step registers
//! ([`super::verilog`]), so its latency is the registers on each path
//! (every path holds the same number, checked); the whole sample's is its
//! pipelined schedule's depth ([`super::schedule`]).

use super::cut::{cut_latency, subgraph};
pub use super::cut::{spec, Spec};
use super::eval::{eval, EvalError};
use super::sample::{plain, MEMORIES};
use super::{Graph, NodeId, Op, Word};
use crate::config::{Order, PipelineConfig};
use crate::fixed::{Format, QuantStats};
use crate::rtl::RtlError;

/// The units, by name.
pub const NAMES: [&str; 3] = ["sample", "bilinear", "composite"];

/// The transfer function the tables hold until others are loaded (a
/// volume file's default in `ercube render`).
pub const DEFAULT_TF: &str = "grey-ramp";

/// Why a unit cannot be built or evaluated: one line naming the problem.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum UnitError {
    /// A name, a word, a table or a configuration that is wrong.
    #[error("{0}")]
    Argument(String),
    /// The description cannot evaluate these words (a value outgrew its
    /// node's word).
    #[error("{0}")]
    Eval(#[from] EvalError),
}

fn bad(msg: impl Into<String>) -> UnitError {
    UnitError::Argument(msg.into())
}

/// A port or an output: its name and raw word.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Port {
    /// The Verilog name.
    pub name: String,
    /// Width, fraction bits (the value is `raw 2^-frac`) and signedness.
    pub word: Word,
}

/// A memory the unit reads: its name, depth and stored format.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Table {
    /// `class_r`, ..., `log_table`, `exp_table`.
    pub name: String,
    /// Words.
    pub depth: usize,
    /// The stored format.
    pub fmt: Format,
}

/// A unit ready to evaluate: its description, ports and table contents.
#[derive(Debug, Clone)]
pub struct Unit {
    name: String,
    cfg: PipelineConfig,
    /// The whole description (what the Verilog is cut from).
    full: Graph,
    /// Ports and outputs in `full`.
    full_ports: Vec<(String, NodeId)>,
    full_outputs: Vec<(String, NodeId)>,
    /// The cone of the outputs, its ports made inputs: what is evaluated.
    graph: Graph,
    /// Per port, its node in `graph`.
    input_nodes: Vec<NodeId>,
    output_nodes: Vec<NodeId>,
    inputs: Vec<Port>,
    outputs: Vec<Port>,
    latency: u32,
    /// Per memory of `graph`: whether it is read, and its contents.
    tables: Vec<(Table, Vec<i64>)>,
}

/// `"btf"`/`"back-to-front"` or `"ftb"`/`"front-to-back"`.
pub fn parse_order(s: &str) -> Result<Order, UnitError> {
    match s.trim() {
        "btf" | "back-to-front" => Ok(Order::BackToFront),
        "ftb" | "front-to-back" => Ok(Order::FrontToBack),
        o => Err(bad(format!(
            "unknown order '{o}': expected btf (back-to-front) or ftb (front-to-back)"
        ))),
    }
}

impl Unit {
    /// The unit `name` ([`NAMES`]) of configuration `toml` (a `--config`
    /// file's text; `None` for the defaults), composited in `order`
    /// (`None`: the configuration's), its tables filled from
    /// [`DEFAULT_TF`].
    pub fn from_toml(
        toml: Option<&str>,
        order: Option<&str>,
        name: &str,
    ) -> Result<Unit, UnitError> {
        let mut cfg = match toml {
            Some(t) => PipelineConfig::from_toml_str(t).map_err(|e| bad(e.to_string()))?,
            None => PipelineConfig::default(),
        };
        if let Some(o) = order {
            cfg.order = parse_order(o)?;
        }
        cfg.validate().map_err(|e| bad(e.to_string()))?;
        Unit::new(&cfg, name)
    }

    /// The unit `name` of a validated configuration.
    pub fn new(cfg: &PipelineConfig, name: &str) -> Result<Unit, UnitError> {
        let full = plain(cfg);
        let node = |n: &str| {
            full.find(n)
                .ok_or_else(|| bad(format!("no node {n} in the description")))
        };
        let (ports, outputs, latency) = if name.trim() == "sample" {
            // Every input node, then the voxel taps.
            let taps = full.mems.iter().position(|m| m.name == "voxels");
            let ports: Vec<(String, NodeId)> = full
                .nodes
                .iter()
                .enumerate()
                .filter(|(_, n)| match n.op {
                    Op::Input => true,
                    Op::Read(m, _) => Some(m.0) == taps,
                    _ => false,
                })
                .map(|(i, n)| (n.name.replace('.', "_"), NodeId(i)))
                .collect();
            // The emitted module's schedule (`ercube rtl`'s, the model's
            // `datapath_latency`): one operator a stage, or packed for
            // `target_mhz`.
            let depth = crate::cost::latency::plain_depth(cfg);
            (ports, full.outputs.clone(), depth)
        } else if let Some(s) = spec(&full, name.trim()) {
            let ports: Vec<(String, NodeId)> = s
                .ports
                .iter()
                .map(|(p, n)| Ok((p.to_string(), node(n)?)))
                .collect::<Result<_, UnitError>>()?;
            let outputs: Vec<(String, NodeId)> = s
                .outputs
                .iter()
                .map(|(p, n)| Ok((p.to_string(), node(n)?)))
                .collect::<Result<_, UnitError>>()?;
            let ids: Vec<NodeId> = ports.iter().map(|p| p.1).collect();
            let outs: Vec<NodeId> = outputs.iter().map(|o| o.1).collect();
            let lat = cut_latency(&full, &ids, &outs)?;
            (ports, outputs, lat)
        } else {
            return Err(bad(format!(
                "unknown unit '{name}': expected {}",
                NAMES.join(", ")
            )));
        };
        let ids: Vec<NodeId> = ports.iter().map(|p| p.1).collect();
        let (graph, input_nodes, output_nodes) = subgraph(&full, &ids, &outputs);
        let port = |(n, id): &(String, NodeId)| Port {
            name: n.clone(),
            word: full.word(*id),
        };
        let inputs = ports.iter().map(port).collect();
        let outs = outputs.iter().map(port).collect();
        // The memories the evaluated cone still reads.
        let read: Vec<bool> = (0..graph.mems.len())
            .map(|m| {
                graph
                    .nodes
                    .iter()
                    .any(|n| matches!(n.op, Op::Read(x, _) if x.0 == m))
            })
            .collect();
        let tables = graph
            .mems
            .iter()
            .zip(&read)
            .filter(|(_, &r)| r)
            .map(|(m, _)| {
                let t = Table {
                    name: m.name.clone(),
                    depth: m.depth as usize,
                    fmt: m.fmt,
                };
                let zeros = vec![0; t.depth];
                (t, zeros)
            })
            .collect();
        let mut u = Unit {
            name: name.trim().to_owned(),
            cfg: *cfg,
            full,
            full_ports: ports,
            full_outputs: outputs,
            graph,
            input_nodes,
            output_nodes,
            inputs,
            outputs: outs,
            latency,
            tables,
        };
        u.fill_tables(DEFAULT_TF)?;
        Ok(u)
    }

    /// The unit's name.
    pub fn name(&self) -> &str {
        &self.name
    }

    /// The configuration.
    pub fn config(&self) -> &PipelineConfig {
        &self.cfg
    }

    /// The input ports, in the order [`Unit::eval`] takes their words.
    pub fn inputs(&self) -> &[Port] {
        &self.inputs
    }

    /// The outputs, in the order [`Unit::eval`] returns their words.
    pub fn outputs(&self) -> &[Port] {
        &self.outputs
    }

    /// Clocks from a sample's inputs to its outputs.
    pub fn latency(&self) -> u32 {
        self.latency
    }

    /// The memories the unit reads (none for a cut).
    pub fn tables(&self) -> impl Iterator<Item = &Table> {
        self.tables.iter().map(|t| &t.0)
    }

    /// Loads the table `name` with `words` (raw words of its format, as
    /// many as it is deep).
    pub fn load_table(&mut self, name: &str, words: &[i64]) -> Result<(), UnitError> {
        let (t, _) = self.find_table(name)?;
        let (depth, f) = (t.depth, t.fmt);
        if words.len() != depth {
            return Err(bad(format!(
                "table {name}: {} words given, it holds {depth}",
                words.len()
            )));
        }
        if let Some((i, w)) = words
            .iter()
            .enumerate()
            .find(|(_, &w)| w < f.min_raw() || w > f.max_raw())
        {
            return Err(bad(format!("table {name}: word {i} = {w} is outside {f}")));
        }
        self.held_mut(name).copy_from_slice(words);
        Ok(())
    }

    /// Fills every table from the named transfer function (a preset of
    /// `--tf`: `grey-ramp`, `ml`, `brain`, ...), as the pipeline's frame
    /// fills them ([`crate::tables::Tables::new`]).
    pub fn fill_tables(&mut self, tf: &str) -> Result<(), UnitError> {
        // The name is checked even on a unit without tables: a misspelt
        // preset is an error wherever it is given.
        let f = golden::scenes::tf_preset(tf).map_err(|e| bad(e.to_string()))?;
        if self.tables.is_empty() {
            return Ok(());
        }
        let lut = golden::tf::Lut::for_bits(
            &f,
            self.cfg.table_entries as usize,
            u32::from(self.cfg.voxel.bits()),
        );
        let t = crate::tables::Tables::new(&self.cfg, &lut).map_err(|e| bad(e.to_string()))?;
        let raw = |v: &[crate::fixed::Fx]| v.iter().map(|x| x.raw()).collect::<Vec<i64>>();
        let cols: Vec<Vec<i64>> = vec![
            t.color.iter().map(|c| c[0].raw()).collect(),
            t.color.iter().map(|c| c[1].raw()).collect(),
            t.color.iter().map(|c| c[2].raw()).collect(),
            raw(&t.alpha),
            raw(&t.log_t),
            raw(&t.exp),
        ];
        for (name, words) in MEMORIES.iter().zip(cols) {
            if self.tables.iter().any(|t| t.0.name == *name) {
                self.load_table(name, &words)?;
            }
        }
        Ok(())
    }

    /// The table `name`'s contents.
    pub fn table(&self, name: &str) -> Option<&[i64]> {
        self.tables
            .iter()
            .find(|t| t.0.name == name)
            .map(|t| t.1.as_slice())
    }

    /// Word `addr` of the table `name`.
    pub fn table_word(&self, name: &str, addr: usize) -> Result<i64, UnitError> {
        let (t, held) = self.find_table(name)?;
        held.get(addr).copied().ok_or_else(|| {
            bad(format!(
                "table {name}: address {addr} is past its {} words",
                t.depth
            ))
        })
    }

    /// Sets word `addr` of the table `name` to `word` (a raw word of its
    /// format), as a host port writes one word.
    pub fn set_table_word(&mut self, name: &str, addr: usize, word: i64) -> Result<(), UnitError> {
        let (t, _) = self.find_table(name)?;
        let (depth, f) = (t.depth, t.fmt);
        if addr >= depth {
            return Err(bad(format!(
                "table {name}: address {addr} is past its {depth} words"
            )));
        }
        if word < f.min_raw() || word > f.max_raw() {
            return Err(bad(format!(
                "table {name}: word {addr} = {word} is outside {f}"
            )));
        }
        self.held_mut(name)[addr] = word;
        Ok(())
    }

    /// The words of the table `name`, which [`Unit::find_table`] found.
    fn held_mut(&mut self, name: &str) -> &mut [i64] {
        self.tables
            .iter_mut()
            .find(|t| t.0.name == name)
            .map(|t| t.1.as_mut_slice())
            .expect("a table found by name")
    }

    /// The table `name` and its words, or an error listing the unit's.
    fn find_table(&self, name: &str) -> Result<(&Table, &[i64]), UnitError> {
        self.tables
            .iter()
            .find(|t| t.0.name == name)
            .map(|t| (&t.0, t.1.as_slice()))
            .ok_or_else(|| {
                let names: Vec<&str> = self.tables().map(|t| t.name.as_str()).collect();
                if names.is_empty() {
                    bad(format!(
                        "unknown table '{name}': unit {} reads no table",
                        self.name
                    ))
                } else {
                    bad(format!(
                        "unknown table '{name}': expected {}",
                        names.join(", ")
                    ))
                }
            })
    }

    /// The index of input `name`.
    pub fn input_index(&self, name: &str) -> Option<usize> {
        self.inputs.iter().position(|p| p.name == name)
    }

    /// The index of output `name`.
    pub fn output_index(&self, name: &str) -> Option<usize> {
        self.outputs.iter().position(|p| p.name == name)
    }

    /// One sample: the outputs' raw words from the inputs' (in
    /// [`Unit::inputs`] order, each within its word), bit for bit the
    /// description's (hence the model's).
    pub fn eval(&self, words: &[i64]) -> Result<Vec<i64>, UnitError> {
        let v = self.values(words)?;
        Ok(self.output_nodes.iter().map(|id| v[id.0] as i64).collect())
    }

    /// One sample's every node's raw word, by probe name (the
    /// description's node names, `bilinear.top`, ...), in node order.
    pub fn node_values(&self, words: &[i64]) -> Result<Vec<(String, i64)>, UnitError> {
        let v = self.values(words)?;
        Ok(self
            .graph
            .nodes
            .iter()
            .zip(v)
            .map(|(n, x)| (n.name.clone(), x as i64))
            .collect())
    }

    fn values(&self, words: &[i64]) -> Result<super::eval::Values, UnitError> {
        if words.len() != self.inputs.len() {
            return Err(bad(format!(
                "unit {} takes {} input words, {} given",
                self.name,
                self.inputs.len(),
                words.len()
            )));
        }
        for (p, &w) in self.inputs.iter().zip(words) {
            let x = p.word;
            let (lo, hi) = if x.signed {
                (-(1i128 << (x.bits - 1)), (1i128 << (x.bits - 1)) - 1)
            } else {
                (0, (1i128 << x.bits) - 1)
            };
            if i128::from(w) < lo || i128::from(w) > hi {
                return Err(bad(format!(
                    "input {}: {w} is outside its {} bits{} ({lo} to {hi})",
                    p.name,
                    x.bits,
                    if x.signed { " signed" } else { "" }
                )));
            }
        }
        let g = &self.graph;
        let input = |name: &str| {
            self.input_nodes
                .iter()
                .position(|id| g.node(*id).name == name)
                .map(|i| words[i])
        };
        let read = |_: &str, m: super::MemId, addr: i128| -> Option<i64> {
            let name = &g.mems[m.0].name;
            let t = self.tables.iter().find(|t| &t.0.name == name)?;
            t.1.get(usize::try_from(addr).ok()?).copied()
        };
        Ok(eval(g, &input, &read, &mut QuantStats::default())?)
    }

    /// The whole sample as `ercube rtl` emits it, named `module`: the
    /// pipelined datapath ([`super::pipeline_rtl`]) on the schedule the
    /// model's latency follows ([`crate::cost::latency::sample_schedule`]),
    /// with its handshake, host table port and the voxel taps read outside
    /// one clock after their column. Its depth is [`Unit::latency`]. A cut
    /// is refused: its Verilog is [`Unit::verilog`].
    pub fn pipelined(
        &self,
        module: &str,
    ) -> Result<super::pipeline_rtl::PipelinedModule, UnitError> {
        if self.name != "sample" {
            return Err(bad(format!(
                "unit {} is a cut: its module is Unit::verilog's (the pipelined module is the whole sample's)",
                self.name
            )));
        }
        let sch = crate::cost::latency::sample_schedule(&self.cfg);
        super::pipeline_rtl::emit_scheduled(&self.full, &sch, module)
            .map_err(|e| bad(format!("rtl: {e}")))
    }

    /// The unit as a Verilog module named `module` (a clock, the ports,
    /// registered outputs), as [`crate::rtl`] emits its calibration
    /// modules; the whole sample is not emitted here (its memory reads and
    /// square root are refused): its module is [`Unit::pipelined`].
    pub fn verilog(&self, module: &str) -> Result<String, RtlError> {
        let ports: Vec<(&str, NodeId)> = self
            .full_ports
            .iter()
            .map(|(n, id)| (n.as_str(), *id))
            .collect();
        let outs: Vec<(&str, NodeId)> = self
            .full_outputs
            .iter()
            .map(|(n, id)| (n.as_str(), *id))
            .collect();
        let c = super::verilog::cut(&self.full, &ports, &outs)?;
        let comment = format!(
            "{} ({}), latency {}: emitted by ercube from the datapath description",
            self.name,
            self.cfg.order.name(),
            self.latency
        );
        Ok(super::verilog::cut_module(module, &comment, &c))
    }
}
