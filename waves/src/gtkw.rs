//! GTKWave save files (`.gtkw`) that open a trace with one group per scope,
//! and the translate filter files that show enumerations by name.

use std::fmt::Write as _;
use std::io::Write as _;
use std::path::{Path, PathBuf};

use crate::atomic::temp_beside;
use crate::error::WavesError;
use crate::scope::TOP;
use crate::tracer::{TraceInfo, TIME_UNITS_PER_CYCLE};

// Trace flags of GTKWave's save format (gtkwave's `TR_*` constants).
const TR_HEX: u32 = 0x2;
const TR_BIN: u32 = 0x8;
const TR_RJUSTIFY: u32 = 0x20;
const TR_BLANK: u32 = 0x200;
const TR_FTRANSLATED: u32 = 0x2000;
const TR_GRP_BEGIN: u32 = 0x80_0000;
const TR_GRP_END: u32 = 0x100_0000;

/// Cycles shown at once when the save file is opened: enough to see a
/// pipeline at work, few enough that every cycle stays readable.
const VISIBLE_CYCLES: u64 = 16;
/// Approximate width of GTKWave's wave pane in its default window.
const WAVE_PIXELS: f64 = 540.0;

impl TraceInfo {
    /// The text of a GTKWave save file for this trace.
    ///
    /// Signals directly in `top` (the clock first) come ungrouped; every
    /// scope below `top` (`ctrl`, `pe_0`, ...) becomes an open group that
    /// also holds its sub-scopes' signals. Vectors are shown in hex,
    /// single bits in binary. The dump file is named by its absolute path
    /// because GTKWave resolves a relative one against its own working
    /// directory, not the save file's.
    pub fn gtkw_text(&self) -> String {
        self.gtkw_text_with(self.dump_path(), &[], &[])
    }

    /// The file a save file opens: the VCD if one was written, else the
    /// FST.
    pub fn dump_path(&self) -> &Path {
        self.vcd_path
            .as_deref()
            .or(self.fst_path.as_deref())
            .unwrap_or(Path::new(""))
    }

    /// The translate filter files of the enumerations for a save file at
    /// `gtkw`: `<stem>.<signal>.txt` beside it (`run.stage.txt` for
    /// `top.ctrl.stage` in `run.gtkw`), one `value name` line per value,
    /// the value in hex as GTKWave prints a vector. Signals with the same
    /// names share a file; returns, per signal, its file's index in the
    /// list, and the list of (path, text).
    pub fn filter_files(&self, gtkw: &Path) -> (Vec<Option<usize>>, Vec<(PathBuf, String)>) {
        let stem = gtkw.file_stem().unwrap_or_default().to_string_lossy();
        let mut files: Vec<(PathBuf, String)> = Vec::new();
        let mut of = Vec::with_capacity(self.signals.len());
        for sig in &self.signals {
            if sig.names.is_empty() {
                of.push(None);
                continue;
            }
            let mut text = format!("# values of {}, written by ercube waves\n", sig.full_name());
            let body: String = sig
                .names
                .iter()
                .map(|(v, n)| format!("{v:X} {n}\n"))
                .collect();
            text.push_str(&body);
            // One file per distinct table: the first signal names it; a
            // different table under the same leaf name takes the full name.
            if let Some(i) = files.iter().position(|(_, t)| t.ends_with(&body)) {
                of.push(Some(i));
                continue;
            }
            let mut path = gtkw.with_file_name(format!("{stem}.{}.txt", sig.name));
            if files.iter().any(|(p, _)| *p == path) {
                let full = sig.full_name().replace('.', "_");
                path = gtkw.with_file_name(format!("{stem}.{full}.txt"));
            }
            files.push((path, text));
            of.push(Some(files.len() - 1));
        }
        (of, files)
    }

    /// The save file's text opening `dump`, signal `i` shown through
    /// filter file `files[filters[i]]` if that is set (absolute paths:
    /// GTKWave resolves them against its working directory).
    fn gtkw_text_with(&self, dump: &Path, filters: &[Option<usize>], files: &[PathBuf]) -> String {
        let dump = std::path::absolute(dump).unwrap_or_else(|_| dump.to_path_buf());
        let mut s = String::new();
        let _ = writeln!(s, "[*] GTKWave save file written by ercube waves");
        let _ = writeln!(s, "[dumpfile] \"{}\"", dump.display());
        if let Some(c) = &self.cycles {
            let _ = writeln!(s, "[timestart] {}", c.start() * TIME_UNITS_PER_CYCLE);
            // GTKWave opens at a few ns per screen; zoom so that the first
            // (up to) VISIBLE_CYCLES cycles fill about WAVE_PIXELS pixels.
            // GTKWave's zoom z shows 2^-z time units per 200 pixels
            // (`calczoom` in its source).
            let shown = (c.end() - c.start() + 1).min(VISIBLE_CYCLES);
            let units_per_frame = (shown * TIME_UNITS_PER_CYCLE) as f64 / WAVE_PIXELS * 200.0;
            let _ = writeln!(s, "*{:.6} -1", -units_per_frame.log2());
        }
        let _ = writeln!(s, "[treeopen] {TOP}.");

        // Group key: the scope right below `top`, in order of first use.
        let mut groups: Vec<(&str, Vec<usize>)> = Vec::new();
        let mut ungrouped = Vec::new();
        for (i, sig) in self.signals.iter().enumerate() {
            match sig.scope.parts().get(1) {
                None => ungrouped.push(i),
                Some(g) => match groups.iter_mut().find(|(name, _)| name == g) {
                    Some((_, v)) => v.push(i),
                    None => groups.push((g, vec![i])),
                },
            }
        }
        // GTKWave keeps the last `@flags` line for the traces that follow,
        // so one is written only when the flags change.
        fn set_flags(s: &mut String, flags: &mut Option<u32>, f: u32) {
            if *flags != Some(f) {
                let _ = writeln!(s, "@{f:x}");
                *flags = Some(f);
            }
        }
        let mut flags = None;
        let filter = |i: usize| filters.get(i).copied().flatten();
        // GTKWave's own order: flags, then `^<n> <filter file>` (n counts
        // the files from 1), then the trace (`write_save_helper` in its
        // savefile.c).
        let trace = |s: &mut String, flags: &mut Option<u32>, i: usize| {
            let radix = if self.signals[i].width == 1 {
                TR_BIN
            } else {
                TR_HEX
            };
            let f = filter(i);
            let translated = if f.is_some() { TR_FTRANSLATED } else { 0 };
            set_flags(s, flags, TR_RJUSTIFY | radix | translated);
            if let Some(n) = f {
                let p = &files[n];
                let p = std::path::absolute(p).unwrap_or_else(|_| p.clone());
                let _ = writeln!(s, "^{} {}", n + 1, p.display());
            }
            let _ = writeln!(s, "{}", self.signals[i].gtkwave_name());
        };
        for &i in &ungrouped {
            trace(&mut s, &mut flags, i);
        }
        for (name, members) in &groups {
            set_flags(&mut s, &mut flags, TR_GRP_BEGIN | TR_BLANK);
            let _ = writeln!(s, "-{name}");
            for &i in members {
                trace(&mut s, &mut flags, i);
            }
            set_flags(&mut s, &mut flags, TR_GRP_END | TR_BLANK);
            let _ = writeln!(s, "-{name}");
        }
        s
    }

    /// Writes a save file to `path` opening [`TraceInfo::dump_path`]
    /// (atomically, like the trace), and the translate filter files of
    /// its enumerations beside it ([`TraceInfo::filter_files`]).
    pub fn write_gtkw(&self, path: impl AsRef<Path>) -> Result<(), WavesError> {
        self.write_gtkw_for(path, self.dump_path())
    }

    /// As [`TraceInfo::write_gtkw`], opening `dump` (e.g. the FST of a
    /// trace that wrote both).
    pub fn write_gtkw_for(
        &self,
        path: impl AsRef<Path>,
        dump: impl AsRef<Path>,
    ) -> Result<(), WavesError> {
        let path = path.as_ref();
        let (of, files) = self.filter_files(path);
        for (p, text) in &files {
            write_atomically(p, text.as_bytes())?;
        }
        let paths: Vec<PathBuf> = files.into_iter().map(|(p, _)| p).collect();
        let text = self.gtkw_text_with(dump.as_ref(), &of, &paths);
        write_atomically(path, text.as_bytes())
    }
}

/// Writes through a temporary file in the same directory and a rename, so
/// that readers never see a half-written file.
fn write_atomically(path: &Path, bytes: &[u8]) -> Result<(), WavesError> {
    let mut tmp = temp_beside(path)?;
    tmp.write_all(bytes)
        .and_then(|()| tmp.flush())
        .map_err(|e| WavesError::io("write", path, e))?;
    tmp.persist(path)
        .map_err(|e| WavesError::io("rename to", path, e.error))?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{ScopePath, SignalInfo};

    #[test]
    fn groups_per_scope() {
        let sig = |scope: ScopePath, name: &str, width| SignalInfo {
            scope,
            name: name.into(),
            width,
            names: Vec::new(),
        };
        let info = TraceInfo {
            vcd_path: Some("/tmp/t/x.vcd".into()),
            fst_path: None,
            signals: vec![
                sig(ScopePath::top(), "clk", 1),
                sig(ScopePath::pe(0), "acc", 16),
                sig(ScopePath::top().child("ctrl"), "state", 3),
                sig(ScopePath::pe(0).child("mac"), "valid", 1),
                sig(ScopePath::pe(1), "acc", 16),
            ],
            cycles: Some(5..=9),
        };
        let expected = "\
[*] GTKWave save file written by ercube waves
[dumpfile] \"/tmp/t/x.vcd\"
[timestart] 50
*-4.210897 -1
[treeopen] top.
@28
top.clk
@800200
-pe_0
@22
top.pe_0.acc[15:0]
@28
top.pe_0.mac.valid
@1000200
-pe_0
@800200
-ctrl
@22
top.ctrl.state[2:0]
@1000200
-ctrl
@800200
-pe_1
@22
top.pe_1.acc[15:0]
@1000200
-pe_1
";
        assert_eq!(info.gtkw_text(), expected);
    }
}
