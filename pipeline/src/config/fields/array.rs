//! The array and its frame: the number of PEs, the compositing order,
//! early termination, the skipping block, the datapath's latency and the
//! clock it is pipelined for.
//!
//! The entries expand in `fields.rs` (their paths, `rules`, `fmt`,
//! `Format`, ..., resolve there), gathered by `config_fields!`'s
//! `@gather` arms (`schema.rs`).

/// Appends these entries to the field table and hands it back to
/// `config_fields!` with the groups still to come.
macro_rules! array_fields {
    (@gather [$($entries:tt)*] $($rest:tt)*) => {
        $crate::config::schema::config_fields! { @gather [$($entries)*
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
        ] $($rest)* }
    };
}

pub(super) use array_fields;
