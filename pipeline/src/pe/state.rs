//! The PE's state declared as hardware ([`crate::hw::state`]): its voxel
//! memory, its compositing buffer (or, with the rays in external memory,
//! its row buffers), the column map, the row plan, the passes' line buffer, the link
//! FIFOs and, front to back, the inherited states and the kept finals,
//! each with the depth and width it has for the geometry's view
//! ([`Geometry`]: the ray memories at the depths [`Geometry::rays`] gives,
//! which for PE `k` of an array, [`Geometry::pe`], are what
//! [`crate::capacity`] finds PE `k` itself holds in that view's frames:
//! the end PEs' rays beyond the volume's sides in the end PEs only). With
//! the rays in external memory, the PE's share of it (its rays and kept
//! finals) is declared too, as off-chip memories. The cost model's memory
//! inventory charges exactly these entries, PE by PE, the on-chip ones as
//! block RAM, FIFOs and registers and the off-chip ones as external bits
//! (`crate::cost::inventory`, `crate::cost::design::array`), so a depth
//! changes in one place.

use super::Pe;
use crate::config::{Order, PipelineConfig, RayBuffer};
use crate::cost::arch;
use crate::cost::inventory::{addr_bits, Geometry};
use crate::cost::memory::MemPorts;
use crate::cost::shapes::{accum_word, RAY_INDEX_BITS};
use crate::hw::state::{StateDecl, StateKind};
use crate::stages::passes::LINE_ROWS;

fn bits(f: crate::fixed::Format) -> u32 {
    u32::from(f.bits())
}

fn decl(
    name: &'static str,
    what: impl Into<String>,
    kind: StateKind,
    (copies, depth, width): (u32, u64, u32),
) -> StateDecl {
    StateDecl {
        name,
        what: what.into(),
        kind,
        copies,
        depth,
        width,
    }
}

const SDP: StateKind = StateKind::Memory(MemPorts::Sdp);
const DUAL_READ: StateKind = StateKind::Memory(MemPorts::DualRead);
const WRITE_TWO_READS: StateKind = StateKind::Memory(MemPorts::WriteTwoReads);
const REG: StateKind = StateKind::Register;
const OFF_CHIP: StateKind = StateKind::OffChip;

impl Pe {
    /// Every state element of a PE of `cfg` for the view of `geo` (PE
    /// `k`'s own: `geo.pe(k)`):
    /// [`Pe::voxel_state`], [`Pe::ray_state`], then
    /// [`Pe::register_state`].
    pub fn declaration(cfg: &PipelineConfig, geo: &Geometry) -> Vec<StateDecl> {
        let mut all = Pe::voxel_state(cfg, geo);
        all.extend(Pe::ray_state(cfg, geo));
        all.extend(Pe::register_state(cfg, geo));
        all
    }

    /// The PE's registers: what it holds across cycles outside its
    /// memories and FIFOs, each a [`StateKind::Register`] of its width
    /// (copies per side or lane): the ray ports and merge edge-ray ports
    /// to each neighbour, the edge voxel port and the edge register it is
    /// driven from (column blocks), the host port of the readout, the
    /// copy of the controller's broadcast, the current slice's active
    /// columns, the row plan's word being gathered, the readout's state
    /// and read register, and with `pass_skip_empty` the pass's latched
    /// edge rays. The counters live
    /// with their incrementers in the control logic and the datapath's
    /// pipeline registers with its schedule
    /// ([`crate::cost::inventory`]).
    pub fn register_state(cfg: &PipelineConfig, geo: &Geometry) -> Vec<StateDecl> {
        let acc = accum_word(cfg);
        let prev = crate::cost::preint::ray_bits(cfg, geo);
        let v = bits(cfg.voxel);
        let row_bits = addr_bits(arch::ray_rows(geo) + 1);
        let slot_bits = addr_bits(arch::rays_per_row(cfg, geo) + 1);
        let (pn, s) = (bits(cfg.position), bits(cfg.step));
        let reg = |name, what: &str, copies, width| decl(name, what, REG, (copies, 1, width));
        let mut out = vec![
            reg(
                "ray_port",
                if geo.units.preint {
                    "ray ports (left, right): accumulators, sample, m, row, valid"
                } else {
                    "ray ports (left, right): accumulators, m, row, valid"
                },
                2,
                acc + prev + RAY_INDEX_BITS + row_bits + 1,
            ),
            reg(
                "merge_edge_port",
                "merge edge-ray ports (left, right)",
                2,
                acc,
            ),
            reg(
                "broadcast_copy",
                "broadcast copy: A, t, b, k, sy, sz^2, rows",
                1,
                3 * pn + 2 * s + 2 * pn + 2 * row_bits,
            ),
            reg(
                "host_port",
                "host port: accumulators, m, row, valid",
                1,
                acc + RAY_INDEX_BITS + row_bits + 1,
            ),
            reg(
                "active",
                "active columns: first slot, count",
                1,
                2 * slot_bits,
            ),
            // The row plan's word gathered from the row's runs, a bit a
            // column map slot (`crate::hw::pe_plan_rtl`).
            reg(
                "plan_word",
                "row plan: the row's word gathered from its runs",
                1,
                arch::rays_per_row(cfg, geo) as u32,
            ),
            reg(
                "readout",
                "readout: start, valid row, row, columns read, read register",
                1,
                1 + 2 * (row_bits + 1) + slot_bits + (acc + RAY_INDEX_BITS + row_bits + 1),
            ),
        ];
        if geo.units.preint {
            // The pass's broadcast the pre-integration unit reads: the
            // table scale `K`, the three rectangles' bounds, the half-step
            // flag.
            out.push(reg(
                "preint_broadcast",
                "pre-integration broadcast copy: K, comp/keep/lead rays, half",
                1,
                s + 12 * RAY_INDEX_BITS + 1,
            ));
        }
        if arch::round_robin_width(cfg).is_none() {
            // Column blocks read the right neighbour's first column while
            // sampling (round-robin blocks carry their aprons instead).
            out.insert(
                1,
                reg("edge_voxel_port", "edge voxel port (two rows)", 1, 2 * v),
            );
            // The words driven next: the first column's two rows (and
            // shading, the last column's and the first two columns'
            // gradient words are the shading unit's), tagged with their
            // rows.
            out.push(reg(
                "edge_register",
                "edge register: first column, rows y0, y0 + 1, and their row",
                1,
                2 * v + addr_bits(geo.dims[1] as u64 + 1),
            ));
        }
        if cfg.pass_skip_empty {
            out.push(reg(
                "pass_edges",
                "sparse pass: latched edge rays (left, right) and their m",
                2,
                acc + RAY_INDEX_BITS + 1,
            ));
        }
        out
    }

    /// The voxel memory: the slice buffer of the PE's stored columns in
    /// row banks (two slices; shading, four slices and two column banks
    /// for the gradient's taps) and, under column blocks, the copy of the
    /// neighbour's edge column (shading, the first two and the last).
    /// Round-robin mappings store each block with its apron and read no
    /// neighbour: no edge-column copies.
    pub fn voxel_state(cfg: &PipelineConfig, geo: &Geometry) -> Vec<StateDecl> {
        let ny = geo.dims[1] as u64;
        let v = bits(cfg.voxel);
        let edges = arch::round_robin_width(cfg).is_none();
        let stored = arch::stored_columns(cfg, geo);
        let mut out = Vec::new();
        if geo.units.shading() {
            let quarter = ny.div_ceil(4);
            out.push(decl(
                "slice_buffer",
                "slice buffer (4 slices x 4 row banks x 2 column banks)",
                DUAL_READ,
                (32, stored.div_ceil(2) * quarter, v),
            ));
            if edges {
                out.push(decl(
                    "edge_columns",
                    "edge columns (first two, last; 4 slices x 4 row banks)",
                    SDP,
                    (48, quarter, v),
                ));
            }
        } else {
            // Two row banks (even and odd voxel rows), each holding both
            // slices (the slice is the word address's top part), read at
            // a row's two columns a clock while the host writes the next
            // slice: a write port and two read ports, as the sample stage
            // emits them (`hw::pe_sample_rtl`). On iCE40, whose blocks have
            // one read port, a bank of both slices takes half the blocks
            // four banks would; on ECP5 and xc7 two copies of a bank cost
            // what four dual-read banks of one slice would.
            let half_rows = ny.div_ceil(2);
            out.push(decl(
                "slice_buffer",
                "slice buffer (2 row banks of 2 slices)",
                WRITE_TWO_READS,
                (2, 2 * stored * half_rows, v),
            ));
            if edges {
                out.push(decl(
                    "edge_column",
                    "edge column (2 row banks of 2 slices)",
                    SDP,
                    (2, 2 * half_rows, v),
                ));
            }
        }
        out
    }

    /// The rays' state: the compositing buffer in two column banks of
    /// the view's ray columns times their rows (or, with the rays in
    /// external memory, the row buffers the controller reads ahead into),
    /// the column map (a slot per ray column), the row plan (a bit a slot
    /// for each ray row), the passes' line buffer
    /// ([`LINE_ROWS`] rows of a pass's children on one PE), a link FIFO per side
    /// (`link_fifo_depth` rows) and, front to back, the inherited states
    /// with their termination flags and the final states kept at the
    /// `K - 1` region boundaries for the fold (every split's parents on
    /// the PE, stacked). With the rays in external memory the PE's rays
    /// (`ray_store`, with their inherited states) and its kept finals are
    /// declared [`StateKind::OffChip`], at the depths they would have on
    /// chip. A pre-integrating
    /// ray carries its previous sample beside its accumulators wherever
    /// they go.
    pub fn ray_state(cfg: &PipelineConfig, geo: &Geometry) -> Vec<StateDecl> {
        let acc = accum_word(cfg);
        let prev = crate::cost::preint::ray_bits(cfg, geo);
        let rays = arch::rays_per_pe(cfg, geo);
        let row = arch::rays_per_row(cfg, geo);
        let mut out = Vec::new();
        if cfg.ray_buffer == RayBuffer::External {
            let rows = arch::row_buffers(cfg);
            out.push(decl(
                "row_buffers",
                format!("row buffers ({rows} rows x 2 column banks; rays in DDR)"),
                SDP,
                (2, (rows * row).div_ceil(2), arch::ray_bits(cfg) + prev),
            ));
            // The rays the row buffers read ahead from and write back to:
            // this PE's share of the external memory, every ray it may
            // hold (front to back with its inherited state and flag,
            // `arch::ray_bits`).
            out.push(decl(
                "ray_store",
                "rays in external memory (DDR)",
                OFF_CHIP,
                (1, rays, arch::ray_bits(cfg) + prev),
            ));
        } else {
            out.push(decl(
                "compositing_buffer",
                "compositing buffer (2 column banks)",
                SDP,
                (2, rays.div_ceil(2), acc + prev),
            ));
        }
        out.push(decl(
            "column_map",
            "column map (slot -> ray column)",
            SDP,
            (1, row, RAY_INDEX_BITS + 1),
        ));
        // The row plan: a bit a held column (a column map slot) for each
        // ray row of the slice, written from the controller's runs by the
        // PE's comparators before the row samples and read by the issue
        // control (`crate::hw::pe_sample_rtl`).
        out.push(decl(
            "row_plan",
            "row plan (a bit a held column, a word a ray row)",
            SDP,
            (1, arch::ray_rows(geo), row as u32),
        ));
        out.push(decl(
            "line_buffer",
            format!("merge line buffer ({LINE_ROWS} rows)"),
            SDP,
            (
                LINE_ROWS as u32,
                geo.rays.children.max(1),
                4 * bits(cfg.merge),
            ),
        ));
        // The FIFOs hold `link_fifo_depth` rows: a leaving column waits in
        // the compositing buffer (charged above) and is read into its FIFO
        // a row a cycle ([`crate::stages::migrate::LinkQueue`]), so the
        // model's FIFOs never hold more than this.
        out.push(decl(
            "link_fifo",
            format!("link FIFO ({} rows per side)", cfg.link_fifo_depth),
            StateKind::Fifo,
            (
                2,
                u64::from(cfg.link_fifo_depth),
                acc + prev + RAY_INDEX_BITS + addr_bits(arch::ray_rows(geo) + 1),
            ),
        ));
        if cfg.order == Order::FrontToBack {
            if cfg.ray_buffer == RayBuffer::OnChip {
                // With an external buffer the inherited state and the
                // flag travel with the ray (`ray_store` above).
                out.push(decl(
                    "inherited",
                    "inherited state + termination flag (front to back)",
                    SDP,
                    (2, rays.div_ceil(2), acc + 1),
                ));
            }
            // On chip, or with the rays in DDR beside them: the same
            // depth either way, what this PE keeps at the splits.
            let (what, kind) = match cfg.ray_buffer {
                RayBuffer::OnChip => ("kept final states, K - 1 boundaries (front to back)", SDP),
                RayBuffer::External => (
                    "kept final states, K - 1 boundaries (front to back, in DDR)",
                    OFF_CHIP,
                ),
            };
            out.push(decl("kept_finals", what, kind, (1, geo.rays.kept, acc)));
        }
        out
    }
}
