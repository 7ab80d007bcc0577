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
        let q = |f: crate::fixed::Format, v: f64, st: &mut QuantStats| -> Result<Fx, FxError> {
            let r = f.from_f64(v)?;
            st.record(&r);
            Ok(r.value)
        };
        let slope_b = [
            q(cfg.position, (grid.phi[0] - e.x) * inv * sp[0], &mut st)?,
            q(cfg.position, (grid.phi[1] - e.y) * inv * sp[1], &mut st)?,
        ];
        let slope_k = [
            q(cfg.step, inv * sp[0], &mut st)?,
            q(cfg.step, inv * sp[1], &mut st)?,
        ];
        let slope_z = q(cfg.position, sp[2], &mut st)?;
        let mut slices = Vec::with_capacity(grid.slices.len());
        for z in grid.slices.clone().rev() {
            let (p, range) = slice_rays(view, grid, z);
            slices.push(SlicePlan {
                z,
                a: [
                    q(cfg.position, p[0].a, &mut st)?,
                    q(cfg.position, p[1].a, &mut st)?,
                ],
                t: [q(cfg.step, p[0].t, &mut st)?, q(cfg.step, p[1].t, &mut st)?],
                range,
            });
        }
        let boundary = |b: f64, st: &mut QuantStats| -> Result<SlicePlan, FxError> {
            Ok(SlicePlan {
                z: (b.ceil() as usize).min(view.dims[2].saturating_sub(1)),
                a: [
                    q(cfg.position, grid.at(e, view.d, b, 0).a, st)?,
                    q(cfg.position, grid.at(e, view.d, b, 1).a, st)?,
                ],
                t: [
                    q(cfg.step, grid.at(e, view.d, b, 0).t, st)?,
                    q(cfg.step, grid.at(e, view.d, b, 1).t, st)?,
                ],
                range: [(0, -1); 2],
            })
        };
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
