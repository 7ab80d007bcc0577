//! Packing values into memory words and wave vectors.

use super::error::FxError;
use super::format::Format;
use super::value::Fx;
use bitvec::field::BitField;
use bitvec::order::Lsb0;
use bitvec::slice::BitSlice;
use bitvec::vec::BitVec;

/// Bit storage for packed values: bit index `n` is bit `n % 64` of storage
/// word `n / 64`, so the vector reads like a little-endian memory word.
pub type Bits = BitVec<u64, Lsb0>;

/// Packs `values` back to back, LSB-first: value `i` occupies indices
/// `i*w .. (i+1)*w` with `w = format.bits()`, and bit `j` of its stored word
/// ([`Fx::to_bits`]) is at index `i*w + j`.
///
/// Every value must have the same layout as `format` (width, fraction and
/// signedness; modes may differ), otherwise [`FxError::FormatMismatch`].
pub fn pack(format: Format, values: &[Fx]) -> Result<Bits, FxError> {
    let w = usize::from(format.bits());
    let mut bits = Bits::with_capacity(w.saturating_mul(values.len()));
    for &v in values {
        if !v.format().same_layout(format) {
            return Err(FxError::FormatMismatch {
                expected: format,
                found: v.format(),
            });
        }
        let start = bits.len();
        bits.resize(start + w, false);
        // With Lsb0 order, store_le puts the value's LSB at the lowest index
        // even when the field straddles two storage words.
        bits[start..].store_le(v.to_bits());
    }
    Ok(bits)
}

/// Inverse of [`pack`]: splits `bits` into `format.bits()`-wide fields,
/// LSB-first, and reads each as a value of `format`.
///
/// The length must be a multiple of the width, otherwise
/// [`FxError::PackLength`].
pub fn unpack(format: Format, bits: &BitSlice<u64, Lsb0>) -> Result<Vec<Fx>, FxError> {
    let w = usize::from(format.bits());
    // `w >= 1`, so the remainder is defined. (`is_multiple_of` is newer
    // than the workspace's declared minimum Rust, 1.85.)
    #[allow(clippy::manual_is_multiple_of)]
    let whole = bits.len() % w == 0;
    if !whole {
        return Err(FxError::PackLength {
            len: bits.len(),
            width: format.bits(),
        });
    }
    Ok(bits
        .chunks_exact(w)
        .map(|field| Fx::from_bits(field.load_le::<u64>(), format))
        .collect())
}
