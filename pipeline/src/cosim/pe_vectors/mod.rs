//! Vector files of one PE's sample stage (`ercube vectors --stage pe`):
//! the emitted `ercube_pe_sample` ([`crate::hw::pe_sample_rtl`]) of PE
//! `K`, its every port's word on every clock of a frame, read from the
//! sample stage co-simulation's capture ([`super::pe_sample::PeCapture`],
//! whose files this reads back unchanged), with the model's expected
//! issues, taps and write-backs; [`files`] writes them as `$readmemh`
//! files with a manifest and a plain Verilog testbench.
//!
//! The clocks are the frame's, numbered as the co-simulation numbers
//! them (clock 0 the first after reset and the tables). Row `c` of an
//! input's file is the word the port holds at the rising edge that starts
//! clock `c` (the controller's broadcast of clock `c`, the held range
//! that takes effect in it, the plan port's run of clock `c - 1`, the
//! right neighbour's edge register during clock `c - 1`); row `c` of an
//! output's file is what the module shows during clock `c` (an issue, the
//! taps of the sample issued the tap stage earlier, a write-back landing).
//! What the model does to the PE without a clock (a slice's voxels, buffer
//! words changed by migration, merges and splits, termination bits, and
//! under a round-robin mapping the column map's entries migration writes
//! and the column decoder the host writes with the voxels) is a list of
//! memory writes, each applied before the rising edge that ends its
//! clock, as the co-simulation's testbench applies them.
//!
//! The right neighbour's edge register is computed from its slice loads
//! and the broadcast as the emitted register reads them (it latches the
//! broadcast's next row, then reads its edge column a clock later and
//! holds otherwise); the rightmost PE's `edge_in` is zero, as in the
//! co-simulation's array.

pub mod files;
mod read;
pub mod tb;

use std::path::Path;
use std::sync::{Arc, Mutex};

use super::pe_sample::run::peaks;
use super::pe_sample::{PeCapture, Widths};
use super::replay::table_rows;
use crate::hw::pe_sample_rtl::{emit, PeSampleShape};
use crate::hw::pipeline_rtl::PipelinedModule;
use crate::FrameRun;

pub use read::{ports, Decl};

/// The memories the writes go to, by code (the events file's `mem`): the
/// slice buffer's row banks and edge columns, the compositing buffer's
/// banks, the termination bits, and under a round-robin mapping the
/// column map's ray indices and slots and the column decoder.
pub const MEMORIES: [&str; 10] = [
    "sb0", "sb1", "ec0", "ec1", "bank0", "bank1", "term", "cm_mx", "cm_sl", "loc",
];

/// A write into one of the module's memories without a clock.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct MemWrite {
    /// Applied before the rising edge that ends this clock.
    pub cycle: u64,
    /// The memory: an index into [`MEMORIES`].
    pub mem: u8,
    /// The word's address.
    pub addr: u64,
    /// The word; for `term`, `slot << 1 | bit` (one bit of the row's word).
    pub data: u128,
}

/// What a port's rows are checked against.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Check {
    /// Stimulus (an input).
    Drive,
    /// Compared on every clock.
    Always,
    /// Compared where the named valid's row is 1.
    When(&'static str),
}

/// One port's rows.
#[derive(Debug, Clone)]
pub struct Column {
    /// The port as the module declares it.
    pub port: Decl,
    /// How it is checked.
    pub check: Check,
    /// A word a clock, masked to the port's width.
    pub words: Vec<u128>,
}

/// One PE's sample stage over a frame: every port's word each clock, the
/// memory writes, the tables and the Verilog.
#[derive(Debug, Clone)]
pub struct PeStream {
    /// The PE, of `pes`.
    pub pe: usize,
    /// PEs in the frame.
    pub pes: usize,
    /// Clocks (rows of every column): to two past the last write-back.
    pub rows: u64,
    /// The inputs then the checked outputs.
    pub columns: Vec<Column>,
    /// Inputs that hold one word over the frame: `col_lo`, `col_end`, `nx_last`.
    pub constants: Vec<(Decl, u128)>,
    /// The memory writes, in the order applied.
    pub writes: Vec<MemWrite>,
    /// Bits of a write's word (`data`).
    pub write_data_bits: u32,
    /// The tables through the host port: `{tbl_we, tbl_sel, tbl_addr,
    /// tbl_data}` rows, hex lines, and how many.
    pub table_rows: (String, usize),
    /// The frame's tables, raw words by name.
    pub tables: Vec<(String, Vec<i64>)>,
    /// The PE module's Verilog and the datapath's (name, text).
    pub verilog: String,
    /// The datapath module's name and Verilog.
    pub datapath: (String, String),
    /// The datapath's depth and tap stage.
    pub depth: u32,
    /// Clocks from issue to the taps.
    pub tap_stage: u64,
    /// Samples PE `pe` issued, and over all PEs.
    pub samples: (u64, u64),
    /// The frame's cycles in the model.
    pub frame_cycles: u64,
    /// The column mapping (`blocks`, `interleave`, `cyclic`).
    pub mapping: &'static str,
    /// The compositing buffer's word, the row plan's slots, and whether
    /// the module has termination bits.
    pub shape: PeSampleShape,
}

impl PeStream {
    /// The column of port `name`.
    pub fn column(&self, name: &str) -> Option<&Column> {
        self.columns.iter().find(|c| c.port.name == name)
    }
}

/// Runs the frame `frame` makes (twice: first for the column map slots
/// and voxel columns a PE needs, as `ercube cosim --stage pe` sizes the
/// module) with the sample stage's capture into `dir`, and reads back PE
/// `pe`'s stream around datapath `dp`.
pub fn capture<'a>(
    frame: &dyn Fn() -> FrameRun<'a>,
    cfg: &crate::config::PipelineConfig,
    view: &golden::geometry::View,
    dp: &PipelinedModule,
    pe: usize,
    dir: &Path,
) -> Result<PeStream, String> {
    let pes = usize::from(cfg.pes);
    if pe >= pes {
        return Err(format!(
            "--pe {pe}: the frame has {pes} PEs (0 to {})",
            pes - 1
        ));
    }
    let (declared, held, cols) = peaks(frame, cfg, view)?;
    let shape = declared.with_slots(held).with_stored(cols);
    let rtl = emit(&shape, dp)?;
    let widths = Widths::of(&shape, dp);
    let tap_stage = widths.tap_stage;
    let cap = PeCapture::create(shape, widths, dir, pes).map_err(|e| e.to_string())?;
    let cap = Arc::new(Mutex::new(cap));
    let f = frame()
        .capture(cap.clone())
        .run()
        .map_err(|e| e.to_string())?;
    let mut c = cap.lock().map_err(|_| "capture poisoned".to_owned())?;
    c.finish().map_err(|e| e.to_string())?;
    if let Some(e) = &c.error {
        return Err(format!("capture: {e}"));
    }
    if let Some(why) = &c.unfit {
        return Err(format!(
            "the frame does not fit the declared memories: {why}"
        ));
    }
    let decls = ports(&rtl.verilog);
    let mut s = read::stream(dir, &shape, &widths, &decls, pe, pes, tap_stage)?;
    s.table_rows = table_rows(dp, &c.tables);
    s.tables = c.tables.clone();
    s.verilog = rtl.verilog;
    s.datapath = (dp.name.clone(), dp.verilog.clone());
    s.depth = dp.depth;
    s.samples = (c.issued[pe], c.issued.iter().sum());
    s.frame_cycles = f.cycles;
    s.mapping = cfg.mapping.name();
    Ok(s)
}
