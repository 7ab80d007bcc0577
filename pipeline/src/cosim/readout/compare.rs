//! What the readout's simulation printed, read back and compared: the
//! host ports clock by clock and the host's baseplane word by word.

use crate::cosim::capture::ReadoutStart;
use crate::cosim::outcome::Mismatch;
use crate::cosim::replay::parse_hex;
use crate::cost::shapes::RAY_INDEX_BITS;
use crate::hw::readout_rtl::ReadoutShape;

/// What the readout's simulation printed, read back.
#[derive(Debug, Clone, Default)]
pub struct ReadoutOutcome {
    /// Readout clocks simulated.
    pub ticks: u64,
    /// Load words the host wrote.
    pub loads: u64,
    /// Per PE: host words streamed, mismatches.
    pub pes: Vec<(u64, u64)>,
    /// The earliest mismatch (by cycle, then PE).
    pub first: Option<Mismatch>,
    /// The host's baseplane from the RTL's stream (raw words, row-major).
    pub raw: Vec<[i64; 4]>,
    /// Lines that say something went wrong.
    pub errors: Vec<String>,
}

impl ReadoutOutcome {
    /// Mismatches over every PE.
    pub fn mismatches(&self) -> u64 {
        self.pes.iter().map(|p| p.1).sum()
    }

    /// Host words over every PE.
    pub fn words(&self) -> u64 {
        self.pes.iter().map(|p| p.0).sum()
    }
}

/// Reads what the readout testbench printed, assembling the host's
/// baseplane of `start`'s region 0 from the host words.
pub fn parse(shape: &ReadoutShape, start: &ReadoutStart, text: &str) -> ReadoutOutcome {
    let [w, h] = start.size;
    let mut o = ReadoutOutcome {
        pes: vec![(0, 0); shape.pes],
        raw: vec![[0; 4]; w * h],
        ..ReadoutOutcome::default()
    };
    let (cw, aw, rb) = (shape.color_bits, shape.alpha_bits, shape.row_bits());
    let field = |s: &str, bits: u32, signed: bool| parse_hex(s, bits, signed).map(|v| v as i64);
    let widths = [
        (cw, shape.color_signed),
        (cw, shape.color_signed),
        (cw, shape.color_signed),
        (aw, shape.alpha_signed),
    ];
    let mut seen = vec![false; shape.pes];
    for line in text.lines() {
        let f: Vec<&str> = line.split_whitespace().collect();
        match f.as_slice() {
            ["RTICKS", n] => o.ticks = n.parse().unwrap_or(0),
            ["RLOADS", n] => o.loads = n.parse().unwrap_or(0),
            ["RPE", k, words, mism] => match k.parse::<usize>().ok().filter(|&k| k < shape.pes) {
                Some(k) => {
                    seen[k] = true;
                    o.pes[k] = (words.parse().unwrap_or(0), mism.parse().unwrap_or(u64::MAX));
                }
                None => o.errors.push(line.to_owned()),
            },
            ["RMISMATCH", cycle, pe, signal, model, rtl] => {
                let dec = |sig: &str, hex: &str| {
                    let bits = match sig {
                        "host_valid" | "done" => (1, false),
                        "host_mx" => (RAY_INDEX_BITS, true),
                        "host_row" => (rb, false),
                        "host_a" => widths[3],
                        _ => widths[0],
                    };
                    field(hex, bits.0, bits.1).map_or(hex.to_owned(), |v| v.to_string())
                };
                Mismatch::from_fields([cycle, pe, signal, model, rtl], dec)
                    .keep_earliest(&mut o.first);
            }
            ["HOST", _k, mx, row, r, g, b, a] => {
                let mx = field(mx, RAY_INDEX_BITS, true);
                let row = field(row, rb, false);
                let words: Vec<Option<i64>> = [r, g, b, a]
                    .iter()
                    .zip(widths)
                    .map(|(s, (n, sg))| field(s, n, sg))
                    .collect();
                let at = match (mx, row) {
                    (Some(mx), Some(row)) => {
                        let x = mx - start.lo;
                        ((0..w as i64).contains(&x) && (0..h as i64).contains(&row))
                            .then(|| row as usize * w + x as usize)
                    }
                    _ => None,
                };
                match (at, words.iter().all(Option::is_some)) {
                    (Some(i), true) => {
                        for (c, v) in words.iter().enumerate() {
                            o.raw[i][c] = v.unwrap_or(0);
                        }
                    }
                    _ => o
                        .errors
                        .push(format!("a host word outside region 0: {line}")),
                }
            }
            ["ERROR", ..] => o.errors.push(line.to_owned()),
            _ => {}
        }
    }
    if let Some(k) = seen.iter().position(|s| !s) {
        o.errors.push(format!("readout PE {k} reported nothing"));
    }
    o
}

/// Raw words compared: how many, how many differ, and the first that does
/// (`x`, `y`, the model's words, the RTL's).
pub type RawCompare = (u64, u64, Option<(usize, usize, [i64; 4], [i64; 4])>);

/// The raw words compared: how many, how many differ, and the first that
/// does (`x`, `y`, the model's words, the RTL's).
pub fn compare_raw(model: &[[i64; 4]], rtl: &[[i64; 4]], width: usize) -> RawCompare {
    let mut diff = 0;
    let mut first = None;
    for (i, (m, r)) in model.iter().zip(rtl).enumerate() {
        if m != r {
            diff += 1;
            if first.is_none() {
                first = Some((i % width.max(1), i / width.max(1), *m, *r));
            }
        }
    }
    if model.len() != rtl.len() {
        diff += model.len().abs_diff(rtl.len()) as u64;
    }
    (model.len().min(rtl.len()) as u64, diff, first)
}
