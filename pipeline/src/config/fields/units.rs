//! The units beside the sample: the gradient and shading unit's formats,
//! the volume of interest's and pre-integration's.
//!
//! The entries expand in `fields.rs` (their paths, `rules`, `fmt`,
//! `Format`, ..., resolve there), gathered by `config_fields!`'s
//! `@gather` arms (`schema.rs`).

/// Appends these entries to the field table and hands it back to
/// `config_fields!` with the groups still to come.
macro_rules! unit_fields {
    (@gather [$($entries:tt)*] $($rest:tt)*) => {
        $crate::config::schema::config_fields! { @gather [$($entries)*
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
        ] $($rest)* }
    };
}

pub(super) use unit_fields;
