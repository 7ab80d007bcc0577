//! The depths and widths of one PE's sample stage
//! ([`super::pe_sample_rtl`]) and where its words live.
//!
//! They are the PE's declaration's
//! ([`crate::pe::Pe::declaration`], through
//! [`super::readout_rtl::ReadoutShape`] for the rays and
//! [`crate::pe::Pe::voxel_state`] for the voxels): the slice buffer is two
//! row banks (even and odd voxel rows) of two slices each, a bank
//! `stored * ceil(ny / 2)` words a slice, read at two columns a clock
//! while the host writes (a write port and two read ports); the edge column, likewise banked, holds the
//! block's first column; the compositing buffer is two banks interleaved
//! by the ray address's low bit, ray `(slot, row)` at `row * slots +
//! slot`, where a held column's slot is its `mx` modulo the slots (a held
//! block is consecutive and at most `slots` wide, so slots never collide
//! and a column keeps its slot while columns arrive and leave).

use super::readout_rtl::ReadoutShape;
use crate::config::PipelineConfig;
use crate::cost::inventory::{addr_bits, Geometry};
use crate::pe::Pe;

/// The depths and widths of one PE's sample stage.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
pub struct PeSampleShape {
    /// The rays' memories (compositing buffer, column map), as the
    /// readout declares them.
    pub rays: ReadoutShape,
    /// Bits of a voxel word.
    pub voxel_bits: u32,
    /// Columns a slice buffer row holds (`stored`).
    pub stored: u64,
    /// Words of a slice in one row bank (`ceil(ny / 2)` rows).
    pub half_rows: u64,
    /// The volume's rows (`ny`).
    pub ny: u64,
    /// The volume's columns (`nx`).
    pub nx: u64,
    /// Bits of the ray index (`RAY_INDEX_BITS`).
    pub index_bits: u32,
    /// Front to back with early ray termination: the threshold, a raw
    /// `accum_alpha` word ([`PipelineConfig::termination_raw`]) the
    /// termination bits compare the written-back opacity with; `None`
    /// otherwise (no termination bits).
    pub termination: Option<i64>,
    /// Under a round-robin mapping (the interleave, the cyclic mapping):
    /// the PE holds several blocks and their aprons, its taps all in its
    /// own memory through a column decoder, and its rays in the slots its
    /// column map names ([`crate::cosim::pe_sample::slots`]); under
    /// column blocks a consecutive block, the column right of it from the
    /// neighbour, ray `mx` in slot `mx` modulo the slots.
    pub round_robin: bool,
}

impl PeSampleShape {
    /// The shape of `cfg`'s PE for a frame of `view`, refused in one line
    /// where the frame cannot be planned.
    pub fn for_view(
        cfg: &PipelineConfig,
        view: &golden::geometry::View,
    ) -> Result<PeSampleShape, String> {
        crate::host::plan(cfg, view).map_err(|e| e.to_string())?;
        let geo = Geometry::for_view(cfg, view).map_err(|e| e.to_string())?;
        PeSampleShape::new(cfg, &geo)
    }

    /// The shape of `cfg`'s PE at the depths it declares for `geo` (a
    /// frame's, or [`Geometry::new`]'s for a volume), refused in one
    /// line where its declaration is not the one the stage reads.
    pub fn new(cfg: &PipelineConfig, geo: &Geometry) -> Result<PeSampleShape, String> {
        let rays = ReadoutShape::new(cfg, geo)?;
        let decls = Pe::voxel_state(cfg, geo);
        let sb = decls
            .iter()
            .find(|d| d.name == "slice_buffer")
            .ok_or("the PE declares no slice buffer")?;
        // The row plan the control reads is the declared one, a bit a
        // column map slot for each ray row.
        let plan = Pe::ray_state(cfg, geo)
            .into_iter()
            .find(|d| d.name == "row_plan")
            .ok_or("the PE declares no row plan")?;
        if plan.copies != 1
            || plan.depth != rays.max_rows
            || u64::from(plan.width) != rays.map_depth
        {
            return Err(format!(
                "the row plan is declared as {} copies of {} words of {} bits; the sample stage reads one word of {} bits for each of {} rows",
                plan.copies, plan.depth, plan.width, rays.map_depth, rays.max_rows
            ));
        }
        let ny = geo.dims[1] as u64;
        let half_rows = ny.div_ceil(2);
        if sb.copies != 2 || sb.depth % (2 * half_rows) != 0 {
            return Err(format!(
                "the slice buffer is declared as {} copies of {} words; the sample stage reads 2 row banks of 2 slices",
                sb.copies, sb.depth
            ));
        }
        Ok(PeSampleShape {
            rays,
            voxel_bits: sb.width,
            stored: sb.depth / (2 * half_rows),
            half_rows,
            ny,
            nx: geo.dims[0] as u64,
            index_bits: crate::cost::shapes::RAY_INDEX_BITS,
            termination: cfg.termination_raw(),
            round_robin: crate::mapping::ColumnMap::of(cfg, geo.dims[0]).round_robin(),
        })
    }

    /// The shape with `n` column slots where the declaration has fewer
    /// (a frame whose PEs hold more columns than the declared `2 W + 1`):
    /// the column map and the compositing buffer grow to match.
    pub fn with_slots(mut self, n: u64) -> PeSampleShape {
        if n > self.rays.map_depth {
            self.rays.map_depth = n;
            self.rays.bank_depth = (n * self.rays.max_rows).div_ceil(2);
        }
        self
    }

    /// The shape with a slice buffer `n` columns wide where the
    /// declaration has fewer: under a round-robin mapping the model's PE
    /// holds each block's apron of one column left and two right
    /// ([`crate::mapping::ColumnMap::held`]), where the declaration
    /// charges one column a block unshaded
    /// ([`crate::cost::arch::apron`]).
    pub fn with_stored(mut self, n: u64) -> PeSampleShape {
        self.stored = self.stored.max(n);
        self
    }

    /// Slots of the column map (`2 W + 1`).
    pub fn slots(&self) -> u64 {
        self.rays.map_depth
    }

    /// Added to a ray index before the slot's modulo: a multiple of the
    /// slots that makes every index of `index_bits` non-negative.
    pub fn slot_offset(&self) -> u64 {
        let s = self.slots();
        (1u64 << (self.index_bits - 1)).div_ceil(s) * s
    }

    /// The slot of ray index `mx`.
    pub fn slot(&self, mx: i64) -> u64 {
        (mx + self.slot_offset() as i64) as u64 % self.slots()
    }

    /// The buffer address of ray `(mx, row)`.
    pub fn ray_addr(&self, mx: i64, row: usize) -> u64 {
        row as u64 * self.slots() + self.slot(mx)
    }

    /// Words of one row bank of the slice buffer (two slices).
    pub fn bank_words(&self) -> u64 {
        2 * self.stored * self.half_rows
    }

    /// Memory bits one PE's module declares: the slice buffer, the edge
    /// column, the compositing buffer and the row plan (a bit a ray: a
    /// word of `slots` bits a row), under a round-robin mapping the
    /// column map and the column decoder (the datapath's tables are its
    /// own).
    pub fn memory_bits(&self) -> u64 {
        let v = u64::from(self.voxel_bits);
        2 * self.bank_words() * v
            + 2 * 2 * self.half_rows * v
            + 2 * self.rays.bank_depth * u64::from(self.rays.buffer_width)
            + self.plan_bits()
            + self.termination_bits()
            + super::pe_columns_rtl::memory_bits(self)
    }

    /// Bits of the termination bits front to back with termination: like
    /// the row plan, one word of `slots` bits a ray row, a bit a ray (the
    /// flag the declaration charges beside each ray's inherited state);
    /// none otherwise.
    pub fn termination_bits(&self) -> u64 {
        if self.termination.is_some() {
            self.plan_bits()
        } else {
            0
        }
    }

    /// Bits of the row plan: one word of `slots` bits for each of the
    /// region's ray rows ([`super::pe_sample_rtl`]); the PE's declared
    /// `row_plan` ([`Pe::ray_state`]), which [`PeSampleShape::new`]
    /// checks, unless [`PeSampleShape::with_slots`] widened the slots.
    pub fn plan_bits(&self) -> u64 {
        self.rays.max_rows * self.slots()
    }

    /// Bits of a voxel row index.
    pub fn row_bits(&self) -> u32 {
        addr_bits(self.ny)
    }

    /// Bits of a voxel column (`0 ..= nx`, signed room for the clamp).
    pub fn col_bits(&self) -> u32 {
        addr_bits(self.nx + 1) + 1
    }
}
