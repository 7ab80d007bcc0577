//! What a replay's simulation printed, read back: per PE the samples
//! issued and checked and the mismatches, and the first mismatch of all
//! (cycle, PE, signal, the model's word, the RTL's word).

use super::replay::{parse_hex, Replay, Role};

/// One difference between the model and the RTL.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Mismatch {
    /// The cycle (the frame's numbering).
    pub cycle: u64,
    /// The PE.
    pub pe: usize,
    /// The signal (`out_valid`, `acc_out_r`, `x0`, ...).
    pub signal: String,
    /// The model's word.
    pub model: String,
    /// The RTL's word.
    pub rtl: String,
}

impl Mismatch {
    /// A mismatch line's fields after its tag (`cycle pe signal model
    /// rtl`, the words in hexadecimal), each word read by `dec(signal,
    /// hex)` (a decimal of the signal's port); an unreadable cycle or PE
    /// reads as the largest, so it sorts last.
    pub fn from_fields(
        [cycle, pe, signal, model, rtl]: [&str; 5],
        dec: impl Fn(&str, &str) -> String,
    ) -> Mismatch {
        Mismatch {
            cycle: cycle.parse().unwrap_or(u64::MAX),
            pe: pe.parse().unwrap_or(usize::MAX),
            signal: signal.to_owned(),
            model: dec(signal, model),
            rtl: dec(signal, rtl),
        }
    }

    /// Keeps in `first` the earlier (by cycle, then PE) of it and `self`.
    pub fn keep_earliest(self, first: &mut Option<Mismatch>) {
        if first
            .as_ref()
            .is_none_or(|f| (self.cycle, self.pe) < (f.cycle, f.pe))
        {
            *first = Some(self);
        }
    }
}

impl std::fmt::Display for Mismatch {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "cycle {}, PE {}, {}: model {}, RTL {}",
            self.cycle, self.pe, self.signal, self.model, self.rtl
        )
    }
}

/// One PE's counts.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize)]
pub struct PeOutcome {
    /// Samples the replayer issued.
    pub issued: u64,
    /// Write-backs it compared.
    pub checked: u64,
    /// Cycles and signals that differed.
    pub mismatches: u64,
    /// Whether samples were left in its stream (not all issued).
    pub left: bool,
}

/// A simulation's result.
#[derive(Debug, Clone, Default)]
pub struct Outcome {
    /// The last cycle checked.
    pub cycles: u64,
    /// Per PE.
    pub pes: Vec<PeOutcome>,
    /// The earliest mismatch (by cycle, then PE).
    pub first: Option<Mismatch>,
    /// Lines the simulation printed that say something went wrong.
    pub errors: Vec<String>,
}

impl Outcome {
    /// Mismatches over every PE.
    pub fn mismatches(&self) -> u64 {
        self.pes.iter().map(|p| p.mismatches).sum()
    }

    /// Samples issued over every PE.
    pub fn issued(&self) -> u64 {
        self.pes.iter().map(|p| p.issued).sum()
    }

    /// Write-backs compared over every PE.
    pub fn checked(&self) -> u64 {
        self.pes.iter().map(|p| p.checked).sum()
    }
}

/// A word the simulation printed in hexadecimal, as a signed or unsigned
/// decimal of `signal`'s port (hexadecimal text when it has unknown bits).
fn decimal(replay: &Replay, signal: &str, hex: &str) -> String {
    let port = replay
        .fields
        .iter()
        .find(|f| f.port.name == signal && f.role != Role::Issue)
        .map(|f| (f.port.word.bits, f.port.word.signed));
    let (bits, signed) = port.unwrap_or((64, false));
    parse_hex(hex, bits, signed).map_or_else(|| hex.to_owned(), |v| v.to_string())
}

/// Reads what a replay of `pes` PEs printed.
pub fn parse(replay: &Replay, pes: usize, text: &str) -> Outcome {
    let mut o = Outcome {
        pes: vec![PeOutcome::default(); pes],
        ..Outcome::default()
    };
    let mut seen = vec![false; pes];
    for line in text.lines() {
        let w: Vec<&str> = line.split_whitespace().collect();
        match w.as_slice() {
            ["CYCLES", n] => o.cycles = n.parse().unwrap_or(0),
            ["PE", k, issued, checked, mism, left] => {
                let Some(k) = k.parse::<usize>().ok().filter(|&k| k < pes) else {
                    o.errors.push(line.to_owned());
                    continue;
                };
                seen[k] = true;
                o.pes[k] = PeOutcome {
                    issued: issued.parse().unwrap_or(0),
                    checked: checked.parse().unwrap_or(0),
                    mismatches: mism.parse().unwrap_or(u64::MAX),
                    left: *left != "0",
                };
            }
            ["MISMATCH", cycle, pe, signal, model, rtl] => {
                Mismatch::from_fields([cycle, pe, signal, model, rtl], |sig, hex| {
                    decimal(replay, sig, hex)
                })
                .keep_earliest(&mut o.first);
            }
            ["ERROR", ..] => o.errors.push(line.to_owned()),
            _ => {}
        }
    }
    if let Some(k) = seen.iter().position(|s| !s) {
        o.errors.push(format!("PE {k} reported nothing"));
    }
    o
}
