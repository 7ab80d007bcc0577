//! Refined frames of the image-order casters: the reference's
//! one-ray-per-pixel rays ([`crate::reference`] at its step, the rays
//! [`crate::gaze::Gaze::full`] casts) and the mip-map caster's
//! ([`crate::mipcast::render`]'s), adaptively ([`render`]) or as a
//! progressive sequence ([`progressive`]).
//!
//! ER is not refined: its rays live in object space, each region's grid
//! covering the whole baseplane, so leaving out an image cell's rays would
//! mean cutting rays out of every region's merge tree, and the per-level
//! frames of [`crate::ergaze`] are whole frames already paid for. The
//! techniques other than the reference and the mip-map are refused.

use std::time::Instant;

use crate::error::{input, Result};
use crate::image::Image;
use crate::mipcast::{self, MipStats};
use crate::reference::{cast_ray, RefPass};
use crate::render::{Prepared, RenderOptions, Technique};
use crate::tf::Lut;

use super::{Refine, RefineStats, Refiner};

/// One refined frame.
#[derive(Debug, Clone)]
pub struct Refined {
    /// The image.
    pub image: Image,
    /// Rays and leaves per level.
    pub stats: RefineStats,
    /// Each pixel's leaf level (0: its own ray or a full-resolution
    /// cell's; `L`: a cell of the first grid, never split).
    pub leaf_level: Vec<u8>,
    /// The mip-map caster's counts (its samples).
    pub mip: Option<MipStats>,
}

impl Refined {
    /// The frame [`crate::render::render`] returns for a refined frame
    /// (its gaze stats are the refinement's rays per level), and the
    /// refinement's own per-pixel leaf levels and stats.
    pub fn into_frame(self) -> (crate::render::Frame, Vec<u8>, RefineStats) {
        let frame = crate::render::Frame {
            image: self.image,
            slice: None,
            mip: self.mip,
            gaze: Some(self.stats.as_gaze()),
            sw: None,
            er_gaze: None,
        };
        (frame, self.leaf_level, self.stats)
    }
}

/// One step of a progressive sequence.
#[derive(Debug, Clone)]
pub struct Step {
    /// Step number from 1.
    pub index: usize,
    /// The image after this step.
    pub image: Image,
    /// Rays this step cast.
    pub rays_new: u64,
    /// Rays cast by all steps so far.
    pub rays: u64,
    /// Seconds spent casting and interpolating over all steps so far (not
    /// counting what the caller does with each step).
    pub time_s: f64,
    /// Rays and leaves per level so far.
    pub stats: RefineStats,
}

/// Most steps a progressive sequence may have.
pub const MAX_STEPS: usize = 1000;

fn refuse_technique(tech: Technique) -> Result<()> {
    match tech {
        Technique::Reference | Technique::MipMap => Ok(()),
        t => Err(input(format!(
            "--refine applies to the reference and the mip-map, not {}: ER's rays live in object space (docs/golden.md#adaptive-and-progressive-refinement)",
            t.name()
        ))),
    }
}

/// Runs `job` with the caster of `tech`'s full-resolution pixel rays;
/// returns its result and, for the mip-map, the caster's counts.
fn with_caster<R>(
    prep: &Prepared,
    lut: &Lut,
    tech: Technique,
    opts: &RenderOptions,
    job: impl Job<R>,
) -> Result<(R, Option<MipStats>)> {
    refuse_technique(tech)?;
    if tech == Technique::Reference {
        let o = &opts.reference;
        let pass = RefPass::new(&prep.view, &prep.stack, o)?;
        let view = &prep.view;
        let cast =
            |x: f64, y: f64, _: &mut ()| cast_ray(&pass, &prep.clip, lut, o, view.rays.dir(x, y));
        return job.run((), |_, _| {}, &cast).map(|(r, ())| (r, None));
    }
    let mip = opts.mip();
    mip.validate()?;
    let pyramid = prep.mipmap_of(lut, &mip)?;
    mipcast::with_pixel_caster(
        &prep.view,
        &pyramid,
        &prep.clip,
        lut,
        &mip,
        |empty, cast| job.run(empty, MipStats::add, cast),
    )?
    .map(|(r, st)| (r, Some(st)))
}

/// What runs with a caster, generic over the caster's counts `S`
/// (per-task counts start from `empty` and are summed with `add`).
trait Job<R> {
    fn run<S: Send + Sync + Clone>(
        self,
        empty: S,
        add: impl Fn(&mut S, &S),
        cast: &(dyn Fn(f64, f64, &mut S) -> [f64; 4] + Sync),
    ) -> Result<(R, S)>;
}

/// The adaptive frame.
struct Once {
    size: [u32; 2],
    refine: Refine,
    gaze: Option<crate::gaze::Gaze>,
}

impl Job<Refined> for Once {
    fn run<S: Send + Sync + Clone>(
        self,
        empty: S,
        add: impl Fn(&mut S, &S),
        cast: &(dyn Fn(f64, f64, &mut S) -> [f64; 4] + Sync),
    ) -> Result<(Refined, S)> {
        let mut rf = Refiner::new(self.size, self.refine, self.gaze)?;
        let mut counts = empty.clone();
        rf.refine(|| empty.clone(), add, &mut counts, cast);
        let (image, leaf_level) = rf.image();
        Ok((
            Refined {
                image,
                stats: rf.stats(),
                leaf_level,
                mip: None,
            },
            counts,
        ))
    }
}

/// Renders `prep` with `tech` (reference or mip-map) adaptively refined
/// by `refine`, and by `opts.reference.gaze`'s profile when it is set.
pub fn render(
    prep: &Prepared,
    lut: &Lut,
    tech: Technique,
    opts: &RenderOptions,
    refine: &Refine,
) -> Result<Refined> {
    let job = Once {
        size: prep.view.size,
        refine: *refine,
        gaze: opts.reference.gaze,
    };
    let (mut r, mip) = with_caster(prep, lut, tech, opts, job)?;
    r.mip = mip;
    Ok(r)
}

/// The progressive sequence.
struct Progressive<F> {
    size: [u32; 2],
    refine: Refine,
    gaze: Option<crate::gaze::Gaze>,
    steps: usize,
    on_step: F,
}

impl<F: FnMut(&Step) -> Result<()>> Job<()> for Progressive<F> {
    fn run<S: Send + Sync + Clone>(
        mut self,
        empty: S,
        add: impl Fn(&mut S, &S),
        cast: &(dyn Fn(f64, f64, &mut S) -> [f64; 4] + Sync),
    ) -> Result<((), S)> {
        let mut spent = 0.0;
        let t = Instant::now();
        let mut rf = Refiner::new(self.size, self.refine, self.gaze)?;
        let mut counts = empty.clone();
        rf.refine(|| empty.clone(), &add, &mut counts, cast);
        let mut rays_new = rf.rays();
        for index in 1..=self.steps {
            if index > 1 {
                let t = Instant::now();
                let left = rf.pixels() - rf.rays();
                let budget = left.div_ceil((self.steps - index + 1) as u64);
                rays_new = rf.step(budget, || empty.clone(), &add, &mut counts, cast);
                spent += t.elapsed().as_secs_f64();
            }
            let t_img = Instant::now();
            let (image, _) = rf.image();
            spent += t_img.elapsed().as_secs_f64();
            if index == 1 {
                spent = t.elapsed().as_secs_f64();
            }
            (self.on_step)(&Step {
                index,
                image,
                rays_new,
                rays: rf.rays(),
                time_s: spent,
                stats: rf.stats(),
            })?;
        }
        debug_assert!(rf.complete());
        Ok(((), counts))
    }
}

/// Progressive refinement of a resting view: `steps` frames, the first
/// the adaptive frame of `refine` (and `opts.reference.gaze`), each next
/// one casting an equal share of the rays still uncast in priority order
/// ([`Refiner::step`]), the last completing every pixel's ray (the
/// one-ray-per-pixel frame bit for bit). No ray is cast twice. Each step
/// goes to `on_step`, whose time is not counted.
pub fn progressive(
    prep: &Prepared,
    lut: &Lut,
    tech: Technique,
    opts: &RenderOptions,
    refine: &Refine,
    steps: usize,
    on_step: impl FnMut(&Step) -> Result<()>,
) -> Result<()> {
    if !(2..=MAX_STEPS).contains(&steps) {
        return Err(input(format!(
            "progressive refinement takes 2 to {MAX_STEPS} steps, not {steps}"
        )));
    }
    let job = Progressive {
        size: prep.view.size,
        refine: *refine,
        gaze: opts.reference.gaze,
        steps,
        on_step,
    };
    with_caster(prep, lut, tech, opts, job).map(|((), _)| ())
}

/// The one-ray-per-pixel frame of `tech` the refined frames save
/// against: the reference's pixel-centre rays at its step (not its
/// supersampled grid), or the mip-map caster's frame.
pub fn full(prep: &Prepared, lut: &Lut, tech: Technique, opts: &RenderOptions) -> Result<Image> {
    refuse_technique(tech)?;
    let mut o = *opts;
    o.reference.refine = None;
    o.reference.gaze = match tech {
        Technique::Reference => Some(crate::gaze::Gaze::full(
            prep.view.size[0],
            prep.view.size[1],
        )),
        _ => None,
    };
    Ok(crate::render::render(prep, lut, tech, &o)?.image)
}
