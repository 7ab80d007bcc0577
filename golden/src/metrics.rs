//! Error metrics between two images, on what the eye sees: premultiplied
//! RGB over black.

use crate::error::{input, Result};
use crate::image::{to8, Image};

/// How far one image is from another.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct ImageError {
    /// Largest difference of any channel after rounding both to 8 bits (0..=255).
    pub max_abs_255: f64,
    /// Root-mean-square difference over all RGB channels, in [0, 1] units.
    pub rmse: f64,
    /// Peak signal-to-noise ratio in dB, `20 log10(1 / rmse)` (infinite for equal images).
    pub psnr: f64,
}

/// Compares `a` with `b` (same size).
pub fn compare(a: &Image, b: &Image) -> Result<ImageError> {
    compare_where(a, b, |_, _| true).map(|(e, _)| e)
}

/// [`compare`] over the pixels `(x, y)` that `keep` accepts; also returns
/// how many it accepted (an empty set compares as equal).
pub fn compare_where(
    a: &Image,
    b: &Image,
    keep: impl Fn(usize, usize) -> bool,
) -> Result<(ImageError, u64)> {
    if (a.width, a.height) != (b.width, b.height) {
        return Err(input(format!(
            "cannot compare a {}x{} image with a {}x{} one",
            a.width, a.height, b.width, b.height
        )));
    }
    let mut max = 0u8;
    let mut sq = 0f64;
    let mut n = 0usize;
    for (i, (p, q)) in a.data.iter().zip(&b.data).enumerate() {
        if !keep(i % a.width.max(1), i / a.width.max(1)) {
            continue;
        }
        n += 1;
        for c in 0..3 {
            max = max.max(to8(p[c]).abs_diff(to8(q[c])));
            let d = p[c] as f64 - q[c] as f64;
            sq += d * d;
        }
    }
    let rmse = (sq / (3 * n).max(1) as f64).sqrt();
    let e = ImageError {
        max_abs_255: max as f64,
        rmse,
        psnr: if rmse > 0.0 {
            -20.0 * rmse.log10()
        } else {
            f64::INFINITY
        },
    };
    Ok((e, n as u64))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn metrics_of_a_known_difference() {
        let a = Image::new(2, 2);
        let mut b = Image::new(2, 2);
        b.data[0] = [0.5, 0.0, 0.0, 1.0];
        let e = compare(&a, &b).unwrap();
        assert_eq!(e.max_abs_255, 128.0);
        assert!((e.rmse - (0.25f64 / 12.0).sqrt()).abs() < 1e-12);
        assert!((e.psnr - (-20.0 * e.rmse.log10())).abs() < 1e-12);
        assert!(compare(&a, &Image::new(3, 2)).is_err());
        assert_eq!(compare(&a, &a).unwrap().psnr, f64::INFINITY);
    }
}
