//! GTKWave save files (`.gtkw`) that open a trace with one group per scope,
//! and the translate filter files that show enumerations by name.

use std::fmt::Write as _;
use std::io::Write as _;
use std::path::{Path, PathBuf};

use crate::atomic::temp_beside;
use crate::error::WavesError;
use crate::scope::TOP;
use crate::tracer::{TraceInfo, TIME_UNITS_PER_CYCLE, TIME_UNIT_PS};

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
/// The window the save file asks for, pixels.
const WINDOW: [u32; 2] = [1400, 1000];
/// Approximate width of GTKWave's wave pane in that window.
const WAVE_PIXELS: f64 = 960.0;
/// GTKWave keeps times in the timescale's unit (ps for `100ps`) times
/// its multiplier, and a save file's times are in those: picoseconds
/// per cycle.
const PS_PER_CYCLE: u64 = TIME_UNITS_PER_CYCLE * TIME_UNIT_PS;

impl TraceInfo {
    /// The text of a GTKWave save file for this trace, as written to
    /// `<dump stem>.gtkw` beside the dump.
    ///
    /// Signals directly in `top` (the clock first) come ungrouped; every
    /// scope below `top` (`ctrl`, `pe_0`, ...) becomes an open group that
    /// also holds its sub-scopes' signals, each shown by its name below
    /// the group (`left_ray_valid` in group `pe_3`), so a PE's two link
    /// ports read apart. Vectors are shown in hex, single bits in binary.
    /// The dump file is named relative to the save file, with the
    /// `[savefile]` line GTKWave resolves it against, so a folder of
    /// traces can move. Changes of the marker signal
    /// ([`TraceConfig::with_markers`](crate::TraceConfig::with_markers))
    /// become named markers.
    pub fn gtkw_text(&self) -> String {
        let dump = self.dump_path();
        let save = dump.with_extension("gtkw");
        self.gtkw_text_with(dump, &save, &[], &[])
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

    /// The save file `save`'s text opening `dump`, signal `i` shown
    /// through filter file `files[filters[i]]` if that is set; files are
    /// named relative to `save`'s folder when they lie in it.
    fn gtkw_text_with(
        &self,
        dump: &Path,
        save: &Path,
        filters: &[Option<usize>],
        files: &[PathBuf],
    ) -> String {
        let dir = save.parent().unwrap_or(Path::new(""));
        let mut s = String::new();
        let _ = writeln!(s, "[*] GTKWave save file written by ercube waves");
        let _ = writeln!(s, "[dumpfile] \"{}\"", relative_to(dir, dump).display());
        let _ = writeln!(s, "[savefile] \"{}\"", relative_to(dir, save).display());
        let _ = writeln!(s, "[size] {} {}", WINDOW[0], WINDOW[1]);
        if let Some(c) = &self.cycles {
            let _ = writeln!(s, "[timestart] {}", c.start() * PS_PER_CYCLE);
            // GTKWave opens at a few ns per screen; zoom so that the first
            // (up to) VISIBLE_CYCLES cycles fill about WAVE_PIXELS pixels.
            // GTKWave's zoom z shows 2^-z time units per 200 pixels
            // (`calczoom` in its source). The zoom line then holds the
            // primary marker (none) and the 26 named markers' times.
            let shown = (c.end() - c.start() + 1).min(VISIBLE_CYCLES);
            let units_per_frame = (shown * PS_PER_CYCLE) as f64 / WAVE_PIXELS * 200.0;
            let _ = write!(s, "*{:.6} -1", -units_per_frame.log2());
            for k in 0..NAMED_MARKERS {
                match self.markers.get(k) {
                    Some((cycle, _)) => {
                        let _ = write!(s, " {}", cycle * PS_PER_CYCLE);
                    }
                    None => s.push_str(" -1"),
                }
            }
            s.push('\n');
            for (k, (_, label)) in self.markers.iter().take(NAMED_MARKERS).enumerate() {
                let _ = writeln!(s, "[markername] {}{label}", (b'A' + k as u8) as char);
            }
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
        // the files from 1), then `+{alias}` and the trace
        // (`write_save_helper` in its savefile.c).
        let trace = |s: &mut String, flags: &mut Option<u32>, i: usize| {
            let sig = &self.signals[i];
            let radix = if sig.width == 1 { TR_BIN } else { TR_HEX };
            let f = filter(i);
            let translated = if f.is_some() { TR_FTRANSLATED } else { 0 };
            set_flags(s, flags, TR_RJUSTIFY | radix | translated);
            if let Some(n) = f {
                let _ = writeln!(s, "^{} {}", n + 1, relative_to(dir, &files[n]).display());
            }
            // Below a group, the name under the group's scope, joined by
            // `_` (GTKWave shows only the last `.`-separated part).
            let parts = sig.scope.parts();
            if parts.len() > 1 {
                let mut alias: Vec<&str> = parts[2..].iter().map(String::as_str).collect();
                alias.push(&sig.name);
                let _ = write!(s, "+{{{}}} ", alias.join("_"));
            }
            let _ = writeln!(s, "{}", sig.gtkwave_name());
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
        let text = self.gtkw_text_with(dump.as_ref(), path, &of, &paths);
        write_atomically(path, text.as_bytes())
    }

    /// The save files [`TraceInfo::write_gtkw_for`] should write, one per
    /// dump: `<stem>.gtkw` for the VCD, and for the FST the same unless a
    /// VCD of the same stem takes that name, then `<stem>.fst.gtkw`.
    pub fn save_files(&self) -> Vec<(PathBuf, PathBuf)> {
        let mut out: Vec<(PathBuf, PathBuf)> = Vec::new();
        for dump in [&self.vcd_path, &self.fst_path].into_iter().flatten() {
            let mut gtkw = dump.with_extension("gtkw");
            if out.iter().any(|(g, _)| *g == gtkw) {
                gtkw = dump.with_extension("fst.gtkw");
            }
            out.push((gtkw, dump.clone()));
        }
        out
    }
}

/// Named markers GTKWave keeps (`A` to `Z`).
const NAMED_MARKERS: usize = 26;

/// `path` relative to folder `dir` when it lies in it (GTKWave resolves
/// such names against the save file's folder through `[savefile]`), else
/// absolute.
fn relative_to(dir: &Path, path: &Path) -> PathBuf {
    // A bare file name's folder is the working directory.
    let dir = if dir.as_os_str().is_empty() {
        Path::new(".")
    } else {
        dir
    };
    let abs = |p: &Path| std::path::absolute(p).unwrap_or_else(|_| p.to_path_buf());
    let (dir, path) = (abs(dir), abs(path));
    match path.strip_prefix(&dir) {
        Ok(rel) if !rel.as_os_str().is_empty() => rel.to_path_buf(),
        _ => path,
    }
}

/// Writes through a temporary file in the same directory and a rename, so
/// that readers never see a half-written file (renamed with the rest of
/// an open staged run's files: the `staging` crate).
fn write_atomically(path: &Path, bytes: &[u8]) -> Result<(), WavesError> {
    let mut tmp = temp_beside(path)?;
    tmp.write_all(bytes)
        .and_then(|()| tmp.flush())
        .map_err(|e| WavesError::io("write", path, e))?;
    staging::place(tmp, path).map_err(|e| WavesError::io("rename to", path, e))?;
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
            markers: vec![(6, "merge".into())],
        };
        let expected = "\
[*] GTKWave save file written by ercube waves
[dumpfile] \"x.vcd\"
[savefile] \"x.gtkw\"
[size] 1400 1000
[timestart] 25000
*-12.346606 -1 30000 -1 -1 -1 -1 -1 -1 -1 -1 -1 -1 -1 -1 -1 -1 -1 -1 -1 -1 -1 -1 -1 -1 -1 -1 -1
[markername] Amerge
[treeopen] top.
@28
top.clk
@800200
-pe_0
@22
+{acc} top.pe_0.acc[15:0]
@28
+{mac_valid} top.pe_0.mac.valid
@1000200
-pe_0
@800200
-ctrl
@22
+{state} top.ctrl.state[2:0]
@1000200
-ctrl
@800200
-pe_1
@22
+{acc} top.pe_1.acc[15:0]
@1000200
-pe_1
";
        assert_eq!(info.gtkw_text(), expected);
    }
}
