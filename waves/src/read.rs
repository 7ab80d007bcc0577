//! Reading a VCD back, for tests that compare a trace with the model.

use std::collections::{BTreeMap, HashMap};
use std::fmt;
use std::fs::File;
use std::io::{self, BufRead, BufReader, Read};
use std::path::Path;

use bitvec::prelude::*;
use vcd::{Command, IdCode, ReferenceIndex, ScopeItem, Value};

use crate::error::WavesError;
use crate::tracer::TIME_UNITS_PER_CYCLE;

/// The value of a signal after one change: `width` bits, possibly with `x`
/// or `z` bits.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct WaveValue {
    width: u32,
    repr: Repr,
}

#[derive(Clone, Debug, PartialEq, Eq)]
enum Repr {
    // Most signals are at most 64 bits and fully known; keeping those as a
    // plain integer keeps large read-back traces small.
    Small(u64),
    Wide(BitVec<u64, Lsb0>),
    // Any `x`/`z`: kept as the msb-first text, as in the file.
    Unknown(Box<str>),
}

impl WaveValue {
    /// Width in bits (that of the signal).
    pub fn width(&self) -> u32 {
        self.width
    }

    /// Whether every bit is 0 or 1.
    pub fn is_known(&self) -> bool {
        !matches!(self.repr, Repr::Unknown(_))
    }

    /// The value as an integer, if it is known and fits in 64 bits.
    pub fn as_u64(&self) -> Option<u64> {
        match &self.repr {
            Repr::Small(v) => Some(*v),
            Repr::Wide(b) => b[64..].not_any().then(|| b[..64].load_le()),
            Repr::Unknown(_) => None,
        }
    }

    /// The bits, `[0]` least significant, if all are known.
    pub fn to_bitvec(&self) -> Option<BitVec<u64, Lsb0>> {
        match &self.repr {
            Repr::Small(v) => {
                let mut b = BitVec::repeat(false, self.width as usize);
                let n = b.len().min(64);
                b[..n].store_le(*v);
                Some(b)
            }
            Repr::Wide(b) => Some(b.clone()),
            Repr::Unknown(_) => None,
        }
    }
}

/// Msb-first `0`/`1`/`x`/`z` text of exactly `width` characters, the form
/// other tools (wellen's `to_bit_string`) print.
impl fmt::Display for WaveValue {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match &self.repr {
            Repr::Small(v) => {
                for b in (0..self.width).rev() {
                    f.write_str(if (v >> b) & 1 == 1 { "1" } else { "0" })?;
                }
                Ok(())
            }
            Repr::Wide(bits) => {
                for b in bits.iter().by_vals().rev() {
                    f.write_str(if b { "1" } else { "0" })?;
                }
                Ok(())
            }
            Repr::Unknown(s) => f.write_str(s),
        }
    }
}

/// One value-change record of a signal.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Change {
    /// VCD time of the record.
    pub time: u64,
    /// The new value.
    pub value: WaveValue,
}

impl Change {
    /// The cycle this record belongs to (see [`TIME_UNITS_PER_CYCLE`]).
    pub fn cycle(&self) -> u64 {
        self.time / TIME_UNITS_PER_CYCLE
    }
}

/// All value-change records of one signal, in file order.
#[derive(Clone, Debug, Default)]
pub struct SignalTrace {
    width: u32,
    changes: Vec<Change>,
}

impl SignalTrace {
    /// Declared width in bits.
    pub fn width(&self) -> u32 {
        self.width
    }

    /// Every record as written, redundant ones included, so that a test can
    /// check that the writer did not emit any.
    pub fn changes(&self) -> &[Change] {
        &self.changes
    }

    /// The value in force at VCD time `time` (after the records at `time`),
    /// `None` before the first record.
    pub fn value_at_time(&self, time: u64) -> Option<&WaveValue> {
        let n = self.changes.partition_point(|c| c.time <= time);
        n.checked_sub(1).map(|i| &self.changes[i].value)
    }

    /// The value of the signal during cycle `cycle`.
    pub fn value_at_cycle(&self, cycle: u64) -> Option<&WaveValue> {
        self.value_at_time(cycle.checked_mul(TIME_UNITS_PER_CYCLE)?)
    }

    /// [`SignalTrace::value_at_cycle`] as an integer; `None` if there is no
    /// value yet or it has `x`/`z` bits.
    pub fn u64_at_cycle(&self, cycle: u64) -> Option<u64> {
        self.value_at_cycle(cycle)?.as_u64()
    }
}

/// A parsed VCD file: every signal by its dotted hierarchical name.
#[derive(Clone, Debug, Default)]
pub struct Trace {
    signals: BTreeMap<String, SignalTrace>,
    end_time: u64,
    timescale: Option<String>,
}

/// The most header text [`Trace::from_reader`] holds in memory.
const MAX_HEADER_BYTES: u64 = 64 << 20;

/// Reads `reader`'s header up to and including the line holding
/// `$enddefinitions` (or to the end), with every `$attrbegin ... $end`
/// line blanked, so line numbers stay those of the file.
fn header_without_attributes(reader: &mut impl BufRead) -> io::Result<Vec<u8>> {
    let mut out = Vec::new();
    let mut line = Vec::new();
    loop {
        line.clear();
        let n = (&mut *reader)
            .take(MAX_HEADER_BYTES.saturating_sub(out.len() as u64) + 1)
            .read_until(b'\n', &mut line)?;
        if n == 0 {
            return Ok(out);
        }
        if out.len() + line.len() > MAX_HEADER_BYTES as usize {
            return Err(io::Error::new(
                io::ErrorKind::InvalidData,
                format!("VCD header longer than {MAX_HEADER_BYTES} bytes"),
            ));
        }
        let text = line.trim_ascii_start();
        if text.starts_with(b"$attrbegin") {
            out.push(b'\n');
            continue;
        }
        out.extend_from_slice(&line);
        if text.windows(15).any(|w| w == b"$enddefinitions") {
            return Ok(out);
        }
    }
}

impl Trace {
    /// Reads and parses the VCD file at `path` with the `vcd` crate.
    pub fn read(path: impl AsRef<Path>) -> Result<Trace, WavesError> {
        let path = path.as_ref();
        let file = File::open(path).map_err(|e| WavesError::io("open", path, e))?;
        Trace::from_reader(BufReader::new(file), path)
    }

    /// Parses VCD text from `reader`; `path` only names it in errors.
    /// GTKWave's `$attrbegin` attributes (the enum tables the tracer
    /// writes) are skipped: the `vcd` crate does not know them.
    pub fn from_reader<R: BufRead>(mut reader: R, path: &Path) -> Result<Trace, WavesError> {
        let header =
            header_without_attributes(&mut reader).map_err(|e| WavesError::io("read", path, e))?;
        let mut parser = vcd::Parser::new(io::Cursor::new(header).chain(reader));
        let err = |parser: &vcd::Parser<_>, e: io::Error| {
            if e.get_ref().is_some_and(|r| r.is::<vcd::ParseError>())
                || e.kind() == io::ErrorKind::UnexpectedEof
            {
                WavesError::Parse {
                    path: path.to_path_buf(),
                    line: parser.line(),
                    message: e.to_string(),
                }
            } else {
                WavesError::io("read", path, e)
            }
        };
        let header = parser.parse_header().map_err(|e| err(&parser, e))?;
        let mut trace = Trace {
            timescale: header.timescale.map(|(n, u)| format!("{n}{u}")),
            ..Trace::default()
        };
        // Several variables may share one id code (same net seen from
        // several scopes), so a code maps to a list of names.
        let mut by_code: HashMap<IdCode, Vec<String>> = HashMap::new();
        let mut stack = Vec::new();
        collect_vars(&header.items, &mut stack, &mut trace.signals, &mut by_code);

        let mut time = 0;
        while let Some(cmd) = parser.next() {
            let bad = |parser: &vcd::Parser<_>, message: String| WavesError::Parse {
                path: path.to_path_buf(),
                line: parser.line(),
                message,
            };
            let (code, values) = match cmd.map_err(|e| err(&parser, e))? {
                Command::Timestamp(t) => {
                    if t < time {
                        return Err(bad(&parser, format!("time {t} after time {time}")));
                    }
                    time = t;
                    trace.end_time = t;
                    continue;
                }
                Command::ChangeScalar(code, v) => (code, vec![v]),
                Command::ChangeVector(code, v) => (code, v.iter().collect()),
                Command::ChangeReal(..) | Command::ChangeString(..) => {
                    return Err(bad(
                        &parser,
                        "real and string values are not supported".into(),
                    ));
                }
                _ => continue,
            };
            let Some(names) = by_code.get(&code) else {
                return Err(bad(&parser, format!("change of undeclared id {code}")));
            };
            for name in names {
                let sig = trace
                    .signals
                    .get_mut(name)
                    .expect("every coded name was inserted by collect_vars");
                let value = to_wave_value(&values, sig.width)
                    .ok_or_else(|| bad(&parser, format!("value wider than {name}")))?;
                sig.changes.push(Change { time, value });
            }
        }
        Ok(trace)
    }

    /// The signal with dotted name `name`, e.g. `top.pe_3.acc` (a vector's
    /// `[msb:0]` range is not part of the name).
    pub fn signal(&self, name: &str) -> Option<&SignalTrace> {
        self.signals.get(name)
    }

    /// All signal names, sorted.
    pub fn names(&self) -> impl Iterator<Item = &str> {
        self.signals.keys().map(String::as_str)
    }

    /// The last timestamp in the file (the end of the trace).
    pub fn end_time(&self) -> u64 {
        self.end_time
    }

    /// The `$timescale`, e.g. `1ns`, if the file has one.
    pub fn timescale(&self) -> Option<&str> {
        self.timescale.as_deref()
    }
}

fn collect_vars(
    items: &[ScopeItem],
    stack: &mut Vec<String>,
    signals: &mut BTreeMap<String, SignalTrace>,
    by_code: &mut HashMap<IdCode, Vec<String>>,
) {
    for item in items {
        match item {
            ScopeItem::Scope(s) => {
                stack.push(s.identifier.clone());
                collect_vars(&s.items, stack, signals, by_code);
                stack.pop();
            }
            ScopeItem::Var(v) => {
                let mut name = stack.iter().map(|s| format!("{s}.")).collect::<String>();
                name.push_str(&v.reference);
                // The usual `[w-1:0]` is left out of the name; any other
                // index is kept so that e.g. `d[7:0]` and `d[15:8]` differ.
                let plain = match v.index {
                    None => true,
                    Some(ReferenceIndex::Range(m, 0)) => i64::from(m) + 1 == i64::from(v.size),
                    Some(_) => false,
                };
                if let (false, Some(idx)) = (plain, v.index) {
                    name.push_str(&idx.to_string());
                }
                signals.insert(
                    name.clone(),
                    SignalTrace {
                        width: v.size,
                        changes: Vec::new(),
                    },
                );
                by_code.entry(v.code).or_default().push(name);
            }
            _ => {}
        }
    }
}

/// Applies VCD's left-extension rule (a shorter vector is padded with 0,
/// or with `x`/`z` if its leftmost bit is one) and packs the result.
fn to_wave_value(values: &[Value], width: u32) -> Option<WaveValue> {
    let w = width as usize;
    if values.is_empty() || values.len() > w {
        return None;
    }
    let pad = match values[0] {
        Value::V0 | Value::V1 => Value::V0,
        v => v,
    };
    let full = std::iter::repeat_n(pad, w - values.len()).chain(values.iter().copied());
    if values.iter().any(|v| matches!(v, Value::X | Value::Z)) || matches!(pad, Value::X | Value::Z)
    {
        let text = full.map(|v| v.to_string()).collect::<String>();
        return Some(WaveValue {
            width,
            repr: Repr::Unknown(text.into()),
        });
    }
    let repr = if w <= 64 {
        Repr::Small(full.fold(0u64, |acc, v| (acc << 1) | u64::from(v == Value::V1)))
    } else {
        let mut bits: BitVec<u64, Lsb0> = full.map(|v| v == Value::V1).collect();
        bits.reverse();
        Repr::Wide(bits)
    };
    Some(WaveValue { width, repr })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// GTKWave's enum-table attributes are skipped and the line numbers of
    /// what follows stay the file's.
    #[test]
    fn attributes_are_skipped() {
        let text = "$timescale 1ns $end
$attrbegin misc 07 st 2 a b 0 1 1 $end
$scope module top $end
$attrbegin misc 07 \"\" 1 $end
$var wire 1 ! s $end
$upscope $end
$enddefinitions $end
#0
1!
#10
z!
";
        let t = Trace::from_reader(text.as_bytes(), Path::new("mem.vcd")).unwrap();
        assert_eq!(t.names().collect::<Vec<_>>(), ["top.s"]);
        assert_eq!(t.signal("top.s").unwrap().u64_at_cycle(0), Some(1));
        let bad = text.replace("#10\nz!", "#10\nq!");
        match Trace::from_reader(bad.as_bytes(), Path::new("mem.vcd")) {
            Err(WavesError::Parse { line, .. }) => assert_eq!(line, 11),
            other => panic!("{other:?}"),
        }
    }

    #[test]
    fn left_extension_and_lookup() {
        let text = "$timescale 1ns $end
$scope module top $end
$var wire 8 ! a [7:0] $end
$var wire 4 \" d [7:4] $end
$var wire 1 # b $end
$var wire 70 $ w [69:0] $end
$upscope $end
$enddefinitions $end
#0
b101 !
bx \"
1#
b1 $
#20
b1 !
0#
b1111111111111111111111111111111111111111111111111111111111111111111111 $
#20
b10 !
#30
";
        let t = Trace::from_reader(text.as_bytes(), Path::new("mem.vcd")).unwrap();
        assert_eq!(t.timescale(), Some("1ns"));
        assert_eq!(t.end_time(), 30);
        assert_eq!(
            t.names().collect::<Vec<_>>(),
            ["top.a", "top.b", "top.d[7:4]", "top.w"]
        );
        let a = t.signal("top.a").unwrap();
        assert_eq!(a.width(), 8);
        assert_eq!(a.changes().len(), 3);
        assert_eq!(a.u64_at_cycle(0), Some(5));
        assert_eq!(a.value_at_time(10).unwrap().to_string(), "00000101");
        // Two records at one time: the later wins.
        assert_eq!(a.u64_at_cycle(2), Some(2));
        assert_eq!(a.value_at_time(19).unwrap().to_string(), "00000101");
        let d = t.signal("top.d[7:4]").unwrap().value_at_cycle(0).unwrap();
        assert!(!d.is_known());
        assert_eq!(d.to_string(), "xxxx");
        let b = t.signal("top.b").unwrap();
        assert_eq!((b.u64_at_cycle(0), b.u64_at_cycle(2)), (Some(1), Some(0)));
        let w = t.signal("top.w").unwrap();
        assert_eq!(w.u64_at_cycle(0), Some(1));
        assert_eq!(w.u64_at_cycle(2), None, "70 ones do not fit in u64");
        let bits = w.value_at_cycle(2).unwrap().to_bitvec().unwrap();
        assert_eq!((bits.len(), bits.count_ones()), (70, 70));
    }

    #[test]
    fn errors_carry_path_and_line() {
        let text = "$scope module top $end\n$var wire 2 ! a $end\n$upscope $end\n$enddefinitions $end\n#0\nb111 !\n";
        let e = Trace::from_reader(text.as_bytes(), Path::new("bad.vcd")).unwrap_err();
        let msg = e.to_string();
        assert!(msg.starts_with("bad.vcd:6:"), "{msg}");
        assert!(msg.contains("wider"), "{msg}");
        let e = Trace::read("/nonexistent/dir/x.vcd").unwrap_err();
        assert!(e.to_string().contains("/nonexistent/dir/x.vcd"), "{e}");
    }
}
