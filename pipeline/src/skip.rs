//! The controller's skipping, mirroring `golden::skip`: an occupancy
//! memory of one bit per block, built by the host from the volume's
//! min-max blocks and the pipeline's *own* classification table (a block
//! is empty when every table entry a sample in its `[min, max]` can reach
//! has a zero opacity word), and the per-row ray runs the controller
//! broadcasts, computed from that memory by golden's
//! [`golden::skip::SampleMask`] (one source of truth for which samples are
//! taken).
//!
//! Empty-space runs are widened by the pipeline's own position error, so
//! that a ray the controller skips is one whose fixed-point interpolation
//! cell lies in an empty block: skipping never changes a bit.

use bitvec::vec::BitVec;
use golden::geometry::Layout;
use golden::occupancy::{MinMax, Occupancy};
use golden::render::Prepared;
use golden::skip::{MaskSpec, SampleMask, Skips, GOLDEN_MARGIN};

use crate::bound::r;
use crate::config::{Order, PipelineConfig};
use crate::datapath::Datapath;
use crate::fixed::{Fx, QuantStats, Wide};
use crate::preint::PreintUnit;
use golden::tf::Lut;

/// One bit per block of the volume (index space), as the controller holds it.
#[derive(Debug, Clone, PartialEq)]
pub struct OccupancyMemory {
    /// Block edge in voxels.
    pub block: usize,
    /// Blocks per index axis.
    pub counts: [usize; 3],
    /// Occupied bits, x fastest.
    pub bits: BitVec,
}

impl OccupancyMemory {
    /// Classifies the min-max blocks `mm` of a volume of `data_bits`-bit
    /// scalars with the datapath's table.
    pub fn new(dp: &Datapath, mm: &MinMax, data_bits: u32) -> OccupancyMemory {
        let mut st = QuantStats::default();
        let visible = |lo: u16, hi: u16| {
            let (a, b) = (
                table_index(dp, voxel_word(&dp.cfg, lo, data_bits, &mut st), &mut st),
                table_index(dp, voxel_word(&dp.cfg, hi, data_bits, &mut st), &mut st),
            );
            // Entries a..=b are indexed; each interpolates toward the next.
            let last = dp.tables().alpha.len() - 1;
            dp.tables().alpha[a.min(last)..=(b + 1).min(last)]
                .iter()
                .any(|w| w.raw() != 0)
        };
        OccupancyMemory::classify(mm, visible)
    }

    /// One bit per block of `mm`: whether `visible` holds for its
    /// `[min, max]`.
    fn classify(mm: &MinMax, mut visible: impl FnMut(u16, u16) -> bool) -> OccupancyMemory {
        OccupancyMemory {
            block: mm.block,
            counts: mm.counts,
            bits: mm.range.iter().map(|&(lo, hi)| visible(lo, hi)).collect(),
        }
    }

    /// Classifies `mm`'s blocks for a pre-integrated frame: a block is
    /// empty when every step between two of its samples has zero
    /// extinction in the unit's table. A sample in the block's `[min, max]`
    /// interpolates bins `a ..= b + 1` (`a`, `b` the bins of its ends;
    /// [`PreintUnit::bin`] is monotonic), and each table word over two of
    /// them is golden's mean over the classification table's entries
    /// between them (`stride` entries a bin): when every entry there has
    /// zero opacity in golden's table `lut`, each word is exactly zero, and
    /// so is its quantised word. A step whose front and back both lie in
    /// empty blocks passes only through empty blocks (the runs cover its
    /// whole segment), so every scalar between its ends lies in some empty
    /// block's range (the interpolated field is continuous along it): its
    /// extinction is zero and skipping it changes no bit.
    pub fn for_preint(
        dp: &Datapath,
        unit: &PreintUnit,
        (lut, stride): (&Lut, f64),
        mm: &MinMax,
        data_bits: u32,
    ) -> OccupancyMemory {
        let mut st = QuantStats::default();
        let cfg = &dp.cfg;
        let last = lut.rgba.len() - 1;
        let bins = unit.bins();
        let visible = |lo: u16, hi: u16| {
            let mut bin = |v: u16| {
                let w = voxel_word(cfg, v, data_bits, &mut st);
                unit.bin(cfg, sample_of(cfg, w, &mut st))
            };
            let (a, b) = (bin(lo), (bin(hi) + 1).min(bins - 1));
            let (e0, e1) = (
                ((a as f64 * stride).floor() as usize).min(last),
                ((b as f64 * stride).ceil() as usize).min(last),
            );
            lut.rgba[e0..=e1].iter().any(|c| c[3] > 0.0)
        };
        OccupancyMemory::classify(mm, visible)
    }

    /// Size of the memory in bits.
    pub fn len(&self) -> usize {
        self.bits.len()
    }

    /// True when the volume has no blocks (never: volumes are non-empty).
    pub fn is_empty(&self) -> bool {
        self.bits.is_empty()
    }

    /// The same bits in golden's form, for the shared run planner.
    pub fn to_golden(&self) -> Occupancy {
        Occupancy {
            block: self.block,
            counts: self.counts,
            bits: self.bits.iter().map(|b| *b).collect(),
        }
    }
}

/// The voxel word the host loads for scalar `v` (see
/// [`crate::host::voxel_words`]): monotonic in `v`, so a block's
/// `[min, max]` maps onto the words of its voxels' range.
pub fn voxel_word(cfg: &PipelineConfig, v: u16, data_bits: u32, st: &mut QuantStats) -> u16 {
    let shift = i32::from(cfg.voxel.bits()) - data_bits as i32;
    crate::reg!(cfg, voxel)
        .assign(Wide::new(i128::from(v), -shift), st)
        .raw() as u16
}

/// The table entry a sample equal to voxel word `w` looks up first: bilinear
/// interpolation of voxel words never leaves their range (rounding onto a
/// grid that holds both ends), and the entry index is monotonic in the
/// sample, so a block's entries lie between its ends'.
fn table_index(dp: &Datapath, w: u16, st: &mut QuantStats) -> usize {
    let cfg = &dp.cfg;
    let s = sample_of(cfg, w, st);
    let f = i32::from(cfg.sample.frac()) - cfg.table_shift();
    let i = if f > 0 { s.raw() >> f } else { s.raw() << (-f) };
    i.max(0) as usize
}

/// Voxel word `w` in the `sample` format: what a sample equal to it holds
/// (a block's ends, whose samples stay between them).
fn sample_of(cfg: &PipelineConfig, w: u16, st: &mut QuantStats) -> Fx {
    let vox = Fx::from_raw_unchecked(i64::from(w), cfg.voxel);
    crate::reg!(cfg, sample).assign(Wide::from(vox), st)
}

/// Margin (voxels) by which empty-space runs are widened: twice the
/// largest difference between a fixed-point ray position and the exact
/// one (`2 r(position) + M r(step)`, [`crate::bound`] term 1), and never
/// below golden's, so that at fine widths the pipeline takes exactly
/// golden's samples.
pub fn margin(cfg: &PipelineConfig, max_index: f64) -> f64 {
    let e = 2.0 * r(cfg.position) + max_index * r(cfg.step);
    (2.0 * e).max(GOLDEN_MARGIN)
}

/// What the controller skipped in a frame.
#[derive(Debug, Clone, Copy, Default, PartialEq, serde::Serialize)]
pub struct SkipCounts {
    /// Slices skipped whole (empty, clipped away or behind the volume).
    pub slices: u64,
    /// Rows of sampled slices that took no cycle (empty, clipped or all
    /// terminated).
    pub beams: u64,
    /// Rays culled (held, never sampled), summed over regions.
    pub rays_culled: u64,
    /// Regions behind the last visible slice, not run.
    pub regions: u64,
    /// Size of the occupancy memory in bits (0 without empty-space skipping).
    pub occupancy_bits: u64,
    /// Fraction of its bits set.
    pub occupied: f64,
}

/// The controller's plan of what a frame of `prep` samples, for the
/// pipeline `dp` with volume blocks `mm` of `data_bits`-bit scalars:
/// golden's [`SampleMask`] over this pipeline's own occupancy memory, with
/// the pipeline's position margin. Returns the mask and the counts the
/// memory adds.
pub fn plan_mask(
    dp: &Datapath,
    mm: &MinMax,
    data_bits: u32,
    prep: &Prepared,
    layout: &Layout,
    skips: Skips,
) -> (SampleMask, SkipCounts) {
    let memory = skips.empty.then(|| OccupancyMemory::new(dp, mm, data_bits));
    mask_from(dp, memory, prep, layout, skips, 1)
}

/// [`plan_mask`] for a pre-integrated frame: the occupancy memory of
/// [`OccupancyMemory::for_preint`] (golden's table `lut` and the unit's
/// bins, `stride` entries each), and each step's runs over the slices it
/// reads (as golden plans its pre-integrated frames, like two substeps).
#[allow(clippy::too_many_arguments)]
pub fn plan_preint_mask(
    dp: &Datapath,
    unit: &PreintUnit,
    (lut, stride): (&Lut, f64),
    mm: &MinMax,
    data_bits: u32,
    prep: &Prepared,
    layout: &Layout,
    skips: Skips,
) -> (SampleMask, SkipCounts) {
    let memory = skips
        .empty
        .then(|| OccupancyMemory::for_preint(dp, unit, (lut, stride), mm, data_bits));
    mask_from(dp, memory, prep, layout, skips, 2)
}

/// The mask of `memory`'s occupancy (none: no empty-space skipping).
fn mask_from(
    dp: &Datapath,
    memory: Option<OccupancyMemory>,
    prep: &Prepared,
    layout: &Layout,
    skips: Skips,
    substeps: u32,
) -> (SampleMask, SkipCounts) {
    let max_index = layout
        .grids
        .iter()
        .flat_map(|g| g.lo.iter().chain(&g.hi))
        .map(|m| m.unsigned_abs())
        .max()
        .unwrap_or(0) as f64;
    let occ = memory.as_ref().map(OccupancyMemory::to_golden);
    let mask = SampleMask::new(
        &prep.view,
        layout,
        MaskSpec {
            occupancy: occ.as_ref(),
            clip: prep.clip.clone(),
            cull: skips.cull,
            ftb: dp.cfg.order == Order::FrontToBack,
            margin: margin(&dp.cfg, max_index),
            substeps,
        },
    );
    let counts = SkipCounts {
        occupancy_bits: memory.as_ref().map_or(0, |m| m.len() as u64),
        occupied: occ.as_ref().map_or(1.0, Occupancy::fraction),
        ..SkipCounts::default()
    };
    (mask, counts)
}
