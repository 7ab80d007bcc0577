//! The widths of every intermediate of the PE's datapath operations, from
//! the [`PipelineConfig`] formats: one source for both the estimator's
//! unit lists and the calibration Verilog of [`crate::rtl`].
//!
//! Each shape follows the fixed-point model (`crate::fixed`): operators are
//! full precision and only an assignment into a declared format rounds
//! (`RND`: add half an LSB, i.e. a carry into the kept bits) and handles
//! overflow (`SAT`: clamp). The widths below are the exact widths of those
//! full-precision intermediates, so nothing is lost before the assignment.

use super::units::{MulShape, Unit};
use crate::config::PipelineConfig;
use crate::fixed::{Format, Overflow, Quant};
use serde::Serialize;

/// Width of a ray index `m` on the PE's datapath (and on the waveforms):
/// 16 bits two's complement covers ray grids to +-32767, far beyond the
/// 2047-voxel position range of the default format.
pub const RAY_INDEX_BITS: u32 = 16;

/// A fixed-point word as wired: width, fraction bits and signedness.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub struct Word {
    /// Width in bits.
    pub bits: u32,
    /// Fraction bits.
    pub frac: i32,
    /// Two's complement.
    pub signed: bool,
}

impl Word {
    /// An unsigned word.
    pub fn unsigned(bits: u32, frac: i32) -> Word {
        Word {
            bits,
            frac,
            signed: false,
        }
    }

    /// A signed word.
    pub fn signed(bits: u32, frac: i32) -> Word {
        Word {
            bits,
            frac,
            signed: true,
        }
    }

    /// Integer bits (sign included), possibly zero or negative.
    pub fn int_bits(&self) -> i32 {
        self.bits as i32 - self.frac
    }

    /// Magnitude bits: the width less a sign bit.
    pub fn magnitude(&self) -> u32 {
        self.bits - u32::from(self.signed)
    }
}

impl From<Format> for Word {
    fn from(f: Format) -> Word {
        Word {
            bits: u32::from(f.bits()),
            frac: i32::from(f.frac()),
            signed: f.is_signed(),
        }
    }
}

/// Assignment of an exact intermediate into a declared format.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub struct Quantizer {
    /// The exact intermediate.
    pub input: Word,
    /// The declared format.
    pub out: Word,
    /// Fraction bits dropped (`input.frac - out.frac`; negative: the
    /// value is shifted up).
    pub drop: i32,
    /// Whether dropped bits are rounded (any mode but `TRN`).
    pub round: bool,
    /// The value after rounding, before overflow handling.
    pub q: Word,
    /// Whether the assignment can go below the format's range (by width).
    pub under: bool,
    /// Whether it can go above.
    pub over: bool,
    /// Whether overflow is handled (any mode but `WRAP`) and possible.
    pub saturate: bool,
    /// Quantisation mode.
    pub quant: Quant,
    /// Overflow mode.
    pub overflow: Overflow,
}

impl Quantizer {
    /// The assignment of `input` into `out`.
    pub fn new(input: Word, out: Format) -> Quantizer {
        let o = Word::from(out);
        let drop = input.frac - o.frac;
        let round = drop > 0 && out.quant() != Quant::Trn;
        let q_bits = if drop > 0 {
            // RND: (s >>> (k-1)) + 1 needs one more bit than s >>> (k-1)
            // to be exact; the final >>> 1 gives it back.
            (input.bits.saturating_sub(drop as u32) + u32::from(round)).max(1)
        } else {
            input.bits + (-drop) as u32
        };
        let q = Word {
            bits: q_bits,
            frac: o.frac,
            signed: input.signed,
        };
        let under = q.signed && (!o.signed || q.bits > o.bits);
        let over = if o.signed {
            q.magnitude() > o.bits - 1
        } else {
            q.magnitude() > o.bits
        };
        let saturate = out.overflow() != Overflow::Wrap && (under || over);
        Quantizer {
            input,
            out: o,
            drop,
            round,
            q,
            under,
            over,
            saturate,
            quant: out.quant(),
            overflow: out.overflow(),
        }
    }

    /// Units of the assignment: a rounding carry and the overflow clamp.
    pub fn units(&self) -> Vec<Unit> {
        let mut u = Vec::new();
        if self.round {
            u.push(Unit::Inc {
                width: self.input.bits.saturating_sub(self.drop as u32) + 1,
            });
        }
        if self.saturate {
            u.push(Unit::Sat {
                input: self.q.bits,
                output: self.out.bits,
            });
        }
        u
    }
}

/// `a + w (b - a)`, the datapath's `lerp`, assigned into `out`; `b = None`
/// is the constant 1.0 (compositing opacity: `A + a (1 - A)`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub struct Lerp {
    /// First endpoint (unsigned).
    pub a: Word,
    /// Second endpoint, or `None` for 1.0.
    pub b: Option<Word>,
    /// Weight (unsigned).
    pub w: Word,
    /// Common fraction bits of the endpoints.
    pub f: i32,
    /// `b - a` at `f` fraction bits, signed.
    pub d: Word,
    /// `w (b - a)`, signed (the weight gets a zero sign bit).
    pub p: Word,
    /// Left shift aligning `a` with the product.
    pub a_shift: i32,
    /// `a + w (b - a)`, signed.
    pub s: Word,
    /// Assignment into the output format.
    pub quant: Quantizer,
}

impl Lerp {
    /// The shape of `a + w (b - a)` into `out`.
    pub fn new(a: Word, b: Option<Word>, w: Word, out: Format) -> Lerp {
        let one = Word::unsigned(a.frac.max(0) as u32 + 1, a.frac);
        let bw = b.unwrap_or(one);
        let f = a.frac.max(bw.frac);
        let int = a.int_bits().max(bw.int_bits()).max(0);
        let d = Word::signed((int + f) as u32 + 1, f);
        // An unsigned w-bit weight times a signed difference fits w + d
        // bits signed.
        let p = Word::signed(w.bits + d.bits, w.frac + f);
        let a_shift = w.frac + f - a.frac;
        let a_al_bits = (a.bits as i32 + a_shift) as u32;
        let s = Word::signed(p.bits.max(a_al_bits + 1) + 1, p.frac);
        Lerp {
            a,
            b,
            w,
            f,
            d,
            p,
            a_shift,
            s,
            quant: Quantizer::new(s, out),
        }
    }

    /// Units: the difference, the multiply-add and the assignment.
    pub fn units(&self) -> Vec<Unit> {
        let mut u = vec![
            Unit::Sub {
                width: self.d.bits - 1,
            },
            Unit::Mul(MulShape {
                a: self.w.bits,
                a_signed: false,
                b: self.d.bits,
                b_signed: true,
                y: self.p.bits,
                // The low a_shift bits of the sum are the product's.
                post_add: Some(self.s.bits - self.a_shift.max(0) as u32),
                registered: false,
                operand_reg: 0,
            }),
        ];
        u.extend(self.quant.units());
        u
    }

    /// Units when the weight arrives from a pipeline register of its own,
    /// which the multiplier block can hold.
    pub fn units_with_weight_register(&self) -> Vec<Unit> {
        let mut u = self.units();
        for unit in &mut u {
            if let Unit::Mul(MulShape { operand_reg, .. }) = unit {
                *operand_reg = self.w.bits;
            }
        }
        u
    }
}

/// `c + m k`: a base in `base` format plus a ray index `m` times a step in
/// `step` format, assigned into `out` (ray positions `A + m t` and slopes
/// `b + m k`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub struct MulAdd {
    /// The base.
    pub c: Word,
    /// The ray index (signed).
    pub m: Word,
    /// The step (unsigned).
    pub k: Word,
    /// `m k`, signed (the step gets a zero sign bit).
    pub p: Word,
    /// Left shifts aligning `c` and `m k` at the sum's fraction bits.
    pub c_shift: i32,
    /// See `c_shift`.
    pub p_shift: i32,
    /// The sum.
    pub s: Word,
    /// Assignment into the output format.
    pub quant: Quantizer,
}

impl MulAdd {
    /// The shape of `c + m k` into `out`.
    pub fn new(c: Word, m: Word, k: Word, out: Format) -> MulAdd {
        // A signed index times an unsigned step fits m + k bits signed.
        let p = Word::signed(m.bits + k.bits, m.frac + k.frac);
        let f = c.frac.max(p.frac);
        let c_shift = f - c.frac;
        let p_shift = f - p.frac;
        let s = Word::signed(
            ((c.bits as i32 + c_shift).max(p.bits as i32 + p_shift) + 1) as u32,
            f,
        );
        MulAdd {
            c,
            m,
            k,
            p,
            c_shift,
            p_shift,
            s,
            quant: Quantizer::new(s, out),
        }
    }

    /// Units: the multiply-add and the assignment.
    pub fn units(&self) -> Vec<Unit> {
        let low = self.c_shift.min(self.p_shift).max(0) as u32;
        let mut u = vec![Unit::Mul(MulShape {
            a: self.m.bits,
            a_signed: true,
            b: self.k.bits,
            b_signed: false,
            y: self.p.bits,
            post_add: Some(self.s.bits - low),
            registered: false,
            operand_reg: 0,
        })];
        u.extend(self.quant.units());
        u
    }
}

/// The classification interpolation weight: the bits of the table position
/// below the entry index, assigned into the `weight` format. `None` when
/// the table has an entry per sample code (no interpolation).
pub fn class_weight(cfg: &PipelineConfig) -> Option<Word> {
    let f = i32::from(cfg.sample.frac()) - cfg.table_shift();
    if f <= 0 {
        return None;
    }
    let wf = i32::from(cfg.weight.frac());
    let kept = f.min(wf);
    if kept <= 0 {
        return None;
    }
    Some(Word::unsigned(kept as u32, kept))
}

/// The exp-table interpolation weight: `log_transmittance` fraction bits
/// below the table index, assigned into the `weight` format.
pub fn exp_weight(cfg: &PipelineConfig) -> Option<Word> {
    let rem = i32::from(cfg.log_transmittance.frac()) - i32::from(cfg.exp_table_bits);
    let kept = rem.min(i32::from(cfg.weight.frac()));
    if kept <= 0 {
        return None;
    }
    Some(Word::unsigned(kept as u32, kept))
}

/// Bits of a classification table entry: R, G, B and opacity.
pub fn table_word(cfg: &PipelineConfig) -> u32 {
    3 * u32::from(cfg.color.bits()) + u32::from(cfg.alpha.bits())
}

/// Bits of a ray's accumulators: R, G, B and opacity.
pub fn accum_word(cfg: &PipelineConfig) -> u32 {
    3 * u32::from(cfg.accum_color.bits()) + u32::from(cfg.accum_alpha.bits())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn default_bilinear_widths() {
        let c = PipelineConfig::default();
        let l = Lerp::new(
            c.voxel.into(),
            Some(c.voxel.into()),
            c.weight.into(),
            c.sample,
        );
        // 12-bit voxels: a 13-bit signed difference, a 13 x 13 product with
        // 12 fraction bits, rounded to the sample's 4.
        assert_eq!(l.d.bits, 13);
        assert_eq!(l.p.bits, 25);
        assert_eq!(l.quant.drop, 8);
        assert!(l.quant.round && l.quant.saturate);
    }

    #[test]
    fn default_position_widths() {
        let c = PipelineConfig::default();
        let m = MulAdd::new(
            c.position.into(),
            Word::signed(RAY_INDEX_BITS, 0),
            c.step.into(),
            c.position,
        );
        assert_eq!(m.p.bits, 41);
        assert_eq!(m.p.frac, 24);
        assert_eq!(m.quant.drop, 8);
    }
}
