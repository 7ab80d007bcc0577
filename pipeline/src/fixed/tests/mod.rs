//! Tests of the fixed-point layer.
//!
//! Two independent oracles:
//! * the `fixed` crate, for what it implements: same-format add, sub, mul
//!   and shifts (truncate toward −∞, wrap or saturate), format-to-format
//!   conversion (truncate), float conversion (nearest, ties to even) and
//!   rounding to an integer (floor, nearest-away, nearest-even,
//!   toward-zero);
//! * a reference written here in `f64` arithmetic that is exact for the
//!   generated magnitudes (below 2^53), which implements every mode from its
//!   *meaning* (nearest with a tie rule, wrap as a Euclidean remainder)
//!   rather than from the carry formula used by the implementation.

mod edges;
mod fixed_oracle;
mod reference;

use super::*;
use proptest::prelude::*;

/// At least 1024 cases: every property here is cheap, and the rounding
/// corner cases (ties, carries out of the integer part) are a small
/// fraction of random inputs.
fn cfg() -> ProptestConfig {
    ProptestConfig {
        cases: ProptestConfig::default().cases.max(1024),
        ..ProptestConfig::default()
    }
}

fn quant_strategy() -> impl Strategy<Value = Quant> {
    prop::sample::select(Quant::ALL.to_vec())
}

fn overflow_strategy() -> impl Strategy<Value = Overflow> {
    prop::sample::select(Overflow::ALL.to_vec())
}

/// Formats up to 24 bits, so every value and every value scaled by up to
/// 2^28 is exact in f64.
fn small_format() -> impl Strategy<Value = Format> {
    (
        1u8..=24,
        any::<bool>(),
        quant_strategy(),
        overflow_strategy(),
    )
        .prop_flat_map(|(bits, signed, q, o)| {
            (0u8..=bits).prop_map(move |frac| {
                Format::new(bits, frac, signed, q, o).expect("valid by range")
            })
        })
}
