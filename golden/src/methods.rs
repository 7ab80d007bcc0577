//! The slice-order methods: ER-Perspective back-to-front (`er`) and
//! front-to-back (`er-ftb`), the box-merge variant (`box`), and the
//! under- and oversampling baselines. All walk the slices along the
//! principal axis and produce a [`Baseplane`], which [`crate::warp`] turns
//! into the final image.

use std::str::FromStr;

use crate::error::{input, Result};
use crate::geometry::{Layout, Merge, View};
use crate::merge::{fold_into, merge, recycle, split_kept, zeroed, Rgba};
use crate::occupancy::Occupancy;
use crate::preint::Colouring;
use crate::render::Prepared;
use crate::sampling::{sample_region, Order, Pass, RegionCount, MAX_SUBSTEPS};
use crate::shading::{GradientMode, Shade, Shader};
use crate::skip::{MaskSpec, SampleMask, Skips, GOLDEN_MARGIN};
use crate::tf::Lut;
use crate::voi::{ViewVoi, Voi};
use crate::warp::{Baseplane, PixelWindow};

/// A slice-order rendering method.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Method {
    /// ER-Perspective back-to-front with the Bartlett merge.
    Er,
    /// ER-Perspective front-to-back with the bilinear split.
    ErFtb,
    /// One ray per voxel at the front, diverging behind.
    Under,
    /// One ray per voxel at the rear, converging in front.
    Over,
    /// ER with a 2x2 box merge instead of Bartlett (Novins-style).
    Box,
}

impl Method {
    /// Every slice-order method, in the order tables list them.
    pub const ALL: [Method; 5] = [
        Method::Er,
        Method::ErFtb,
        Method::Under,
        Method::Over,
        Method::Box,
    ];

    /// The method's name on the command line.
    pub fn name(self) -> &'static str {
        match self {
            Method::Er => "er",
            Method::ErFtb => "er-ftb",
            Method::Under => "under",
            Method::Over => "over",
            Method::Box => "box",
        }
    }

    /// The rays this method casts for `view`.
    pub fn layout(self, view: &View) -> Result<Layout> {
        match self {
            Method::Er | Method::ErFtb => Layout::exponential(view, Merge::Bartlett),
            Method::Box => Layout::exponential(view, Merge::Box),
            Method::Under => Layout::single(view, 0.0),
            Method::Over => Layout::single(view, (view.dims[2] as f64 - 1.0).max(0.0)),
        }
    }
}

impl FromStr for Method {
    type Err = crate::Error;
    fn from_str(s: &str) -> Result<Method> {
        Method::ALL
            .into_iter()
            .find(|m| m.name() == s)
            .ok_or_else(|| {
                input(format!(
                    "unknown method '{s}': use er, er-ftb, under, over or box"
                ))
            })
    }
}

/// Options of the slice-order methods.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Options {
    /// Early ray termination threshold for `er-ftb` (1.0 disables it).
    pub terminate: f32,
    /// Samples per slice crossing (see [`crate::sampling`]); 1 is the
    /// paper's scheme.
    pub substeps: u32,
    /// Empty-space skipping and culling (neither changes the image).
    pub skips: Skips,
    /// Gradient shading before compositing (see [`crate::shading`]);
    /// `None` renders emission-absorption only.
    pub shade: Option<Shade>,
    /// A volume of interest scaling opacity (see [`crate::voi`]).
    pub voi: Option<Voi>,
    /// Pre-integrated classification of each slice step from its front
    /// and back scalars (see [`crate::preint`]).
    pub preintegrate: bool,
    /// How a pre-integrated step weighs the colours along it (see
    /// [`crate::preint::Colouring`]).
    pub pre_colouring: Colouring,
    /// Plain samples (one substep, no pre-integration, shading or volume
    /// of interest) taken eight rays at a time (see `sampling::lanes`),
    /// which gives the one-ray path's bits faster, and pre-integrated
    /// steps reusing their neighbour step's tap (`sampling::TapCache`);
    /// `false` takes the one-ray path with both taps of every step, for
    /// the identity tests and benchmarks.
    pub lanes: bool,
}

impl Default for Options {
    fn default() -> Options {
        Options {
            terminate: 0.99,
            substeps: DEFAULT_SUBSTEPS,
            skips: Skips::default(),
            shade: None,
            voi: None,
            preintegrate: false,
            pre_colouring: Colouring::Fast,
            lanes: true,
        }
    }
}

/// Default samples per slice crossing: one, the paper's scheme and the
/// chip's. Two substeps trade twice the samples for much less error on
/// hard-edged data (see [`crate::sampling`] and docs/golden.md).
pub const DEFAULT_SUBSTEPS: u32 = 1;

impl Options {
    /// Refuses options no method can run with.
    pub fn validate(&self) -> Result<()> {
        if !(self.terminate.is_finite() && self.terminate > 0.0 && self.terminate <= 1.0) {
            return Err(input(format!(
                "termination threshold {} must lie in (0, 1]",
                self.terminate
            )));
        }
        if !(1..=MAX_SUBSTEPS).contains(&self.substeps) {
            return Err(input(format!(
                "substeps {} must be 1 to {MAX_SUBSTEPS}",
                self.substeps
            )));
        }
        if let Some(sh) = &self.shade {
            sh.validate()?;
        }
        if let Some(v) = &self.voi {
            v.validate()?;
        }
        if !self.preintegrate && self.pre_colouring != Colouring::Fast {
            return Err(input(format!(
                "--pre-colouring {} weighs pre-integrated steps; add --preintegrate",
                self.pre_colouring.name()
            )));
        }
        if self.preintegrate {
            if self.substeps != 1 {
                return Err(input(
                    "--preintegrate classifies whole slice steps; drop --substeps",
                ));
            }
            if self.shade.is_some() {
                return Err(input(
                    "--preintegrate does not shade yet; drop the shading options",
                ));
            }
        }
        Ok(())
    }
}

/// What a slice-order render counted.
#[derive(Debug, Clone, PartialEq, Default, serde::Serialize)]
pub struct Stats {
    /// Region boundaries `b_0..b_K` in slices.
    pub regions: Vec<f64>,
    /// Samples taken in all.
    pub samples_total: u64,
    /// Samples per slice along the principal axis, front (slice 0) to back.
    pub samples_per_slice: Vec<u64>,
    /// Rays per region, front (region 0) to back.
    pub rays_per_region: Vec<u64>,
    /// Region boundaries at which rays were merged (or split).
    pub merges: u64,
    /// Samples per slice crossing.
    pub substeps: u32,
    /// Slices skipped whole: empty, clipped away or behind the volume.
    pub slices_skipped: u64,
    /// Ray rows skipped in sampled slices: empty, clipped or terminated.
    pub beams_skipped: u64,
    /// Rays culled (cannot reach the image), summed over regions.
    pub rays_culled: u64,
    /// Regions behind the last visible slice, not run.
    pub regions_skipped: u64,
    /// Fraction of blocks occupied under the table (1 when not skipping).
    pub occupied_blocks: f64,
}

impl Stats {
    fn add(&mut self, slices: std::ops::Range<usize>, c: RegionCount) {
        for (z, n) in slices.zip(c.samples) {
            self.samples_per_slice[z] += n;
        }
        self.beams_skipped += c.beams_skipped;
        self.slices_skipped += c.slices_skipped;
    }
}

/// A slice-order render before the warp.
#[derive(Debug, Clone)]
pub struct Output {
    /// Region 0's rays at slice 0.
    pub baseplane: Baseplane,
    /// Counts.
    pub stats: Stats,
}

/// Renders `prep` with `method`.
pub fn render(method: Method, prep: &Prepared, lut: &Lut, opts: &Options) -> Result<Output> {
    render_within(method, prep, lut, opts, None)
}

/// [`render`] of a frame whose image is needed only in `window`: the rays
/// are culled to it (see [`SampleMask::within`]), and the baseplane is
/// exact for the window's pixels only.
pub fn render_within(
    method: Method,
    prep: &Prepared,
    lut: &Lut,
    opts: &Options,
    window: Option<&PixelWindow>,
) -> Result<Output> {
    opts.validate()?;
    let view = &prep.view;
    let layout = method.layout(view)?;
    let preint = opts
        .preintegrate
        .then(|| prep.preint_for(lut, opts.pre_colouring));
    // A pre-integrated step reads slices z and z + 1, and its table may
    // see a little beyond the entries its scalars look up.
    let occ = opts.skips.empty.then(|| match &preint {
        Some(pt) => prep.occupancy_for(pt.occupancy_lut(lut)),
        None => prep.occupancy_for(lut),
    });
    let mask = SampleMask::within(
        view,
        &layout,
        MaskSpec {
            occupancy: occ.as_deref(),
            clip: prep.clip.clone(),
            cull: opts.skips.cull,
            ftb: method == Method::ErFtb,
            margin: GOLDEN_MARGIN,
            // Pre-integration reads the next slice, like substeps do.
            substeps: if opts.preintegrate { 2 } else { opts.substeps },
        },
        window,
    );
    let mut stats = Stats {
        substeps: opts.substeps,
        regions: layout.bounds.clone(),
        samples_per_slice: vec![0; view.dims[2]],
        rays_per_region: layout.grids.iter().map(|g| g.len() as u64).collect(),
        rays_culled: mask.culled_rays,
        occupied_blocks: occ.as_deref().map_or(1.0, Occupancy::fraction),
        ..Stats::default()
    };
    let order = match method {
        Method::ErFtb => Order::FrontToBack {
            terminate: opts.terminate,
        },
        _ => Order::BackToFront,
    };
    let shader = match &opts.shade {
        Some(sh) => {
            let grads = (sh.gradient == GradientMode::Voxels).then(|| prep.gradients());
            Some(Shader::with_gradients(view, grads, sh)?)
        }
        None => None,
    };
    let voi = match &opts.voi {
        Some(v) => Some(ViewVoi::new(view, v)?),
        None => None,
    };
    let pass = Pass {
        view,
        stack: &prep.stack,
        lut,
        mask: &mask,
        order,
        substeps: opts.substeps,
        shader: shader.as_ref(),
        voi: voi.as_ref(),
        preint: preint.as_deref(),
        lanes: opts.lanes,
        clear_below: lut.clear_below(),
    };
    let runs = mask.regions_to_run();
    stats.regions_skipped = (layout.grids.len() - runs) as u64;
    for i in runs..layout.grids.len() {
        stats.slices_skipped += layout.grids[i].slices.len() as u64;
    }
    let base = match method {
        Method::ErFtb => front_to_back(&layout, runs, &pass, &mut stats),
        _ => back_to_front(&layout, runs, &pass, &mut stats),
    };
    stats.samples_total = stats.samples_per_slice.iter().sum();
    Ok(Output {
        baseplane: Baseplane {
            grid: layout.baseplane(),
            data: base,
        },
        stats,
    })
}

/// Back-to-front: each region's rays composite its slices from the rear,
/// then merge into the next region's rays. Only the first `runs` regions
/// run; the rest would composite nothing.
fn back_to_front(layout: &Layout, runs: usize, pass: &Pass, stats: &mut Stats) -> Vec<Rgba> {
    let mut buf = zeroed(layout.grids[runs - 1].len());
    for i in (0..runs).rev() {
        let grid = &layout.grids[i];
        stats.add(grid.slices.clone(), sample_region(pass, i, grid, &mut buf));
        if i > 0 {
            let kind = layout.merge.expect("multi-region layouts merge");
            let next = merge(kind, &buf, grid, &layout.grids[i - 1]);
            recycle(std::mem::replace(&mut buf, next));
            stats.merges += 1;
        }
    }
    buf
}

/// Front-to-back: each region's rays composite its slices from the front,
/// then split into the next region's rays. Folding back into one image:
/// every ray's result is its own final state plus the Bartlett merge of
/// what its children added behind it (child result minus what the child
/// inherited at the split). A ray whose children sample nothing keeps its
/// state exactly, and with zero opacity in front the fold is the
/// back-to-front merge cascade.
fn front_to_back(layout: &Layout, runs: usize, pass: &Pass, stats: &mut Stats) -> Vec<Rgba> {
    // finals[i]: region i's rays after its last slice; inherited[i - 1]:
    // what region i's rays received at the split (region 0 inherits zero).
    let mut finals: Vec<Vec<Rgba>> = Vec::with_capacity(runs);
    let mut inherited: Vec<Vec<Rgba>> = Vec::with_capacity(runs.saturating_sub(1));
    let mut buf = zeroed(layout.grids[0].len());
    for i in 0..runs {
        let grid = &layout.grids[i];
        if i > 0 {
            let (next, kept) = split_kept(&buf, &layout.grids[i - 1], grid);
            finals.push(std::mem::replace(&mut buf, next));
            stats.merges += 1;
            inherited.push(kept);
        }
        stats.add(grid.slices.clone(), sample_region(pass, i, grid, &mut buf));
    }
    let kind = layout.merge.expect("ER layouts merge");
    let mut result = buf;
    for i in (1..runs).rev() {
        // What region i's rays added behind their inheritance, merged
        // onto region i - 1's final states.
        let inh = inherited.pop().expect("one inheritance per split");
        let mut front = finals.pop().expect("one final state per region");
        fold_into(
            kind,
            (&result, &inh),
            (&layout.grids[i], &layout.grids[i - 1]),
            &mut front,
        );
        recycle(inh);
        recycle(std::mem::replace(&mut result, front));
    }
    result
}
