//! The architecture: who owns which columns, how rays migrate over the
//! links and their FIFOs, the sparse passes, the external ray buffer and
//! the host's load link.
//!
//! The entries expand in `fields.rs` (their paths, `rules`, `fmt`,
//! `Format`, ..., resolve there), gathered by `config_fields!`'s
//! `@gather` arms (`schema.rs`).

/// Appends these entries to the field table and hands it back to
/// `config_fields!` with the groups still to come.
macro_rules! architecture_fields {
    (@gather [$($entries:tt)*] $($rest:tt)*) => {
        $crate::config::schema::config_fields! { @gather [$($entries)*
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
        ] $($rest)* }
    };
}

pub(super) use architecture_fields;
