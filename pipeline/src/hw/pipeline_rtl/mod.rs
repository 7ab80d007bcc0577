//! A whole [`Graph`] as one pipelined Verilog-2005 module, registers where
//! its [`schedule`](super::schedule) puts the stage boundaries.
//!
//! - Each node's logic is in its scheduled stage (`hw::verilog::comb`:
//!   the same operator text as the calibration cuts, every assignment by
//!   [`crate::rtl`]'s quantiser); a value read `n` stages after its own is
//!   held by `n` registers (`<wire>_d<stage>`).
//! - A valid bit travels with each sample (`valid_d<stage>`); the outputs
//!   load only from a valid sample, so a bubble never changes them.
//! - Every register has a synchronous reset to zero (no X reaches an
//!   output in a four-state simulator, whatever the inputs of a bubble).
//! - Memories with a depth are tables: synchronous-read RAMs (the read's
//!   data register is the stage boundary) written through one host port
//!   (`tbl_we`, `tbl_sel`, `tbl_addr`, `tbl_data`), as yosys infers them.
//!   A memory without a depth (the voxel taps) is outside: its address is
//!   an output in the address's stage and its words inputs one clock
//!   later, like a block RAM's.
//! - An integer square root is the pipelined unit of `hw/isqrt_rtl.rs`,
//!   a divider that of `hw/div_rtl.rs`.
//!
//! Ports are taken once and held down the pipeline with the sample, so
//! samples issue back to back; the schedule's `register_bits` counts
//! ports as held registers outside the datapath and so does not count
//! these delay lines. Every port is taken at issue but the ray's state
//! read from the compositing buffer, taken where the schedule has it
//! arrive ([`super::schedule::RAY_PORTS`], [`super::schedule::RAY_STAGE`]
//! clocks after issue). The module's text is written by `text`
//! (`text.rs`) from what [`emit_scheduled`] builds.

mod text;

use super::schedule::schedule;
use super::{Graph, NodeId, Op, Word};
use crate::rtl::{range, Body, RtlError};
use text::{decl, text};

/// A register: name, word, source expression.
pub(crate) struct Reg {
    name: String,
    word: Word,
    src: String,
}

impl Reg {
    pub(crate) fn new(name: &str, word: Word, src: &str) -> Reg {
        Reg {
            name: name.to_owned(),
            word,
            src: src.to_owned(),
        }
    }
}

/// One port of the emitted module.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Port {
    /// Verilog name.
    pub name: String,
    /// Whether the module reads it.
    pub input: bool,
    /// Its word (width, fraction bits, signedness).
    pub word: Word,
    /// The declared format, when the node has one.
    pub format: Option<String>,
    /// Clocks after issue at which it is read or valid.
    pub stage: u32,
    /// What it carries.
    pub meaning: String,
}

/// A table of the host write port: its `tbl_sel` code, depth and word.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Table {
    /// The memory's name.
    pub name: String,
    /// Its `tbl_sel` code.
    pub sel: u32,
    /// Words.
    pub depth: u64,
    /// Bits per word.
    pub bits: u32,
    /// Read ports (each a synchronous read with its data register).
    pub reads: u32,
}

/// The emitted module and what a testbench or a reader needs of it.
#[derive(Debug, Clone)]
pub struct PipelinedModule {
    /// Module name.
    pub name: String,
    /// The Verilog text.
    pub verilog: String,
    /// Clocks from issue to the registered outputs.
    pub depth: u32,
    /// Every port, clock and reset included, in declaration order.
    pub ports: Vec<Port>,
    /// The tables behind the host write port.
    pub tables: Vec<Table>,
    /// Bits of every register the module declares (pipeline, delay lines,
    /// valid bits, square-root stages, table read registers, outputs).
    pub register_bits: u64,
    /// Of those, the schedule's own pipeline registers and delay lines of
    /// the datapath's values ([`super::schedule::Schedule::register_bits`]);
    /// the rest hold the sample's ports down the pipeline, the valid bits,
    /// the table reads and the outputs.
    pub schedule_register_bits: u64,
    /// Bits of the tables.
    pub memory_bits: u64,
}

/// What a port of the plain sample or of the pre-integrated one carries.
fn meaning(name: &str) -> &'static str {
    match name {
        "slot.m" => "ray index m (the ray slot)",
        "a" => "x position base of the row (x = a + m t)",
        "t" => "x position step per ray",
        "b" => "x slope base of the row (sx = b + m k)",
        "k" => "x slope step per ray",
        "row.wy" => "y interpolation weight of the row",
        "sy" => "y slope of the row",
        "sz" => "z slope of the slice",
        "acc_r" | "acc_g" | "acc_b" => "the ray's colour accumulator before the sample",
        "acc_a" => "the ray's opacity accumulator before the sample",
        "v00" | "v01" => "voxel tap of row y0, column x0 / x0 + 1",
        "v10" | "v11" => "voxel tap of row y0 + 1, column x0 / x0 + 1",
        "x0" => "voxel tap column (the taps' read address)",
        _ if name.starts_with("acc_out") => "the ray's accumulator after the sample",
        "pre.prev" => "the ray's previous sample (the step's other scalar)",
        "pre.step" => "the sample composites a step (else the accumulators pass unchanged)",
        "pre.lead" => "the step is slice 0's half step at the sample",
        "pre.half" => "the step's path is halved (the last slice's, to the volume's face)",
        "pre.scale" => "the pre-integration table's scale K (per frame)",
        _ => "",
    }
}

/// `s` with `.` as `_`: a Verilog identifier of a probe name.
pub fn verilog_name(s: &str) -> String {
    s.replace('.', "_")
}

/// Bits of a table address of `depth` words.
fn addr_bits(depth: u64) -> u32 {
    crate::cost::inventory::addr_bits(depth)
}

/// Emits `g` as module `name`: see the module documentation.
pub fn emit(g: &Graph, name: &str) -> Result<PipelinedModule, RtlError> {
    emit_scheduled(g, &schedule(g), name)
}

/// Emits `g` as module `name` on the stages of `sch`, a schedule of `g`
/// (one for a clock: `crate::cost::latency::sample_schedule`).
pub fn emit_scheduled(
    g: &Graph,
    sch: &super::schedule::Schedule,
    name: &str,
) -> Result<PipelinedModule, RtlError> {
    let (stage, reads, depth) = (&sch.stage, &sch.reads, sch.depth.max(1));
    let n = g.nodes.len();
    // Addresses of the outside memory's reads are outputs in their stage.
    let mut tap = vec![None; n];
    for (i, node) in g.nodes.iter().enumerate() {
        if let Op::Read(m, a) = node.op {
            if g.mems[m.0].depth == 0 {
                tap[a.0] = Some(reads[i]);
            }
        }
    }
    let mut last: Vec<u32> = stage.clone();
    for (i, node) in g.nodes.iter().enumerate() {
        for o in node.op.operands() {
            last[o.0] = last[o.0].max(reads[i]);
        }
    }
    for (_, id) in &g.outputs {
        if tap[id.0].is_none() {
            last[id.0] = last[id.0].max(depth - 1);
        }
    }
    let base = |i: usize| -> String {
        let nd = &g.nodes[i];
        match nd.op {
            Op::Input => verilog_name(&nd.name),
            Op::Read(m, _) if g.mems[m.0].depth == 0 => verilog_name(&nd.name),
            _ => format!("n_{}", verilog_name(&nd.name)),
        }
    };
    let sig = |id: NodeId, k: u32| -> String {
        let i = id.0;
        assert!(k >= stage[i], "{} read before its stage", g.nodes[i].name);
        if k == stage[i] || matches!(g.nodes[i].op, Op::Const(_)) {
            base(i)
        } else {
            format!("{}_d{k}", base(i))
        }
    };
    let valid = |k: u32| -> String {
        if k == 0 {
            "in_valid".to_owned()
        } else {
            format!("valid_d{k}")
        }
    };

    // Tables: their select codes and the host port's widths.
    let tables: Vec<Table> = g
        .mems
        .iter()
        .enumerate()
        .filter(|(_, m)| m.depth > 0)
        .enumerate()
        .map(|(k, (mi, m))| Table {
            name: m.name.clone(),
            sel: k as u32,
            depth: m.depth,
            bits: u32::from(m.fmt.bits()),
            reads: g
                .nodes
                .iter()
                .filter(|n| matches!(n.op, Op::Read(r, _) if r.0 == mi))
                .count() as u32,
        })
        .collect();
    let sel_bits = addr_bits(tables.len().max(2) as u64);
    let ta = tables.iter().map(|t| addr_bits(t.depth)).max().unwrap_or(1);
    let td = tables.iter().map(|t| t.bits).max().unwrap_or(1);

    let mut ports = vec![
        port(
            "clk",
            true,
            Word::unsigned(1, 0),
            0,
            "clock; every register loads on its rising edge",
        ),
        port(
            "rst",
            true,
            Word::unsigned(1, 0),
            0,
            "synchronous reset of every register to zero",
        ),
        port(
            "in_valid",
            true,
            Word::unsigned(1, 0),
            0,
            "a sample issues this clock",
        ),
        port(
            "tbl_we",
            true,
            Word::unsigned(1, 0),
            0,
            "host table write enable",
        ),
        port(
            "tbl_sel",
            true,
            Word::unsigned(sel_bits, 0),
            0,
            "host table select (see the table list)",
        ),
        port(
            "tbl_addr",
            true,
            Word::unsigned(ta, 0),
            0,
            "host table write address",
        ),
        port(
            "tbl_data",
            true,
            Word::unsigned(td, 0),
            0,
            "host table write word (low bits)",
        ),
    ];
    let mut b = Body::new();
    let mut regs: Vec<Reg> = Vec::new();
    let mut mem_reads: Vec<Vec<(String, String)>> = vec![Vec::new(); g.mems.len()];
    let mut outs = Vec::new();
    for (i, node) in g.nodes.iter().enumerate() {
        let id = NodeId(i);
        let v = base(i);
        let w = node.word;
        let get = |o: NodeId| sig(o, reads[i]);
        match node.op {
            Op::Input => ports.push(Port {
                name: v.clone(),
                input: true,
                word: w,
                format: node.fmt.map(|f| f.to_string()),
                stage: stage[i],
                meaning: meaning(&node.name).to_owned(),
            }),
            Op::Reg(d) => regs.push(Reg::new(&v, w, &get(d))),
            Op::Read(m, a) if g.mems[m.0].depth == 0 => {
                if !g.outputs.iter().any(|o| o.1 == a) {
                    return Err(RtlError::Unsupported(format!(
                        "a read of {} at an address that is not an output",
                        g.mems[m.0].name
                    )));
                }
                ports.push(Port {
                    name: v.clone(),
                    input: true,
                    word: w,
                    format: node.fmt.map(|f| f.to_string()),
                    stage: stage[i],
                    meaning: meaning(&node.name).to_owned(),
                });
            }
            Op::Read(m, a) => {
                let ab = addr_bits(g.mems[m.0].depth);
                let wa = g.word(a);
                let at = get(a);
                let addr = if wa.bits >= ab {
                    format!("{at}[{}:0]", ab - 1)
                } else {
                    format!("{{{}'b0, {at}}}", ab - wa.bits)
                };
                b.line(&format!("wire {} {v}_a = {addr};", range(ab)));
                mem_reads[m.0].push((v.clone(), format!("{v}_a")));
            }
            Op::Div(x, y) => {
                let q = super::div_rtl::div(
                    &mut b,
                    &mut regs,
                    &v,
                    (&get(x), g.word(x)),
                    (&get(y), g.word(y)),
                    w,
                    stage[i] - reads[i] + 1,
                )?;
                b.line(&format!("wire {} {v} = {q};", decl(w)));
            }
            Op::Isqrt(x) => {
                let f = node.fmt.expect("a square root has a format");
                let y = super::isqrt_rtl::isqrt(
                    &mut b,
                    &mut regs,
                    &v,
                    &get(x),
                    g.word(x),
                    f,
                    stage[i] - reads[i] + 1,
                )?;
                b.line(&format!("wire {} {v} = {y};", decl(w)));
            }
            _ => {
                super::verilog::comb(&mut b, g, id, &v, &get)?;
            }
        }
        // The delay line to the last reader.
        if !matches!(node.op, Op::Const(_)) {
            for k in stage[i] + 1..=last[i] {
                regs.push(Reg::new(&sig(id, k), w, &sig(id, k - 1)));
            }
        }
    }
    for (oname, id) in &g.outputs {
        let node = g.node(*id);
        let p = |stage: u32| Port {
            name: verilog_name(oname),
            input: false,
            word: node.word,
            format: node.fmt.map(|f| f.to_string()),
            stage,
            meaning: meaning(oname).to_owned(),
        };
        match tap[id.0] {
            Some(k) => {
                ports.push(p(k));
                b.line(&format!(
                    "assign {} = {} ? {} : {}'d0;",
                    verilog_name(oname),
                    valid(k),
                    sig(*id, k),
                    node.word.bits
                ));
            }
            None => {
                ports.push(p(depth));
                outs.push((verilog_name(oname), node.word, sig(*id, depth - 1)));
            }
        }
    }
    ports.insert(
        3,
        port(
            "out_valid",
            false,
            Word::unsigned(1, 0),
            depth,
            "the outputs hold a sample issued `depth` clocks ago",
        ),
    );
    for k in 1..depth {
        regs.push(Reg::new(&valid(k), Word::unsigned(1, 0), &valid(k - 1)));
    }

    let register_bits = regs.iter().map(|r| u64::from(r.word.bits)).sum::<u64>()
        + outs.iter().map(|o| u64::from(o.1.bits)).sum::<u64>()
        + 1
        + g.mems
            .iter()
            .zip(&mem_reads)
            .map(|(m, r)| r.len() as u64 * u64::from(m.fmt.bits()))
            .sum::<u64>();
    let memory_bits = tables.iter().map(|t| t.depth * u64::from(t.bits)).sum();
    let mut m = PipelinedModule {
        name: name.to_owned(),
        verilog: String::new(),
        depth,
        ports,
        tables,
        register_bits,
        schedule_register_bits: sch.register_bits,
        memory_bits,
    };
    m.verilog = text(g, &m, &b, &regs, &outs, &mem_reads, (sel_bits, ta, td))?;
    Ok(m)
}

/// A one-bit or plain port.
fn port(name: &str, input: bool, word: Word, stage: u32, meaning: &str) -> Port {
    Port {
        name: name.to_owned(),
        input,
        word,
        format: None,
        stage,
        meaning: meaning.to_owned(),
    }
}
