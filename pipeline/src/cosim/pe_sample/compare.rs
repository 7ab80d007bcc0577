//! Reading back the sample stage's simulation: each PE's issues, taps
//! and write-backs beside the model's, line by line, and the buffers the
//! RTL held at the readout's start beside the model's rays.

use std::io::{BufRead, BufReader};
use std::path::Path;

use super::Widths;
use crate::cosim::capture::ReadoutStart;
use crate::cosim::outcome::Mismatch;
use crate::hw::pe_sample_rtl::PeSampleShape;

/// What the comparison found.
#[derive(Debug, Clone, Default, serde::Serialize)]
pub struct StageOutcome {
    /// Lines compared (issues, taps, write-backs), over all PEs.
    pub compared: [u64; 3],
    /// Lines that differ.
    pub mismatches: u64,
    /// The earliest difference.
    #[serde(skip)]
    pub first: Option<Mismatch>,
}

/// The signals of each kind of line, after its cycle.
const SIGNALS: [(&str, &str, [&str; 5]); 3] = [
    (
        "I",
        "in_valid",
        ["slot_m", "acc_r", "acc_g", "acc_b", "acc_a"],
    ),
    ("T", "tap_valid", ["v00", "v01", "v10", "v11", ""]),
    (
        "W",
        "wb_valid",
        [
            "wb_addr",
            "acc_out_r",
            "acc_out_g",
            "acc_out_b",
            "acc_out_a",
        ],
    ),
];

fn lines(p: &Path) -> Result<impl Iterator<Item = String>, String> {
    let f = std::fs::File::open(p).map_err(|e| format!("{}: {e}", p.display()))?;
    Ok(BufReader::new(f).lines().map_while(Result::ok))
}

fn cycle_of(l: &str) -> u64 {
    l.split(' ')
        .nth(1)
        .and_then(|c| u64::from_str_radix(c, 16).ok())
        .unwrap_or(u64::MAX)
}

impl StageOutcome {
    fn note(&mut self, m: Mismatch) {
        self.mismatches += 1;
        if self.first.as_ref().is_none_or(|f| m.cycle < f.cycle) {
            self.first = Some(m);
        }
    }
}

/// Compares `pe<K>.{I,T,W}` (the model's) with `rtl<K>.{I,T,W}` for `pes`
/// PEs in `dir`.
pub fn streams(dir: &Path, pes: usize) -> Result<StageOutcome, String> {
    let mut o = StageOutcome::default();
    for k in 0..pes {
        for (kind, (ext, valid, names)) in SIGNALS.iter().enumerate() {
            let mut model = lines(&dir.join(format!("pe{k}.{ext}")))?;
            let mut rtl = lines(&dir.join(format!("rtl{k}.{ext}")))?;
            loop {
                let (m, r) = (model.next(), rtl.next());
                let (m, r) = match (m, r) {
                    (None, None) => break,
                    (Some(m), None) => {
                        o.note(Mismatch {
                            cycle: cycle_of(&m),
                            pe: k,
                            signal: (*valid).to_owned(),
                            model: "1".into(),
                            rtl: "0".into(),
                        });
                        continue;
                    }
                    (None, Some(r)) => {
                        o.note(Mismatch {
                            cycle: cycle_of(&r),
                            pe: k,
                            signal: (*valid).to_owned(),
                            model: "0".into(),
                            rtl: "1".into(),
                        });
                        continue;
                    }
                    (Some(m), Some(r)) => (m, r),
                };
                o.compared[kind] += 1;
                if m == r {
                    continue;
                }
                let (cm, cr) = (cycle_of(&m), cycle_of(&r));
                if cm != cr {
                    // One side did it in a clock the other did not.
                    let early_model = cm < cr;
                    o.note(Mismatch {
                        cycle: cm.min(cr),
                        pe: k,
                        signal: (*valid).to_owned(),
                        model: if early_model { "1" } else { "0" }.into(),
                        rtl: if early_model { "0" } else { "1" }.into(),
                    });
                    continue;
                }
                let (fm, fr): (Vec<&str>, Vec<&str>) = (
                    m.split(' ').skip(2).collect(),
                    r.split(' ').skip(2).collect(),
                );
                let at = (0..fm.len().max(fr.len()))
                    .find(|&i| fm.get(i) != fr.get(i))
                    .unwrap_or(0);
                let word = |v: Option<&&str>| {
                    v.and_then(|s| i128::from_str_radix(s, 16).ok())
                        .map_or_else(
                            || v.map_or("-".into(), |s| (*s).to_owned()),
                            |x| x.to_string(),
                        )
                };
                o.note(Mismatch {
                    cycle: cm,
                    pe: k,
                    signal: names.get(at).copied().unwrap_or("?").to_owned(),
                    model: word(fm.get(at)),
                    rtl: word(fr.get(at)),
                });
            }
        }
    }
    Ok(o)
}

/// The buffers the RTL held at the readout's start against the model's
/// rays: the rays' words compared and the first that differs (PE, `mx`,
/// row, model, RTL), and the readout's start with the RTL's words.
pub struct Buffers {
    /// Ray words compared.
    pub compared: u64,
    /// Ray words that differ.
    pub differ: u64,
    /// The first that differs: PE, `mx`, row, the model's word, the RTL's.
    pub first: Option<RayDiff>,
    /// The model's start with every word the RTL's.
    pub start: ReadoutStart,
}

/// A ray word that differs: PE, `mx`, row, the model's word, the RTL's
/// (none where the RTL's memory held no defined word).
pub type RayDiff = (usize, i64, usize, [i64; 4], Option<[i64; 4]>);

/// Reads `buf<K>.hex` in `dir` and compares the held rays of `start`,
/// PE `k`'s ray `(mx, row)` at `addr(k, mx, row)`.
pub fn buffers(
    dir: &Path,
    shape: &PeSampleShape,
    widths: &Widths,
    start: &ReadoutStart,
    addr: &dyn Fn(usize, i64, usize) -> Option<u64>,
) -> Result<Buffers, String> {
    let signed = [shape.rays.color_signed, shape.rays.alpha_signed];
    let mut out = Buffers {
        compared: 0,
        differ: 0,
        first: None,
        start: start.clone(),
    };
    for (k, pe) in out.start.pes.iter_mut().enumerate() {
        let mut banks: Vec<[Option<u128>; 2]> = Vec::new();
        for l in lines(&dir.join(format!("buf{k}.hex")))? {
            let mut it = l.split(' ').map(|w| u128::from_str_radix(w, 16).ok());
            banks.push([it.next().flatten(), it.next().flatten()]);
        }
        let mut at = 0;
        for (c, &mx) in pe.mx.iter().enumerate() {
            for row in 0..pe.rows[c] {
                let addr = addr(k, mx, row).map_or(usize::MAX, |a| a as usize);
                let rtl = banks
                    .get(addr / 2)
                    .and_then(|b| b[addr % 2])
                    .map(|w| widths.unpack(w, signed));
                let model = pe.words[at];
                out.compared += 1;
                if rtl != Some(model) {
                    out.differ += 1;
                    if out.first.is_none() {
                        out.first = Some((k, mx, row, model, rtl));
                    }
                }
                pe.words[at] = rtl.unwrap_or([0; 4]);
                at += 1;
            }
        }
    }
    Ok(out)
}
