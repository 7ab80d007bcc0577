//! The files a [`crate::Tracer`] writes: VCD (through the `vcd` crate) and
//! FST (through `fst-writer`), fed the same value changes, each into a
//! temporary file beside its target and renamed over it at the end.

use std::fs::File;
use std::io::{self, BufWriter, Seek, Write};
use std::path::{Path, PathBuf};

use fst_writer::{
    FstBodyWriter, FstFileType, FstHeaderWriter, FstInfo, FstScopeType, FstSignalId, FstSignalType,
    FstVarDirection, FstVarType,
};
use tempfile::NamedTempFile;
use vcd::{IdCode, ReferenceIndex, ScopeType, TimescaleUnit, VarType};

use crate::atomic::temp_beside;
use crate::error::WavesError;
use crate::tracer::{SignalInfo, TIME_UNITS_PER_CYCLE, TIME_UNIT_PS};

/// FST keeps value changes in memory until a block is flushed; a block
/// every 32 MiB bounds the memory of long frames (fst-writer's own
/// converter flushes at the same size).
const FST_FLUSH_BYTES: usize = 32 << 20;

/// Every output of a trace; at least one is present.
pub(crate) struct Sinks {
    vcd: Option<VcdSink>,
    fst: Option<FstSink>,
    /// Msb-first `0`/`1` text of the value being emitted (reused).
    pub(crate) bits: Vec<u8>,
}

struct VcdSink {
    path: PathBuf,
    tmp: NamedTempFile,
    out: vcd::Writer<BufWriter<File>>,
    line: Vec<u8>,
}

struct FstSink {
    path: PathBuf,
    tmp: NamedTempFile,
    /// The header writer until the header is written, then the body's.
    header: Option<FstHeaderWriter<BufWriter<File>>>,
    body: Option<FstBodyWriter<BufWriter<File>>>,
    /// FST ids in signal order.
    ids: Vec<FstSignalId>,
}

/// The files a finished trace wrote.
pub(crate) struct Written {
    pub(crate) vcd: Option<PathBuf>,
    pub(crate) fst: Option<PathBuf>,
}

fn fst_io(e: fst_writer::FstWriteError) -> io::Error {
    match e {
        fst_writer::FstWriteError::Io(e) => e,
        other => io::Error::other(other.to_string()),
    }
}

fn clone_file(tmp: &NamedTempFile) -> Result<File, WavesError> {
    tmp.as_file()
        .try_clone()
        .map_err(|e| WavesError::io("open", tmp.path(), e))
}

/// A scope of the header tree: its signals and sub-scopes, in the order in
/// which they were first registered.
#[derive(Default)]
struct Node {
    name: String,
    vars: Vec<usize>,
    children: Vec<Node>,
}

/// Scopes must be written as a tree, each opened once, while signals were
/// registered in arbitrary order: group them first.
fn scope_tree(info: &[SignalInfo]) -> Node {
    let mut root = Node::default();
    for (i, sig) in info.iter().enumerate() {
        let mut node = &mut root;
        for part in sig.scope.parts() {
            let pos = match node.children.iter().position(|c| &c.name == part) {
                Some(p) => p,
                None => {
                    node.children.push(Node {
                        name: part.clone(),
                        ..Node::default()
                    });
                    node.children.len() - 1
                }
            };
            node = &mut node.children[pos];
        }
        node.vars.push(i);
    }
    root
}

impl Sinks {
    /// Opens the temporary files of `vcd` and `fst`.
    pub(crate) fn open(vcd: Option<&Path>, fst: Option<&Path>) -> Result<Sinks, WavesError> {
        let vcd = match vcd {
            None => None,
            Some(path) => {
                let tmp = temp_beside(path)?;
                let file = clone_file(&tmp)?;
                Some(VcdSink {
                    path: path.to_path_buf(),
                    tmp,
                    out: vcd::Writer::new(BufWriter::with_capacity(1 << 16, file)),
                    line: Vec::with_capacity(128),
                })
            }
        };
        let fst = match fst {
            None => None,
            Some(path) => {
                let tmp = temp_beside(path)?;
                let file = clone_file(&tmp)?;
                let info = FstInfo {
                    // The header's last field, time zero: an offset added
                    // to every time, not the start (set in `finish`).
                    start_time: 0,
                    // TIME_UNIT_PS = 100 ps = 10^-10 s.
                    timescale_exponent: -10,
                    version: concat!("ercube waves ", env!("CARGO_PKG_VERSION")).to_string(),
                    date: String::new(),
                    file_type: FstFileType::Verilog,
                };
                let header = FstHeaderWriter::new(BufWriter::with_capacity(1 << 16, file), &info)
                    .map_err(|e| WavesError::io("write trace", tmp.path(), fst_io(e)))?;
                Some(FstSink {
                    path: path.to_path_buf(),
                    tmp,
                    header: Some(header),
                    body: None,
                    ids: Vec::new(),
                })
            }
        };
        Ok(Sinks {
            vcd,
            fst,
            bits: Vec::with_capacity(64),
        })
    }

    /// The path errors while writing are reported against (the VCD's
    /// temporary file, else the FST's).
    pub(crate) fn error_path(&self) -> PathBuf {
        match (&self.vcd, &self.fst) {
            (Some(v), _) => v.tmp.path().to_path_buf(),
            (None, Some(f)) => f.tmp.path().to_path_buf(),
            (None, None) => PathBuf::new(),
        }
    }

    /// The path of the first output (the VCD if there is one).
    pub(crate) fn path(&self) -> &Path {
        match (&self.vcd, &self.fst) {
            (Some(v), _) => &v.path,
            (None, Some(f)) => &f.path,
            (None, None) => Path::new(""),
        }
    }

    /// Writes the headers: every signal of `info`, signal `i` with VCD id
    /// code `i`.
    pub(crate) fn header(&mut self, info: &[SignalInfo]) -> io::Result<()> {
        let root = scope_tree(info);
        if let Some(v) = &mut self.vcd {
            let out = &mut v.out;
            out.version(concat!("ercube waves ", env!("CARGO_PKG_VERSION")))?;
            out.comment(&format!(
                "one clock cycle = {TIME_UNITS_PER_CYCLE} time units ({} MHz): \
                 values at time {TIME_UNITS_PER_CYCLE}*c are those of cycle c",
                crate::tracer::CLOCK_MHZ
            ))?;
            out.timescale(TIME_UNIT_PS as u32, TimescaleUnit::PS)?;
            let tables = enum_tables(info);
            for (handle, (i, _)) in tables.iter().enumerate() {
                write_enum_table(out.writer(), &info[*i], handle + 1)?;
            }
            fn write_node(
                out: &mut vcd::Writer<BufWriter<File>>,
                node: &Node,
                info: &[SignalInfo],
                tables: &[(usize, &[(u64, String)])],
            ) -> io::Result<()> {
                out.scope_def(ScopeType::Module, &node.name)?;
                for &i in &node.vars {
                    let w = info[i].width;
                    if let Some(h) = tables.iter().position(|t| t.1 == info[i].names.as_slice()) {
                        // The variable that follows takes enum table `h`.
                        writeln!(out.writer(), "$attrbegin misc 07 \"\" {} $end", h + 1)?;
                    }
                    let index = (w > 1).then(|| ReferenceIndex::Range(w as i32 - 1, 0));
                    out.var_def(
                        VarType::Wire,
                        w,
                        IdCode::from(i as u64),
                        &info[i].name,
                        index,
                    )?;
                }
                for child in &node.children {
                    write_node(out, child, info, tables)?;
                }
                out.upscope()
            }
            for top in &root.children {
                write_node(out, top, info, &tables)?;
            }
            out.enddefinitions()?;
        }
        if let Some(f) = &mut self.fst {
            let Some(mut h) = f.header.take() else {
                return Ok(());
            };
            let mut ids = vec![None; info.len()];
            fn write_node(
                h: &mut FstHeaderWriter<BufWriter<File>>,
                node: &Node,
                info: &[SignalInfo],
                ids: &mut [Option<FstSignalId>],
            ) -> fst_writer::Result<()> {
                h.scope(&node.name, "", FstScopeType::Module)?;
                for &i in &node.vars {
                    // Vectors carry their range in the name, as GTKWave's
                    // vcd2fst writes them, so both files read back alike.
                    let w = info[i].width;
                    let name = if w > 1 {
                        format!("{}[{}:0]", info[i].name, w - 1)
                    } else {
                        info[i].name.clone()
                    };
                    ids[i] = Some(h.var(
                        name,
                        FstSignalType::bit_vec(w),
                        FstVarType::Wire,
                        FstVarDirection::Implicit,
                        None,
                    )?);
                }
                for child in &node.children {
                    write_node(h, child, info, ids)?;
                }
                h.up_scope()
            }
            for top in &root.children {
                write_node(&mut h, top, info, &mut ids).map_err(fst_io)?;
            }
            f.ids = ids.into_iter().flatten().collect();
            f.body = Some(h.finish().map_err(fst_io)?);
        }
        Ok(())
    }

    /// Starts the values of time `time`.
    pub(crate) fn timestamp(&mut self, time: u64) -> io::Result<()> {
        if let Some(v) = &mut self.vcd {
            v.out.timestamp(time)?;
        }
        if let Some(body) = self.fst.as_mut().and_then(|f| f.body.as_mut()) {
            if body.size() >= FST_FLUSH_BYTES {
                body.flush().map_err(fst_io)?;
            }
            body.time_change(time).map_err(fst_io)?;
        }
        Ok(())
    }

    /// Writes signal `i`'s new value, `self.bits` (msb first, exactly the
    /// signal's width).
    pub(crate) fn change(&mut self, i: usize) -> io::Result<()> {
        let bits = &self.bits;
        if let Some(v) = &mut self.vcd {
            let code = IdCode::from(i as u64);
            if bits.len() == 1 {
                v.out.change_scalar(code, bits[0] == b'1')?;
            } else {
                // `vcd::Writer::change_vector` formats each bit through
                // `write!`; building the line here is several times faster
                // and produces the same text.
                let line = &mut v.line;
                line.clear();
                line.push(b'b');
                line.extend_from_slice(bits);
                line.push(b' ');
                write!(line, "{code}")?;
                line.push(b'\n');
                v.out.writer().write_all(line)?;
            }
        }
        if let Some(f) = &mut self.fst {
            if let (Some(body), Some(&id)) = (f.body.as_mut(), f.ids.get(i)) {
                body.signal_change(id, bits).map_err(fst_io)?;
            }
        }
        Ok(())
    }

    /// Ends the files at `end` (a final timestamp, if any), names `start`
    /// (the first traced cycle's time, if any) as the FST's start time,
    /// and renames them to their targets (at once, or with the rest of an open
    /// staged run's files: the `staging` crate).
    pub(crate) fn finish(
        mut self,
        start: Option<u64>,
        end: Option<u64>,
    ) -> Result<Written, WavesError> {
        let mut written = Written {
            vcd: None,
            fst: None,
        };
        if let Some(mut v) = self.vcd.take() {
            let tmp_path = v.tmp.path().to_path_buf();
            let io = |e: io::Error| WavesError::io("write trace", &tmp_path, e);
            if let Some(t) = end {
                v.out.timestamp(t).map_err(io)?;
            }
            v.out.flush().map_err(io)?;
            drop(v.out);
            // Renamed now, or with the rest of a staged run's files.
            staging::place(v.tmp, &v.path)
                .map_err(|e| WavesError::io("rename trace to", &v.path, e))?;
            written.vcd = Some(v.path);
        }
        if let Some(f) = self.fst.take() {
            let tmp_path = f.tmp.path().to_path_buf();
            let io = |e: io::Error| WavesError::io("write trace", &tmp_path, e);
            let Some(mut body) = f.body else {
                return Err(io(io::Error::other("FST header was never written")));
            };
            if let Some(t) = end {
                body.time_change(t).map_err(fst_io).map_err(io)?;
            }
            let mut out = body.finish().map_err(fst_io).map_err(io)?;
            if let Some(t) = start {
                // The header block: its type byte, its length, then the
                // start time (big-endian), which the writer leaves at 0.
                out.seek(io::SeekFrom::Start(1 + 8)).map_err(io)?;
                out.write_all(&t.to_be_bytes()).map_err(io)?;
            }
            out.flush().map_err(io)?;
            drop(out);
            staging::place(f.tmp, &f.path)
                .map_err(|e| WavesError::io("rename trace to", &f.path, e))?;
            written.fst = Some(f.path);
        }
        Ok(written)
    }
}

/// The distinct value-name tables of `info`'s enumerations, each with the
/// first signal that uses it (which names it and gives its width).
fn enum_tables(info: &[SignalInfo]) -> Vec<(usize, &[(u64, String)])> {
    let mut out: Vec<(usize, &[(u64, String)])> = Vec::new();
    for (i, sig) in info.iter().enumerate() {
        if !sig.names.is_empty() && !out.iter().any(|t| t.1 == sig.names.as_slice()) {
            out.push((i, &sig.names));
        }
    }
    out
}

/// Writes `sig`'s value names as enum table `handle`, in the attribute
/// GTKWave's VCD extension defines (`$attrbegin misc 07 name count
/// names... values... handle $end`, values as bit strings of the
/// signal's width), which wellen, and so Surfer, reads.
fn write_enum_table(out: &mut impl Write, sig: &SignalInfo, handle: usize) -> io::Result<()> {
    write!(out, "$attrbegin misc 07 {} {}", sig.name, sig.names.len())?;
    for (_, name) in &sig.names {
        write!(out, " {name}")?;
    }
    let w = sig.width as usize;
    for (code, _) in &sig.names {
        write!(out, " {code:0w$b}")?;
    }
    writeln!(out, " {handle} $end")
}
