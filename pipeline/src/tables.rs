//! The PE's lookup tables, loaded by the host: the classification table
//! (the golden model's `Lut`, quantised into the `color` and `alpha`
//! formats) and the two tables of the log-domain opacity unit.

use golden::tf::Lut;

use crate::config::PipelineConfig;
use crate::fixed::{Fx, FxError};

/// Tables in their hardware formats.
#[derive(Debug, Clone)]
pub struct Tables {
    /// Classification colour per entry (R, G, B in `color`).
    pub color: Vec<[Fx; 3]>,
    /// Classification opacity per entry (`alpha`).
    pub alpha: Vec<Fx>,
    /// `-log2(1 - a)` per alpha code (`log_transmittance`), saturating for
    /// `a >= 1`.
    pub log_t: Vec<Fx>,
    /// `2^(-j / 2^exp_table_bits)` for `j = 0 ..= 2^exp_table_bits`
    /// (`opacity_corr`); the extra last entry (`1/2`) lets the top index
    /// interpolate.
    pub exp: Vec<Fx>,
}

impl Tables {
    /// Quantises `lut` and builds the opacity tables for `cfg`. The table
    /// must have `cfg.table_entries` entries.
    pub fn new(cfg: &PipelineConfig, lut: &Lut) -> Result<Tables, FxError> {
        let q = |f: crate::fixed::Format, v: f64| f.from_f64(v).map(|q| q.value);
        let mut color = Vec::with_capacity(lut.rgba.len());
        let mut alpha = Vec::with_capacity(lut.rgba.len());
        for e in &lut.rgba {
            color.push([
                q(cfg.color, f64::from(e[0]))?,
                q(cfg.color, f64::from(e[1]))?,
                q(cfg.color, f64::from(e[2]))?,
            ]);
            alpha.push(q(cfg.alpha, f64::from(e[3]))?);
        }
        let codes = 1usize << cfg.alpha.bits();
        let lsb = cfg.alpha.lsb();
        let log_t = (0..codes)
            .map(|c| {
                let a = c as f64 * lsb;
                // Full opacity has no finite logarithm: any value above the format
                // saturates to its largest code.
                let l = if a >= 1.0 {
                    1e9
                } else {
                    -(-a).ln_1p() / std::f64::consts::LN_2
                };
                q(cfg.log_transmittance, l)
            })
            .collect::<Result<Vec<_>, _>>()?;
        let n = 1usize << cfg.exp_table_bits;
        let exp = (0..=n)
            .map(|j| q(cfg.opacity_corr, (-(j as f64) / n as f64).exp2()))
            .collect::<Result<Vec<_>, _>>()?;
        Ok(Tables {
            color,
            alpha,
            log_t,
            exp,
        })
    }
}
