//! One frame, end to end: volume -> classify -> slices (and empty-space
//! blocks) -> method ->
//! baseplane -> warp -> image, or the reference ray caster for the same
//! camera. The command line, the benchmarks and the tests all go through
//! here, so every method sees the same view, stack and table.

use std::str::FromStr;
use std::sync::{Arc, Mutex, OnceLock};

use crate::camera::Camera;
use crate::clip::{check_planes, ClipPlane, ViewClip};
use crate::ergaze::ErGazeStats;
use crate::error::{input, Result};
use crate::gaze::GazeStats;
use crate::geometry::View;
use crate::gradients::Gradients;
use crate::image::Image;
use crate::methods::{self, Method, Options, Output};
use crate::mipcast::{self, MipOptions, MipStats};
use crate::mipmap::{Classify, MipMap};
use crate::occupancy::{MinMax, Occupancy, DEFAULT_BLOCK};
use crate::preint::{Colouring, PreTable};
use crate::reference::{self, RefOptions};
use crate::shading::{GradientMode, Shader};
use crate::shearwarp::{Classified, SwOptions, SwStats};
use crate::slices::SliceStack;
use crate::tf::{Lut, TransferFunction};
use crate::volume::{Volume, VoxelType};
use crate::warp::warp;

/// Any golden rendering technique.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Technique {
    /// A slice-order method.
    Slice(Method),
    /// The supersampled image-order reference.
    Reference,
    /// Ray casting a pre-classified 3D mip-map ([`crate::mipcast`]).
    MipMap,
    /// Perspective shear-warp ([`crate::shearwarp`]).
    ShearWarp,
}

impl Technique {
    /// Name on the command line.
    pub fn name(self) -> &'static str {
        match self {
            Technique::Slice(m) => m.name(),
            Technique::Reference => "reference",
            Technique::MipMap => "mipmap",
            Technique::ShearWarp => "shear-warp",
        }
    }
}

impl FromStr for Technique {
    type Err = crate::Error;
    fn from_str(s: &str) -> Result<Technique> {
        match s {
            "reference" => return Ok(Technique::Reference),
            "mipmap" => return Ok(Technique::MipMap),
            "shear-warp" => return Ok(Technique::ShearWarp),
            _ => {}
        }
        s.parse::<Method>().map(Technique::Slice).map_err(|_| {
            input(format!(
                "unknown method '{s}': use reference, er, er-ftb, under, over, box, mipmap or shear-warp"
            ))
        })
    }
}

/// Table entries for a volume's scalar range: one per value for 8-bit
/// data, 4096 (VolumePro's 12-bit index) for 16-bit data.
pub fn lut_for(kind: VoxelType, tf: &TransferFunction) -> Lut {
    match kind {
        VoxelType::U8 => Lut::for_bits(tf, 256, 8),
        VoxelType::U16 => Lut::for_bits(tf, 4096, 16),
    }
}

/// A camera placed against a volume, with the volume permuted for it, its
/// empty-space blocks and the clip planes in view space. Build once per
/// view and render any number of frames, tables and methods.
#[derive(Debug, Clone)]
pub struct Prepared {
    /// The view geometry.
    pub view: View,
    /// The permuted, padded volume (shared by the views of a camera path
    /// that keep the principal axis, see [`Prepared::moved`]).
    pub stack: Arc<SliceStack>,
    /// Min-max blocks of the volume (index space).
    pub blocks: MinMax,
    /// Clip planes in view space.
    pub clip: ViewClip,
    /// The occupancy map of the last table used, by the table's key: the
    /// map is rebuilt only when the transfer function changes.
    occupancy: Arc<Mutex<Option<KeyedOccupancy>>>,
    /// The pre-classified mip-map of the last table used, by
    /// [`classification_key`]: rebuilt only when the table changes.
    /// One slot per [`Classify`] (the post-classified pyramid does not
    /// depend on the table and is built once).
    mipmap: Arc<Mutex<[Option<KeyedMipMap>; 2]>>,
    /// The shear-warp classified, run-length encoded stack of the last
    /// table used, by [`classification_key`], shared like the mip-map.
    classified: Arc<Mutex<Option<KeyedClassified>>>,
    /// The stack's gradients for shading, built on first use and shared
    /// like the stack.
    gradients: Arc<OnceLock<Arc<Gradients>>>,
    /// The pre-integrated table of the last table used, by
    /// [`classification_key`].
    preint: Arc<Mutex<Option<KeyedPreTable>>>,
    /// The coarse levels `1..` of a gaze-directed ER frame
    /// ([`crate::ergaze`]); empty unless [`Prepared::with_gaze_levels`]
    /// made them.
    coarse: Arc<Vec<Prepared>>,
}

/// An occupancy map and the key of the table it was built for.
type KeyedOccupancy = (u64, Arc<Occupancy>);

/// A mip-map and the key of the table it was classified with.
type KeyedMipMap = (u64, Arc<MipMap>);

/// A pre-integrated table and the key of the table it integrates.
type KeyedPreTable = ((u64, Colouring), Arc<PreTable>);

/// A classified stack and the key of its table.
type KeyedClassified = (u64, Arc<Classified>);

/// Distance in front of the eye where an eye inside the slab clips (voxels).
pub const DEFAULT_NEAR: f64 = 1.0;

/// How a volume is prepared for a camera.
#[derive(Debug, Clone, PartialEq)]
pub struct PrepareOptions {
    /// Edge of the empty-space blocks in voxels.
    pub block: usize,
    /// Clip planes (world units).
    pub clip: Vec<ClipPlane>,
    /// The near plane: an eye on or inside the slab sees only slices at
    /// least this far in front of it (voxels).
    pub near: f64,
}

impl Default for PrepareOptions {
    fn default() -> PrepareOptions {
        PrepareOptions {
            block: DEFAULT_BLOCK,
            clip: Vec::new(),
            near: DEFAULT_NEAR,
        }
    }
}

impl Prepared {
    /// Places `camera` against `volume` with the default options.
    pub fn new(volume: &Volume, camera: &Camera) -> Result<Prepared> {
        Prepared::with(volume, camera, &PrepareOptions::default())
    }

    /// Places `camera` against `volume` with `opts`.
    pub fn with(volume: &Volume, camera: &Camera, opts: &PrepareOptions) -> Result<Prepared> {
        Prepared::place(volume, camera, opts, None)
    }

    /// [`Prepared::with`], taking `volume`: its voxels become the slice
    /// stack ([`SliceStack::from_volume`]), so a one-off frame holds them
    /// once. The result is the same as [`Prepared::with`]'s.
    pub fn owning(volume: Volume, camera: &Camera, opts: &PrepareOptions) -> Result<Prepared> {
        check_planes(&opts.clip)?;
        let view = View::new(volume.dims(), volume.spacing(), camera, opts.near)?;
        let blocks = MinMax::new(&volume, opts.block)?;
        let clip = ViewClip::new(&opts.clip, &view.axes, volume.spacing());
        let stack = Arc::new(SliceStack::from_volume(volume, &view.axes)?);
        Ok(Prepared {
            view,
            stack,
            blocks,
            clip,
            occupancy: Arc::default(),
            mipmap: Arc::default(),
            classified: Arc::default(),
            gradients: Arc::default(),
            preint: Arc::default(),
            coarse: Arc::default(),
        })
    }

    /// `volume` (the one this was prepared from) seen by another camera,
    /// reusing what does not depend on the camera: the min-max blocks and
    /// the occupancy cache (they depend on the volume and the table only)
    /// when the block size is unchanged, and the permuted slice stack (with
    /// the mip-maps built from it) when the principal axis is unchanged. A
    /// camera path pays for those once; the result is the same as
    /// [`Prepared::with`]'s.
    pub fn moved(
        &self,
        volume: &Volume,
        camera: &Camera,
        opts: &PrepareOptions,
    ) -> Result<Prepared> {
        Prepared::place(volume, camera, opts, Some(self))
    }

    /// [`Prepared::with`], taking what `reuse` has that still holds.
    fn place(
        volume: &Volume,
        camera: &Camera,
        opts: &PrepareOptions,
        reuse: Option<&Prepared>,
    ) -> Result<Prepared> {
        check_planes(&opts.clip)?;
        let view = View::new(volume.dims(), volume.spacing(), camera, opts.near)?;
        let (stack, mipmap, classified, gradients) = match reuse {
            Some(r) if r.view.axes == view.axes => (
                Arc::clone(&r.stack),
                Arc::clone(&r.mipmap),
                Arc::clone(&r.classified),
                Arc::clone(&r.gradients),
            ),
            _ => (
                Arc::new(SliceStack::new(volume, &view.axes)?),
                Arc::default(),
                Arc::default(),
                Arc::default(),
            ),
        };
        let (blocks, occupancy) = match reuse {
            Some(r) if r.blocks.block == opts.block => (r.blocks.clone(), Arc::clone(&r.occupancy)),
            _ => (MinMax::new(volume, opts.block)?, Arc::default()),
        };
        let clip = ViewClip::new(&opts.clip, &view.axes, volume.spacing());
        Ok(Prepared {
            view,
            stack,
            blocks,
            clip,
            occupancy,
            mipmap,
            classified,
            gradients,
            preint: match reuse {
                Some(r) => Arc::clone(&r.preint),
                None => Arc::default(),
            },
            // They depend on the camera: a moved view prepares its own.
            coarse: Arc::default(),
        })
    }

    /// This view with the coarse levels `1..=levels` a gaze-directed ER
    /// frame renders ([`crate::ergaze::prepare_levels`]; `volume`,
    /// `camera` and `opts` are the ones this was prepared with).
    pub fn with_gaze_levels(
        mut self,
        volume: &Volume,
        camera: &Camera,
        opts: &PrepareOptions,
        levels: u32,
    ) -> Result<Prepared> {
        self.coarse = Arc::new(crate::ergaze::prepare_levels(volume, camera, opts, levels)?);
        Ok(self)
    }

    /// The coarse levels prepared by [`Prepared::with_gaze_levels`].
    pub fn gaze_levels(&self) -> &[Prepared] {
        &self.coarse
    }

    /// The stack's shading gradients ([`Gradients::new`]),
    /// built on the first call and shared by the views of a camera path
    /// that share the stack.
    pub fn gradients(&self) -> Arc<Gradients> {
        Arc::clone(
            self.gradients
                .get_or_init(|| Arc::new(Gradients::new(&self.view, &self.stack))),
        )
    }

    /// Whether `other` shares this one's slice stack (no permutation was
    /// paid for it).
    pub fn shares_stack(&self, other: &Prepared) -> bool {
        Arc::ptr_eq(&self.stack, &other.stack)
    }
}

mod caches;

/// Settings of every technique.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RenderOptions {
    /// Slice-order options.
    pub slice: Options,
    /// Reference options.
    pub reference: RefOptions,
    /// Mip-map step factor (see [`MipOptions::step`]); termination and
    /// empty-space skipping follow [`RenderOptions::slice`].
    pub mip_step: f64,
    /// Pre- or post-classified mip-map.
    pub mip_classify: Classify,
    /// Shear-warp intermediate pixels per voxel of the front slice;
    /// termination, run skipping and culling follow [`RenderOptions::slice`].
    pub sw_scale: f64,
}

impl Default for RenderOptions {
    fn default() -> RenderOptions {
        RenderOptions {
            slice: Options::default(),
            reference: RefOptions::default(),
            mip_step: mipcast::DEFAULT_MIP_STEP,
            mip_classify: Classify::Post,
            sw_scale: crate::shearwarp::DEFAULT_SCALE,
        }
    }
}

impl RenderOptions {
    /// The defaults with no empty-space skipping or culling: every ray
    /// samples every slice it crosses (for sample-count comparisons with
    /// a renderer that does not skip).
    pub fn unskipped() -> RenderOptions {
        let mut o = RenderOptions::default();
        o.slice.skips = crate::skip::Skips {
            empty: false,
            cull: false,
        };
        o
    }

    /// The mip-map caster's options: its step, er-ftb's termination
    /// threshold and the empty-space switch.
    pub fn mip(&self) -> MipOptions {
        MipOptions {
            step: self.mip_step,
            terminate: self.slice.terminate,
            skip_empty: self.slice.skips.empty,
            classify: self.mip_classify,
            shade: self.slice.shade,
            voi: self.slice.voi,
        }
    }
}

impl RenderOptions {
    /// The shear-warp renderer's options: its scale, er-ftb's termination
    /// threshold, the empty-space switch (the runs), culling (the
    /// intermediate image cut to what the final image reads) and the volume
    /// of interest.
    pub fn shear_warp(&self) -> SwOptions {
        SwOptions {
            scale: self.sw_scale,
            terminate: self.slice.terminate,
            skip_empty: self.slice.skips.empty,
            cull: self.slice.skips.cull,
            voi: self.slice.voi,
        }
    }
}

/// One rendered frame.
#[derive(Debug, Clone)]
pub struct Frame {
    /// The final image.
    pub image: Image,
    /// Baseplane and counts of a slice-order method.
    pub slice: Option<Output>,
    /// Counts of the mip-map caster.
    pub mip: Option<MipStats>,
    /// Rays of a gaze-directed or refined ([`crate::refine`]) caster
    /// frame.
    pub gaze: Option<GazeStats>,
    /// Counts of the shear-warp renderer.
    pub sw: Option<SwStats>,
    /// Levels of a gaze-directed ER frame.
    pub er_gaze: Option<ErGazeStats>,
}

impl Frame {
    /// Samples the method took (interpolated and classified), when it
    /// counts them.
    pub fn samples(&self) -> Option<u64> {
        match (&self.slice, &self.mip, &self.sw, &self.er_gaze) {
            (Some(o), _, _, _) => Some(o.stats.samples_total),
            (None, Some(m), _, _) => Some(m.samples_total),
            (None, None, Some(s), _) => Some(s.samples_total),
            (None, None, None, Some(g)) => Some(g.samples_total),
            (None, None, None, None) => None,
        }
    }
}

impl Frame {
    /// Gives the frame's buffers back to the pool of spare ray buffers
    /// ([`crate::merge::recycle`]), for the next
    /// frame (a renderer drawing frame after frame touches fresh memory
    /// once instead of every frame).
    pub fn recycle(self) {
        crate::merge::recycle(self.image.data);
        if let Some(out) = self.slice {
            crate::merge::recycle(out.baseplane.data);
        }
    }
}

/// Renders one frame of `prep` with `tech`.
pub fn render(prep: &Prepared, lut: &Lut, tech: Technique, opts: &RenderOptions) -> Result<Frame> {
    if let Some(r) = &opts.reference.refine {
        let out = crate::refine::frame::render(prep, lut, tech, opts, r)?;
        return Ok(out.into_frame().0);
    }
    match tech {
        Technique::Reference => match &opts.reference.gaze {
            Some(g) => {
                let (image, stats) = crate::gaze::render(
                    &prep.view,
                    &prep.stack,
                    &prep.clip,
                    lut,
                    &opts.reference,
                    g,
                )?;
                Ok(Frame {
                    image,
                    slice: None,
                    mip: None,
                    gaze: Some(stats),
                    sw: None,
                    er_gaze: None,
                })
            }
            None => Ok(Frame {
                image: reference::render(
                    &prep.view,
                    &prep.stack,
                    &prep.clip,
                    lut,
                    &opts.reference,
                )?,
                slice: None,
                mip: None,
                gaze: None,
                sw: None,
                er_gaze: None,
            }),
        },
        Technique::MipMap => {
            let mip = opts.mip();
            mip.validate()?;
            let pyramid = prep.mipmap_of(lut, &mip)?;
            let (image, stats, gaze) = match &opts.reference.gaze {
                Some(g) => {
                    let (i, s, g) =
                        mipcast::render_gaze(&prep.view, &pyramid, &prep.clip, lut, &mip, g)?;
                    (i, s, Some(g))
                }
                None => {
                    let (i, s) = mipcast::render(&prep.view, &pyramid, &prep.clip, lut, &mip)?;
                    (i, s, None)
                }
            };
            Ok(Frame {
                image,
                slice: None,
                mip: Some(stats),
                gaze,
                sw: None,
                er_gaze: None,
            })
        }
        Technique::ShearWarp => {
            let o = &opts.slice;
            let refuse = |what: &str| -> Result<Frame> {
                Err(crate::error::input(format!("the shear-warp method {what}")))
            };
            if opts.reference.gaze.is_some() {
                return refuse("has no gaze-directed resolution");
            }
            if o.substeps != methods::DEFAULT_SUBSTEPS {
                return refuse("takes one sample per slice; drop --substeps");
            }
            let sw = opts.shear_warp();
            sw.validate()?;
            let cls = prep.classified_for(lut)?;
            let shader = match &o.shade {
                Some(sh) => {
                    let grads = (sh.gradient == GradientMode::Voxels).then(|| prep.gradients());
                    Some(Shader::with_gradients(&prep.view, grads, sh)?)
                }
                None => None,
            };
            let (image, stats) = crate::shearwarp::render_shaded(
                &prep.view,
                &cls,
                &prep.clip,
                &sw,
                shader.as_ref().map(|s| (s, &*prep.stack)),
            )?;
            Ok(Frame {
                image,
                slice: None,
                mip: None,
                gaze: None,
                sw: Some(stats),
                er_gaze: None,
            })
        }
        Technique::Slice(m) if opts.reference.gaze.is_some() => {
            let g = opts.reference.gaze.as_ref().expect("matched");
            let (image, stats) =
                crate::ergaze::render(m, prep, prep.gaze_levels(), lut, &opts.slice, g)?;
            Ok(Frame {
                image,
                slice: None,
                mip: None,
                gaze: None,
                sw: None,
                er_gaze: Some(stats),
            })
        }
        Technique::Slice(m) => {
            let out = methods::render(m, prep, lut, &opts.slice)?;
            Ok(Frame {
                image: warp(&prep.view, &out.baseplane),
                slice: Some(out),
                mip: None,
                gaze: None,
                sw: None,
                er_gaze: None,
            })
        }
    }
}
