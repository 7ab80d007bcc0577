//! The co-simulation of a dense boundary pass (the split, front to back,
//! [`crate::cosim::split`]; the merge, back to front,
//! [`crate::cosim::merge`]; the fold, front to back,
//! [`crate::cosim::fold`]): one emitted module a PE, every pass of a
//! frame replayed from the model's capture and every clock's line-buffer
//! write and child word compared with the model's.
//!
//! The passes share everything but their ports and what they compare: the
//! record sink, the vector file's layout, the testbench around the PEs,
//! the outcome it prints (`<P>TICKS`, `<P>PE`, `<P>MISMATCH` with the
//! pass's one-letter prefix), the run and its failure lines. A pass
//! supplies those parts through [`PassKind`], as the model's side does
//! through [`crate::stages::boundary`].

use std::any::Any;
use std::marker::PhantomData;
use std::path::Path;

use golden::geometry::View;

use crate::array::StageCycles;
use crate::config::PipelineConfig;
use crate::cosim::capture::{Issue, IssueSink};
use crate::cosim::outcome::Mismatch;
use crate::cosim::replay::parse_hex;
use crate::cost::inventory::Geometry;
use crate::fixed::Format;
use crate::rtl::RtlError;

pub mod testbench;

use testbench::Bench;

/// The widths a pass's testbench and outcome read from its shape, and
/// the module's figures.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct PassDims {
    /// PEs in the array.
    pub pes: usize,
    /// The colour and opacity accumulators' formats.
    pub acc: [Format; 2],
    /// The line buffer's word format (`merge`).
    pub merge: Format,
    /// Entries of a line buffer row (the most children a PE computes).
    pub width: u64,
    /// Bits of a column (child) counter.
    pub col_bits: u32,
    /// Bits of a row counter.
    pub row_bits: u32,
    /// Rows of the line buffer.
    pub rows: u32,
    /// Memory bits a PE (the line buffer).
    pub memory_bits: u64,
    /// Register bits a PE.
    pub register_bits: u64,
}

impl PassDims {
    /// Channel `ch`'s accumulator format (R, G, B colour, A opacity).
    pub fn acc_of(&self, ch: usize) -> Format {
        self.acc[usize::from(ch == 3)]
    }
}

/// One boundary pass's own parts of its co-simulation.
pub trait PassKind: Sized + 'static {
    /// The stage's name (`split`, `merge`): the vector file's stem and the
    /// failure lines' prefix.
    const STAGE: &'static str;
    /// The testbench's line prefix (`S`, `M`).
    const PREFIX: &'static str;
    /// The emitted module's name.
    const MODULE: &'static str;
    /// The generated testbench's module name.
    const TOP: &'static str;
    /// The module's shape (formats, depths, counters).
    type Shape;
    /// One pass as the model ran it.
    type Capture: Clone + std::fmt::Debug + Send + 'static;
    /// One PE in one clock of a pass.
    type Tick;

    /// The shape of `cfg`'s PE for the worst view of `geo`, or why the
    /// module does not cover it.
    fn shape(cfg: &PipelineConfig, geo: &Geometry) -> Result<Self::Shape, String>;
    /// The shape for a frame's `view`, or why the module does not cover it.
    fn shape_for_view(cfg: &PipelineConfig, view: &View) -> Result<Self::Shape, String>;
    /// The module's Verilog.
    fn emit(cfg: &PipelineConfig, shape: &Self::Shape) -> Result<String, RtlError>;
    /// The frame's cycles of the stage.
    fn cycles(stages: &StageCycles) -> u64;
    /// The widths the shared parts read from `shape`.
    fn dims(shape: &Self::Shape) -> PassDims;
    /// The pass's first cycle, its grids (first row, rows, the other
    /// grid's first row) and each PE's child count.
    fn header(pass: &Self::Capture) -> (u64, (i64, usize, i64), Vec<usize>);
    /// PE `k`'s line of the pass header in the vector file.
    fn child_line(pass: &Self::Capture, k: usize) -> String;
    /// The clocks, each PE's in index order.
    fn ticks(pass: &Self::Capture) -> &[Vec<Self::Tick>];
    /// One PE's clock in the vector file: inputs, then the model's outputs.
    fn tick_fields(d: &PassDims, tick: &Self::Tick) -> Vec<String>;
    /// Whether the model's PE wrote the line buffer and a child word.
    fn writes(tick: &Self::Tick) -> (bool, bool);
    /// The testbench's pass-specific parts.
    fn bench() -> Bench;

    /// Builds the pass's module (`module`, its text, possibly a modified
    /// copy of the emitted one) with `sim` under `cache`, and runs it in
    /// `dir` on the model's passes.
    fn simulate(
        shape: &Self::Shape,
        module: &str,
        passes: &[Self::Capture],
        sim: super::build::Simulator,
        cache: &Path,
        dir: &Path,
    ) -> Result<PassRun<Self>, String> {
        simulate(shape, module, passes, sim, cache, dir)
    }
}

/// A sink keeping a frame's passes of kind `K`.
#[derive(Debug, Clone)]
pub struct PassRecord<K: PassKind> {
    /// The passes, in the frame's order.
    pub passes: Vec<K::Capture>,
}

impl<K: PassKind> Default for PassRecord<K> {
    fn default() -> Self {
        PassRecord { passes: Vec::new() }
    }
}

impl<K: PassKind> PassRecord<K> {
    /// Keeps `pass` when it is one of `K`'s.
    fn keep(&mut self, pass: &dyn Any) {
        if let Some(p) = pass.downcast_ref::<K::Capture>() {
            self.passes.push(p.clone());
        }
    }
}

impl<K: PassKind> IssueSink for PassRecord<K> {
    fn issue(&mut self, _issue: &Issue) {}

    fn split_pass(&mut self, pass: &crate::cosim::split::SplitCapture) {
        self.keep(pass);
    }

    fn merge_pass(&mut self, pass: &crate::cosim::merge::MergeCapture) {
        self.keep(pass);
    }

    fn fold_pass(&mut self, pass: &crate::cosim::fold::FoldCapture) {
        self.keep(pass);
    }
}

/// What a pass's simulation printed, read back.
#[derive(Debug, Clone, Default)]
pub struct PassOutcome {
    /// Clocks simulated (over every pass).
    pub ticks: u64,
    /// Per PE: line-buffer writes and child words compared, mismatches.
    pub pes: Vec<(u64, u64, u64)>,
    /// The earliest mismatch (by cycle, then PE).
    pub first: Option<Mismatch>,
    /// Lines that say something went wrong.
    pub errors: Vec<String>,
}

impl PassOutcome {
    /// Mismatches over every PE.
    pub fn mismatches(&self) -> u64 {
        self.pes.iter().map(|p| p.2).sum()
    }
    /// Line-buffer writes and child words compared, over every PE.
    pub fn compared(&self) -> (u64, u64) {
        self.pes.iter().fold((0, 0), |(a, b), p| (a + p.0, b + p.1))
    }
}

/// Reads what `K`'s testbench printed.
pub fn parse<K: PassKind>(shape: &K::Shape, text: &str) -> PassOutcome {
    let d = K::dims(shape);
    let mut o = PassOutcome {
        pes: vec![(0, 0, 0); d.pes],
        ..PassOutcome::default()
    };
    let mb = u32::from(d.merge.bits());
    let merge_child = K::bench().merge_child;
    let mut seen = vec![false; d.pes];
    let (ticks_tag, pe_tag, mism_tag) = (
        format!("{}TICKS", K::PREFIX),
        format!("{}PE", K::PREFIX),
        format!("{}MISMATCH", K::PREFIX),
    );
    for line in text.lines() {
        let f: Vec<&str> = line.split_whitespace().collect();
        match f.as_slice() {
            [tag, n] if *tag == ticks_tag => o.ticks = n.parse().unwrap_or(0),
            [tag, k, lines, words, mism] if *tag == pe_tag => {
                match k.parse::<usize>().ok().filter(|&k| k < d.pes) {
                    Some(k) => {
                        seen[k] = true;
                        o.pes[k] = (
                            lines.parse().unwrap_or(0),
                            words.parse().unwrap_or(0),
                            mism.parse().unwrap_or(u64::MAX),
                        );
                    }
                    None => o.errors.push(line.to_owned()),
                }
            }
            [tag, cycle, pe, signal, model, rtl] if *tag == mism_tag => {
                let dec = |sig: &str, hex: &str| {
                    let (bits, signed) = match sig.split_once('_') {
                        Some(("lx", _)) => (mb, d.merge.is_signed()),
                        Some(("w", _)) if merge_child => (mb, d.merge.is_signed()),
                        Some(("w", "a")) => (u32::from(d.acc[1].bits()), d.acc[1].is_signed()),
                        Some(("w", "r" | "g" | "b")) => {
                            (u32::from(d.acc[0].bits()), d.acc[0].is_signed())
                        }
                        _ => (1, false),
                    };
                    parse_hex(hex, bits, signed).map_or(hex.to_owned(), |v| v.to_string())
                };
                Mismatch::from_fields([cycle, pe, signal, model, rtl], dec)
                    .keep_earliest(&mut o.first);
            }
            ["ERROR", ..] => o.errors.push(line.to_owned()),
            _ => {}
        }
    }
    if let Some(k) = seen.iter().position(|s| !s) {
        o.errors
            .push(format!("{} PE {k} reported nothing", K::STAGE));
    }
    o
}

/// A pass's stage simulated and compared.
#[derive(Debug, Clone)]
pub struct PassRun<K> {
    /// What the simulation reported.
    pub outcome: PassOutcome,
    /// The model's clocks of the stage (over every pass).
    pub model_ticks: u64,
    /// Passes replayed.
    pub passes: usize,
    /// The model's line-buffer writes and child words.
    pub model_writes: (u64, u64),
    /// The build.
    pub built: super::build::Built,
    /// Seconds the simulation ran.
    pub run_s: f64,
    /// Lines of Verilog: the module, the testbench.
    pub lines: [usize; 2],
    /// The pass.
    pub kind: PhantomData<K>,
}

impl<K: PassKind> PassRun<K> {
    /// Every way the run failed: mismatches, clocks or words missing.
    pub fn problems(&self) -> Vec<String> {
        let o = &self.outcome;
        let st = K::STAGE;
        let mut v = Vec::new();
        match &o.first {
            Some(m) => v.push(format!(
                "{st}: {} mismatches; the first: {m}",
                o.mismatches()
            )),
            None if o.mismatches() > 0 => v.push(format!("{st}: {} mismatches", o.mismatches())),
            None => {}
        }
        if o.ticks != self.model_ticks {
            v.push(format!(
                "{st}: the RTL ran {} clocks of the model's {}",
                o.ticks, self.model_ticks
            ));
        }
        if o.compared() != self.model_writes {
            v.push(format!(
                "{st}: the RTL compared {:?} line-buffer writes and child words of the model's {:?}",
                o.compared(),
                self.model_writes
            ));
        }
        v.extend(o.errors.iter().map(|e| format!("{st}: {e}")));
        v
    }
}

/// Builds `K`'s module (`module`, its text, possibly a modified copy of
/// the emitted one) with `sim` under `cache`, and runs it in `dir` on the
/// model's passes.
pub fn simulate<K: PassKind>(
    shape: &K::Shape,
    module: &str,
    passes: &[K::Capture],
    sim: super::build::Simulator,
    cache: &Path,
    dir: &Path,
) -> Result<PassRun<K>, String> {
    let d = K::dims(shape);
    let ticks = testbench::write_files::<K>(&d, passes, dir)?;
    let tb = testbench::testbench::<K>(&d);
    let sources = [
        (format!("{}.v", K::MODULE), module),
        (format!("{}.v", K::TOP), tb.as_str()),
    ];
    let sources: Vec<(&str, &str)> = sources.iter().map(|(n, t)| (n.as_str(), *t)).collect();
    let built =
        super::build::build(sim, cache, &sources, K::TOP, false).map_err(|e| e.to_string())?;
    let args = vec![format!("+passes={}", passes.len())];
    let (text, run_s) = super::build::run(&built, dir, &args).map_err(|e| e.to_string())?;
    let outcome = parse::<K>(shape, &text);
    let each = passes.iter().flat_map(|p| K::ticks(p).iter().flatten());
    let model_writes = each.fold((0, 0), |(a, b), t| {
        let (line, child) = K::writes(t);
        (a + u64::from(line), b + u64::from(child))
    });
    Ok(PassRun {
        outcome,
        model_ticks: ticks,
        passes: passes.len(),
        model_writes,
        built,
        run_s,
        lines: [module.lines().count(), tb.lines().count()],
        kind: PhantomData,
    })
}

/// A pass's per-PE records (one a clock the PE stepped) turned into one
/// row a clock of every PE's record, a PE that stepped fewer clocks
/// padded with the default (idle) record.
pub(crate) fn by_clock<T: Copy + Default>(per_pe: &[Vec<T>]) -> Vec<Vec<T>> {
    let clocks = per_pe.iter().map(Vec::len).max().unwrap_or(0);
    (0..clocks)
        .map(|i| {
            per_pe
                .iter()
                .map(|v| v.get(i).copied().unwrap_or_default())
                .collect()
        })
        .collect()
}
