//! The host driver: turns the golden model's view geometry (one source of
//! truth: `golden::geometry`, `golden::sampling::slice_rays`) into the
//! per-region and per-slice constants the controller broadcasts, quantised
//! into the datapath's formats, and the voxel words loaded into PE memory.

use glam::DVec3;
use golden::geometry::{Layout, RayGrid, View};
use golden::methods::Method;
use golden::sampling::slice_rays;
use golden::slices::Plane;
use golden::volume::Volume;

use crate::config::PipelineConfig;
use crate::fixed::{Fx, FxError, QuantStats};

/// What the controller broadcasts for one slice.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SlicePlan {
    /// View-space slice index.
    pub z: usize,
    /// Ray position of ray 0 on x and y (`position`).
    pub a: [Fx; 2],
    /// Ray spacing on x and y (`step`).
    pub t: [Fx; 2],
    /// Rays sampling this slice on x and y, inclusive (empty when lo > hi).
    pub range: [(i64, i64); 2],
    /// In a pre-integrated frame, what the pass does with its samples
    /// (`range` is then the hull of the step's ranges).
    pub pre: Option<PreStep>,
}

/// What a pre-integrated pass broadcasts beside its slice plan
/// ([`crate::preint`]): which rays composite a step, which record their
/// sample as the back (back to front) or front (front to back) scalar of
/// the next, and which take slice 0's half step in front. Each is a ray
/// rectangle, inclusive, empty when `lo > hi` on an axis; a PE compares
/// its ray's indices with them.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct PreStep {
    /// Rays that composite the step between this pass's sample and their
    /// previous one.
    pub comp: [(i64, i64); 2],
    /// Rays that keep this pass's sample for their next step.
    pub keep: [(i64, i64); 2],
    /// Rays that composite slice 0's half step at their own scalar.
    pub lead: [(i64, i64); 2],
    /// The composited step is half a slice step long (the last slice's,
    /// to the volume's face).
    pub half: bool,
    /// The slice whose step `comp` composites (its runs decide which of
    /// those rays a skipping controller samples).
    pub comp_z: Option<usize>,
    /// The slice whose step `keep`'s sample serves.
    pub keep_z: Option<usize>,
}

impl PreStep {
    /// Whether ray `(mx, my)` lies in rectangle `r`.
    #[inline(always)]
    pub fn within(r: &[(i64, i64); 2], mx: i64, my: i64) -> bool {
        (r[0].0..=r[0].1).contains(&mx) && (r[1].0..=r[1].1).contains(&my)
    }

    /// The rays the pass samples: the hull of its three rectangles.
    pub fn rays(&self) -> [(i64, i64); 2] {
        hull(hull(self.comp, self.keep), self.lead)
    }
}

/// Nothing (an empty ray rectangle).
pub(crate) const NONE: [(i64, i64); 2] = [(0, -1), (0, -1)];

/// The smallest rectangle holding both (an empty one holds nothing).
fn hull(a: [(i64, i64); 2], b: [(i64, i64); 2]) -> [(i64, i64); 2] {
    let empty = |r: &[(i64, i64); 2]| r[0].0 > r[0].1 || r[1].0 > r[1].1;
    match (empty(&a), empty(&b)) {
        (true, _) => b,
        (_, true) => a,
        _ => std::array::from_fn(|k| (a[k].0.min(b[k].0), a[k].1.max(b[k].1))),
    }
}

/// The passes a pre-integrated frame runs over region `region` (its plan
/// `rp`, slices back to front), in the order `order` runs them
/// ([`crate::preint`]). Slice `z`'s step is `[z, z + 1]`, the last
/// slice's `[nz - 1, nz - 1/2]`, and slice 0 adds `[-1/2, 0]` at its own
/// scalar, as golden's. Back to front a *prime* pass first samples the
/// step's back end of the region's rear slice (slice `z + 1`, or the face
/// at depth `nz - 1/2` in slice `nz - 1`'s data) with this region's rays,
/// then each slice composites its step and keeps its sample for the slice
/// in front; front to back each slice composites the step of the slice
/// before and keeps its own, and a *finish* pass samples the rear slice's
/// back end. The host's roundings of the extra passes' constants count
/// into `st`.
pub fn preint_passes(
    cfg: &PipelineConfig,
    view: &View,
    rp: &RegionPlan,
    st: &mut QuantStats,
) -> Result<Vec<SlicePlan>, PlanError> {
    let nz = view.dims[2];
    let z_range = rp.grid.slices.clone();
    if z_range.is_empty() {
        return Ok(Vec::new());
    }
    let (lo, hi) = (z_range.start, z_range.end - 1);
    // Slices back to front in the plan: slice z at index hi - z.
    let at = |z: usize| &rp.slices[hi - z];
    let range = |z: usize| at(z).range;
    // The back end of the region's rear step: slice `hi + 1`, or the face.
    let end_depth = if hi + 1 < nz {
        (hi + 1) as f64
    } else {
        nz as f64 - 0.5
    };
    let end = |st: &mut QuantStats| depth_plan(cfg, view, &rp.grid, end_depth, st);
    let with = |s: SlicePlan, pre: PreStep| SlicePlan {
        range: pre.rays(),
        pre: Some(pre),
        ..s
    };
    let lead = |z: usize| if z == 0 { range(0) } else { NONE };
    let mut out = Vec::with_capacity(z_range.len() + 1);
    match cfg.order {
        crate::config::Order::BackToFront => {
            let prime = PreStep {
                comp: NONE,
                keep: range(hi),
                lead: NONE,
                half: false,
                comp_z: None,
                keep_z: Some(hi),
            };
            out.push(with(end(st)?, prime));
            for z in (lo..=hi).rev() {
                let pre = PreStep {
                    comp: range(z),
                    keep: if z > lo { range(z - 1) } else { NONE },
                    lead: lead(z),
                    half: z + 1 == nz,
                    comp_z: Some(z),
                    keep_z: (z > lo).then(|| z - 1),
                };
                out.push(with(*at(z), pre));
            }
        }
        crate::config::Order::FrontToBack => {
            for z in lo..=hi {
                let pre = PreStep {
                    comp: if z > lo { range(z - 1) } else { NONE },
                    keep: range(z),
                    lead: lead(z),
                    half: false,
                    comp_z: (z > lo).then(|| z - 1),
                    keep_z: Some(z),
                };
                out.push(with(*at(z), pre));
            }
            let finish = PreStep {
                comp: range(hi),
                keep: NONE,
                lead: NONE,
                half: hi + 1 == nz,
                comp_z: Some(hi),
                keep_z: None,
            };
            out.push(with(end(st)?, finish));
        }
    }
    Ok(out)
}

/// What the controller holds for one region.
#[derive(Debug, Clone)]
pub struct RegionPlan {
    /// The region's rays (golden's grid: rectangle, reference plane, offset).
    pub grid: RayGrid,
    /// Spacing-scaled slope of ray 0 per axis (`position`) and per ray
    /// index (`step`): ray `m`'s slope is `b + m k`.
    pub slope_b: [Fx; 2],
    /// See `slope_b`.
    pub slope_k: [Fx; 2],
    /// The z spacing as a slope term (`position`).
    pub slope_z: Fx,
    /// Slices, back to front.
    pub slices: Vec<SlicePlan>,
    /// Ray positions on the region's front boundary `b_i` (no ranges: no
    /// sampling happens there), where the rays merge into the next region's
    /// and so where they must sit in the PE of their position.
    pub front: SlicePlan,
    /// Ray positions on the region's rear boundary `b_(i+1)`, where front
    /// to back the rays split into the next region's (they are one voxel
    /// apart there, so every voxel column in their span holds one).
    pub rear: SlicePlan,
}

/// Everything the host loads before a frame.
#[derive(Debug, Clone)]
pub struct FramePlan {
    /// Regions, front (0) to back.
    pub regions: Vec<RegionPlan>,
    /// View-space volume dimensions.
    pub dims: [usize; 3],
    /// Quantisation events of the host's own conversions.
    pub stats: QuantStats,
    /// In a pre-integrated frame, each region's passes in the order they
    /// run ([`preint_passes`]); empty otherwise (the regions' slices run).
    pub passes: Vec<Vec<SlicePlan>>,
}

impl FramePlan {
    /// The passes region `i` samples, in the order `ftb` runs them: its
    /// slices (back to front, or front to back), or a pre-integrated
    /// frame's planned passes.
    pub fn region_passes(&self, i: usize, ftb: bool) -> Vec<&SlicePlan> {
        match self.passes.get(i) {
            Some(p) => p.iter().collect(),
            None if ftb => self.regions[i].slices.iter().rev().collect(),
            None => self.regions[i].slices.iter().collect(),
        }
    }
}

/// The plan of `grid`'s rays at depth `depth` (no ray range: a boundary
/// plane, or a pre-integrated step's back end): their positions there,
/// the data slice `ceil(depth)` (at most the last).
fn depth_plan(
    cfg: &PipelineConfig,
    view: &View,
    grid: &RayGrid,
    depth: f64,
    st: &mut QuantStats,
) -> Result<SlicePlan, FxError> {
    let q = |f: crate::config::Reg, v: f64, st: &mut QuantStats| -> Result<Fx, FxError> {
        let r = f.from_f64(v)?;
        st.record_as(f.id, &r);
        Ok(r.value)
    };
    let p = |k| grid.at(view.eye, view.d, depth, k);
    Ok(SlicePlan {
        z: (depth.ceil() as usize).min(view.dims[2].saturating_sub(1)),
        a: [
            q(crate::reg!(cfg, position), p(0).a, st)?,
            q(crate::reg!(cfg, position), p(1).a, st)?,
        ],
        t: [
            q(crate::reg!(cfg, step), p(0).t, st)?,
            q(crate::reg!(cfg, step), p(1).t, st)?,
        ],
        range: NONE,
        pre: None,
    })
}

/// Plans a frame of `view` for ER (both orders share the layout).
pub fn plan(cfg: &PipelineConfig, view: &View) -> Result<FramePlan, PlanError> {
    let layout: Layout = Method::Er.layout(view).map_err(PlanError::Golden)?;
    let mut st = QuantStats::default();
    let mut regions = Vec::with_capacity(layout.grids.len());
    for grid in &layout.grids {
        let inv = 1.0 / (grid.z_ref + view.d);
        let e = view.eye;
        let sp = view.spacing;
        let q = |f: crate::config::Reg, v: f64, st: &mut QuantStats| -> Result<Fx, FxError> {
            let r = f.from_f64(v)?;
            st.record_as(f.id, &r);
            Ok(r.value)
        };
        let slope_b = [
            q(
                crate::reg!(cfg, position),
                (grid.phi[0] - e.x) * inv * sp[0],
                &mut st,
            )?,
            q(
                crate::reg!(cfg, position),
                (grid.phi[1] - e.y) * inv * sp[1],
                &mut st,
            )?,
        ];
        let slope_k = [
            q(crate::reg!(cfg, step), inv * sp[0], &mut st)?,
            q(crate::reg!(cfg, step), inv * sp[1], &mut st)?,
        ];
        let slope_z = q(crate::reg!(cfg, position), sp[2], &mut st)?;
        let mut slices = Vec::with_capacity(grid.slices.len());
        for z in grid.slices.clone().rev() {
            let (p, range) = slice_rays(view, grid, z);
            slices.push(SlicePlan {
                z,
                a: [
                    q(crate::reg!(cfg, position), p[0].a, &mut st)?,
                    q(crate::reg!(cfg, position), p[1].a, &mut st)?,
                ],
                t: [
                    q(crate::reg!(cfg, step), p[0].t, &mut st)?,
                    q(crate::reg!(cfg, step), p[1].t, &mut st)?,
                ],
                range,
                pre: None,
            });
        }
        let boundary = |b: f64, st: &mut QuantStats| depth_plan(cfg, view, grid, b, st);
        let front = boundary(layout.bounds[regions.len()], &mut st)?;
        // Quantised only front to back, so back to front the host's
        // counters stay as they were.
        let rear = if cfg.order == crate::config::Order::FrontToBack {
            boundary(layout.bounds[regions.len() + 1], &mut st)?
        } else {
            front
        };
        regions.push(RegionPlan {
            front,
            rear,
            grid: grid.clone(),
            slope_b,
            slope_k,
            slope_z,
            slices,
        });
    }
    Ok(FramePlan {
        regions,
        dims: view.dims,
        stats: st,
        passes: Vec::new(),
    })
}

/// Where the host reads the view-space scalars it loads into the PEs:
/// the volume through the view's axes, or golden's slice stack of the
/// same view (the same values, already permuted; a frame that hands the
/// volume to the stack holds the voxels once).
#[derive(Clone, Copy)]
pub enum VoxelSource<'a> {
    /// A volume seen through `view`.
    Volume(&'a Volume, &'a View),
    /// Golden's permuted, padded stack of the view.
    Stack(&'a golden::slices::SliceStack),
}

impl VoxelSource<'_> {
    /// The scalar at view-space `(x, y, z)`.
    #[inline]
    pub fn get(&self, x: usize, y: usize, z: usize) -> u16 {
        match self {
            VoxelSource::Volume(vol, view) => {
                let i = view.axes.to_index(DVec3::new(x as f64, y as f64, z as f64));
                vol.get(i.x as usize, i.y as usize, i.z as usize)
            }
            // Stacks hold u8 or u16 scalars, exact in f32.
            VoxelSource::Stack(s) => s.slice(z).get((y + 1) * s.row + x + 1) as u16,
        }
    }

    /// The first `n` data bytes of view-space row `(y, z)` in place, when
    /// the source holds them as bytes (an 8-bit slice stack); `None`
    /// otherwise ([`VoxelSource::row`] reads any source).
    pub fn row_bytes(&self, y: usize, z: usize, n: usize) -> Option<&[u8]> {
        match self {
            VoxelSource::Stack(s) => {
                let start = (y + 1) * s.row + 1;
                match s.slice(z) {
                    Plane::U8(p) => Some(&p[start..start + n]),
                    Plane::U16(_) => None,
                }
            }
            VoxelSource::Volume(..) => None,
        }
    }

    /// The scalars of view-space row `(y, z)`, `x` from 0, into `out`
    /// (one per element): [`VoxelSource::get`] along the row, with the
    /// stack's plane and voxel type resolved once per row instead of per
    /// voxel.
    pub fn row(&self, y: usize, z: usize, out: &mut [u16]) {
        match self {
            VoxelSource::Stack(s) => {
                let start = (y + 1) * s.row + 1;
                let voxels = start..start + out.len();
                match s.slice(z) {
                    Plane::U8(p) => {
                        for (o, &v) in out.iter_mut().zip(&p[voxels]) {
                            *o = u16::from(v);
                        }
                    }
                    Plane::U16(p) => out.copy_from_slice(&p[voxels]),
                }
            }
            VoxelSource::Volume(..) => {
                for (x, o) in out.iter_mut().enumerate() {
                    *o = self.get(x, y, z);
                }
            }
        }
    }
}

/// Voxel words of the view-space volume, `[z][y][x]`: each scalar scaled
/// to the `voxel` word (shifted up when the word is wider than the data,
/// quantised down with the voxel format's rounding when narrower).
pub fn voxel_words(
    cfg: &PipelineConfig,
    volume: &Volume,
    view: &View,
    st: &mut QuantStats,
) -> Vec<u16> {
    let [nx, ny, nz] = view.dims;
    let data_bits = volume.kind().bits();
    let source = VoxelSource::Volume(volume, view);
    let mut out = Vec::with_capacity(nx * ny * nz);
    let mut row = vec![0; nx];
    for z in 0..nz {
        for y in 0..ny {
            source.row(y, z, &mut row);
            out.extend(
                row.iter()
                    .map(|&v| crate::skip::voxel_word(cfg, v, data_bits, st)),
            );
        }
    }
    out
}

/// Why a frame could not be planned.
#[derive(Debug, thiserror::Error)]
pub enum PlanError {
    /// The golden geometry refused the view.
    #[error("{0}")]
    Golden(golden::Error),
    /// A constant does not fit its format.
    #[error("{0}")]
    Fixed(#[from] FxError),
}
