//! The bit-exact evaluator of a [`Graph`]: every node's raw word, from the
//! inputs' words and the memories' contents, with each operator's exact
//! semantics ([`crate::fixed`]'s: full-precision operators, rounding and
//! overflow only on assignment). Registers pass their input through (the
//! values of one sample as it moves down the pipeline).
//!
//! Each value is checked against its node's wired word: a value that does
//! not fit is an error naming the node, so the evaluator also proves the
//! description's widths on every input it sees.

use super::{Graph, MemId, Op};
use crate::fixed::{QuantStats, Wide};

/// Why a graph could not be evaluated.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum EvalError {
    /// A value outside its node's wired word.
    #[error("{node}: value {value} does not fit {bits} bits{}", if *.signed { " signed" } else { "" })]
    Width {
        /// Probe name.
        node: String,
        /// The raw value.
        value: i128,
        /// The word's width.
        bits: u32,
        /// The word's signedness.
        signed: bool,
    },
    /// An input without a value, or a read outside its memory.
    #[error("{0}")]
    Missing(String),
    /// An operator's exact result outgrew 128 bits.
    #[error("{0}: {1}")]
    Fixed(String, crate::fixed::FxError),
}

/// Every node's raw word, by node.
pub type Values = Vec<i128>;

/// `raw 2^s`, checked.
fn up(raw: i128, s: i32, name: &str) -> Result<i128, EvalError> {
    let s = u32::try_from(s).map_err(|_| EvalError::Missing(format!("{name}: negative shift")))?;
    raw.checked_mul(1i128 << s.min(126))
        .filter(|_| s < 126)
        .ok_or_else(|| EvalError::Missing(format!("{name}: shift overflows")))
}

/// A memory read: the reading node's probe name, the memory and the
/// address; `None` outside the memory.
pub type ReadFn<'a> = &'a dyn Fn(&str, MemId, i128) -> Option<i64>;

/// Evaluates `g`: `input` gives each input port's raw word by name,
/// `read` each memory word read; assignments are counted in `st`.
pub fn eval(
    g: &Graph,
    input: &dyn Fn(&str) -> Option<i64>,
    read: ReadFn,
    st: &mut QuantStats,
) -> Result<Values, EvalError> {
    let mut v: Values = Vec::with_capacity(g.nodes.len());
    for n in &g.nodes {
        let f = n.word.frac;
        let at = |v: &Values, id: super::NodeId| -> Result<i128, EvalError> {
            up(v[id.0], f - g.word(id).frac, &n.name)
        };
        let x = match n.op {
            Op::Input => i128::from(
                input(&n.name).ok_or_else(|| EvalError::Missing(format!("input {}", n.name)))?,
            ),
            Op::Const(c) => c,
            Op::Add(a, b) => at(&v, a)? + at(&v, b)?,
            Op::Sub(a, b) => at(&v, a)? - at(&v, b)?,
            Op::Mul(a, b) => v[a.0]
                .checked_mul(v[b.0])
                .ok_or_else(|| EvalError::Missing(format!("{}: product overflows", n.name)))?,
            Op::Quantize(x) | Op::Isqrt(x) | Op::ShrQuantize(x, _) => {
                let fmt = n.fmt.expect("an assignment has a format");
                let w = Wide::new(v[x.0], g.word(x).frac);
                match n.op {
                    Op::Isqrt(_) => crate::datapath::isqrt_into(
                        w,
                        crate::config::Reg {
                            id: crate::config::FormatId::OTHER,
                            format: fmt,
                        },
                        "hw isqrt",
                        st,
                    )
                    .map_err(|e| EvalError::Fixed(n.name.clone(), e))?
                    .raw()
                    .into(),
                    Op::ShrQuantize(_, s) if v[s.0] >= 64 => 0,
                    Op::ShrQuantize(_, s) => i128::from(
                        fmt.assign(Wide::new(w.raw, w.frac + v[s.0] as i32), st)
                            .raw(),
                    ),
                    _ => i128::from(fmt.assign(w, st).raw()),
                }
            }
            Op::Field(x, lo) => {
                let y = if lo >= 0 {
                    v[x.0] >> lo
                } else {
                    up(v[x.0], -lo, &n.name)?
                };
                let y = y & ((1i128 << n.word.bits) - 1);
                // A signed field takes its top bit as the sign.
                if n.word.signed && y >> (n.word.bits - 1) != 0 {
                    y - (1i128 << n.word.bits)
                } else {
                    y
                }
            }
            Op::Ge(a, b) | Op::Eq(a, b) => {
                let fr = g.word(a).frac.max(g.word(b).frac);
                let ua = up(v[a.0], fr - g.word(a).frac, &n.name)?;
                let ub = up(v[b.0], fr - g.word(b).frac, &n.name)?;
                i128::from(if matches!(n.op, Op::Ge(..)) {
                    ua >= ub
                } else {
                    ua == ub
                })
            }
            Op::NonZero(x) => i128::from(v[x.0] != 0),
            Op::Mux { sel, f: lo, t } => at(&v, if v[sel.0] != 0 { t } else { lo })?,
            Op::Read(m, a) => i128::from(read(&n.name, m, v[a.0]).ok_or_else(|| {
                EvalError::Missing(format!("{}: address {} outside", n.name, v[a.0]))
            })?),
            Op::Reg(d) => v[d.0],
            Op::Div(a, b) => divide(v[a.0], g.word(a).frac, v[b.0], g.word(b).frac, n)?,
        };
        let w = n.word;
        let (lo, hi) = if w.signed {
            (-(1i128 << (w.bits - 1)), 1i128 << (w.bits - 1))
        } else {
            (0, 1i128 << w.bits)
        };
        if x < lo || x >= hi {
            return Err(EvalError::Width {
                node: n.name.clone(),
                value: x,
                bits: w.bits,
                signed: w.signed,
            });
        }
        v.push(x);
    }
    Ok(v)
}

/// [`Op::Div`]: `num 2^-fa / (den 2^-fb)` on node `n`'s grid, truncated,
/// saturated at its word's largest value (also for a zero divisor).
fn divide(num: i128, fa: i32, den: i128, fb: i32, n: &super::Node) -> Result<i128, EvalError> {
    if num < 0 || den < 0 {
        return Err(EvalError::Missing(format!(
            "{}: a negative operand",
            n.name
        )));
    }
    let max = (1i128 << n.word.bits) - 1;
    if den == 0 {
        return Ok(max);
    }
    // floor(num 2^s / den): nested floors of non-negative integers are
    // the floor of the whole, so a right shift first is exact too.
    let s = n.word.frac + fb - fa;
    let scaled = if s >= 0 {
        up(num, s, &n.name)?
    } else {
        num >> (-s).min(127)
    };
    Ok((scaled / den).min(max))
}
