//! The messages of the role and cross-field rules.

use crate::config::testing::{error_for, spec};
use crate::config::PipelineConfig;
use crate::fixed::{Format, Overflow, Quant};

#[test]
fn role_errors_name_the_field() {
    let cases: [(&str, String, &str); 26] = [
        ("voxel", spec(12, 0, true), "voxel.signed = true"),
        ("voxel", spec(12, 2, false), "voxel.frac = 2"),
        ("voxel", spec(20, 0, false), "voxel.bits = 20 exceeds"),
        ("position", spec(28, 16, false), "position.signed = false"),
        ("position", spec(28, 0, true), "position.frac = 0"),
        (
            "position",
            spec(17, 16, true),
            "position has 1 integer bit(s)",
        ),
        ("step", spec(25, 24, true), "step.signed = true"),
        ("step", spec(24, 24, false), "t = 1 is not representable"),
        ("step", spec(4, 0, false), "step.frac = 0"),
        ("weight", spec(12, 10, false), "weight has 2 integer bits"),
        ("weight", spec(12, 12, true), "weight.signed = true"),
        (
            "sample",
            spec(14, 4, false),
            "sample has 10 integer bits, fewer than voxel.bits = 12",
        ),
        ("sample", spec(16, 4, true), "sample.signed = true"),
        ("color", spec(8, 0, false), "color.frac = 0"),
        ("alpha", spec(12, 8, false), "alpha has 4 integer bits"),
        ("path", spec(16, 14, true), "path.signed = true"),
        (
            "path",
            spec(16, 15, false),
            "path has 1 integer bit(s); at least 2 are needed",
        ),
        ("path", spec(4, 0, false), "path.frac = 0"),
        (
            "log_transmittance",
            spec(20, 15, true),
            "log_transmittance.signed = true",
        ),
        (
            "log_transmittance",
            spec(18, 15, false),
            "log_transmittance has 3 integer bit(s); at least 4 are needed",
        ),
        (
            "opacity_corr",
            spec(16, 14, false),
            "opacity_corr has 2 integer bits",
        ),
        (
            "opacity_corr",
            spec(12, 12, true),
            "opacity_corr.signed = true",
        ),
        (
            "accum_color",
            spec(8, 4, false),
            "accum_color.frac = 4 is below color.frac = 8",
        ),
        (
            "accum_alpha",
            spec(16, 10, false),
            "accum_alpha.frac = 10 is below opacity_corr.frac = 15",
        ),
        (
            "merge",
            spec(20, 12, false),
            "merge.frac = 12 is below accum_color.frac = 16",
        ),
        ("merge", spec(16, 16, true), "merge.signed = true"),
    ];
    for (key, value, needle) in cases {
        let e = error_for(key, &value);
        assert_eq!(e.field(), Some(key), "{key} = {value}: {e}");
        let msg = e.to_string();
        assert!(msg.starts_with(key), "{msg}");
        assert!(msg.contains(needle), "{msg} lacks {needle}");
        assert!(!msg.contains('\n'), "{msg}");
    }
    // Cross-field: a narrow sample makes the default table too big.
    let text = format!("sample = {}\n", spec(12, 0, false));
    let c = PipelineConfig::from_toml_str(&text).unwrap();
    assert_eq!(c.sample.bits(), 12);
    let text = format!(
        "voxel = {}\nsample = {}\n",
        spec(8, 0, false),
        spec(10, 2, false)
    );
    let e = PipelineConfig::from_toml_str(&text).unwrap_err();
    assert_eq!(
        e.to_string(),
        "table_entries = 4096 needs 12 index bits, more than sample.bits = 10"
    );
    // Merge integer headroom must cover the accumulators'.
    let wide_alpha = Format::new(17, 16, false, Quant::Rnd, Overflow::Sat).unwrap();
    let mut c = PipelineConfig {
        accum_alpha: wide_alpha,
        merge: wide_alpha,
        ..PipelineConfig::default()
    };
    c.validate().unwrap();
    c.merge = Format::new(16, 16, false, Quant::Rnd, Overflow::Sat).unwrap();
    assert_eq!(
        c.validate().unwrap_err().to_string(),
        "merge has 0 integer bits, fewer than accum_alpha's 1"
    );
}

#[test]
fn opacity_correction_cross_rules() {
    // log_transmittance must hold -log2(2^-alpha.frac) = alpha.frac.
    let text = format!("alpha = {}\n", spec(16, 16, false));
    let c = PipelineConfig::from_toml_str(&text).unwrap();
    assert_eq!(c.log_transmittance.int_bits(), 5);
    let text = format!(
        "alpha = {}\nlog_transmittance = {}\n",
        spec(16, 16, false),
        spec(19, 15, false)
    );
    let e = PipelineConfig::from_toml_str(&text).unwrap_err();
    assert_eq!(e.field(), Some("log_transmittance"));
    assert_eq!(
        e.to_string(),
        "log_transmittance has 4 integer bits, but -log2 of the smallest transmittance 2^-16 (alpha.frac = 16) needs ceil(log2(17)) = 5"
    );
    // alpha.frac = 15: -log2(2^-15) = 15 still fits 4 integer bits.
    let text = format!(
        "alpha = {}\nlog_transmittance = {}\n",
        spec(15, 15, false),
        spec(19, 15, false)
    );
    PipelineConfig::from_toml_str(&text).unwrap();

    // The exp table is indexed by fraction bits of p.
    let e = error_for("log_transmittance", &spec(14, 8, false));
    assert_eq!(e.field(), Some("exp_table_bits"));
    assert_eq!(
        e.to_string(),
        "exp_table_bits = 10 exceeds log_transmittance.frac = 8: the exp table is indexed by fraction bits of p"
    );
    let e = error_for("exp_table_bits", "16");
    assert_eq!(
        e.to_string(),
        "exp_table_bits = 16 exceeds log_transmittance.frac = 15: the exp table is indexed by fraction bits of p"
    );
    let text = format!(
        "exp_table_bits = 16\nlog_transmittance = {}\n",
        spec(21, 16, false)
    );
    assert_eq!(
        PipelineConfig::from_toml_str(&text).unwrap().exp_table_bits,
        16
    );
    let c = PipelineConfig {
        exp_table_bits: 0,
        ..PipelineConfig::default()
    };
    assert_eq!(
        c.validate().unwrap_err().to_string(),
        "exp_table_bits = 0 is outside 1..=16"
    );

    // Every message is one line starting with the field it names.
    for (key, value) in [
        ("path", spec(16, 15, false)),
        ("log_transmittance", spec(18, 15, false)),
        ("log_transmittance", spec(14, 8, false)),
        ("exp_table_bits", "0".to_owned()),
        ("exp_table_bits", "16".to_owned()),
    ] {
        let e = error_for(key, &value);
        let msg = e.to_string();
        let field = e.field().unwrap();
        assert!(msg.starts_with(field), "{msg}");
        assert!(!msg.contains('\n'), "{msg}");
    }
}

#[test]
fn code_built_configs_are_validated() {
    let c = PipelineConfig {
        pes: 0,
        ..PipelineConfig::default()
    };
    assert_eq!(c.validate().unwrap_err().field(), Some("pes"));
    let c = PipelineConfig {
        table_entries: 1 << 17,
        ..PipelineConfig::default()
    };
    assert_eq!(c.validate().unwrap_err().field(), Some("table_entries"));
    // Deserialising through serde validates too.
    let mut bad = serde_json::to_value(PipelineConfig::default()).unwrap();
    bad["pes"] = serde_json::json!(0);
    let err = serde_json::from_value::<PipelineConfig>(bad).unwrap_err();
    assert!(err.to_string().contains("pes = 0"), "{err}");
}

/// `link_lanes` stays in `1..=4` and above one needs the overlapped
/// migration, each refused in one line naming the field.
#[test]
fn link_lanes_need_the_overlapped_migration() {
    use crate::config::Migration;
    let ok = PipelineConfig {
        link_lanes: 4,
        migration: Migration::Overlapped,
        ..PipelineConfig::default()
    };
    assert!(ok.validate().is_ok());
    for (c, want) in [
        (
            PipelineConfig {
                link_lanes: 2,
                ..PipelineConfig::default()
            },
            "link_lanes = 2 needs migration = \"overlapped\"",
        ),
        (
            PipelineConfig {
                link_lanes: 5,
                ..ok
            },
            "link_lanes = 5 is outside 1..=4",
        ),
        (
            PipelineConfig {
                link_lanes: 0,
                ..ok
            },
            "link_lanes = 0 is outside 1..=4",
        ),
    ] {
        let e = c.validate().unwrap_err().to_string();
        assert!(e.starts_with(want), "{e}");
        assert!(!e.contains('\n'), "{e}");
    }
    let e = PipelineConfig::from_toml_str("link_lanes = 3\n").unwrap_err();
    assert!(e.to_string().contains("needs migration"), "{e}");
}

/// `link_fifo_depth` stays in `1..=4096`: a FIFO of no row could never
/// send, and an absurd depth is a one-line error, not an allocation.
#[test]
fn link_fifo_depth_is_a_row_to_4096() {
    for (text, want) in [
        (
            "link_fifo_depth = 0\n",
            "link_fifo_depth = 0 is outside 1..=4096",
        ),
        (
            "link_fifo_depth = 4097\n",
            "link_fifo_depth = 4097 is outside 1..=4096",
        ),
    ] {
        let e = PipelineConfig::from_toml_str(text).unwrap_err().to_string();
        assert!(e.contains(want), "{e}");
        assert!(!e.contains('\n'), "{e}");
    }
    // Past u16 the TOML itself is refused, in one line.
    let e = PipelineConfig::from_toml_str("link_fifo_depth = 100000000\n")
        .unwrap_err()
        .to_string();
    assert!(e.contains("link_fifo_depth"), "{e}");
    for d in [1, 2, 4096] {
        let c = PipelineConfig::from_toml_str(&format!("link_fifo_depth = {d}\n")).expect("valid");
        assert_eq!(c.link_fifo_depth, d);
    }
}
