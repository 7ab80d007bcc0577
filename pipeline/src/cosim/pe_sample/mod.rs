//! The co-simulation of the PE's sample stage ([`crate::hw::pe_sample_rtl`]):
//! every PE's control, voxel memory, compositing buffer and datapath in
//! Verilog, driven by the controller's broadcast replayed from the model
//! clock by clock, and compared with the model on every sample.
//!
//! The capture ([`PeCapture`], fed by the clocked sample path) writes:
//!
//! - `bus.txt`: the controller's broadcast of every sampling clock (the
//!   prologue's too): whether the clock samples, the row's first clock,
//!   the row, slice parity and voxel rows, the row's words, the next
//!   row's voxel rows the edge registers read, the row's y position and
//!   the slice (the volume of interest's `voi.y`, `voi.z`);
//! - per PE, what the model does to the PE outside the sample stage, at
//!   each slice's start: the held range (`pe<K>.map`), every compositing
//!   buffer word that migration, merges or splits changed (`pe<K>.ev`,
//!   kind 3: the words that differ from what the stage's own write-backs
//!   left) and, front to back with termination, every ray's termination
//!   bit that differs from what the write-backs left (kind 5: row, slot,
//!   bit); and the slice's voxels to load (kind 1), in the clock before
//!   its first sampling clock;
//! - `plan.txt`: the controller's runs on the PEs' plan port, one a clock
//!   from each sampled slice's first clock (clock, first run of its row,
//!   row, lo, hi: [`PeCapture::plan_runs`]), which each PE's comparators
//!   turn into its row plan's words (bit `i` of row `r` set when held
//!   column `lo + i` lies inside the row's runs; front to back the PE
//!   leaves out those its termination bits mark when it issues);
//! - per PE, the model's issues (`pe<K>.I`: cycle, ray, the accumulators
//!   read), their taps (`pe<K>.T`) and write-backs (`pe<K>.W`: land cycle,
//!   buffer address, the words), in the text the testbench prints for the
//!   RTL's, so that [`compare`] reads the two side by side.
//!
//! The model starts the readout while the datapath still carries the
//! last row's samples (the buffer's write port is free of the readout's
//! read port); the readout reads that row last, long after they land.
//! So the testbench dumps each PE's buffer once the readout has started
//! and the last write-back has landed ([`PeCapture::dump_cycle`]), which
//! [`compare::buffers`] checks against the model's rays and which the
//! readout stage ([`super::readout`]) can then be fed; the capture checks
//! that the readout reads no ray before its write-back lands
//! ([`PeCapture::early_read`]).

pub mod bench;
mod columns;
pub mod compare;
mod plan;
pub mod run;
pub mod slots;
mod words;

pub use words::{BusCycle, Widths};

use std::fmt::Write as _;
use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

use super::capture::{Capture, Issue, IssueSink, ReadoutStart, ReadoutTick};
use super::replay::masked;
use crate::datapath::Datapath;
use crate::hw::pe_sample_rtl::PeSampleShape;
use crate::pe::Pe;
use crate::stages::sample::{RowRuns, SampleBus};

/// Hands `capture` the broadcast of the clock `bus` is for.
pub(crate) fn sample_bus(capture: &Capture, bus: &SampleBus) {
    capture
        .lock()
        .unwrap_or_else(|e| e.into_inner())
        .sample_bus(&BusCycle::of(bus));
}

/// Tells `capture` the PEs planned the slice's rows from `first_row` on
/// after clock `cycle`, inside `runs`.
pub(crate) fn rows_planned(
    capture: &Capture,
    cycle: u64,
    first_row: usize,
    pes: &[Pe],
    runs: &RowRuns,
) {
    capture
        .lock()
        .unwrap_or_else(|e| e.into_inner())
        .rows_planned(cycle, first_row, pes, runs);
}

/// Tells `capture` the controller sends the slice's `runs` (of rows from
/// `first_row` on) of the rows that take clocks (`lens`) to the PEs' plan
/// ports, one a clock from clock `from`.
pub(crate) fn plan_runs(
    capture: &Capture,
    from: u64,
    first_row: usize,
    runs: &RowRuns,
    lens: &[usize],
) {
    capture
        .lock()
        .unwrap_or_else(|e| e.into_inner())
        .plan_runs(from, first_row, runs, lens);
}

/// Tells `capture` a slice starts after clock `cycle`.
pub(crate) fn slice_begin(capture: &Capture, cycle: u64, z: usize, pes: &[Pe]) {
    capture
        .lock()
        .unwrap_or_else(|e| e.into_inner())
        .slice_begin(cycle, z, pes);
}

/// The capture of the sample stage's co-simulation: it writes the
/// streams as the frame runs (see the module's text).
pub struct PeCapture {
    shape: PeSampleShape,
    widths: Widths,
    dir: PathBuf,
    bus: BufWriter<File>,
    plan_port: BufWriter<File>,
    /// Per PE: events, held range, issues, taps, write-backs.
    ev: Vec<BufWriter<File>>,
    map: Vec<BufWriter<File>>,
    iss: Vec<BufWriter<File>>,
    taps: Vec<BufWriter<File>>,
    wbs: Vec<BufWriter<File>>,
    /// Per PE under a round-robin mapping, the column map's entries.
    cm: Vec<BufWriter<File>>,
    /// Under a round-robin mapping, the rays' slots.
    slots: Option<slots::Slots>,
    /// Per PE, the buffer as the stage's own write-backs leave it.
    shadow: Vec<Vec<Option<[i64; 4]>>>,
    /// Per PE, the clock each buffer word's last write-back lands in.
    lands: Vec<Vec<Option<u64>>>,
    /// Per PE, the first held column and the held columns in the slice's
    /// x range at the slice's start.
    held: Vec<(i64, usize)>,
    /// The last broadcast's clock and row.
    row_at: (u64, usize),
    /// The slice begun whose voxels are not loaded yet: they are, in the
    /// clock before its first sampling clock (a slice that samples nothing
    /// is never loaded, so that it cannot overwrite the half of the slice
    /// buffer a slice still in the datapath reads).
    pending_load: Option<usize>,
    volumes: bool,
    /// Samples each PE issued.
    pub issued: Vec<u64>,
    /// Buffer words written outside the sample stage, over all PEs.
    pub outside_words: u64,
    /// Runs the controller drove on the plan port (each to every PE).
    pub plan_runs: u64,
    /// Held columns inside a slice's x range that a sampled row leaves
    /// out (the runs' gaps: empty space and culling inside the row),
    /// summed over PEs and rows.
    pub skipped_in_rows: u64,
    /// Front to back: in-run columns of sampled rows that the termination
    /// bits leave out (terminated rays), summed over PEs and rows.
    pub terminated_in_rows: u64,
    /// Termination bits written outside the sample stage, over all PEs.
    pub outside_flags: u64,
    /// Per PE, each ray's termination bit as the stage's own write-backs
    /// leave it.
    term: Vec<Vec<Option<bool>>>,
    /// Why the frame does not fit the emitted memories, if it does not.
    pub unfit: Option<String>,
    /// A file that could not be written.
    pub error: Option<String>,
    /// The datapath's tables, raw words.
    pub tables: Vec<(String, Vec<i64>)>,
    /// The units' per-frame words by the composed module's port names
    /// (the PE's frame registers).
    pub frame: Vec<(String, i64)>,
    /// The readout's start and clocks.
    pub readout: Option<ReadoutStart>,
    /// The readout's clocks.
    pub ticks: Vec<ReadoutTick>,
    /// The last sampling clock.
    pub last_cycle: u64,
    /// The clock the last write-back lands in.
    pub last_land: u64,
    /// The first readout read of a ray whose write-back had not landed
    /// (a buffer read through the readout's one clock of read latency
    /// before the write): PE, ray, the read's clock, the land's.
    pub early_read: Option<String>,
}

fn create(dir: &Path, name: &str) -> std::io::Result<BufWriter<File>> {
    Ok(BufWriter::new(File::create(dir.join(name))?))
}

impl PeCapture {
    /// A capture writing into `dir` for `pes` PEs of `shape`.
    pub fn create(
        shape: PeSampleShape,
        widths: Widths,
        dir: &Path,
        pes: usize,
    ) -> std::io::Result<PeCapture> {
        let per = |ext: &str| -> std::io::Result<Vec<BufWriter<File>>> {
            (0..pes)
                .map(|k| create(dir, &format!("pe{k}.{ext}")))
                .collect()
        };
        let words = (2 * shape.rays.bank_depth) as usize;
        Ok(PeCapture {
            shape,
            widths,
            dir: dir.to_owned(),
            bus: create(dir, "bus.txt")?,
            plan_port: create(dir, "plan.txt")?,
            ev: per("ev")?,
            map: per("map")?,
            iss: per("I")?,
            taps: per("T")?,
            wbs: per("W")?,
            cm: if shape.round_robin {
                per("cm")?
            } else {
                Vec::new()
            },
            slots: shape
                .round_robin
                .then(|| slots::Slots::new(pes, Some(shape.slots()))),
            shadow: vec![vec![None; words]; pes],
            lands: vec![vec![None; words]; pes],
            held: vec![(0, 0); pes],
            row_at: (0, 0),
            pending_load: None,
            volumes: false,
            issued: vec![0; pes],
            outside_words: 0,
            plan_runs: 0,
            skipped_in_rows: 0,
            terminated_in_rows: 0,
            outside_flags: 0,
            term: vec![vec![None; words]; pes],
            unfit: None,
            error: None,
            tables: Vec::new(),
            frame: Vec::new(),
            readout: None,
            ticks: Vec::new(),
            last_cycle: 0,
            last_land: 0,
            early_read: None,
        })
    }

    /// Flushes every stream.
    pub fn finish(&mut self) -> std::io::Result<()> {
        self.bus.flush()?;
        self.plan_port.flush()?;
        for f in self
            .ev
            .iter_mut()
            .chain(&mut self.map)
            .chain(&mut self.iss)
            .chain(&mut self.taps)
            .chain(&mut self.wbs)
            .chain(&mut self.cm)
        {
            f.flush()?;
        }
        Ok(())
    }

    fn fail(&mut self, e: std::io::Error) {
        if self.error.is_none() {
            self.error = Some(e.to_string());
        }
    }

    fn unfit(&mut self, why: String) {
        if self.unfit.is_none() {
            self.unfit = Some(why);
        }
    }

    /// Each PE's voxels, `[z][y][l]`, and its columns, once.
    fn volumes(&mut self, pes: &[Pe]) -> std::io::Result<()> {
        for (k, pe) in pes.iter().enumerate() {
            let mut f = create(&self.dir, &format!("pe{k}.vol"))?;
            for i in 0..pe.mem.len() {
                writeln!(f, "{:x}", pe.mem.get(i))?;
            }
            f.flush()?;
            let w = pe.held_columns();
            self.decoder(k, pe)?;
            if w as u64 > self.shape.stored || (!self.shape.round_robin && pe.cols.len() != w) {
                self.unfit(format!(
                    "PE {k} holds {w} voxel columns, past the declared {}",
                    self.shape.stored
                ));
            }
            std::fs::write(
                self.dir.join(format!("pe{k}.cfg")),
                format!(
                    "{:x} {:x} {:x} {:x}\n",
                    w,
                    pe.cols.start,
                    pe.cols.end,
                    self.shape.nx - 1
                ),
            )?;
        }
        Ok(())
    }

    fn begin_slice(&mut self, cycle: u64, z: usize, pes: &[Pe]) -> std::io::Result<()> {
        if !self.volumes {
            self.volumes = true;
            self.volumes(pes)?;
        }
        let s = self.shape;
        self.pending_load = Some(z);
        for (k, pe) in pes.iter().enumerate() {
            if !self.column_map(cycle, (k, z), pe)? {
                continue;
            }
            for c in &pe.rays {
                if c.acc.len() as u64 > s.rays.max_rows {
                    self.unfit(format!(
                        "PE {k}'s column {} has {} rows, past the declared {}",
                        c.mx,
                        c.acc.len(),
                        s.rays.max_rows
                    ));
                    break;
                }
                for (row, a) in c.acc.iter().enumerate() {
                    let addr = self.addr(k, c.mx, row).unwrap_or(0) as usize;
                    if s.termination.is_some() {
                        self.flag(cycle, k, (c.mx, row), (c.ftb[row].done, a.raw))?;
                    }
                    if self.shadow[k][addr] != Some(a.raw) {
                        self.shadow[k][addr] = Some(a.raw);
                        self.outside_words += 1;
                        writeln!(
                            self.ev[k],
                            "{:x} 3 {:x} 0 {:x}",
                            cycle,
                            addr,
                            self.widths.pack(&a.raw)
                        )?;
                    }
                }
            }
        }
        Ok(())
    }

    /// Ray `(mx, row)`'s termination bit `done` (its words `acc`) at a
    /// slice's start on PE `k`: a kind 5 event of clock `cycle` where it
    /// differs from what the stage's write-backs left. A ray whose words
    /// the stage left as they are keeps the bit they wrote, or the model's
    /// flag is not the comparator's (an error).
    fn flag(
        &mut self,
        cycle: u64,
        k: usize,
        (mx, row): (i64, usize),
        (done, acc): (bool, [i64; 4]),
    ) -> std::io::Result<()> {
        let addr = self.addr(k, mx, row).unwrap_or(0) as usize;
        let was = self.term[k][addr];
        if was == Some(done) {
            return Ok(());
        }
        if was.is_some() && self.shadow[k][addr] == Some(acc) {
            return Err(std::io::Error::other(format!(
                "PE {k}'s ray ({mx}, {row}) has the termination flag {done} at clock {cycle}, its write-back's comparator {}",
                !done
            )));
        }
        self.term[k][addr] = Some(done);
        self.outside_flags += 1;
        let slot = self.slot_of(k, mx).unwrap_or(0);
        writeln!(
            self.ev[k],
            "{cycle:x} 5 {row:x} {:x} {:x}",
            slot,
            u8::from(done)
        )
    }

    /// The buffer words the stages after the last slice changed (the
    /// last merges and folds), written before the readout starts.
    fn before_readout(&mut self, start: &ReadoutStart) -> std::io::Result<()> {
        let s = self.shape;
        for (k, pe) in start.pes.iter().enumerate() {
            if let Some(t) = &mut self.slots {
                if let Err(e) = t.hold(k, &pe.mx, start.cycle) {
                    self.unfit(e);
                    continue;
                }
            }
            let mut at = 0;
            for (c, &mx) in pe.mx.iter().enumerate() {
                for row in 0..pe.rows[c] {
                    let word = pe.words[at];
                    at += 1;
                    let addr = self.addr(k, mx, row).unwrap_or(0) as usize;
                    if row as u64 >= s.rays.max_rows || pe.mx.len() as u64 > s.slots() {
                        continue;
                    }
                    if self.shadow[k][addr] != Some(word) {
                        self.shadow[k][addr] = Some(word);
                        self.outside_words += 1;
                        writeln!(
                            self.ev[k],
                            "{:x} 3 {:x} 0 {:x}",
                            start.cycle,
                            addr,
                            self.widths.pack(&word)
                        )?;
                    }
                }
            }
        }
        Ok(())
    }

    fn record(&mut self, issue: &Issue) -> std::io::Result<()> {
        let (k, s, w) = (issue.pe, &issue.input, self.widths);
        if self.row_at.0 != issue.cycle {
            return Err(std::io::Error::other(format!(
                "an issue in cycle {} without a broadcast",
                issue.cycle
            )));
        }
        self.issued[k] += 1;
        self.last_cycle = self.last_cycle.max(issue.cycle);
        let mut l = format!("I {:x} {:x}", issue.cycle, masked(s.m, w.m));
        for i in 0..4 {
            let _ = write!(l, " {:x}", masked(s.acc.raw[i], w.acc(i)));
        }
        writeln!(self.iss[k], "{l}")?;
        let mut l = format!("T {:x}", issue.cycle);
        for t in s.taps {
            let _ = write!(l, " {:x}", masked(i64::from(t), w.voxel));
        }
        writeln!(self.taps[k], "{l}")?;
        if let Some(t) = &mut self.slots {
            t.landed(k, s.m, s.land);
        }
        let addr = self.addr(k, s.m, self.row_at.1).unwrap_or(u64::MAX);
        let mut l = format!("W {:x} {:x}", s.land, addr);
        for i in 0..4 {
            let _ = write!(l, " {:x}", masked(issue.out.raw[i], w.acc(i)));
        }
        writeln!(self.wbs[k], "{l}")?;
        if let Some(slot) = self.shadow[k].get_mut(addr as usize) {
            *slot = Some(issue.out.raw);
        }
        if let (Some(t), Some(bit)) = (self.shape.termination, self.term[k].get_mut(addr as usize))
        {
            *bit = Some(issue.out.raw[3] >= t);
        }
        if let Some(l) = self.lands[k].get_mut(addr as usize) {
            *l = Some(s.land);
        }
        self.last_land = self.last_land.max(s.land);
        Ok(())
    }

    /// The clock whose middle the testbench dumps the buffers in: the
    /// readout's start, or past it the clock after the last write-back
    /// lands (a write-back landing in clock `c` is in the memory from
    /// clock `c + 1`).
    pub fn dump_cycle(&self, start: &ReadoutStart) -> u64 {
        start.cycle.max(self.last_land + 1)
    }

    /// Notes a readout read of a ray before its write-back landed: the
    /// host word of clock `t` is the buffer read in clock `t - 1`, which
    /// sees the write-backs that landed up to clock `t - 2`.
    fn check_read(&mut self, tick: &ReadoutTick) {
        for (k, o) in tick.host.iter().enumerate() {
            let Some(o) = o else { continue };
            let addr = self.addr(k, o.mx, o.row as usize).unwrap_or(u64::MAX) as usize;
            let land = self
                .lands
                .get(k)
                .and_then(|l| l.get(addr))
                .copied()
                .flatten();
            if let Some(land) = land.filter(|&l| l + 2 > tick.cycle) {
                if self.early_read.is_none() {
                    self.early_read = Some(format!(
                        "PE {k} reads ray ({}, {}) in clock {} and its write-back lands in clock {land}",
                        o.mx,
                        o.row,
                        tick.cycle - 1
                    ));
                }
            }
        }
    }
}

impl IssueSink for PeCapture {
    fn begin(&mut self, dp: &Datapath) {
        self.tables = super::capture::table_words(dp);
        self.frame = super::capture::frame_words(dp);
    }

    fn issue(&mut self, issue: &Issue) {
        if let Err(e) = self.record(issue) {
            self.fail(e);
        }
    }

    fn sample_bus(&mut self, b: &BusCycle) {
        self.row_at = (b.cycle, b.row);
        if let Some(z) = self.pending_load.take() {
            for f in &mut self.ev {
                if let Err(e) =
                    writeln!(f, "{:x} 1 {:x} {:x} 0", b.cycle.saturating_sub(1), z, z & 1)
                {
                    self.error.get_or_insert(e.to_string());
                }
            }
        }
        let (nv, nz, ny0, ny1) = match b.next {
            Some((z, y0, y1)) => (1, z & 1, y0, y1),
            None => (0, 0, 0, 0),
        };
        let mut l = format!(
            "{:x} {:x} {:x} {:x} {:x} {:x} {:x}",
            b.cycle,
            u8::from(b.go),
            u8::from(b.first),
            b.row,
            b.z & 1,
            b.y.0,
            b.y.1
        );
        for v in &b.words {
            let _ = write!(l, " {:x}", *v as u64);
        }
        let _ = write!(
            l,
            " {nv:x} {nz:x} {ny0:x} {ny1:x} {:x} {:x}",
            b.yp as u64, b.z
        );
        if let Err(e) = writeln!(self.bus, "{l}") {
            self.fail(e);
        }
    }

    fn slice_begin(&mut self, cycle: u64, z: usize, pes: &[Pe]) {
        if let Err(e) = self.begin_slice(cycle, z, pes) {
            self.fail(e);
        }
    }

    fn rows_planned(&mut self, _cycle: u64, first_row: usize, pes: &[Pe], runs: &RowRuns) {
        self.plan(first_row, pes, runs);
    }

    fn plan_runs(&mut self, from: u64, first_row: usize, runs: &RowRuns, lens: &[usize]) {
        if let Err(e) = self.write_runs(from, first_row, runs, lens) {
            self.fail(e);
        }
    }

    fn readout_begin(&mut self, start: &ReadoutStart) {
        self.readout = Some(start.clone());
        if let Err(e) = self.before_readout(start) {
            self.fail(e);
        }
    }

    fn readout_tick(&mut self, tick: &ReadoutTick) {
        self.check_read(tick);
        self.ticks.push(tick.clone());
    }
}
