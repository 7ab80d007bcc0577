//! Reading and writing configs as TOML text.

use super::error::ConfigError;
use super::fields::{RawConfig, FIELD_DOCS};
use super::PipelineConfig;
use std::fmt::Write as _;
use std::path::Path;

impl PipelineConfig {
    /// Parses and validates a TOML config. Missing keys keep their default.
    pub fn from_toml_str(text: &str) -> Result<PipelineConfig, ConfigError> {
        let raw: RawConfig = toml::from_str(text).map_err(|e| {
            let message = e.message().replace('\n', " ");
            let message = message.trim();
            match e.span() {
                Some(span) => {
                    let line = text[..span.start.min(text.len())].matches('\n').count() + 1;
                    ConfigError::Toml(format!("line {line}: {message}"))
                }
                None => ConfigError::Toml(message.to_owned()),
            }
        })?;
        PipelineConfig::try_from(raw)
    }

    /// Reads, parses and validates a TOML config file.
    pub fn from_toml_file(path: &Path) -> Result<PipelineConfig, ConfigError> {
        let text = std::fs::read_to_string(path).map_err(|source| ConfigError::Io {
            path: path.to_owned(),
            source,
        })?;
        PipelineConfig::from_toml_str(&text)
    }

    /// The complete config as commented TOML, one inline table per format,
    /// which [`from_toml_str`](PipelineConfig::from_toml_str) reads back to
    /// an equal config.
    pub fn to_toml(&self) -> String {
        let values = RawConfig::from(*self).toml_values();
        let mut out = String::from(
            "# ercube pipeline datapath widths.\n\
             # Each format: bits (1..=63), frac (0..=bits), signed,\n\
             # quant = TRN | TRN_ZERO | RND | RND_ZERO | RND_MIN_INF | RND_INF | RND_CONV,\n\
             # overflow = WRAP | SAT | SAT_ZERO | SAT_SYM (ap_fixed semantics).\n",
        );
        for ((key, doc), value) in FIELD_DOCS.iter().zip(values.iter()) {
            // Writing to a String cannot fail.
            let _ = write!(out, "\n# {doc}\n{key} = {value}\n");
        }
        out
    }

    /// The default config as commented TOML, for users to dump and edit.
    pub fn default_toml() -> String {
        PipelineConfig::default().to_toml()
    }
}

#[cfg(test)]
mod tests {
    use crate::config::fields::FIELD_DOCS;
    use crate::config::{ConfigError, PipelineConfig};
    use crate::fixed::{Format, Overflow, Quant};

    #[test]
    fn default_toml_round_trips() {
        let text = PipelineConfig::default_toml();
        assert!(text.contains(
            r#"alpha = { bits = 12, frac = 12, signed = false, quant = "RND", overflow = "SAT" }"#
        ));
        assert!(text.contains("\npes = 16\n"));
        assert!(text.contains(
            r#"path = { bits = 16, frac = 13, signed = false, quant = "RND", overflow = "SAT" }"#
        ));
        assert!(text.contains(
            r#"log_transmittance = { bits = 20, frac = 15, signed = false, quant = "RND", overflow = "SAT" }"#
        ));
        assert!(text.contains("\nexp_table_bits = 10\n"));
        assert!(!text.contains("opacity_slope_bits"));
        assert_eq!(
            PipelineConfig::from_toml_str(&text).unwrap(),
            PipelineConfig::default()
        );
        // Every key is written, so the dump does not depend on defaults.
        for (key, _) in FIELD_DOCS {
            assert!(text.contains(&format!("\n{key} = ")), "{key} missing");
        }
    }

    #[test]
    fn edited_config_round_trips() {
        let c = PipelineConfig {
            voxel: Format::new(8, 0, false, Quant::Trn, Overflow::Wrap).unwrap(),
            sample: Format::new(12, 4, false, Quant::RndConv, Overflow::Sat).unwrap(),
            table_entries: 256,
            alpha: Format::new(10, 10, false, Quant::RndZero, Overflow::SatZero).unwrap(),
            pes: 256,
            path: Format::new(12, 9, false, Quant::Trn, Overflow::Sat).unwrap(),
            log_transmittance: Format::new(24, 18, false, Quant::RndConv, Overflow::Wrap).unwrap(),
            exp_table_bits: 16,
            opacity_corr: Format::new(14, 14, false, Quant::Rnd, Overflow::Sat).unwrap(),
            ..PipelineConfig::default()
        };
        c.validate().unwrap();
        assert_eq!(c.table_shift(), 0);
        let text = c.to_toml();
        assert!(text.contains("\nexp_table_bits = 16\n"), "{text}");
        assert!(text.contains(
            r#"log_transmittance = { bits = 24, frac = 18, signed = false, quant = "RND_CONV", overflow = "WRAP" }"#
        ));
        assert_eq!(PipelineConfig::from_toml_str(&text).unwrap(), c);
        // serde through other front ends goes the same way.
        let json = serde_json::to_string(&c).unwrap();
        assert_eq!(serde_json::from_str::<PipelineConfig>(&json).unwrap(), c);
        let plain = toml::to_string(&c).unwrap();
        assert_eq!(PipelineConfig::from_toml_str(&plain).unwrap(), c);
    }

    #[test]
    fn partial_toml_keeps_defaults() {
        let c = PipelineConfig::from_toml_str(
            "pes = 4\nalpha = { bits = 10, frac = 10, signed = false }\n",
        )
        .unwrap();
        assert_eq!(c.pes, 4);
        assert_eq!(c.alpha, Format::unsigned(10, 10).unwrap());
        assert_eq!(c.position, PipelineConfig::default().position);
        assert_eq!(
            PipelineConfig::from_toml_str("").unwrap(),
            PipelineConfig::default()
        );
    }

    #[test]
    fn toml_shape_errors_are_one_line() {
        let e = PipelineConfig::from_toml_str("pes = 4\nalpah = 3\n").unwrap_err();
        let msg = e.to_string();
        assert!(matches!(e, ConfigError::Toml(_)));
        assert!(
            msg.starts_with("TOML line 2: unknown field `alpah`"),
            "{msg}"
        );
        assert!(!msg.contains('\n'), "{msg}");
        let e = PipelineConfig::from_toml_str(
            "alpha = { bits = 12, frac = 12, signed = false, quant = \"ROUND\" }",
        )
        .unwrap_err();
        assert!(e.to_string().contains("ROUND"), "{e}");
        let e = PipelineConfig::from_toml_str("alpha = { bits = 12, frac = 12 }").unwrap_err();
        assert!(e.to_string().contains("signed"), "{e}");
        let e = PipelineConfig::from_toml_str("pes = \"many\"").unwrap_err();
        assert!(e.to_string().starts_with("TOML line 1:"), "{e}");
    }

    #[test]
    fn reads_files() {
        let dir = std::env::temp_dir().join(format!("ercube-config-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("pipeline.toml");
        std::fs::write(&path, PipelineConfig::default_toml()).unwrap();
        assert_eq!(
            PipelineConfig::from_toml_file(&path).unwrap(),
            PipelineConfig::default()
        );
        let missing = dir.join("missing.toml");
        let e = PipelineConfig::from_toml_file(&missing).unwrap_err();
        assert!(matches!(e, ConfigError::Io { .. }));
        assert!(e.to_string().starts_with("cannot read "), "{e}");
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
