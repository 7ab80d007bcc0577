//! What the architecture tests share (`mapping`, `migration`, `links`,
//! `occupancy`, `skip`): an architecture ([`Arch`]: ownership mapping,
//! migration, ray buffer placement, sparse links and passes, lanes) and
//! the configuration built from it, the transfer function and camera the
//! small scenes are seen through, and the frames run untraced or clocked.

use glam::DVec3;
use golden::camera::Camera;
use golden::methods::Method;
use golden::render::Prepared;
use golden::skip::Skips;
use golden::tf::Lut;
use golden::volume::Volume;
use pipeline::array::{Array, Frame, FrameRun, Voxels};
use pipeline::config::{Mapping, Migration, Order, PipelineConfig, RayBuffer};
use waves::Tracer;

use crate::scenes::tf;

/// An architecture of the array: the configuration fields that choose who
/// owns which columns, when and how rays move, and where they live.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Arch {
    /// Which PE owns a voxel column while sampling.
    pub mapping: Mapping,
    /// Columns per round-robin block (`cyclic`).
    pub cyclic_width: u16,
    /// Between slices or overlapped with sampling.
    pub migration: Migration,
    /// On chip or in external memory.
    pub ray_buffer: RayBuffer,
    /// Transparent rows stay off the links.
    pub link_skip_empty: bool,
    /// Transparent rays skip the passes and the readout.
    pub pass_skip_empty: bool,
    /// Rays a link carries per cycle and direction.
    pub link_lanes: u16,
}

impl Arch {
    /// Column blocks migrating between slices, rays on chip, dense links
    /// and passes, one lane: the default architecture.
    pub const BLOCKS: Arch = Arch {
        mapping: Mapping::Blocks,
        cyclic_width: 1,
        migration: Migration::BetweenSlices,
        ray_buffer: RayBuffer::OnChip,
        link_skip_empty: false,
        pass_skip_empty: false,
        link_lanes: 1,
    };

    /// Cube-4's interleave.
    pub const fn interleave(self) -> Arch {
        Arch {
            mapping: Mapping::Interleave,
            cyclic_width: 1,
            ..self
        }
    }

    /// Round-robin blocks of `width` columns.
    pub const fn cyclic(self, width: u16) -> Arch {
        Arch {
            mapping: Mapping::Cyclic,
            cyclic_width: width,
            ..self
        }
    }

    /// Migration overlapped with sampling.
    pub const fn overlapped(self) -> Arch {
        Arch {
            migration: Migration::Overlapped,
            ..self
        }
    }

    /// The rays in external memory.
    pub const fn external(self) -> Arch {
        Arch {
            ray_buffer: RayBuffer::External,
            ..self
        }
    }

    /// Transparent rows off the links (`link_skip_empty`) as `on` says.
    pub const fn sparse_links(self, on: bool) -> Arch {
        Arch {
            link_skip_empty: on,
            ..self
        }
    }

    /// Transparent rays out of the passes and the readout
    /// (`pass_skip_empty`) as `on` says.
    pub const fn sparse_passes(self, on: bool) -> Arch {
        Arch {
            pass_skip_empty: on,
            ..self
        }
    }

    /// `n` lanes on the links.
    pub const fn lanes(self, n: u16) -> Arch {
        Arch {
            link_lanes: n,
            ..self
        }
    }

    /// `base` with this architecture's fields.
    pub fn on(self, base: PipelineConfig) -> PipelineConfig {
        PipelineConfig {
            mapping: self.mapping,
            cyclic_width: self.cyclic_width,
            migration: self.migration,
            ray_buffer: self.ray_buffer,
            link_skip_empty: self.link_skip_empty,
            pass_skip_empty: self.pass_skip_empty,
            link_lanes: self.link_lanes,
            ..base
        }
    }

    /// The configuration the architecture tests run: `pes` PEs, back to
    /// front or front to back (terminating at 0.9), occupancy blocks of 4,
    /// this architecture.
    pub fn config(self, pes: u16, ftb: bool) -> PipelineConfig {
        self.on(PipelineConfig {
            pes,
            order: if ftb {
                Order::FrontToBack
            } else {
                Order::BackToFront
            },
            terminate: if ftb { 0.9 } else { 1.0 },
            occupancy_block: 4,
            ..PipelineConfig::default()
        })
    }
}

/// A table transparent below `threshold`, blue to orange over the next 50
/// data units and near opaque white at 255, at `cfg`'s entries.
pub fn lut(cfg: &PipelineConfig, threshold: f64) -> Lut {
    let t = tf(&[
        (0.0, [0.0; 4]),
        (threshold, [0.2, 0.4, 0.9, 0.0]),
        (threshold + 50.0, [1.0, 0.7, 0.3, 0.6]),
        (255.0, [1.0, 1.0, 1.0, 0.95]),
    ]);
    Lut::for_bits(&t, cfg.table_entries as usize, 8)
}

/// A `width` x `height` camera from `eye` towards `look` (up is y, or z
/// when looking along y); `None` where the camera refuses.
pub fn camera(eye: DVec3, look: DVec3, fov: f64, width: u32, height: u32) -> Option<Camera> {
    let f = (look - eye).normalize();
    let up = if f.y.abs() > 0.9 { DVec3::Z } else { DVec3::Y };
    Camera::new(eye, look, up, fov, width, height).ok()
}

/// The untraced frame of `cfg` with `skips`.
pub fn frame(
    cfg: &PipelineConfig,
    vol: &Volume,
    lut: &Lut,
    prep: &Prepared,
    skips: Skips,
) -> Result<Frame, pipeline::RunError> {
    FrameRun::prepared(cfg, lut, prep, Voxels::Volume(vol))
        .skips(skips)
        .run()
}

/// The frame of `cfg` with skipping on and every stage clocked cycle by
/// cycle (the migrations step the links and their FIFOs, the probes note
/// every cycle), the PEs stepped in reverse when `reversed` (their order
/// within a cycle cannot matter): what the untraced paths must agree with.
pub fn clocked(
    cfg: &PipelineConfig,
    vol: &Volume,
    lut: &Lut,
    prep: &Prepared,
    reversed: bool,
) -> Frame {
    let layout = Method::Er.layout(&prep.view).expect("layout");
    let mm = golden::occupancy::MinMax::new(vol, usize::from(cfg.occupancy_block)).expect("blocks");
    let dp = pipeline::datapath::Datapath::new(
        *cfg,
        pipeline::tables::Tables::new(cfg, lut).expect("tables"),
    );
    let (mask, counts) = pipeline::skip::plan_mask(&dp, &mm, 8, prep, &layout, Skips::default());
    let mut a = Array::new(cfg, vol, lut, &prep.view, Tracer::disabled()).expect("array");
    a.set_skipping(mask, counts, &prep.view);
    a.set_clocked(true);
    if reversed {
        a.set_step_order((0..usize::from(cfg.pes)).rev().collect());
    }
    a.run(&prep.view).expect("clocked frame")
}

/// Two blobs in empty space, seen from in front at 70 degrees on a 32x28
/// image: most rays stay transparent for most of the frame.
pub fn two_blobs() -> (Volume, Prepared) {
    let vol = crate::scenes::sparse([48, 40, 44], 2, 7);
    let cam = camera(
        DVec3::new(23.5, 19.5, -30.0),
        DVec3::new(23.5, 19.5, 21.5),
        70.0,
        32,
        28,
    )
    .expect("camera");
    let prep = Prepared::new(&vol, &cam).expect("view");
    (vol, prep)
}
