//! The replay: each PE's captured issue stream as a file, and a generated
//! top that drives one emitted datapath per PE with it, cycle by cycle, and
//! checks every output on every cycle.
//!
//! A stream file (`pe<K>.stim`) has one line per issued sample, in issue
//! order: the issue cycle, the write-back cycle, then every field of
//! [`Replay::fields`] as a hexadecimal word (two's complement over the
//! port's width). The replayer of PE `K` (module `ercube_cosim_pe`) keeps
//! the next line in registers; on the clock edge that ends cycle `c` it
//!
//! 1. checks what the module shows in cycle `c`: `out_valid` exactly when
//!    the model wrote a sample back in `c`, then that sample's accumulators,
//!    and the tap column `x0` of the sample issued `stage(x0)` clocks
//!    before (zero in a bubble);
//! 2. drives cycle `c + 1`: `in_valid` and the sample's ports if the next
//!    line issues then (zeros and `in_valid` low otherwise: a bubble), and
//!    the voxel taps of the sample issued `stage(v00)` clocks before, one
//!    clock after its tap column, as a block RAM would return them.
//!
//! Expectations wait in rings indexed by cycle modulo a power of two
//! longer than the pipeline. The top (`ercube_cosim`) resets every
//! replayer, writes the frame's tables into every datapath through the
//! host port (`tables.hex`, one row per word), runs cycles `0..=cycles`
//! (`+cycles=N`), and prints one line per PE; each replayer prints its first
//! mismatch. Nothing in the text depends on the frame, so a build serves
//! every frame of the same configuration and PE count.

use std::fmt::Write as _;
use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

use super::capture::{table_words, Issue, IssueSink};
use crate::datapath::Datapath;
use crate::hw::pipeline_rtl::{PipelinedModule, Port};

mod testbench;

/// The generated top's name.
pub const TOP: &str = "ercube_cosim";

/// The per-PE replayer's name.
pub const REPLAYER: &str = "ercube_cosim_pe";

/// How a port of the datapath is fed or checked.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Role {
    /// An input taken with the sample at issue.
    Issue,
    /// An input read `stage` clocks after issue (the voxel taps).
    Late,
    /// An output shown `stage` clocks after issue (the tap column).
    Probe,
    /// An output shown when the sample is written back (the
    /// accumulators, with `out_valid`).
    Result,
}

/// One port of the datapath as the replay sees it.
#[derive(Debug, Clone)]
pub struct Field {
    /// The port.
    pub port: Port,
    /// How it is fed or checked.
    pub role: Role,
}

/// Why a replay cannot be made.
#[derive(Debug, thiserror::Error)]
pub enum ReplayError {
    /// The module has a port the capture has no word for.
    #[error("the emitted datapath has port {0}, which the capture does not carry")]
    UnknownPort(String),
}

/// The word of `issue` that port `name` carries (the accumulators
/// written back for `acc_out_*`); `None` for a port the capture does not
/// carry.
pub fn word_of(issue: &Issue, name: &str) -> Option<i64> {
    let s = &issue.input;
    Some(match name {
        "slot_m" => s.m,
        "a" => s.a,
        "t" => s.t,
        "b" => s.b,
        "k" => s.k,
        "row_wy" => s.wy,
        "sy" => s.sy,
        "sz" => s.sz,
        "acc_r" => s.acc.raw[0],
        "acc_g" => s.acc.raw[1],
        "acc_b" => s.acc.raw[2],
        "acc_a" => s.acc.raw[3],
        "v00" => i64::from(s.taps[0]),
        "v01" => i64::from(s.taps[1]),
        "v10" => i64::from(s.taps[2]),
        "v11" => i64::from(s.taps[3]),
        "x0" => s.x0,
        "acc_out_r" => issue.out.raw[0],
        "acc_out_g" => issue.out.raw[1],
        "acc_out_b" => issue.out.raw[2],
        "acc_out_a" => issue.out.raw[3],
        "voi_y" => s.units.y,
        "voi_z" => s.units.z,
        "pre_prev" => s.units.pre.prev,
        "pre_step" => i64::from(s.units.pre.step),
        "pre_lead" => i64::from(s.units.pre.lead),
        "pre_half" => i64::from(s.units.pre.half),
        _ => {
            let tap = name.strip_prefix("shade_")?;
            let k = crate::hw::compose::SHADE_TAPS
                .iter()
                .position(|t| t.replace('.', "_") == tap)?;
            i64::from(s.units.taps[k])
        }
    })
}

/// Whether port `name` is a unit's per-frame port (a broadcast register
/// the host writes once a frame: `shade_ka`, `voi_centre_x`, `pre_scale`,
/// ...), whose word is the frame's rather than a sample's.
pub fn is_frame_port(name: &str) -> bool {
    let probe = Issue {
        cycle: 0,
        pe: 0,
        input: Default::default(),
        out: Default::default(),
    };
    ["shade_", "voi_", "pre_"]
        .iter()
        .any(|p| name.starts_with(p))
        && word_of(&probe, name).is_none()
}

/// `v`'s low `bits` bits as an unsigned word.
pub fn masked(v: i64, bits: u32) -> u128 {
    if bits >= 128 {
        v as i128 as u128
    } else {
        (v as i128 as u128) & ((1u128 << bits) - 1)
    }
}

/// A word read back in hexadecimal, sign-extended when `signed`.
pub fn parse_hex(s: &str, bits: u32, signed: bool) -> Option<i128> {
    let u = u128::from_str_radix(s, 16).ok()?;
    let v = u as i128;
    Some(if signed && bits < 128 && (v >> (bits - 1)) & 1 == 1 {
        v - (1i128 << bits)
    } else {
        v
    })
}

/// The control ports: driven by the replayer or the top, not captured.
const CONTROL: [&str; 8] = [
    "clk",
    "rst",
    "in_valid",
    "out_valid",
    "tbl_we",
    "tbl_sel",
    "tbl_addr",
    "tbl_data",
];

/// The fields of `m`'s ports, in the module's order.
pub fn fields(m: &PipelinedModule) -> Result<Vec<Field>, ReplayError> {
    let probe = Issue {
        cycle: 0,
        pe: 0,
        input: Default::default(),
        out: Default::default(),
    };
    m.ports
        .iter()
        .filter(|p| !CONTROL.contains(&p.name.as_str()))
        .map(|p| {
            if word_of(&probe, &p.name).is_none() && !(p.input && is_frame_port(&p.name)) {
                return Err(ReplayError::UnknownPort(p.name.clone()));
            }
            let role = match (p.input, p.stage) {
                (true, 0) => Role::Issue,
                (true, _) => Role::Late,
                (false, s) if s == m.depth => Role::Result,
                (false, _) => Role::Probe,
            };
            Ok(Field {
                port: p.clone(),
                role,
            })
        })
        .collect()
}

/// The width of `m`'s port `name` (1 if it has none).
pub fn port_bits(m: &PipelinedModule, name: &str) -> u32 {
    m.ports
        .iter()
        .find(|p| p.name == name)
        .map_or(1, |p| p.word.bits)
}

/// The host port's rows writing `tables` (by name) into `m`'s tables:
/// `{1, tbl_sel, tbl_addr, tbl_data}` in hexadecimal, one a line, table
/// after table in `tbl_sel` order; and the row count.
pub fn table_rows(m: &PipelinedModule, tables: &[(String, Vec<i64>)]) -> (String, usize) {
    let (sb, ab, db) = (
        port_bits(m, "tbl_sel"),
        port_bits(m, "tbl_addr"),
        port_bits(m, "tbl_data"),
    );
    let mut s = String::new();
    let mut n = 0;
    for t in &m.tables {
        let Some((_, words)) = tables.iter().find(|c| c.0 == t.name) else {
            continue;
        };
        for (a, &w) in words.iter().enumerate().take(t.depth as usize) {
            let row = (1u128 << (sb + ab + db))
                | (u128::from(t.sel) << (ab + db))
                | ((a as u128) << db)
                | masked(w, db);
            let _ = writeln!(s, "{row:x}");
            n += 1;
        }
    }
    (s, n)
}

/// The replay of one configuration's datapath: the module, its fields and
/// the generated text.
#[derive(Debug, Clone)]
pub struct Replay {
    /// The emitted datapath.
    pub module: PipelinedModule,
    /// Its captured ports, in the stream files' order.
    pub fields: Vec<Field>,
    /// Bits of the rings' index: `2^ring_bits` cycles exceed the longest
    /// wait (the pipeline's depth or the model's latency).
    pub ring_bits: u32,
    /// The units' per-frame port words ([`super::capture::frame_words`]),
    /// driven with every sample (the module takes its ports at issue).
    pub frame: Vec<(String, i64)>,
    /// Datapaths a PE: 2 where a pre-integrated sample composites two
    /// steps (back to front, slice 0's step and its half step), the
    /// second step replayed through PE `k`'s second datapath (replayer
    /// `pes + k`, stream `pe<pes + k>.stim`) with the model's
    /// accumulators between the steps; else 1.
    pub lanes: usize,
}

impl Replay {
    /// The replay of `module` for a model writing back `latency` clocks
    /// after issue.
    pub fn new(module: PipelinedModule, latency: u64) -> Result<Replay, ReplayError> {
        let fields = fields(&module)?;
        let longest = latency.max(u64::from(module.depth)) + 2;
        let ring_bits = (64 - longest.leading_zeros()).max(2);
        Ok(Replay {
            module,
            fields,
            ring_bits,
            frame: Vec::new(),
            lanes: 1,
        })
    }

    /// The replay with a second datapath a PE for the second of a
    /// sample's two pre-integrated steps ([`Replay::lanes`]).
    pub fn with_second_steps(self) -> Replay {
        Replay { lanes: 2, ..self }
    }

    /// The word port `name` carries for `issue`: the sample's, or the
    /// frame's for a unit's per-frame port (zero if not known).
    pub fn word(&self, issue: &Issue, name: &str) -> i64 {
        word_of(issue, name)
            .or_else(|| self.frame.iter().find(|f| f.0 == name).map(|f| f.1))
            .unwrap_or(0)
    }

    /// Rows the top writes through the host port (every word of every
    /// table).
    pub fn table_words(&self) -> usize {
        self.module.tables.iter().map(|t| t.depth as usize).sum()
    }

    /// A stream file's line for `issue`, written back at `land`.
    pub fn line(&self, issue: &Issue, land: u64, out: &mut String) {
        let _ = write!(out, "{:x} {:x}", issue.cycle, land);
        for f in &self.fields {
            let v = self.word(issue, &f.port.name);
            let _ = write!(out, " {:x}", masked(v, f.port.word.bits));
        }
        out.push('\n');
    }
}

/// A sink writing each PE's issue stream file (`pe<K>.stim`) and the host
/// port's table rows (`tables.hex`) into a directory, as the frame runs.
pub struct StreamFiles {
    replay: Replay,
    dir: PathBuf,
    files: Vec<BufWriter<File>>,
    /// Issues after this cycle are left out.
    last_issue: u64,
    /// Write back at issue plus this instead of the model's cycle.
    realign: Option<u64>,
    line: String,
    /// Issues written, per replayer (PE `k`'s second steps at `pes + k`).
    pub issued: Vec<u64>,
    pes: usize,
    /// The last write-back cycle written.
    pub last_land: u64,
    /// The model's latency, known at the frame's start.
    pub latency: u64,
    /// The first error writing.
    pub error: Option<std::io::Error>,
}

impl StreamFiles {
    /// Streams for `pes` PEs into `dir`, keeping issues up to cycle
    /// `last_issue`; `realign` writes results back `realign` clocks after
    /// issue (the module's depth) instead of at the model's cycle.
    pub fn create(
        replay: Replay,
        dir: &Path,
        pes: usize,
        last_issue: u64,
        realign: Option<u64>,
    ) -> std::io::Result<StreamFiles> {
        let files = (0..pes * replay.lanes)
            .map(|k| File::create(dir.join(format!("pe{k}.stim"))).map(BufWriter::new))
            .collect::<std::io::Result<Vec<_>>>()?;
        Ok(StreamFiles {
            issued: vec![0; files.len()],
            replay,
            dir: dir.to_owned(),
            files,
            last_issue,
            realign,
            line: String::new(),
            pes,
            last_land: 0,
            latency: 0,
            error: None,
        })
    }

    /// Flushes the streams; the first error met, if any.
    pub fn finish(&mut self) -> std::io::Result<()> {
        if let Some(e) = self.error.take() {
            return Err(e);
        }
        for f in &mut self.files {
            f.flush()?;
        }
        Ok(())
    }
}

impl IssueSink for StreamFiles {
    fn begin(&mut self, dp: &Datapath) {
        self.latency = dp.latency;
        self.replay.frame = super::capture::frame_words(dp);
        let (rows, _) = table_rows(&self.replay.module, &table_words(dp));
        if let Err(e) = std::fs::write(self.dir.join("tables.hex"), rows) {
            self.error.get_or_insert(e);
        }
    }

    fn issue(&mut self, issue: &Issue) {
        if issue.cycle > self.last_issue || self.error.is_some() {
            return;
        }
        let land = match self.realign {
            Some(d) => issue.cycle + d,
            None => issue.input.land,
        };
        self.last_land = self.last_land.max(land);
        let (first, second) = super::capture::PreIn::steps(issue);
        for (lane, step) in [(0, Some(first)), (1, second)] {
            let Some(step) = step else { continue };
            if lane >= self.replay.lanes {
                self.error = Some(std::io::Error::other(format!(
                    "cycle {}, PE {}: a sample composites two steps and the replay has one datapath a PE",
                    issue.cycle, issue.pe
                )));
                return;
            }
            let k = lane * self.pes + issue.pe;
            self.line.clear();
            self.replay.line(&step, land, &mut self.line);
            if let Some(f) = self.files.get_mut(k) {
                if let Err(e) = f.write_all(self.line.as_bytes()) {
                    self.error = Some(e);
                }
                self.issued[k] += 1;
            }
        }
    }
}
