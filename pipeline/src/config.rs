//! Run-time configuration of every datapath width of the PE array.
//!
//! A [`PipelineConfig`] is built in code (start from [`Default`]) or read
//! from TOML with [`PipelineConfig::from_toml_str`]; each datapath register
//! is a [`Format`] written as an inline table:
//!
//! ```toml
//! alpha = { bits = 12, frac = 12, signed = false, quant = "RND", overflow = "SAT" }
//! ```
//!
//! Keys left out of a TOML file keep their default, unknown keys are
//! errors, and every config is checked by [`PipelineConfig::validate`],
//! whose errors are one line naming the field, e.g.
//! `alpha.frac = 20 exceeds alpha.bits = 16`.
//! [`PipelineConfig::to_toml`] writes a complete, commented file that reads
//! back to the same config, so `ercube` can dump the defaults for editing.

use crate::fixed::{Format, FormatSpec, Overflow, Quant, MAX_BITS};
use serde::{Deserialize, Serialize};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use thiserror::Error;

/// Largest supported PE count. The array is 1D and each PE owns a column of
/// the slice buffer; 256 covers one PE per voxel column of a 256-wide
/// volume and keeps PE indices in 8 bits.
pub const MAX_PES: u16 = 256;

/// Largest classification table. 2^16 entries index a full 16-bit sample;
/// anything larger cannot be addressed by the widest voxel.
pub const MAX_TABLE_ENTRIES: u32 = 1 << 16;

/// Largest exp table of the opacity-correction unit, in index bits:
/// 2^16 entries, the same bound as the classification table.
pub const MAX_EXP_TABLE_BITS: u8 = 16;

/// Fewest integer bits of `log_transmittance`: `-log2` transmittances up to
/// 16, i.e. transmittance down to 2^-16.
pub const MIN_LOG_TRANSMITTANCE_INT_BITS: u8 = 4;

/// Widest voxel: volumes are stored as 8- or 16-bit words.
pub const MAX_VOXEL_BITS: u8 = 16;

/// Why a configuration cannot be used. Every message is one line and names
/// the field.
#[derive(Debug, Error)]
pub enum ConfigError {
    /// A field's value is impossible or inconsistent with another field.
    #[error("{message}")]
    Invalid {
        /// The TOML key at fault, e.g. `alpha`.
        field: String,
        /// The full one-line message, starting with the field name.
        message: String,
    },
    /// The TOML text does not parse into the config's shape (syntax error,
    /// unknown key, wrong type, unknown mode name).
    #[error("TOML {0}")]
    Toml(String),
    /// The config file could not be read.
    #[error("cannot read {}: {source}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// The underlying error.
        #[source]
        source: std::io::Error,
    },
}

impl ConfigError {
    /// The field at fault, for [`ConfigError::Invalid`].
    pub fn field(&self) -> Option<&str> {
        match self {
            ConfigError::Invalid { field, .. } => Some(field),
            _ => None,
        }
    }
}

fn invalid(field: &str, message: String) -> ConfigError {
    ConfigError::Invalid {
        field: field.to_owned(),
        message,
    }
}

/// Widths of every datapath register of the PE array, and the array size.
///
/// The defaults model a VolumePro-class datapath (12-bit voxels and
/// opacities, 8 fraction bits of colour) with enough position range for
/// 1024³ volumes; each field's documentation says why its default was
/// chosen.
///
/// # Opacity correction
///
/// Classification opacities are for a unit sample spacing; a ray that
/// crosses a slice step along a path of length `ds` voxels needs the
/// corrected opacity `a' = 1 - (1 - a)^ds`. The opacity-correction unit
/// computes it in the log domain, from four fields:
///
/// 1. `L = -log2(1 - a)`, read from a table indexed by the alpha code
///    (`2^alpha.bits` entries), stored in [`log_transmittance`];
/// 2. `p = L * ds`, with `ds` in the [`path`] format, assigned to
///    [`log_transmittance`];
/// 3. `T = 2^-p = 2^-int(p) * 2^-frac(p)`: an exp table indexed by the top
///    [`exp_table_bits`] bits of `frac(p)`, linearly interpolated with the
///    remaining fraction bits (interpolation weight in the [`weight`]
///    format), entries and result in the [`opacity_corr`] format, then
///    shifted right by `int(p)`;
/// 4. `a' = 1 - T` in [`opacity_corr`].
///
/// [`log_transmittance`]: PipelineConfig::log_transmittance
/// [`path`]: PipelineConfig::path
/// [`exp_table_bits`]: PipelineConfig::exp_table_bits
/// [`weight`]: PipelineConfig::weight
/// [`opacity_corr`]: PipelineConfig::opacity_corr
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "RawConfig", into = "RawConfig")]
pub struct PipelineConfig {
    /// Voxel word as read from volume memory: unsigned integer, at most 16
    /// bits, no fraction.
    ///
    /// Default `ufixed<12,12,TRN,SAT>`: 12 bits is the native CT word and
    /// VolumePro's voxel width; SAT so that loading wider data clamps at
    /// the top of the range instead of wrapping bright voxels to dark.
    pub voxel: Format,
    /// Ray position inside a slice, in voxel units: signed (rays start
    /// outside the volume), with at least one fraction bit for the
    /// interpolation weights.
    ///
    /// Default `fixed<28,12,RND,SAT>`: 12 integer bits including the sign
    /// reach ±2047, i.e. a 1024-voxel extent with as much again of margin
    /// for rays outside the volume; 16 fraction bits place a ray to 1/65536
    /// voxel, so even a position advanced incrementally over 1024 slices
    /// drifts by at most 1/128 voxel with RND (1/64 with TRN). SAT keeps a
    /// ray far outside the volume outside instead of wrapping it into view.
    pub position: Format,
    /// Per-slice ray spacing `t`, with `0 < t <= 1`: unsigned, with at least
    /// one integer bit so that `t = 1` is representable.
    ///
    /// Default `ufixed<25,1,RND,SAT>`: 24 fraction bits so that `t` times
    /// 1024 slices is accurate to 1/32768 voxel with RND; SAT so that a
    /// rounding overshoot above 1 clamps instead of wrapping to 0.
    pub step: Format,
    /// Bilinear interpolation weights, the fraction bits of a position:
    /// unsigned, at most one integer bit.
    ///
    /// Default `ufixed<12,0,TRN,SAT>`: 12 bits keep the weight error below
    /// one voxel LSB even across a full-range edge (4095 × 2^-12 < 1);
    /// TRN because taking the top fraction wires of the position is free,
    /// and rounding would need a carry into the integer (address) part.
    /// The opacity-correction unit's exp-table interpolation weight (step 3
    /// of [opacity correction](PipelineConfig#opacity-correction)) uses this
    /// format too.
    pub weight: Format,
    /// Interpolated sample: unsigned, with at least as many integer bits as
    /// the voxel (a convex combination of voxels never exceeds the largest).
    ///
    /// Default `ufixed<16,12,RND,SAT>`: the 12 voxel bits plus 4 fraction
    /// bits, so two interpolation stages keep sub-LSB detail for the
    /// classification lookup.
    pub sample: Format,
    /// Classification table colour entries (each of R, G, B): unsigned
    /// fraction with at most one integer bit.
    ///
    /// Default `ufixed<9,1,RND,SAT>`: 8 fraction bits per channel as in
    /// VolumePro and the 8-bit output image, plus 1 integer bit so that
    /// white (1.0) is exact; without it SAT capped white at 255/256, a full
    /// grey level of error. SAT so that loading a value above 1 clamps
    /// instead of wrapping.
    pub color: Format,
    /// Classification table opacity entries: unsigned fraction with at most
    /// one integer bit.
    ///
    /// Default `ufixed<12,0,RND,SAT>`: VolumePro's 12-bit alpha. Opacities
    /// below half an LSB (2^-13 per unit length) round to zero: a medium of
    /// opacity 1e-4 per voxel vanishes (1024 such slices would reach 0.097);
    /// widen `alpha` for faint material.
    pub alpha: Format,
    /// Number of classification table entries: a power of two, indexed by
    /// the top `log2(table_entries)` bits of the sample, so at most
    /// `2^sample.bits`.
    ///
    /// Default 4096: one entry per 12-bit voxel value.
    pub table_entries: u32,
    /// Ray path length per slice step, in voxels: `ds = |(dx/dz, dy/dz, 1)|`
    /// (scaled by the voxel spacing), the exponent of
    /// [opacity correction](PipelineConfig#opacity-correction) (step 2).
    /// `ds` lies in `[1, 4)` for views up to about 140 degrees: unsigned,
    /// with at least 2 integer bits and at least 1 fraction bit.
    ///
    /// Default `ufixed<16,3,RND,SAT>`: up to 8, so views up to about 160
    /// degrees across the volume fit (the paper's 127-degree view needs 3);
    /// 13 fraction bits give `ds` to 1.2e-4;
    /// SAT so that a steeper ray clamps at about 8 instead of wrapping to a
    /// short path.
    pub path: Format,
    /// Log-domain transmittance `-log2(1 - a)` per unit path (the table of
    /// step 1 of [opacity correction](PipelineConfig#opacity-correction))
    /// and per step (`p = L * ds`, step 2): unsigned, with at least 4
    /// integer bits and enough to hold `-log2` of the smallest representable
    /// transmittance `2^-alpha.frac`, i.e. integer bits >=
    /// `ceil(log2(alpha.frac + 1))`, and at least `exp_table_bits` fraction
    /// bits to index the exp table.
    ///
    /// Default `ufixed<20,5,RND,SAT>`: 5 integer bits reach 32, i.e.
    /// transmittance down to 2^-32, below any `opacity_corr` LSB; 15
    /// fraction bits leave 5 interpolation bits under the 10-bit exp-table
    /// index. SAT so that a long path through dense material clamps at an
    /// (already negligible) transmittance instead of wrapping to 1.
    pub log_transmittance: Format,
    /// Index bits of the exp table over `frac(p)` (step 3 of
    /// [opacity correction](PipelineConfig#opacity-correction)); the table
    /// has `2^exp_table_bits` entries. `1..=16`, and at most
    /// `log_transmittance.frac`.
    ///
    /// Default 10: 1024 entries; linear interpolation of `2^-f` over a
    /// 2^-10 step is accurate to below 3e-8, far under an `opacity_corr`
    /// LSB.
    pub exp_table_bits: u8,
    /// Opacity-correction result `a' = 1 - (1 - a)^ds`, and also the exp
    /// table entries and transmittance `T` it is computed from (steps 3 and
    /// 4 of [opacity correction](PipelineConfig#opacity-correction)):
    /// unsigned fraction with at most one integer bit.
    ///
    /// Default `ufixed<16,1,RND,SAT>`: 1 integer bit so that transmittance
    /// 1.0 (`frac(p) = 0`) is exact; 15 fraction bits, 3 more than `alpha`,
    /// so the correction does not lose what classification provides.
    pub opacity_corr: Format,
    /// Compositing accumulator of colour: unsigned, with at least as many
    /// fraction bits as `color`.
    ///
    /// Default `ufixed<16,0,RND,SAT>`: 8 guard bits over the colour so that
    /// hundreds of faint contributions add up instead of each rounding to
    /// zero; SAT so that a full ray stays white instead of wrapping black.
    pub accum_color: Format,
    /// Compositing accumulator of opacity: unsigned, with at least as many
    /// fraction bits as `opacity_corr`.
    ///
    /// Default `ufixed<16,0,RND,SAT>`: 4 guard bits over the 12-bit alpha
    /// (1 over the 15 fraction bits of `opacity_corr`) for the same reason
    /// as `accum_color`; SAT so that opacity approaching 1 stays there
    /// (early ray termination tests it).
    pub accum_alpha: Format,
    /// Intermediate of the Bartlett (tent-weighted) merge of neighbouring
    /// rays' accumulators at an ER-Perspective region boundary: unsigned,
    /// with at least the fraction and integer bits of both accumulators.
    ///
    /// Default `ufixed<20,4,RND,SAT>`: the accumulator plus 4 integer bits
    /// of headroom, enough for the weighted sum of up to 16 full
    /// accumulators before normalisation.
    pub merge: Format,
    /// Number of processing elements in the 1D array, `1..=256`.
    ///
    /// Default 16: a power of two dividing every power-of-two volume
    /// width, so slices split into whole PE beats.
    pub pes: u16,
    /// Compositing order: `back-to-front` (golden `er`: merge at region
    /// boundaries) or `front-to-back` (golden `er-ftb`: split at region
    /// boundaries, fold at the end, early ray termination).
    ///
    /// Default `back-to-front`, the model's original mode, bit for bit.
    pub order: Order,
    /// Early ray termination threshold of the front-to-back order, as a
    /// fraction of full opacity in `(0, 1]`: a ray whose opacity word
    /// reaches it takes no more samples. 1 disables termination. The
    /// controller quantises it *up* to the `accum_alpha` grid
    /// ([`PipelineConfig::termination_raw`]), so a terminated ray's
    /// opacity is never below the fraction asked for.
    ///
    /// Default 1 (off): termination trades up to `1 - terminate` per pixel
    /// for speed, a choice the user makes. Ignored back to front.
    pub terminate: f64,
    /// Edge in voxels of the blocks of the controller's occupancy memory
    /// (one bit per block: may a sample in it be visible?), a power of two
    /// from 2 to 64.
    ///
    /// Default 16: 4 kbit for a 256^3 volume, one block RAM.
    pub occupancy_block: u16,
}

// `terminate` is the only float field, and every validated config has a
// finite one (NaN is refused), so equality is an equivalence on them.
impl Eq for PipelineConfig {}

/// The compositing order of the PE array.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Order {
    /// ER back-to-front: rays composite from the rear, merge at each region
    /// boundary (golden `er`).
    #[default]
    BackToFront,
    /// ER front-to-back: rays composite from the front, split at each
    /// region boundary, fold back to one baseplane at the end (golden
    /// `er-ftb`), with early ray termination.
    FrontToBack,
}

impl Order {
    /// The name in TOML and on the command line.
    pub fn name(self) -> &'static str {
        match self {
            Order::BackToFront => "back-to-front",
            Order::FrontToBack => "front-to-back",
        }
    }
}

fn fmt(bits: u8, frac: u8, signed: bool, quant: Quant, overflow: Overflow) -> Format {
    match Format::new(bits, frac, signed, quant, overflow) {
        Ok(f) => f,
        // The defaults below are literals inside the valid range; the test
        // `default_validates` builds every one of them.
        Err(e) => unreachable!("invalid default format: {e}"),
    }
}

impl Default for PipelineConfig {
    fn default() -> Self {
        use Overflow::Sat;
        use Quant::{Rnd, Trn};
        PipelineConfig {
            voxel: fmt(12, 0, false, Trn, Sat),
            position: fmt(28, 16, true, Rnd, Sat),
            step: fmt(25, 24, false, Rnd, Sat),
            weight: fmt(12, 12, false, Trn, Sat),
            sample: fmt(16, 4, false, Rnd, Sat),
            color: fmt(9, 8, false, Rnd, Sat),
            alpha: fmt(12, 12, false, Rnd, Sat),
            table_entries: 4096,
            path: fmt(16, 13, false, Rnd, Sat),
            log_transmittance: fmt(20, 15, false, Rnd, Sat),
            exp_table_bits: 10,
            opacity_corr: fmt(16, 15, false, Rnd, Sat),
            accum_color: fmt(16, 16, false, Rnd, Sat),
            accum_alpha: fmt(16, 16, false, Rnd, Sat),
            merge: fmt(20, 16, false, Rnd, Sat),
            pes: 16,
            order: Order::BackToFront,
            terminate: 1.0,
            occupancy_block: 16,
        }
    }
}

/// One-line descriptions written above each key by
/// [`PipelineConfig::to_toml`].
const FIELD_DOCS: [(&str, &str); 19] = [
    (
        "voxel",
        "voxel word from volume memory: unsigned, frac = 0, <= 16 bits",
    ),
    ("position", "ray position in voxel units: signed, frac >= 1"),
    (
        "step",
        "per-slice ray spacing t in (0, 1]: unsigned, >= 1 integer bit",
    ),
    ("weight", "bilinear weights: unsigned, <= 1 integer bit"),
    (
        "sample",
        "interpolated sample: unsigned, integer bits >= voxel.bits",
    ),
    (
        "color",
        "classification RGB entries: unsigned, <= 1 integer bit",
    ),
    (
        "alpha",
        "classification opacity entries: unsigned, <= 1 integer bit",
    ),
    (
        "table_entries",
        "classification table size: power of two, <= 2^sample.bits",
    ),
    (
        "path",
        "ray path length per slice step, ds in [1, 4): unsigned, >= 2 integer bits, frac >= 1",
    ),
    (
        "log_transmittance",
        "-log2(1 - alpha) and -log2 T per step: unsigned, >= 4 integer bits and 2^int > alpha.frac",
    ),
    (
        "exp_table_bits",
        "exp table index bits over frac(p): 1..=16, <= log_transmittance.frac",
    ),
    (
        "opacity_corr",
        "exp table, transmittance and corrected opacity: unsigned, <= 1 integer bit",
    ),
    (
        "accum_color",
        "colour accumulator: unsigned, frac >= color.frac",
    ),
    (
        "accum_alpha",
        "opacity accumulator: unsigned, frac >= opacity_corr.frac",
    ),
    (
        "merge",
        "Bartlett merge intermediate: unsigned, covers both accumulators",
    ),
    ("pes", "number of processing elements, 1..=256"),
    (
        "order",
        "compositing order: \"back-to-front\" (merge) or \"front-to-back\" (split, fold, termination)",
    ),
    (
        "terminate",
        "front-to-back early ray termination opacity in (0, 1]; 1 disables it",
    ),
    (
        "occupancy_block",
        "edge of the occupancy memory's empty-space blocks in voxels: a power of two, 2..=64",
    ),
];

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
        let raw = RawConfig::from(*self);
        let values: [String; 19] = [
            raw.voxel.to_string(),
            raw.position.to_string(),
            raw.step.to_string(),
            raw.weight.to_string(),
            raw.sample.to_string(),
            raw.color.to_string(),
            raw.alpha.to_string(),
            raw.table_entries.to_string(),
            raw.path.to_string(),
            raw.log_transmittance.to_string(),
            raw.exp_table_bits.to_string(),
            raw.opacity_corr.to_string(),
            raw.accum_color.to_string(),
            raw.accum_alpha.to_string(),
            raw.merge.to_string(),
            raw.pes.to_string(),
            format!("\"{}\"", raw.order.name()),
            // `{:?}` keeps the decimal point, so TOML reads a float back.
            format!("{:?}", raw.terminate),
            raw.occupancy_block.to_string(),
        ];
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

    /// Every register format with its field name, in declaration order.
    pub fn formats(&self) -> [(&'static str, Format); 13] {
        [
            ("voxel", self.voxel),
            ("position", self.position),
            ("step", self.step),
            ("weight", self.weight),
            ("sample", self.sample),
            ("color", self.color),
            ("alpha", self.alpha),
            ("path", self.path),
            ("log_transmittance", self.log_transmittance),
            ("opacity_corr", self.opacity_corr),
            ("accum_color", self.accum_color),
            ("accum_alpha", self.accum_alpha),
            ("merge", self.merge),
        ]
    }

    /// Checks that the datapath can work: each field's signedness and
    /// integer/fraction split suits its role, and related fields agree.
    /// Returns the first problem found, as a one-line message naming the
    /// field.
    pub fn validate(&self) -> Result<(), ConfigError> {
        let v = self.voxel;
        if v.is_signed() {
            return Err(invalid(
                "voxel",
                "voxel.signed = true, but voxels are unsigned words".into(),
            ));
        }
        if v.frac() != 0 {
            return Err(invalid(
                "voxel",
                format!(
                    "voxel.frac = {}, but voxels are integers (frac = 0)",
                    v.frac()
                ),
            ));
        }
        if v.bits() > MAX_VOXEL_BITS {
            return Err(invalid(
                "voxel",
                format!(
                    "voxel.bits = {} exceeds the {MAX_VOXEL_BITS}-bit volume word",
                    v.bits()
                ),
            ));
        }

        let p = self.position;
        if !p.is_signed() {
            return Err(invalid(
                "position",
                "position.signed = false, but rays start outside the volume at negative coordinates"
                    .into(),
            ));
        }
        if p.frac() == 0 {
            return Err(invalid(
                "position",
                "position.frac = 0 leaves no fraction bits for interpolation weights".into(),
            ));
        }
        if p.int_bits() < 2 {
            return Err(invalid(
                "position",
                format!(
                    "position has {} integer bit(s) including the sign; at least 2 are needed to address a voxel",
                    p.int_bits()
                ),
            ));
        }

        let s = self.step;
        if s.is_signed() {
            return Err(invalid("step", "step.signed = true, but 0 < t <= 1".into()));
        }
        if s.int_bits() < 1 {
            return Err(invalid(
                "step",
                format!(
                    "step.frac = {} equals step.bits, so t = 1 is not representable",
                    s.frac()
                ),
            ));
        }
        if s.frac() == 0 {
            return Err(invalid(
                "step",
                "step.frac = 0 leaves only t = 1; fractional spacing needs fraction bits".into(),
            ));
        }

        fraction_field("weight", self.weight)?;

        let sm = self.sample;
        if sm.is_signed() {
            return Err(invalid(
                "sample",
                "sample.signed = true, but samples index the classification table".into(),
            ));
        }
        if sm.int_bits() < v.bits() {
            return Err(invalid(
                "sample",
                format!(
                    "sample has {} integer bits, fewer than voxel.bits = {}",
                    sm.int_bits(),
                    v.bits()
                ),
            ));
        }

        fraction_field("color", self.color)?;
        fraction_field("alpha", self.alpha)?;

        let n = self.table_entries;
        if n < 2 || !n.is_power_of_two() || n > MAX_TABLE_ENTRIES {
            return Err(invalid(
                "table_entries",
                format!("table_entries = {n} is not a power of two in 2..={MAX_TABLE_ENTRIES}"),
            ));
        }
        if n.trailing_zeros() > u32::from(sm.bits()) {
            return Err(invalid(
                "table_entries",
                format!(
                    "table_entries = {n} needs {} index bits, more than sample.bits = {}",
                    n.trailing_zeros(),
                    sm.bits()
                ),
            ));
        }

        let ds = self.path;
        if ds.is_signed() {
            return Err(invalid(
                "path",
                "path.signed = true, but path lengths are positive".into(),
            ));
        }
        if ds.int_bits() < 2 {
            return Err(invalid(
                "path",
                format!(
                    "path has {} integer bit(s); at least 2 are needed for ds in [1, 4)",
                    ds.int_bits()
                ),
            ));
        }
        if ds.frac() == 0 {
            return Err(invalid(
                "path",
                "path.frac = 0 leaves only integer path lengths; oblique rays need fraction bits"
                    .into(),
            ));
        }

        let lt = self.log_transmittance;
        if lt.is_signed() {
            return Err(invalid(
                "log_transmittance",
                "log_transmittance.signed = true, but -log2 of a transmittance in (0, 1] is non-negative"
                    .into(),
            ));
        }
        if lt.int_bits() < MIN_LOG_TRANSMITTANCE_INT_BITS {
            return Err(invalid(
                "log_transmittance",
                format!(
                    "log_transmittance has {} integer bit(s); at least {MIN_LOG_TRANSMITTANCE_INT_BITS} are needed",
                    lt.int_bits()
                ),
            ));
        }
        // -log2 of the smallest transmittance, 2^-alpha.frac, is alpha.frac:
        // it needs ceil(log2(alpha.frac + 1)) integer bits, its bit length.
        let alpha_frac = self.alpha.frac();
        let needed = u8::BITS - alpha_frac.leading_zeros();
        if u32::from(lt.int_bits()) < needed {
            return Err(invalid(
                "log_transmittance",
                format!(
                    "log_transmittance has {} integer bits, but -log2 of the smallest transmittance 2^-{alpha_frac} (alpha.frac = {alpha_frac}) needs ceil(log2({})) = {needed}",
                    lt.int_bits(),
                    u32::from(alpha_frac) + 1
                ),
            ));
        }

        let e = self.exp_table_bits;
        if e == 0 || e > MAX_EXP_TABLE_BITS {
            return Err(invalid(
                "exp_table_bits",
                format!("exp_table_bits = {e} is outside 1..={MAX_EXP_TABLE_BITS}"),
            ));
        }
        if e > lt.frac() {
            return Err(invalid(
                "exp_table_bits",
                format!(
                    "exp_table_bits = {e} exceeds log_transmittance.frac = {}: the exp table is indexed by fraction bits of p",
                    lt.frac()
                ),
            ));
        }

        fraction_field("opacity_corr", self.opacity_corr)?;

        accumulator("accum_color", self.accum_color, "color", self.color)?;
        accumulator(
            "accum_alpha",
            self.accum_alpha,
            "opacity_corr",
            self.opacity_corr,
        )?;

        let m = self.merge;
        if m.is_signed() {
            return Err(invalid(
                "merge",
                "merge.signed = true, but Bartlett weights and accumulators are non-negative"
                    .into(),
            ));
        }
        for (name, acc) in [
            ("accum_color", self.accum_color),
            ("accum_alpha", self.accum_alpha),
        ] {
            if m.frac() < acc.frac() {
                return Err(invalid(
                    "merge",
                    format!(
                        "merge.frac = {} is below {name}.frac = {}",
                        m.frac(),
                        acc.frac()
                    ),
                ));
            }
            if m.int_bits() < acc.int_bits() {
                return Err(invalid(
                    "merge",
                    format!(
                        "merge has {} integer bits, fewer than {name}'s {}",
                        m.int_bits(),
                        acc.int_bits()
                    ),
                ));
            }
        }

        if self.pes == 0 || self.pes > MAX_PES {
            return Err(invalid(
                "pes",
                format!("pes = {} is outside 1..={MAX_PES}", self.pes),
            ));
        }

        let b = self.occupancy_block;
        if !(b.is_power_of_two() && (2..=64).contains(&b)) {
            return Err(invalid(
                "occupancy_block",
                format!("occupancy_block = {b} is not a power of two from 2 to 64"),
            ));
        }
        let t = self.terminate;
        if !(t.is_finite() && t > 0.0 && t <= 1.0) {
            return Err(invalid(
                "terminate",
                format!("terminate = {t} is outside (0, 1] (1 disables early ray termination)"),
            ));
        }
        // The fold adds what a ray's children added behind it to the ray's
        // own state, which can pass 1 (by up to 7/16 per boundary where
        // neighbouring rays differ); the fold keeps its words in `merge`.
        if self.order == Order::FrontToBack && m.int_bits() < 1 {
            return Err(invalid(
                "merge",
                "merge has 0 integer bits, but order = \"front-to-back\" folds results above 1 into it"
                    .into(),
            ));
        }
        Ok(())
    }

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

/// Checks a `[0, 1]`-valued field: unsigned, some fraction bits, and at
/// most one integer bit (more would only waste width).
fn fraction_field(name: &str, f: Format) -> Result<(), ConfigError> {
    if f.is_signed() {
        return Err(invalid(
            name,
            format!("{name}.signed = true, but {name} lies in [0, 1]"),
        ));
    }
    if f.frac() == 0 {
        return Err(invalid(
            name,
            format!("{name}.frac = 0, but {name} is a fraction in [0, 1]"),
        ));
    }
    if f.int_bits() > 1 {
        return Err(invalid(
            name,
            format!(
                "{name} has {} integer bits; a value in [0, 1] needs at most 1",
                f.int_bits()
            ),
        ));
    }
    Ok(())
}

/// Checks a compositing accumulator against the input it accumulates.
fn accumulator(
    name: &str,
    acc: Format,
    input_name: &str,
    input: Format,
) -> Result<(), ConfigError> {
    if acc.is_signed() {
        return Err(invalid(
            name,
            format!("{name}.signed = true, but front-to-back compositing only adds"),
        ));
    }
    if acc.frac() < input.frac() {
        return Err(invalid(
            name,
            format!(
                "{name}.frac = {} is below {input_name}.frac = {}: faint contributions would round to zero",
                acc.frac(),
                input.frac()
            ),
        ));
    }
    Ok(())
}

/// The unvalidated TOML/JSON shape of [`PipelineConfig`]. Integers are
/// `i64` so that out-of-range values are reported as written.
#[derive(Debug, Clone, Copy, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
struct RawConfig {
    voxel: FormatSpec,
    position: FormatSpec,
    step: FormatSpec,
    weight: FormatSpec,
    sample: FormatSpec,
    color: FormatSpec,
    alpha: FormatSpec,
    table_entries: i64,
    path: FormatSpec,
    log_transmittance: FormatSpec,
    exp_table_bits: i64,
    opacity_corr: FormatSpec,
    accum_color: FormatSpec,
    accum_alpha: FormatSpec,
    merge: FormatSpec,
    pes: i64,
    order: Order,
    terminate: f64,
    occupancy_block: i64,
}

impl Default for RawConfig {
    fn default() -> Self {
        PipelineConfig::default().into()
    }
}

impl From<PipelineConfig> for RawConfig {
    fn from(c: PipelineConfig) -> RawConfig {
        RawConfig {
            voxel: c.voxel.spec(),
            position: c.position.spec(),
            step: c.step.spec(),
            weight: c.weight.spec(),
            sample: c.sample.spec(),
            color: c.color.spec(),
            alpha: c.alpha.spec(),
            table_entries: i64::from(c.table_entries),
            path: c.path.spec(),
            log_transmittance: c.log_transmittance.spec(),
            exp_table_bits: i64::from(c.exp_table_bits),
            opacity_corr: c.opacity_corr.spec(),
            accum_color: c.accum_color.spec(),
            accum_alpha: c.accum_alpha.spec(),
            merge: c.merge.spec(),
            pes: i64::from(c.pes),
            order: c.order,
            terminate: c.terminate,
            occupancy_block: i64::from(c.occupancy_block),
        }
    }
}

fn format_field(name: &str, spec: FormatSpec) -> Result<Format, ConfigError> {
    Format::try_from(spec).map_err(|e| invalid(name, e.describe(name)))
}

fn int_field<T: TryFrom<i64>>(name: &str, value: i64, range: &str) -> Result<T, ConfigError> {
    T::try_from(value).map_err(|_| invalid(name, format!("{name} = {value} is outside {range}")))
}

impl TryFrom<RawConfig> for PipelineConfig {
    type Error = ConfigError;

    fn try_from(r: RawConfig) -> Result<PipelineConfig, ConfigError> {
        let config = PipelineConfig {
            voxel: format_field("voxel", r.voxel)?,
            position: format_field("position", r.position)?,
            step: format_field("step", r.step)?,
            weight: format_field("weight", r.weight)?,
            sample: format_field("sample", r.sample)?,
            color: format_field("color", r.color)?,
            alpha: format_field("alpha", r.alpha)?,
            table_entries: int_field(
                "table_entries",
                r.table_entries,
                &format!("2..={MAX_TABLE_ENTRIES}"),
            )?,
            path: format_field("path", r.path)?,
            log_transmittance: format_field("log_transmittance", r.log_transmittance)?,
            exp_table_bits: int_field(
                "exp_table_bits",
                r.exp_table_bits,
                &format!("1..={MAX_EXP_TABLE_BITS}"),
            )?,
            opacity_corr: format_field("opacity_corr", r.opacity_corr)?,
            accum_color: format_field("accum_color", r.accum_color)?,
            accum_alpha: format_field("accum_alpha", r.accum_alpha)?,
            merge: format_field("merge", r.merge)?,
            pes: int_field("pes", r.pes, &format!("1..={MAX_PES}"))?,
            order: r.order,
            terminate: r.terminate,
            occupancy_block: int_field("occupancy_block", r.occupancy_block, "2..=64")?,
        };
        config.validate()?;
        Ok(config)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn spec(bits: i64, frac: i64, signed: bool) -> String {
        format!("{{ bits = {bits}, frac = {frac}, signed = {signed}, quant = \"RND\", overflow = \"SAT\" }}")
    }

    /// Parses `key = value` on top of the defaults and returns the error.
    fn error_for(key: &str, value: &str) -> ConfigError {
        let text = format!("{key} = {value}\n");
        match PipelineConfig::from_toml_str(&text) {
            Ok(c) => panic!("{text} was accepted as {c:?}"),
            Err(e) => e,
        }
    }

    #[test]
    fn default_validates() {
        let c = PipelineConfig::default();
        assert_eq!(c.validate().map_err(|e| e.to_string()), Ok(()));
        // The defaults the field documentation states.
        let shown: Vec<String> = c.formats().iter().map(|(_, f)| f.to_string()).collect();
        assert_eq!(
            shown,
            [
                "ufixed<12,12,TRN,SAT>",
                "fixed<28,12,RND,SAT>",
                "ufixed<25,1,RND,SAT>",
                "ufixed<12,0,TRN,SAT>",
                "ufixed<16,12,RND,SAT>",
                "ufixed<9,1,RND,SAT>",
                "ufixed<12,0,RND,SAT>",
                "ufixed<16,3,RND,SAT>",
                "ufixed<20,5,RND,SAT>",
                "ufixed<16,1,RND,SAT>",
                "ufixed<16,0,RND,SAT>",
                "ufixed<16,0,RND,SAT>",
                "ufixed<20,4,RND,SAT>",
            ]
        );
        assert_eq!((c.table_entries, c.exp_table_bits, c.pes), (4096, 10, 16));
        assert_eq!(c.table_shift(), 0);
        assert_eq!(c.position.int_bits(), 12);
        assert_eq!(c.max_position(), 2047);
        assert!(c.check_extent(1024).is_ok());
        assert!(c.check_extent(2047).is_ok());
        let e = c.check_extent(2048).unwrap_err();
        assert_eq!(e.field(), Some("position"));
        assert_eq!(
            e.to_string(),
            "position holds coordinates up to 2047, below the volume extent 2048"
        );
    }

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
    fn format_errors_name_the_field() {
        let e = error_for("alpha", &spec(16, 20, false));
        assert_eq!(e.field(), Some("alpha"));
        assert_eq!(e.to_string(), "alpha.frac = 20 exceeds alpha.bits = 16");
        let e = error_for("merge", &spec(0, 0, false));
        assert_eq!(e.to_string(), "merge.bits = 0 is outside 1..=63");
        let e = error_for("position", &spec(64, 16, true));
        assert_eq!(e.to_string(), "position.bits = 64 is outside 1..=63");
        let e = error_for("color", &spec(8, -1, false));
        assert_eq!(
            e.to_string(),
            "color.frac = -1 is negative; only 0 <= frac <= bits is supported"
        );
    }

    #[test]
    fn integer_errors_name_the_field() {
        assert_eq!(
            error_for("pes", "0").to_string(),
            "pes = 0 is outside 1..=256"
        );
        assert_eq!(
            error_for("pes", "257").to_string(),
            "pes = 257 is outside 1..=256"
        );
        assert_eq!(
            error_for("pes", "-3").to_string(),
            "pes = -3 is outside 1..=256"
        );
        assert_eq!(
            error_for("pes", "70000").to_string(),
            "pes = 70000 is outside 1..=256"
        );
        assert_eq!(
            error_for("table_entries", "1000").to_string(),
            "table_entries = 1000 is not a power of two in 2..=65536"
        );
        assert_eq!(
            error_for("table_entries", "-1").to_string(),
            "table_entries = -1 is outside 2..=65536"
        );
        for value in ["0", "17", "-1", "300"] {
            let e = error_for("exp_table_bits", value);
            assert_eq!(e.field(), Some("exp_table_bits"));
            assert_eq!(
                e.to_string(),
                format!("exp_table_bits = {value} is outside 1..=16")
            );
        }
        // The removed slope table is an unknown key now.
        let e = error_for("opacity_slope_bits", "6");
        assert!(
            e.to_string().contains("unknown field `opacity_slope_bits`"),
            "{e}"
        );
    }

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
