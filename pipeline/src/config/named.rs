//! Which register format an assignment writes: [`FormatId`] numbers the
//! format fields of the table in `fields.rs` (the order of
//! [`PipelineConfig::formats`]), so the quantisation counters
//! ([`crate::fixed::QuantStats`]) can say which register saturated or
//! rounded, and [`Reg`] carries the number beside a format at the
//! assignment sites. Whether a format's overflow is a designed clamp or a
//! range violation is [`FormatId::clamps`].

use super::fields::{FIELD_KINDS, FORMAT_COUNT};
use super::PipelineConfig;
use crate::fixed::{Format, Fx, QuantStats, Wide};

/// A register format of the configuration by its place among the format
/// fields, or [`FormatId::OTHER`] for an assignment into a format that is
/// no field of its own (a test's, or a generic evaluator's).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct FormatId(u8);

/// The format fields whose overflow is a designed clamp: the value's
/// range is that of the format by construction, and saturating is the
/// answer the arithmetic wants (each field's rustdoc says why it
/// saturates). An overflow anywhere else is a range violation.
///
/// - `voxel`: wider data clamps at the top of the range;
/// - `step`, `weight`: a rounding overshoot of a fraction clamps one LSB
///   below 1;
/// - `color`, `alpha`, `opacity_corr`, `voi_weight`, `normal_dot`,
///   `specular`: values in `[0, 1]` clamp at their top (white, opaque);
/// - `log_transmittance`: a long path through dense material clamps at an
///   already negligible transmittance;
/// - `accum_color`, `accum_alpha`: a full ray stays white and opaque;
/// - `voi_dist`: a far sample stays far (its weight is 0 or 1 either way).
const CLAMPS: [&str; 13] = [
    "voxel",
    "step",
    "weight",
    "color",
    "alpha",
    "opacity_corr",
    "voi_weight",
    "normal_dot",
    "specular",
    "log_transmittance",
    "accum_color",
    "accum_alpha",
    "voi_dist",
];

// Every name above is a format field (a compile-time check).
const _: () = {
    let mut i = 0;
    while i < CLAMPS.len() {
        FormatId::named(CLAMPS[i]);
        i += 1;
    }
};

/// Whether two strings are equal, in a const context.
const fn same(a: &str, b: &str) -> bool {
    let (a, b) = (a.as_bytes(), b.as_bytes());
    if a.len() != b.len() {
        return false;
    }
    let mut i = 0;
    while i < a.len() {
        if a[i] != b[i] {
            return false;
        }
        i += 1;
    }
    true
}

impl FormatId {
    /// How many ids there are: every format field and [`FormatId::OTHER`].
    pub const COUNT: usize = FORMAT_COUNT + 1;

    /// An assignment into a format that is no field of its own.
    pub const OTHER: FormatId = FormatId(FORMAT_COUNT as u8);

    /// The format field named `name`; fails to compile (panics) when the
    /// table has no such format field. Use [`reg!`](crate::reg) at
    /// assignment sites.
    pub const fn named(name: &str) -> FormatId {
        let mut i = 0;
        let mut n = 0u8;
        while i < FIELD_KINDS.len() {
            let (field, is_format) = FIELD_KINDS[i];
            if is_format {
                if same(field, name) {
                    return FormatId(n);
                }
                n += 1;
            }
            i += 1;
        }
        panic!("no format field of that name")
    }

    /// Every id, in table order, [`FormatId::OTHER`] last.
    pub fn all() -> impl Iterator<Item = FormatId> {
        (0..Self::COUNT as u8).map(FormatId)
    }

    /// The index of this id's counters.
    #[inline(always)]
    pub const fn index(self) -> usize {
        self.0 as usize
    }

    /// The field's name (`"other"` for [`FormatId::OTHER`]).
    pub fn name(self) -> &'static str {
        FIELD_KINDS
            .iter()
            .filter(|(_, is_format)| *is_format)
            .nth(self.index())
            .map_or("other", |(name, _)| name)
    }

    /// Whether an overflow of this format is a designed clamp (see
    /// `CLAMPS` above); `false` means a range violation no derived bound
    /// covers.
    pub fn clamps(self) -> bool {
        CLAMPS.iter().any(|&c| FormatId::named(c) == self)
    }

    /// This format in `cfg` (`None` for [`FormatId::OTHER`]).
    pub fn format(self, cfg: &PipelineConfig) -> Option<Format> {
        cfg.formats().get(self.index()).map(|&(_, f)| f)
    }
}

/// A register's format with its identity: assignments through it count
/// under its [`FormatId`]. Dereferences to the [`Format`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Reg {
    /// Which field the format is.
    pub id: FormatId,
    /// The format.
    pub format: Format,
}

impl std::ops::Deref for Reg {
    type Target = Format;
    fn deref(&self) -> &Format {
        &self.format
    }
}

impl Reg {
    /// [`Format::assign`], counting the event under this register.
    #[inline(always)]
    pub fn assign(&self, w: impl Into<Wide>, stats: &mut QuantStats) -> Fx {
        let q = self.format.quantize(w.into());
        stats.record_as(self.id, &q);
        q.value
    }
}

/// The [`Reg`] of field `$field` of config `$cfg` (the id is a constant):
/// `reg!(self.cfg, path)`.
#[macro_export]
macro_rules! reg {
    ($cfg:expr, $field:ident) => {
        $crate::config::Reg {
            id: const { $crate::config::FormatId::named(stringify!($field)) },
            format: $cfg.$field,
        }
    };
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ids_follow_the_formats_and_name_them() {
        let cfg = PipelineConfig::default();
        let named = cfg.formats();
        for (i, (name, f)) in named.iter().enumerate() {
            let id = FormatId::named(name);
            assert_eq!(id.index(), i);
            assert_eq!(id.name(), *name);
            assert_eq!(id.format(&cfg), Some(*f));
        }
        assert_eq!(FormatId::OTHER.name(), "other");
        assert_eq!(FormatId::OTHER.format(&cfg), None);
        assert_eq!(FormatId::all().count(), named.len() + 1);
        let r = reg!(cfg, path);
        assert_eq!((r.id.name(), r.format), ("path", cfg.path));
    }

    #[test]
    fn the_path_is_no_clamp_and_opacity_is() {
        assert!(!FormatId::named("path").clamps());
        assert!(!FormatId::named("position").clamps());
        assert!(!FormatId::OTHER.clamps());
        assert!(FormatId::named("accum_alpha").clamps());
        assert!(FormatId::named("opacity_corr").clamps());
    }
}
