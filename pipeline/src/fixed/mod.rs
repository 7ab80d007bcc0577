//! Bit-accurate fixed-point arithmetic with `ap_fixed`/`ac_fixed` semantics.
//!
//! Every datapath register of the chip model has a declared [`Format`]: a
//! width, a number of fraction bits, a signedness, and the quantisation
//! ([`Quant`]) and overflow ([`Overflow`]) modes that apply when a value is
//! *assigned* into a register of that format. As in HLS C++ types,
//! operators are full precision: `a * b`, `a + b`, `a - b`, `-a`, `a << n`
//! and `a >> n` on [`Fx`] values give an exact [`Wide`] intermediate, and
//! only [`Format::quantize`] (or its counting form [`Format::assign`]) drops
//! bits. Rounding is applied first and overflow handling second, on the
//! rounded value, exactly as `ap_fixed_base`'s converting constructor does,
//! so a round-up that carries out of the integer part counts as an overflow.
//!
//! # Value model
//!
//! A value is an integer *raw* word interpreted as `raw * 2^-frac`. [`Fx`]
//! stores the raw word in an `i64` next to its [`Format`]; [`Wide`] stores an
//! `i128` raw word with an `i32` fraction exponent (negative exponents are
//! allowed, so scaling by a power of two never loses or creates bits).
//!
//! # Supported formats
//!
//! `1 <= bits <= 63` and `0 <= frac <= bits` (so the binary point lies inside
//! or at the edges of the word, as in the `fixed` crate; `ap_fixed`'s
//! fraction counts above the width or below zero are not supported). The
//! 63-bit ceiling is what makes every single [`Fx`] operation infallible in
//! `i128`: operands are below `2^63` in magnitude and aligning binary points
//! shifts by at most 63 bits, so a sum or product stays below `2^127`.
//! Chains of operations on [`Wide`] values are checked instead
//! ([`Wide::checked_add`] and friends return [`FxError::WideOverflow`]).
//!
//! # Bit packing
//!
//! [`pack`] and [`unpack`] store values of one format back to back in a
//! [`Bits`] vector, LSB-first: value `i` occupies bit indices
//! `i*bits .. (i+1)*bits`, and bit `j` of its two's-complement word sits at
//! index `i*bits + j`. With `BitVec<u64, Lsb0>` storage, bit index `n` is
//! bit `n % 64` of storage word `n / 64`, which is how a memory word of the
//! chip is laid out.

mod error;
mod format;
mod pack;
mod quantize;
mod value;
mod word;

#[cfg(test)]
mod tests;

pub use error::{FormatError, FxError};
pub use format::{Format, FormatSpec, Overflow, Quant, MAX_BITS};
pub use pack::{pack, unpack, Bits};
pub use quantize::{Counts, FormatCounts, QuantStats, Quantized};
pub use value::{Fx, Wide};
pub use word::Word64;
