//! The field table: every field of [`PipelineConfig`], described once.
//!
//! Each entry gives the field's rustdoc, type, default, the range an
//! integer's conversion error names, the comment above its key in a TOML
//! dump, and the rule [`PipelineConfig::validate`] checks it with (in
//! `rules.rs`). [`config_fields!`] expands the table; the order of the
//! entries is the order of the struct, of a TOML dump, of serde's output,
//! of [`PipelineConfig::formats`] and of the checks.

use super::rules;
use super::schema::{config_fields, default_format as fmt};
use super::{Mapping, Migration, Order, RayBuffer, MAX_EXP_TABLE_BITS, MAX_PES, MAX_TABLE_ENTRIES};
use crate::fixed::Format;
use crate::fixed::Overflow::Sat;
use crate::fixed::Quant::{Rnd, Trn};

config_fields! {
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
    pub struct PipelineConfig {
        /// Voxel word as read from volume memory: unsigned integer, at most 16
        /// bits, no fraction.
        ///
        /// Default `ufixed<12,12,TRN,SAT>`: 12 bits is the native CT word and
        /// VolumePro's voxel width; SAT so that loading wider data clamps at
        /// the top of the range instead of wrapping bright voxels to dark.
        pub voxel: Format {
            default: fmt(12, 0, false, Trn, Sat),
            toml: "voxel word from volume memory: unsigned, frac = 0, <= 16 bits",
            check: rules::voxel,
        },
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
        pub position: Format {
            default: fmt(28, 16, true, Rnd, Sat),
            toml: "ray position in voxel units: signed, frac >= 1",
            check: rules::position,
        },
        /// Per-slice ray spacing `t`, with `0 < t <= 1`: unsigned, with at least
        /// one integer bit so that `t = 1` is representable.
        ///
        /// Default `ufixed<25,1,RND,SAT>`: 24 fraction bits so that `t` times
        /// 1024 slices is accurate to 1/32768 voxel with RND; SAT so that a
        /// rounding overshoot above 1 clamps instead of wrapping to 0.
        pub step: Format {
            default: fmt(25, 24, false, Rnd, Sat),
            toml: "per-slice ray spacing t in (0, 1]: unsigned, >= 1 integer bit",
            check: rules::step,
        },
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
        pub weight: Format {
            default: fmt(12, 12, false, Trn, Sat),
            toml: "bilinear weights: unsigned, <= 1 integer bit",
            check: rules::fraction,
        },
        /// Interpolated sample: unsigned, with at least as many integer bits as
        /// the voxel (a convex combination of voxels never exceeds the largest).
        ///
        /// Default `ufixed<16,12,RND,SAT>`: the 12 voxel bits plus 4 fraction
        /// bits, so two interpolation stages keep sub-LSB detail for the
        /// classification lookup.
        pub sample: Format {
            default: fmt(16, 4, false, Rnd, Sat),
            toml: "interpolated sample: unsigned, integer bits >= voxel.bits",
            check: rules::sample,
        },
        /// Classification table colour entries (each of R, G, B): unsigned
        /// fraction with at most one integer bit.
        ///
        /// Default `ufixed<9,1,RND,SAT>`: 8 fraction bits per channel as in
        /// VolumePro and the 8-bit output image, plus 1 integer bit so that
        /// white (1.0) is exact; without it SAT capped white at 255/256, a full
        /// grey level of error. SAT so that loading a value above 1 clamps
        /// instead of wrapping.
        pub color: Format {
            default: fmt(9, 8, false, Rnd, Sat),
            toml: "classification RGB entries: unsigned, <= 1 integer bit",
            check: rules::fraction,
        },
        /// Classification table opacity entries: unsigned fraction with at most
        /// one integer bit.
        ///
        /// Default `ufixed<12,0,RND,SAT>`: VolumePro's 12-bit alpha. Opacities
        /// below half an LSB (2^-13 per unit length) round to zero: a medium of
        /// opacity 1e-4 per voxel vanishes (1024 such slices would reach 0.097);
        /// widen `alpha` for faint material.
        pub alpha: Format {
            default: fmt(12, 12, false, Rnd, Sat),
            toml: "classification opacity entries: unsigned, <= 1 integer bit",
            check: rules::fraction,
        },
        /// Number of classification table entries: a power of two, indexed by
        /// the top `log2(table_entries)` bits of the sample, so at most
        /// `2^sample.bits`.
        ///
        /// Default 4096: one entry per 12-bit voxel value.
        pub table_entries: u32 {
            default: 4096,
            range: 2..=MAX_TABLE_ENTRIES,
            toml: "classification table size: power of two, <= 2^sample.bits",
            check: rules::table_entries,
        },
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
        pub path: Format {
            default: fmt(16, 13, false, Rnd, Sat),
            toml: "ray path length per slice step, ds in [1, 4): unsigned, >= 2 integer bits, frac >= 1",
            check: rules::path,
        },
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
        pub log_transmittance: Format {
            default: fmt(20, 15, false, Rnd, Sat),
            toml: "-log2(1 - alpha) and -log2 T per step: unsigned, >= 4 integer bits and 2^int > alpha.frac",
            check: rules::log_transmittance,
        },
        /// Index bits of the exp table over `frac(p)` (step 3 of
        /// [opacity correction](PipelineConfig#opacity-correction)); the table
        /// has `2^exp_table_bits` entries. `1..=16`, and at most
        /// `log_transmittance.frac`.
        ///
        /// Default 10: 1024 entries; linear interpolation of `2^-f` over a
        /// 2^-10 step is accurate to below 3e-8, far under an `opacity_corr`
        /// LSB.
        pub exp_table_bits: u8 {
            default: 10,
            range: 1..=MAX_EXP_TABLE_BITS,
            toml: "exp table index bits over frac(p): 1..=16, <= log_transmittance.frac",
            check: rules::exp_table_bits,
        },
        /// Opacity-correction result `a' = 1 - (1 - a)^ds`, and also the exp
        /// table entries and transmittance `T` it is computed from (steps 3 and
        /// 4 of [opacity correction](PipelineConfig#opacity-correction)):
        /// unsigned fraction with at most one integer bit.
        ///
        /// Default `ufixed<16,1,RND,SAT>`: 1 integer bit so that transmittance
        /// 1.0 (`frac(p) = 0`) is exact; 15 fraction bits, 3 more than `alpha`,
        /// so the correction does not lose what classification provides.
        pub opacity_corr: Format {
            default: fmt(16, 15, false, Rnd, Sat),
            toml: "exp table, transmittance and corrected opacity: unsigned, <= 1 integer bit",
            check: rules::fraction,
        },
        /// Compositing accumulator of colour: unsigned, with at least as many
        /// fraction bits as `color`.
        ///
        /// Default `ufixed<16,0,RND,SAT>`: 8 guard bits over the colour so that
        /// hundreds of faint contributions add up instead of each rounding to
        /// zero; SAT so that a full ray stays white instead of wrapping black.
        pub accum_color: Format {
            default: fmt(16, 16, false, Rnd, Sat),
            toml: "colour accumulator: unsigned, frac >= color.frac",
            check: rules::accum_color,
        },
        /// Compositing accumulator of opacity: unsigned, with at least as many
        /// fraction bits as `opacity_corr`.
        ///
        /// Default `ufixed<16,0,RND,SAT>`: 4 guard bits over the 12-bit alpha
        /// (1 over the 15 fraction bits of `opacity_corr`) for the same reason
        /// as `accum_color`; SAT so that opacity approaching 1 stays there
        /// (early ray termination tests it).
        pub accum_alpha: Format {
            default: fmt(16, 16, false, Rnd, Sat),
            toml: "opacity accumulator: unsigned, frac >= opacity_corr.frac",
            check: rules::accum_alpha,
        },
        /// Intermediate of the Bartlett (tent-weighted) merge of neighbouring
        /// rays' accumulators at an ER-Perspective region boundary: unsigned,
        /// with at least the fraction and integer bits of both accumulators.
        ///
        /// Default `ufixed<20,4,RND,SAT>`: the accumulator plus 4 integer bits
        /// of headroom, enough for the weighted sum of up to 16 full
        /// accumulators before normalisation.
        pub merge: Format {
            default: fmt(20, 16, false, Rnd, Sat),
            toml: "Bartlett merge intermediate: unsigned, covers both accumulators",
            check: rules::merge,
        },
        /// Number of processing elements in the 1D array, `1..=256`.
        ///
        /// Default 16: a power of two dividing every power-of-two volume
        /// width, so slices split into whole PE beats.
        pub pes: u16 {
            default: 16,
            range: 1..=MAX_PES,
            toml: "number of processing elements, 1..=256",
            check: rules::pes,
        },
        /// Compositing order: `back-to-front` (golden `er`: merge at region
        /// boundaries) or `front-to-back` (golden `er-ftb`: split at region
        /// boundaries, fold at the end, early ray termination).
        ///
        /// Default `back-to-front`, the model's original mode, bit for bit.
        pub order: Order {
            default: Order::BackToFront,
            toml: "compositing order: \"back-to-front\" (merge) or \"front-to-back\" (split, fold, termination)",
        },
        /// Early ray termination threshold of the front-to-back order, as a
        /// fraction of full opacity in `(0, 1]`: a ray whose opacity word
        /// reaches it takes no more samples. 1 disables termination. The
        /// controller quantises it *up* to the `accum_alpha` grid
        /// ([`PipelineConfig::termination_raw`]), so a terminated ray's
        /// opacity is never below the fraction asked for.
        ///
        /// Default 1 (off): termination trades up to `1 - terminate` per pixel
        /// for speed, a choice the user makes. Ignored back to front.
        // No `check`: `validate` checks `terminate` after the table, i.e.
        // after `occupancy_block`, the order the rules have always run in,
        // so a config wrong in both keeps reporting `occupancy_block`.
        pub terminate: f64 {
            default: 1.0,
            toml: "front-to-back early ray termination opacity in (0, 1]; 1 disables it",
        },
        /// Edge in voxels of the blocks of the controller's occupancy memory
        /// (one bit per block: may a sample in it be visible?), a power of two
        /// from 2 to 64.
        ///
        /// Default 16: 4 kbit for a 256^3 volume, one block RAM.
        pub occupancy_block: u16 {
            default: 16,
            range: 2..=64,
            toml: "edge of the occupancy memory's empty-space blocks in voxels: a power of two, 2..=64",
            check: rules::occupancy_block,
        },
        /// Clocks from a sample's issue to the write-back of its ray's
        /// accumulators, `0..=256`; 0 derives it from the widths (the depth
        /// `ercube cost` schedules, [`crate::cost::datapath_latency`]).
        /// It sets the drain before a merge, split, fold or the readout and
        /// the stall when a ray's next sample would issue before its last
        /// was written back; 1 is a datapath that composites in the cycle
        /// it reads.
        ///
        /// Default 0 (derived: 35 clocks back to front and 36 front to
        /// back at the default widths, the depth of the schedule `ercube
        /// rtl` emits).
        pub datapath_latency: u16 {
            default: 0,
            range: 0..=256,
            toml: "clocks from a sample's issue to its accumulators' write-back, 0..=256; 0 = the depth of the emitted schedule",
            check: rules::datapath_latency,
        },
        /// The FPGA family whose delay model [`target_mhz`] pipelines the
        /// sample datapath for: `ecp5` or `ice40` (the families with a
        /// fitted model, [`crate::cost::fmax::model`]).
        ///
        /// Default `ecp5`. Unused while `target_mhz` is 0.
        ///
        /// [`target_mhz`]: PipelineConfig::target_mhz
        pub target_family: crate::cost::Target {
            default: crate::cost::Target::Ecp5,
            toml: "FPGA family target_mhz pipelines for: \"ecp5\" or \"ice40\"",
        },
        /// The clock in MHz the sample datapath is pipelined for on
        /// [`target_family`], `0..=1000`: pipeline registers go where the
        /// delay model of [`crate::cost::fmax`] says a stage would exceed the
        /// period ([`crate::cost::fmax::clock_schedule`]), fewer stages for
        /// a slow clock, more where a fast one needs them. 0 keeps one
        /// multiplier or one carry chain a stage. A derived
        /// [`datapath_latency`], the model's cycles and `ercube rtl`'s
        /// module follow the schedule; a clock no schedule reaches is
        /// refused.
        ///
        /// Default 0 (one operator a stage).
        ///
        /// [`target_family`]: PipelineConfig::target_family
        /// [`datapath_latency`]: PipelineConfig::datapath_latency
        pub target_mhz: u16 {
            default: 0,
            range: 0..=1000,
            toml: "MHz the sample datapath is pipelined for on target_family, 0..=1000; 0 = one multiplier or carry chain a stage",
            check: rules::target_mhz,
        },
        /// Voxel gradient component (shading): a central difference of two
        /// voxel words times the axis's [`grad_scale`], then interpolated
        /// like the scalar; in voxel codes per `2 s_min` (`s_min` the
        /// smallest voxel spacing). Signed; a shaded frame needs at least
        /// `voxel.bits + 1` integer bits including the sign (a full-range
        /// difference; checked when a frame is shaded).
        ///
        /// Default `fixed<20,14,RND,SAT>`: 14 integer bits hold a 12-bit
        /// difference with its sign and one bit to spare; 6 fraction bits
        /// keep the interpolated gradient to 1/64 of a voxel code, under
        /// 1e-4 of the direction of any gradient the normal fade lets
        /// through. SAT so that a saturated difference keeps its direction's
        /// sign.
        ///
        /// [`grad_scale`]: PipelineConfig::grad_scale
        pub gradient: Format {
            default: fmt(20, 6, true, Rnd, Sat),
            toml: "voxel gradient component (shading): signed; shading needs integer bits >= voxel.bits + 1",
            check: rules::gradient,
        },
        /// Per-axis gradient scale `s_min / s_axis` in `(0, 1]` (1 on every
        /// axis of an isotropic volume), broadcast per frame: unsigned, with
        /// one integer bit so that 1 is exact.
        ///
        /// Default `ufixed<16,1,RND,SAT>`: 15 fraction bits set an
        /// anisotropic axis's weight to 3e-5.
        pub grad_scale: Format {
            default: fmt(16, 15, false, Rnd, Sat),
            toml: "per-axis gradient scale s_min / s_axis in (0, 1]: unsigned, >= 1 integer bit",
            check: rules::grad_scale,
        },
        /// Gradient magnitude `|g|`, an exact integer square root truncated
        /// into this format (as [`path`]): unsigned, with at least
        /// `gradient.int_bits` integer bits (`sqrt 3` times the largest
        /// component fits one bit more than its magnitude).
        ///
        /// Default `ufixed<20,14,TRN,SAT>`.
        ///
        /// [`path`]: PipelineConfig::path
        pub grad_norm: Format {
            default: fmt(20, 6, false, Trn, Sat),
            toml: "gradient magnitude: unsigned, integer bits >= gradient.int_bits",
            check: rules::grad_norm,
        },
        /// Light and half vector components in view space, unit vectors
        /// broadcast per frame: signed, at least 2 integer bits including the
        /// sign (so that +-1 is exact).
        ///
        /// Default `fixed<16,2,RND,SAT>`: 14 fraction bits, a direction to
        /// 6e-5.
        pub light: Format {
            default: fmt(16, 14, true, Rnd, Sat),
            toml: "light and half vectors: signed, >= 2 integer bits",
            check: rules::light,
        },
        /// `|n . L|` and `|n . H|`, the quotient `|g . L| / |g|` of the
        /// shading unit's divider (truncated: a restoring divider's
        /// quotient), and the normal fade `min(1, |g| / F)`: in `[0, 1]`,
        /// unsigned with at most one integer bit.
        ///
        /// Default `ufixed<13,1,TRN,SAT>`: 12 fraction bits, as `weight`.
        pub normal_dot: Format {
            default: fmt(13, 12, false, Trn, Sat),
            toml: "normal dot products |n.L|, |n.H| and the normal fade: unsigned, <= 1 integer bit",
            check: rules::fraction,
        },
        /// Entries of the specular power table `x^shininess` and the
        /// interpolated power: in `[0, 1]`, unsigned with at most one
        /// integer bit.
        ///
        /// Default `ufixed<13,1,RND,SAT>`.
        pub specular: Format {
            default: fmt(13, 12, false, Rnd, Sat),
            toml: "specular power table entries x^shininess: unsigned, <= 1 integer bit",
            check: rules::fraction,
        },
        /// Index bits of the specular power table over `|n . H|` (the table
        /// has `2^shade_table_bits + 1` entries, linearly interpolated with
        /// the remaining fraction bits), `1..=16`, at most `normal_dot.frac`.
        ///
        /// Default 8: 257 entries; the interpolation error of `x^10` over a
        /// 1/256 step is below 8e-5.
        pub shade_table_bits: u8 {
            default: 8,
            range: 1..=MAX_EXP_TABLE_BITS,
            toml: "specular power table index bits over |n.H|: 1..=16, <= normal_dot.frac",
            check: rules::shade_table_bits,
        },
        /// Material coefficients `ka`, `kd`, `ks`, broadcast per frame:
        /// unsigned.
        ///
        /// Default `ufixed<16,4,RND,SAT>`: up to 15.99 (the golden model
        /// accepts up to 10), 12 fraction bits.
        pub material: Format {
            default: fmt(16, 12, false, Rnd, Sat),
            toml: "material coefficients ka, kd, ks: unsigned, frac >= 1",
            check: rules::unsigned_frac,
        },
        /// Reciprocals `1 / F` of the normal fade and `1 / G` of the
        /// gradient-opacity modulation, in per voxel code of [`gradient`],
        /// broadcast per frame (the PE multiplies, it does not divide):
        /// unsigned.
        ///
        /// Default `ufixed<24,4,RND,SAT>`: 20 fraction bits; the default fade
        /// `F = 1` of 8-bit data is 32 codes at 12-bit voxels, a reciprocal
        /// of 1/32 held to 2^-21 relative.
        ///
        /// [`gradient`]: PipelineConfig::gradient
        pub grad_recip: Format {
            default: fmt(24, 20, false, Rnd, Sat),
            toml: "reciprocals of the normal fade and gradient-opacity scales: unsigned, frac >= 1",
            check: rules::unsigned_frac,
        },
        /// The volume of interest's per-axis scale `s_axis / R` (the
        /// voxel spacing over the ramp width `R`, or over 1 with no ramp),
        /// broadcast per frame: it turns a position difference in voxels
        /// into a distance in ramp units. Unsigned.
        ///
        /// Default `ufixed<28,8,RND,SAT>`: up to 255 (a ramp down to 1/255
        /// of the spacing), 20 fraction bits, so a 2048-voxel difference is
        /// scaled to 2e-3 ramp units.
        pub voi_axis: Format {
            default: fmt(28, 20, false, Rnd, Sat),
            toml: "volume of interest: per-axis scale spacing / ramp, unsigned, frac >= 1",
            check: rules::unsigned_frac,
        },
        /// The volume of interest's distances in ramp units (world units
        /// with no ramp): per-axis distances, the box's half extents, the
        /// sphere's radius and the signed distance to the boundary. Signed,
        /// at least 2 integer bits including the sign (the weight's `1/2`
        /// offset).
        ///
        /// Default `fixed<32,16,RND,SAT>`: +-32767 ramp units, 16 fraction
        /// bits. SAT keeps a far sample far (its weight is 0 or 1 either
        /// way).
        pub voi_dist: Format {
            default: fmt(32, 16, true, Rnd, Sat),
            toml: "volume of interest: distances in ramp units, signed, >= 2 integer bits",
            check: rules::voi_dist,
        },
        /// The volume of interest's weight `w = clamp(1/2 - d, 0, 1)` (and
        /// `1 - w` outside): in `[0, 1]`, unsigned, at most one integer bit.
        ///
        /// Default `ufixed<13,1,RND,SAT>`: 12 fraction bits, as `alpha`.
        pub voi_weight: Format {
            default: fmt(13, 12, false, Rnd, Sat),
            toml: "volume of interest: weight in [0, 1], unsigned, <= 1 integer bit",
            check: rules::voi_weight,
        },
        /// The volume of interest's gain `S - 1` (`S` the opacity scale in
        /// `[0, 100]`), broadcast per frame: signed.
        ///
        /// Default `fixed<20,8,RND,SAT>`: -1 to 99 with 12 fraction bits.
        pub voi_gain: Format {
            default: fmt(20, 12, true, Rnd, Sat),
            toml: "volume of interest: gain scale - 1 in [-1, 99], signed",
            check: rules::voi_gain,
        },
        /// The volume of interest's opacity factor `1 + (S - 1) w` in
        /// `[0, 100]`, which multiplies the classified opacity (the product
        /// is assigned into `alpha`, saturating at its top): unsigned,
        /// with an integer bit (a factor of 1 must be exact).
        ///
        /// Default `ufixed<20,8,RND,SAT>`: up to 255, 12 fraction bits.
        pub voi_factor: Format {
            default: fmt(20, 12, false, Rnd, Sat),
            toml: "volume of interest: opacity factor in [0, 100], unsigned, >= 1 integer bit",
            check: rules::voi_factor,
        },
        /// Pre-integrated classification ([`crate::preint`]): the table's
        /// mean extinction per unit length of a linear segment, in `log2`
        /// units (`tau / ln 2`, so that `p = tau len` feeds the `2^-p`
        /// stage of [opacity correction](PipelineConfig#opacity-correction)
        /// directly), its entries and their bilinear interpolation:
        /// unsigned, with fraction bits. Unused unless a frame is
        /// pre-integrated.
        ///
        /// Default `ufixed<22,7,RND,SAT>`: 7 integer bits reach 128, above
        /// golden's opaque entry (`80 / ln 2 = 115.4`); 15 fraction bits, as
        /// `log_transmittance`, resolve the faintest opacity `alpha` holds.
        pub preint_tau: Format {
            default: fmt(22, 15, false, Rnd, Sat),
            toml: "pre-integration: mean extinction per unit length in log2 units, unsigned with fraction bits",
            check: rules::unsigned_frac,
        },
        /// Pre-integrated classification: the table's extinction-weighted
        /// mean colour per channel (`c tau / ln 2`, at most `preint_tau`'s
        /// value), its entries and their interpolation; the divider turns it
        /// into the segment's colour (`color`): unsigned, with fraction bits.
        ///
        /// Default `ufixed<22,7,RND,SAT>`, as `preint_tau`.
        pub preint_color: Format {
            default: fmt(22, 15, false, Rnd, Sat),
            toml: "pre-integration: extinction-weighted colour in log2 units, unsigned with fraction bits",
            check: rules::unsigned_frac,
        },
        /// Which PE owns which voxel columns while the array samples:
        /// `blocks` (`W = ceil(nx / P)` columns each), `interleave` (Cube-4:
        /// column `x` on PE `x mod P`) or `cyclic` (blocks of
        /// [`cyclic_width`] columns dealt round-robin). See [`Mapping`].
        ///
        /// Default `blocks`, the model's original mapping, bit and cycle
        /// for bit and cycle.
        ///
        /// [`cyclic_width`]: PipelineConfig::cyclic_width
        pub mapping: Mapping {
            default: Mapping::Blocks,
            toml: "column ownership while sampling: \"blocks\", \"interleave\" (x mod P) or \"cyclic\" (cyclic_width-column blocks round-robin)",
        },
        /// Columns per block of the `cyclic` mapping, `1..=256`.
        ///
        /// Default 4: a quarter of the default occupancy block, so the
        /// occupied runs of a row spread over the PEs, while rays cross a
        /// block edge a quarter as often as under the interleave.
        pub cyclic_width: u16 {
            default: 4,
            range: 1..=256,
            toml: "columns per round-robin block of the cyclic mapping, 1..=256",
            check: rules::cyclic_width,
        },
        /// When rays whose owner changes between slices cross the links:
        /// `between-slices` (a stage of its own) or `overlapped` (while the
        /// slice samples; rows wait only for their own rays). See
        /// [`Migration`].
        ///
        /// Default `between-slices`, the model's original schedule.
        pub migration: Migration {
            default: Migration::BetweenSlices,
            toml: "ray migration: \"between-slices\" (its own stage) or \"overlapped\" (while sampling)",
        },
        /// Whether a migrating column crosses the links without its
        /// transparent rows (all-zero accumulators; front to back also
        /// nothing inherited and not terminated): the receiver's slots read
        /// zero until written, so they need no move. The column's last row
        /// always travels, closing it. Costs a valid bit per buffer slot.
        ///
        /// Default false: every row travels, the original protocol.
        pub link_skip_empty: bool {
            default: false,
            toml: "migrating columns leave their transparent rows behind (true) or send every row (false)",
        },
        /// Rays each link carries per cycle and direction, `1..=4`, while
        /// the overlapped migration runs (`migration = "overlapped"`): lane
        /// `i` of a port is its own register, so a ray still hops one link
        /// a cycle, but up to `link_lanes` rays leave a PE each way in a
        /// cycle. Costs the ray ports' registers and the compositing
        /// buffer's write ports per lane. With `ray_buffer = "external"`
        /// rays do not travel and the lanes change nothing.
        ///
        /// Default 1: one ray per link and direction, the original link.
        pub link_lanes: u16 {
            default: 1,
            range: 1..=4,
            toml: "rays per link, direction and cycle during the overlapped migration, 1..=4",
            check: rules::link_lanes,
        },
        /// Rows each link FIFO holds, per side, `1..=4096`: the rays a PE
        /// has read out of its compositing buffer to send to one
        /// neighbour. A leaving column stays in the compositing buffer
        /// until its rows enter the FIFO; the PE feeds the FIFO one row a
        /// cycle (per lane) and stops while it is full, so the FIFO never
        /// holds more than this and the link never waits for it. The cost
        /// model charges exactly this depth (`link_fifo`).
        ///
        /// Default 2: the row landing from the buffer's registered read
        /// beside the row leaving, so a row can leave every cycle.
        pub link_fifo_depth: u16 {
            default: 2,
            range: 1..=4096,
            toml: "rows per link FIFO and side (fed from the compositing buffer), 1..=4096",
            check: rules::link_fifo_depth,
        },
        /// Whether the back-to-front merge, the front-to-back split and
        /// fold, and the readout spend cycles only on rays that can be
        /// non-zero: a pass
        /// skips parent rows no PE holds anything in and child rows whose
        /// parents are all transparent, and within a row each PE works
        /// only its children with a non-zero parent (the slot lasts as long
        /// as the busiest PE's list); the readout streams only non-zero
        /// rays (the host's baseplane starts cleared). Costs a valid bitmap
        /// beside each compositing bank and the line buffer (see
        /// `pipeline::stages::passes`). The fold skips within slots only:
        /// every back row keeps a slot.
        ///
        /// Default false: every ray is merged and read out, the original
        /// schedule.
        pub pass_skip_empty: bool {
            default: false,
            toml: "the merge, split, fold and readout skip transparent rays (true) or visit every ray (false)",
        },
        /// Where the rays' compositing buffer lives: `on-chip` (block RAM in
        /// each PE) or `external` (DDR/HBM, streamed a row at a time). See
        /// [`RayBuffer`].
        ///
        /// Default `on-chip`, the model's original placement.
        pub ray_buffer: RayBuffer {
            default: RayBuffer::OnChip,
            toml: "compositing buffer placement: \"on-chip\" or \"external\" (streamed per row)",
        },
        /// Bytes per cycle the external ray buffer moves (reads and writes
        /// share it), `1..=4096`; used when `ray_buffer = "external"`.
        ///
        /// Default 64: one DDR4-3200 channel (25.6 GB/s) at a 400 MHz
        /// clock, or 128 bytes per cycle at 200 MHz.
        pub ray_buffer_bandwidth: u16 {
            default: 64,
            range: 1..=4096,
            toml: "external ray buffer bytes per cycle (reads and writes together), 1..=4096",
            check: rules::ray_buffer_bandwidth,
        },
        /// Row buffers per PE of the external ray buffer, `2..=64`: the
        /// controller reads a row's rays up to `ray_buffer_rows - 1` rows
        /// ahead of the row sampling, which hides the latency when the
        /// rows between cover it; used when `ray_buffer = "external"`.
        ///
        /// Default 8: seven rows of prefetch cover the default latency of
        /// 100 cycles at rows of 16 or more cycles.
        pub ray_buffer_rows: u16 {
            default: 8,
            range: 2..=64,
            toml: "external ray buffer: on-chip row buffers per PE (prefetch depth + 1), 2..=64",
            check: rules::ray_buffer_rows,
        },
        /// Cycles from an external ray buffer request to its first word,
        /// `0..=4096`; used when `ray_buffer = "external"`.
        ///
        /// Default 100: about 250 ns of DDR4 access latency at 400 MHz.
        pub ray_buffer_latency: u16 {
            default: 100,
            range: 0..=4096,
            toml: "external ray buffer latency in cycles, 0..=4096",
            check: rules::ray_buffer_latency,
        },
        /// Bytes per cycle of the host's link into the PE memories,
        /// `1..=4096`: a frame that finds the volume not yet in PE memory
        /// spends [`crate::VoxelLoad::cycles`] loading it first, each PE's
        /// memory taking at most one voxel word a cycle.
        ///
        /// Default 32: PCIe 3.0 x8 (7.9 GB/s) at a 250 MHz clock.
        pub host_bandwidth: u16 {
            default: 32,
            range: 1..=4096,
            toml: "host-to-PE-memory voxel load bytes per cycle, 1..=4096",
            check: rules::host_bandwidth,
        },
    }
}

#[cfg(test)]
mod tests;
