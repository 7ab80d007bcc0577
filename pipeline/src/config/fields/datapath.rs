//! The sample datapath's register formats and tables: the voxel word, the
//! ray's position, step and weights, the interpolated sample, the
//! classification's colour, opacity and table, the path length, the
//! opacity correction, the accumulators and the merge.
//!
//! The entries expand in `fields.rs` (their paths, `rules`, `fmt`,
//! `Format`, ..., resolve there), gathered by `config_fields!`'s
//! `@gather` arms (`schema.rs`).

/// Appends these entries to the field table and hands it back to
/// `config_fields!` with the groups still to come.
macro_rules! datapath_fields {
    (@gather [$($entries:tt)*] $($rest:tt)*) => {
        $crate::config::schema::config_fields! { @gather [$($entries)*
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
        ] $($rest)* }
    };
}

pub(super) use datapath_fields;
