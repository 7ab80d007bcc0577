//! Quantities derived from a config that the datapath and the controller
//! read: the termination word, the position range and the table
//! addressing.

use super::error::{invalid, ConfigError};
use super::{Order, PipelineConfig};
use crate::fixed::{Format, Overflow, Quant, MAX_BITS};

impl PipelineConfig {
    /// The early-termination threshold as a raw `accum_alpha` word, rounded
    /// up (`ceil(terminate / lsb)`): a ray is terminated once its opacity
    /// word is at least this. `None` when termination is off
    /// (`terminate = 1`, or back to front). The threshold may lie above the
    /// format's largest word, in which case no ray ever reaches it.
    pub fn termination_raw(&self) -> Option<i64> {
        if self.order != Order::FrontToBack || self.terminate >= 1.0 {
            return None;
        }
        // ceil(x) = -floor(-x): truncate the negated fraction in a signed
        // format with accum_alpha's fraction bits and a wide integer part
        // (63 bits hold -1 <= -x < 0 at any accum_alpha.frac <= 62; at 63
        // the format is exactly [-1, 1)).
        let frac = self.accum_alpha.frac();
        let neg = Format::new(MAX_BITS, frac, true, Quant::Trn, Overflow::Sat)
            .ok()?
            .from_f64(-self.terminate)
            .ok()?;
        Some(-neg.value.raw())
    }

    /// The largest voxel coordinate the position format can hold exactly:
    /// `2^(int_bits - 1) - 1` for a signed format.
    pub fn max_position(&self) -> u64 {
        let magnitude_bits = u32::from(self.position.int_bits()).saturating_sub(1);
        (1u64 << magnitude_bits).saturating_sub(1)
    }

    /// How a sample addresses the classification table: the table position
    /// of a sample is `sample * 2^shift` with
    /// `shift = log2(table_entries) - voxel.bits`, because the table spans
    /// the voxel word's full range, one entry per `2^-shift` voxel units.
    /// The integer part of that position is the entry index.
    ///
    /// ```
    /// use pipeline::config::PipelineConfig;
    ///
    /// // Default: 4096 entries for 12-bit voxels, one entry per voxel value.
    /// let c = PipelineConfig::default();
    /// assert_eq!(c.table_shift(), 0);
    /// // 256 entries: one entry per 16 voxel values.
    /// let c = PipelineConfig { table_entries: 256, ..c };
    /// assert_eq!(c.table_shift(), -4);
    /// ```
    pub fn table_shift(&self) -> i32 {
        self.table_entries.trailing_zeros() as i32 - i32::from(self.voxel.bits())
    }

    /// Checks that positions can span a volume `extent` voxels wide along
    /// any axis: sample positions run from 0 to `extent`, one past the last
    /// voxel for the interpolation footprint.
    pub fn check_extent(&self, extent: u32) -> Result<(), ConfigError> {
        if u64::from(extent) > self.max_position() {
            return Err(invalid(
                "position",
                format!(
                    "position holds coordinates up to {}, below the volume extent {extent}",
                    self.max_position()
                ),
            ));
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use crate::config::testing::error_for;
    use crate::config::{ConfigError, Order, PipelineConfig};
    use crate::fixed::{Format, Overflow, Quant};

    #[test]
    fn table_shift_spans_the_voxel_range() {
        let c = PipelineConfig::default();
        assert_eq!(c.table_shift(), 0);
        let c = PipelineConfig {
            table_entries: 1 << 16,
            ..c
        };
        assert_eq!(c.table_shift(), 4);
        let c = PipelineConfig {
            voxel: Format::new(8, 0, false, Quant::Trn, Overflow::Sat).unwrap(),
            table_entries: 2,
            ..c
        };
        assert_eq!(c.table_shift(), -7);
    }

    #[test]
    fn order_and_termination_round_trip_and_validate() {
        let c = PipelineConfig::default();
        assert_eq!((c.order, c.terminate), (Order::BackToFront, 1.0));
        assert_eq!(c.termination_raw(), None);
        let text = c.to_toml();
        assert!(text.contains("\norder = \"back-to-front\"\n"), "{text}");
        assert!(text.contains("\nterminate = 1.0\n"), "{text}");
        let f =
            PipelineConfig::from_toml_str("order = \"front-to-back\"\nterminate = 0.99\n").unwrap();
        assert_eq!((f.order, f.terminate), (Order::FrontToBack, 0.99));
        assert_eq!(PipelineConfig::from_toml_str(&f.to_toml()).unwrap(), f);
        // Rounded up to the 16-bit accumulator: ceil(0.99 * 65536) = 64881.
        assert_eq!(f.termination_raw(), Some(64881));
        let raw = f.termination_raw().map_or(0.0, |r| r as f64);
        assert!(raw / 65536.0 >= 0.99 && (raw - 1.0) / 65536.0 < 0.99);
        // Exactly representable thresholds stay put; 1 is off.
        let half = PipelineConfig {
            terminate: 0.5,
            ..f
        };
        assert_eq!(half.termination_raw(), Some(32768));
        assert_eq!(
            PipelineConfig {
                terminate: 1.0,
                ..f
            }
            .termination_raw(),
            None
        );
        // Back to front ignores the threshold.
        assert_eq!(
            PipelineConfig {
                order: Order::BackToFront,
                ..half
            }
            .termination_raw(),
            None
        );
        for bad in ["0", "1.5", "-0.2", "nan", "inf"] {
            let e = error_for("terminate", bad);
            assert_eq!(e.field(), Some("terminate"), "{bad}: {e}");
            let msg = e.to_string();
            assert!(
                msg.starts_with("terminate = ") && msg.contains("(0, 1]"),
                "{msg}"
            );
            assert!(!msg.contains('\n'), "{msg}");
        }
        let e = error_for("order", "\"sideways\"");
        assert!(matches!(e, ConfigError::Toml(_)), "{e}");
        assert!(e.to_string().contains("sideways"), "{e}");
        // The fold needs an integer bit in `merge`.
        let no_int = Format::new(16, 16, false, Quant::Rnd, Overflow::Sat).unwrap();
        let c = PipelineConfig {
            merge: no_int,
            ..PipelineConfig::default()
        };
        c.validate().unwrap();
        let e = PipelineConfig {
            order: Order::FrontToBack,
            ..c
        }
        .validate()
        .unwrap_err();
        assert_eq!(e.field(), Some("merge"));
        assert!(e.to_string().starts_with("merge has 0 integer bits"), "{e}");
    }
}
