//! GTKWave save files (`.gtkw`) that open a trace with one group per scope.

use std::fmt::Write as _;
use std::io::Write as _;
use std::path::Path;

use crate::atomic::temp_beside;
use crate::error::WavesError;
use crate::scope::TOP;
use crate::tracer::{TraceInfo, TIME_UNITS_PER_CYCLE};

// Trace flags of GTKWave's save format (gtkwave's `TR_*` constants).
const TR_HEX: u32 = 0x2;
const TR_BIN: u32 = 0x8;
const TR_RJUSTIFY: u32 = 0x20;
const TR_BLANK: u32 = 0x200;
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
        let dump = std::path::absolute(&self.vcd_path).unwrap_or_else(|_| self.vcd_path.clone());
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
        let mut flags = None;
        let mut set_flags = |s: &mut String, f: u32| {
            if flags != Some(f) {
                let _ = writeln!(s, "@{f:x}");
                flags = Some(f);
            }
        };
        let signal_flags = |i: usize| {
            let radix = if self.signals[i].width == 1 {
                TR_BIN
            } else {
                TR_HEX
            };
            TR_RJUSTIFY | radix
        };
        for &i in &ungrouped {
            set_flags(&mut s, signal_flags(i));
            let _ = writeln!(s, "{}", self.signals[i].gtkwave_name());
        }
        for (name, members) in &groups {
            set_flags(&mut s, TR_GRP_BEGIN | TR_BLANK);
            let _ = writeln!(s, "-{name}");
            for &i in members {
                set_flags(&mut s, signal_flags(i));
                let _ = writeln!(s, "{}", self.signals[i].gtkwave_name());
            }
            set_flags(&mut s, TR_GRP_END | TR_BLANK);
            let _ = writeln!(s, "-{name}");
        }
        s
    }

    /// Writes [`TraceInfo::gtkw_text`] to `path` (atomically, like the VCD).
    pub fn write_gtkw(&self, path: impl AsRef<Path>) -> Result<(), WavesError> {
        write_atomically(path.as_ref(), self.gtkw_text().as_bytes())
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
        };
        let info = TraceInfo {
            vcd_path: "/tmp/t/x.vcd".into(),
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
