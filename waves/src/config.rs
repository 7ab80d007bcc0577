//! What to trace: output path, PE set, cycle window, signal names.

use std::collections::BTreeSet;
use std::ops::RangeInclusive;
use std::path::{Path, PathBuf};

use crate::error::WavesError;
use crate::scope::ScopePath;

/// Which PEs are traced. Scopes that belong to no PE (`top`, `top.ctrl`)
/// are not affected by this filter.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub enum PeFilter {
    /// Every PE.
    #[default]
    All,
    /// Only these PE indices.
    Only(BTreeSet<u32>),
}

impl PeFilter {
    /// Whether PE `k` is selected.
    pub fn contains(&self, k: u32) -> bool {
        match self {
            PeFilter::All => true,
            PeFilter::Only(set) => set.contains(&k),
        }
    }

    /// Parses `all`, or a comma-separated list of indices and inclusive
    /// ranges such as `0,3,8-11`, the form a command line would take.
    pub fn parse(text: &str) -> Result<Self, WavesError> {
        let bad = |reason: String| WavesError::InvalidSpec {
            what: "PE list",
            text: text.to_string(),
            reason,
        };
        let t = text.trim();
        if t.eq_ignore_ascii_case("all") {
            return Ok(PeFilter::All);
        }
        let mut set = BTreeSet::new();
        for item in t.split(',').map(str::trim) {
            let num = |s: &str| {
                s.trim()
                    .parse::<u32>()
                    .map_err(|e| bad(format!("{s:?}: {e}")))
            };
            match item.split_once('-') {
                Some((a, b)) => {
                    let (a, b) = (num(a)?, num(b)?);
                    if a > b {
                        return Err(bad(format!("empty range {item}")));
                    }
                    set.extend(a..=b);
                }
                None => {
                    set.insert(num(item)?);
                }
            }
        }
        Ok(PeFilter::Only(set))
    }
}

/// Parses a cycle window: `A..=B`, `A..B` (B excluded), `A..`, `..=B`,
/// `..B` or a single cycle `N`.
pub fn parse_cycle_window(text: &str) -> Result<RangeInclusive<u64>, WavesError> {
    let bad = |reason: String| WavesError::InvalidSpec {
        what: "cycle window",
        text: text.to_string(),
        reason,
    };
    let num = |s: &str| {
        s.trim()
            .parse::<u64>()
            .map_err(|e| bad(format!("{s:?}: {e}")))
    };
    let t = text.trim();
    let Some((a, b)) = t.split_once("..") else {
        let n = num(t)?;
        return Ok(n..=n);
    };
    let start = if a.trim().is_empty() { 0 } else { num(a)? };
    let end = if let Some(b) = b.strip_prefix('=') {
        num(b)?
    } else if b.trim().is_empty() {
        u64::MAX
    } else {
        num(b)?
            .checked_sub(1)
            .ok_or_else(|| bad("empty window".to_string()))?
    };
    if start > end {
        return Err(bad("empty window".to_string()));
    }
    Ok(start..=end)
}

/// A named group of signals that a model declares (e.g. a chip's `ctrl`,
/// `datapath`, `ports`), selected as a whole by
/// [`TraceConfig::with_groups`]; signals declared through
/// [`crate::Tracer::register_in`] belong to one.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Group {
    /// The name a selection uses.
    pub name: &'static str,
    /// Whether the group is traced when no selection is given: models
    /// keep bulky groups off by default so that a plain trace stays small.
    pub default: bool,
}

/// Options of a trace. Built with [`TraceConfig::new`] and the `with_*`
/// methods; the defaults trace every signal (of every group on by default)
/// into one VCD.
#[derive(Clone, Debug)]
pub struct TraceConfig {
    /// The VCD file, if one is written.
    pub(crate) path: Option<PathBuf>,
    /// The FST file, if one is written.
    pub(crate) fst: Option<PathBuf>,
    pub(crate) pes: PeFilter,
    pub(crate) cycles: RangeInclusive<u64>,
    pub(crate) signals: Vec<String>,
    pub(crate) groups: Option<BTreeSet<String>>,
    pub(crate) clock: bool,
    pub(crate) markers: Option<(String, Vec<u64>)>,
}

impl TraceConfig {
    /// Trace everything into the VCD file `path`, with a `top.clk` signal.
    pub fn new(path: impl Into<PathBuf>) -> Self {
        TraceConfig {
            path: Some(path.into()),
            fst: None,
            pes: PeFilter::All,
            cycles: 0..=u64::MAX,
            signals: Vec::new(),
            groups: None,
            clock: true,
            markers: None,
        }
    }

    /// Trace everything into the FST file `path` only (no VCD).
    pub fn new_fst(path: impl Into<PathBuf>) -> Self {
        TraceConfig {
            path: None,
            fst: Some(path.into()),
            ..TraceConfig::new(PathBuf::new())
        }
    }

    /// Also write the same values as FST to `path`: one record, two
    /// files, so a test or a designer can compare them.
    pub fn with_fst(mut self, path: impl Into<PathBuf>) -> Self {
        self.fst = Some(path.into());
        self
    }

    /// Trace only the signals of these groups (and the ungrouped ones);
    /// without this call, the groups on by default ([`Group::default`]).
    /// Which names exist is the model's business: it checks them
    /// ([`crate::Tracer::selected_groups`]).
    pub fn with_groups<I, S>(mut self, groups: I) -> Self
    where
        I: IntoIterator<Item = S>,
        S: Into<String>,
    {
        self.groups = Some(groups.into_iter().map(Into::into).collect());
        self
    }

    /// Whether the signals of `group` are traced.
    pub fn selects_group(&self, group: &Group) -> bool {
        match &self.groups {
            None => group.default,
            Some(set) => set.contains(group.name),
        }
    }

    /// Mark changes of signal `full_name` (e.g. `top.ctrl.stage`) in the
    /// save file, named by the value's name ([`crate::TraceInfo::markers`]):
    /// the first change into each value, and every change into one of
    /// `always` (e.g. the rare stages worth finding), in time order.
    pub fn with_markers(
        mut self,
        full_name: impl Into<String>,
        always: impl IntoIterator<Item = u64>,
    ) -> Self {
        self.markers = Some((full_name.into(), always.into_iter().collect()));
        self
    }

    /// Trace only the PEs selected by `pes`.
    pub fn with_pes(mut self, pes: PeFilter) -> Self {
        self.pes = pes;
        self
    }

    /// Trace only cycles in `cycles` (inclusive at both ends).
    pub fn with_cycles(mut self, cycles: RangeInclusive<u64>) -> Self {
        self.cycles = cycles;
        self
    }

    /// Trace only signals matching one of `patterns`; an empty list (the
    /// default) traces all. Patterns are globs with `*` and `?`; a pattern
    /// containing a `.` is matched against the full name (`top.pe_*.acc`),
    /// any other against the signal's own name (`acc`, `*_valid`).
    pub fn with_signals<I, S>(mut self, patterns: I) -> Self
    where
        I: IntoIterator<Item = S>,
        S: Into<String>,
    {
        self.signals = patterns.into_iter().map(Into::into).collect();
        self
    }

    /// Whether to add a `top.clk` signal that rises at the start of every
    /// sampled cycle and falls half-way through it. On by default because
    /// cycle boundaries are then visible in a viewer; it costs two records
    /// per sampled cycle.
    pub fn with_clock(mut self, clock: bool) -> Self {
        self.clock = clock;
        self
    }

    /// The VCD file that [`crate::Tracer::finish`] creates, if any.
    pub fn path(&self) -> Option<&Path> {
        self.path.as_deref()
    }

    /// The FST file that [`crate::Tracer::finish`] creates, if any.
    pub fn fst_path(&self) -> Option<&Path> {
        self.fst.as_deref()
    }

    /// Whether a signal `name` in `scope` is selected by the PE and name
    /// filters (the cycle window is applied per sample, not here).
    pub fn selects(&self, scope: &ScopePath, name: &str) -> bool {
        if let Some(k) = scope.pe_index() {
            if !self.pes.contains(k) {
                return false;
            }
        }
        if self.signals.is_empty() {
            return true;
        }
        let full = format!("{scope}.{name}");
        self.signals.iter().any(|p| {
            let subject = if p.contains('.') { &full[..] } else { name };
            glob_match(p.as_bytes(), subject.as_bytes())
        })
    }
}

/// Matches `*` (any run, including across dots) and `?` (one character).
fn glob_match(pattern: &[u8], text: &[u8]) -> bool {
    // Greedy matching with a single backtrack point is enough for globs
    // that only have `*` and `?`, and stays linear-ish instead of
    // exponential on patterns like `*a*a*a`.
    let (mut p, mut t) = (0, 0);
    let mut star: Option<(usize, usize)> = None;
    while t < text.len() {
        if p < pattern.len() && (pattern[p] == b'?' || pattern[p] == text[t]) {
            p += 1;
            t += 1;
        } else if p < pattern.len() && pattern[p] == b'*' {
            star = Some((p, t));
            p += 1;
        } else if let Some((sp, st)) = star {
            p = sp + 1;
            t = st + 1;
            star = Some((sp, st + 1));
        } else {
            return false;
        }
    }
    pattern[p..].iter().all(|&c| c == b'*')
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn globs() {
        assert!(glob_match(b"acc", b"acc"));
        assert!(!glob_match(b"acc", b"acc2"));
        assert!(glob_match(b"*_valid", b"in_valid"));
        assert!(!glob_match(b"*_valid", b"in_valid_n"));
        assert!(glob_match(b"a?c", b"abc"));
        assert!(!glob_match(b"a?c", b"ac"));
        assert!(glob_match(b"*", b""));
        assert!(glob_match(b"top.pe_*.acc", b"top.pe_12.acc"));
        assert!(!glob_match(b"top.pe_*.acc", b"top.ctrl.state"));
        assert!(glob_match(b"*a*a*b", b"aaaaaaab"));
        assert!(!glob_match(b"*a*a*b", b"aaaaaaa"));
    }

    #[test]
    fn selection() {
        let c = TraceConfig::new("x.vcd")
            .with_pes(PeFilter::parse("1,3").unwrap())
            .with_signals(["acc", "top.ctrl.*"]);
        assert!(c.selects(&ScopePath::pe(1), "acc"));
        assert!(!c.selects(&ScopePath::pe(2), "acc"));
        assert!(!c.selects(&ScopePath::pe(1), "valid"));
        assert!(c.selects(&ScopePath::pe(3).child("mac"), "acc"));
        assert!(!c.selects(&ScopePath::pe(2).child("mac"), "acc"));
        assert!(c.selects(&ScopePath::top().child("ctrl"), "state"));
        assert!(!c.selects(&ScopePath::top(), "state"));
        assert!(c.selects(&ScopePath::top(), "acc"));
    }

    #[test]
    fn pe_lists() {
        assert_eq!(PeFilter::parse("all").unwrap(), PeFilter::All);
        assert_eq!(
            PeFilter::parse(" 0, 3,8-10 ").unwrap(),
            PeFilter::Only([0, 3, 8, 9, 10].into())
        );
        for bad in ["", "x", "3-1", "1,,2", "-1", "4294967296"] {
            assert!(PeFilter::parse(bad).is_err(), "{bad}");
        }
    }

    #[test]
    fn windows() {
        assert_eq!(parse_cycle_window("5..=9").unwrap(), 5..=9);
        assert_eq!(parse_cycle_window("5..9").unwrap(), 5..=8);
        assert_eq!(parse_cycle_window("5..").unwrap(), 5..=u64::MAX);
        assert_eq!(parse_cycle_window("..=7").unwrap(), 0..=7);
        assert_eq!(parse_cycle_window("..7").unwrap(), 0..=6);
        assert_eq!(parse_cycle_window("42").unwrap(), 42..=42);
        for bad in ["", "a..b", "9..5", "5..5", "..0", "1..=x"] {
            assert!(parse_cycle_window(bad).is_err(), "{bad}");
        }
    }
}
