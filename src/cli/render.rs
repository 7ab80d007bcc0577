//! `ercube render`: one image of a volume with one method.

use std::path::PathBuf;
use std::sync::Arc;
use std::time::Instant;

use anyhow::Result;
use clap::Args;

use golden::render::{lut_for, render, Prepared, Technique};

use super::args::{with_threads, SliceArgs, ViewArgs};
use super::chip::{self, PipelineArgs};
use super::memory::FrameSpec;
use super::method::MethodArg;
use super::progress::Stage;
use super::stats::{frame_json, median, write_json};
use pipeline::cost::clock::ClockSource;

mod pipeline_frame;
mod versus;
use pipeline_frame::frame_pipeline;
pub use versus::refine_of;
pub use versus::Rays;
use versus::{footprint_level_of, footprint_of, gaze_of, versus_full, versus_reference};

/// Arguments of `ercube render`.
#[derive(Debug, Clone, Args)]
pub struct RenderArgs {
    #[command(flatten)]
    pub view: ViewArgs,
    /// Method.
    #[arg(long, value_enum, default_value = "er")]
    pub method: MethodArg,
    /// Output PNG (RGB over black).
    #[arg(long, default_value = "render.png")]
    pub out: PathBuf,
    /// Write statistics as JSON here.
    #[arg(long)]
    pub stats: Option<PathBuf>,
    /// Write the final RGBA image as float32 H x W x 4 .npy here.
    #[arg(long)]
    pub npy: Option<PathBuf>,
    /// Write the baseplane image (before the warp) as float32 .npy here.
    #[arg(long)]
    pub baseplane_npy: Option<PathBuf>,
    /// Also render the reference and report the error against it.
    #[arg(long)]
    pub compare_reference: bool,
    #[command(flatten)]
    pub slice: SliceArgs,
    /// Worker threads (default: all cores); results are identical for any count.
    #[arg(long)]
    pub threads: Option<usize>,
    /// Render this many frames and report the median time (the image is
    /// the last frame's; every frame is identical).
    #[arg(long, default_value_t = 1)]
    pub repeat: usize,
    #[command(flatten)]
    pub pipeline: PipelineArgs,
    /// er, er-ftb and the pipeline: how many rays. `voxels` (default)
    /// casts the paper's one to two rays per voxel whatever the image;
    /// `footprint` casts no more than the image needs: the frame at the
    /// coarsest prefiltered level whose rays still give every pixel two
    /// across (docs/golden.md#rays-matched-to-the-image; the pipeline's
    /// host loads the PEs with that level, docs/pipeline.md).
    #[arg(long, value_enum, default_value_t = Rays::Voxels)]
    pub rays: Rays,
    /// Reference, mipmap, er and er-ftb: gaze-directed variable resolution
    /// around pixel x,y (full resolution near it, one ray per 16 pixels and
    /// a quarter of the samples at the periphery; ER renders one frame per
    /// level; docs/golden.md#gaze-directed-variable-resolution).
    #[arg(long, value_parser = super::args::parse_point2, allow_hyphen_values = true)]
    pub gaze: Option<[f64; 2]>,
    /// With --gaze: the profile's radii in pixels, inner (full
    /// resolution) and outer (coarsest level); default a tenth and four
    /// tenths of the image's larger side.
    #[arg(long, value_parser = super::args::parse_point2)]
    pub gaze_radii: Option<[f64; 2]>,
    /// With --gaze: the coarsest level (one ray per 2^L x 2^L pixels).
    #[arg(long, default_value_t = 2)]
    pub gaze_levels: u32,
    /// With --gaze: also render the same method at full resolution (the
    /// reference: one ray per pixel) and report its time and samples and
    /// the error inside the sweet spot (within the inner radius) and
    /// outside it, separately.
    #[arg(long)]
    pub compare_full: bool,
    /// Reference and mipmap: adaptive refinement, `complexity` or
    /// `complexity:THRESHOLD` (default 0.02): one ray per 2^L x 2^L
    /// pixels, cells split while a channel differs across their corners
    /// by more than the threshold, the rest interpolated bilinearly; with
    /// --gaze, only where the profile allows too. With --compare-full,
    /// the error inside refined cells and inside unsplit ones
    /// (docs/golden.md#adaptive-and-progressive-refinement).
    #[arg(long, value_name = "complexity[:THRESHOLD]")]
    pub refine: Option<String>,
    /// With --refine: the coarsest level L (one ray per 2^L x 2^L pixels),
    /// 1 to 6.
    #[arg(long, default_value_t = golden::refine::Refine::DEFAULT_LEVELS)]
    pub refine_levels: u32,
}

/// Runs `f` `n` times (at least once), returning the last result and each
/// run's wall-clock seconds.
pub fn timed<T>(n: usize, f: impl FnMut() -> Result<T>) -> Result<(T, Vec<f64>)> {
    timed_with(n, f, drop)
}

/// [`timed`] for golden frames: each frame but the last gives its buffers
/// back before the next starts (untimed), as a renderer drawing frame
/// after frame does.
pub fn timed_frames(
    n: usize,
    f: impl FnMut() -> Result<golden::render::Frame>,
) -> Result<(golden::render::Frame, Vec<f64>)> {
    timed_with(n, f, golden::render::Frame::recycle)
}

/// [`timed`], handing each result but the last to `done` before the next
/// run starts.
fn timed_with<T>(
    n: usize,
    mut f: impl FnMut() -> Result<T>,
    mut done: impl FnMut(T),
) -> Result<(T, Vec<f64>)> {
    if n == 0 || n > 100_000 {
        anyhow::bail!("--repeat {n} must be 1 to 100000");
    }
    let mut times = Vec::with_capacity(n);
    let mut last = None;
    for _ in 0..n {
        if let Some(prev) = last.take() {
            done(prev);
        }
        let t = Instant::now();
        last = Some(f()?);
        times.push(t.elapsed().as_secs_f64());
    }
    Ok((last.expect("at least one run"), times))
}

/// One `ercube render` frame in memory: everything `run` writes, before
/// it is written (the library's route, `ercube::frame`, returns it).
pub struct Rendered {
    /// The final image (`--out`, `--npy`).
    pub image: golden::image::Image,
    /// The baseplane before the warp of a slice-order golden method
    /// (`--baseplane-npy`; the pipeline's is in [`Rendered::chip`]).
    pub baseplane: Option<golden::warp::Baseplane>,
    /// The pipeline's frame: raw accumulator words (`--raw-npy`), cycles
    /// and counters; `None` for golden methods.
    pub chip: Option<pipeline::Frame>,
    /// What `--stats` writes.
    pub stats: serde_json::Value,
    /// The one-line summary the command prints (before ` -> OUT`).
    pub summary: String,
    /// Further lines the command prints after the summary (the pipeline's
    /// frame rate).
    pub notes: Vec<String>,
}

impl Rendered {
    /// Writes the files `a` asks for: the PNG, `--npy`,
    /// `--baseplane-npy`, `--raw-npy` and `--stats`, each atomically.
    fn write(&self, a: &RenderArgs) -> Result<()> {
        self.image.write_png(&a.out)?;
        if let Some(p) = &a.npy {
            self.image.write_npy(p)?;
        }
        let base = (self.baseplane.as_ref()).or(self.chip.as_ref().map(|f| &f.baseplane));
        if let (Some(p), Some(b)) = (&a.baseplane_npy, base) {
            b.to_image().write_npy(p)?;
        }
        if let (Some(p), Some(f)) = (&a.pipeline.raw_npy, &self.chip) {
            chip::write_raw_npy(p, f)?;
        }
        if let Some(p) = &a.stats {
            write_json(p, &self.stats)?;
        }
        Ok(())
    }
}

/// Runs `ercube render`: every output path is checked first, and the
/// outputs appear together only if the whole run succeeds.
pub fn run(a: &RenderArgs) -> Result<()> {
    let p = &a.pipeline;
    super::outputs::check_files(&[
        Some(&a.out),
        a.stats.as_deref(),
        a.npy.as_deref(),
        a.baseplane_npy.as_deref(),
        p.vcd.as_deref(),
        p.fst.as_deref(),
        p.raw_npy.as_deref(),
    ])?;
    let (summary, notes) = super::outputs::all_or_nothing(&[], || {
        let r = frame(a, None)?;
        r.write(a)?;
        Ok((r.summary, r.notes))
    })?;
    super::say(&format!("{summary} -> {}", a.out.display()));
    for n in notes {
        super::say(&n);
    }
    Ok(())
}

/// Renders the frame `a` describes, of the volume `given` in memory
/// (instead of `--scene` or `--volume`) when it is `Some`, and writes
/// nothing.
pub fn frame(a: &RenderArgs, given: Option<golden::volume::Volume>) -> Result<Rendered> {
    frame_reusing(a, given, None)
}

/// [`frame`], preparing the volume through `reuse` when it is given: a
/// caller rendering frame after frame in one process keeps what the last
/// frame prepared.
pub fn frame_reusing(
    a: &RenderArgs,
    given: Option<golden::volume::Volume>,
    reuse: Option<&mut Reuse>,
) -> Result<Rendered> {
    let Some(tech) = a.method.technique() else {
        return with_threads(a.threads, || frame_pipeline(a, given, reuse, None));
    };
    chip::check_unused(&a.pipeline)?;
    with_threads(a.threads, || frame_golden(a, tech, given, reuse))
}

/// [`frame`] of a pipeline method, stepped from outside: the array's
/// clock hands every cycle over through `tap`
/// ([`pipeline::stepper::Stepper`]). The frame runs once, clocked, with the
/// same image, raw words and statistics as [`frame`]'s (apart from the
/// wall-clock times).
pub fn frame_tapped(
    a: &RenderArgs,
    given: Option<golden::volume::Volume>,
    tap: pipeline::stepper::Tap,
) -> Result<Rendered> {
    if a.method.technique().is_some() {
        anyhow::bail!(
            "only the pipeline steps cycle by cycle; {} is a golden method",
            a.method.name()
        );
    }
    if a.repeat != 1 {
        anyhow::bail!("a stepped frame runs once; drop --repeat {}", a.repeat);
    }
    with_threads(a.threads, || frame_pipeline(a, given, None, Some(tap)))
}

/// The last frame's volume and its preparation, kept between the frames of
/// a caller that renders many in one process (the Python module): the same
/// voxels seen again, by any camera, are prepared by [`Prepared::moved`],
/// which keeps the permuted slice stack while the principal axis holds and
/// the empty-space blocks and occupancy map while the block size does,
/// instead of building them again; by the same camera and preparation
/// options, the kept preparation is taken whole. Frames are the same as
/// without it; the cost is that the last volume and its stack stay in
/// memory.
///
/// A caller holding the voxels elsewhere (a numpy array) can have the
/// kept volume lent back for the next frame ([`Reuse::lend_if`]) instead
/// of copying its voxels into a new one.
///
/// A pipeline frame also leaves its PE memories and datapath here, as the
/// command's `--repeat` frames hand them on ([`pipeline::Resident`]): the
/// next pipeline frame loads its volume again into those buffers and takes
/// the datapath's tables when its configuration and table are the same.
#[derive(Default)]
pub struct Reuse {
    /// The kept volume (`None` while it is lent to a frame) and its
    /// preparation.
    last: Option<(Option<golden::volume::Volume>, Arc<Prepared>)>,
    /// The last pipeline frame's memories and datapath.
    spare: Option<pipeline::Resident>,
    /// The buffer the kept volume's voxels were copied from, when it is
    /// one that cannot change ([`Frozen`]): the same buffer seen again
    /// holds the same voxels, so they need no comparison. Reset whenever
    /// another volume is kept.
    frozen: Option<Frozen>,
    /// The camera and options the kept preparation was placed for (set
    /// with it, read only beside it).
    placed: Option<(golden::camera::Camera, golden::render::PrepareOptions)>,
}

/// Where a caller's voxels lie in a buffer that cannot change while it
/// is alive (the Python module's read-only arrays of `ercube.load`): the
/// buffer's identity, never given to another buffer in the process, and
/// the voxels' first byte's offset in it. Two borrowed volumes with the
/// same `Frozen`, dimensions and voxel type hold the same voxels.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Frozen {
    /// The buffer's identity.
    pub buffer: u64,
    /// The voxels' offset in it, in bytes.
    pub offset: usize,
}

impl Reuse {
    /// Nothing kept yet.
    pub const fn new() -> Reuse {
        Reuse {
            last: None,
            spare: None,
            frozen: None,
            placed: None,
        }
    }

    /// Drops the kept volume, preparation, memories and datapath.
    pub fn clear(&mut self) {
        self.last = None;
        self.spare = None;
        self.frozen = None;
        self.placed = None;
    }

    /// The unchanging buffer the kept volume was copied from, if any.
    pub fn frozen(&self) -> Option<Frozen> {
        self.frozen
            .filter(|_| matches!(self.last, Some((Some(_), _))))
    }

    /// Records that the kept volume, which the frame just ended was given,
    /// was copied from (or is still) the voxels at `frozen`; nothing when
    /// no volume is kept.
    pub fn kept_from(&mut self, frozen: Option<Frozen>) {
        self.frozen = frozen.filter(|_| matches!(self.last, Some((Some(_), _))));
    }

    /// The kept volume, lent for the next frame when `same` says it is
    /// the one wanted; otherwise `None` and the kept volume is dropped.
    /// The next frame given the lent volume, unchanged, gives it back with
    /// its preparation; [`Reuse::end_loan`] after that frame drops a
    /// preparation whose volume did not come back (the frame failed or
    /// prepared without the kept one).
    pub fn lend_if(
        &mut self,
        same: impl FnOnce(&golden::volume::Volume) -> bool,
    ) -> Option<golden::volume::Volume> {
        match &mut self.last {
            Some((kept @ Some(_), _)) if kept.as_ref().is_some_and(same) => kept.take(),
            _ => {
                self.last = None;
                None
            }
        }
    }

    /// Ends a loan of [`Reuse::lend_if`]: a preparation whose volume was
    /// not given back is dropped.
    pub fn end_loan(&mut self) {
        if matches!(self.last, Some((None, _))) {
            self.last = None;
        }
    }

    /// `vol` prepared for `cam` with `slice`'s options, from the last
    /// frame's preparation when `vol` holds the same voxels and spacing
    /// (or is the volume [`Reuse::lend_if`] lent).
    fn prepared(
        &mut self,
        vol: golden::volume::Volume,
        cam: &golden::camera::Camera,
        slice: &SliceArgs,
    ) -> Result<Arc<Prepared>> {
        let opts = slice.prepare()?;
        let same = |v: &golden::volume::Volume| {
            v.dims() == vol.dims() && v.spacing() == vol.spacing() && v.voxels() == vol.voxels()
        };
        // The same camera and options keep the whole preparation, the
        // camera's own parts (the view, its coarse levels) too.
        let placed = self.placed.as_ref() == Some(&(*cam, opts.clone()));
        let prep = match &self.last {
            Some((None, p)) if placed => Arc::clone(p),
            Some((None, p)) => Arc::new(p.moved(&vol, cam, &opts)?),
            Some((Some(v), p)) if same(v) && placed => Arc::clone(p),
            Some((Some(v), p)) if same(v) => Arc::new(p.moved(v, cam, &opts)?),
            _ => {
                // The old volume goes before the new one is prepared.
                self.last = None;
                Arc::new(Prepared::with(&vol, cam, &opts)?)
            }
        };
        self.last = Some((Some(vol), Arc::clone(&prep)));
        self.placed = Some((*cam, opts));
        self.frozen = None;
        Ok(prep)
    }
}

/// `vol` prepared for `cam`: through `reuse` when given, else owning the
/// voxels (a one-off frame holds them once, as the slice stack).
fn prepare_for(
    slice: &SliceArgs,
    vol: golden::volume::Volume,
    cam: &golden::camera::Camera,
    reuse: Option<&mut Reuse>,
) -> Result<Arc<Prepared>> {
    match reuse {
        Some(r) => r.prepared(vol, cam, slice),
        None => Ok(Arc::new(slice.prepared_owning(vol, cam)?)),
    }
}

/// [`frame`] with a golden method.
fn frame_golden(
    a: &RenderArgs,
    tech: Technique,
    given: Option<golden::volume::Volume>,
    reuse: Option<&mut Reuse>,
) -> Result<Rendered> {
    if !matches!(tech, Technique::Slice(_)) && a.slice.preintegrate {
        anyhow::bail!(
            "--preintegrate applies to the slice-order methods; {} does not take it",
            tech.name()
        );
    }
    if !matches!(tech, Technique::Slice(_)) && a.baseplane_npy.is_some() {
        anyhow::bail!(
            "--baseplane-npy needs a slice-order method; {} has no baseplane",
            tech.name()
        );
    }
    let mut opts = a.slice.options()?;
    let spec = FrameSpec {
        technique: Some(tech),
        shade: opts.slice.shade.is_some(),
        size: a.view.camera.size,
    };
    let (vol, tf, cam) = a.view.load_given(tech.name(), &spec, given)?;
    a.slice.apply_tf(&mut opts, &tf)?;
    // The comparison's reference is always the full one.
    let full = opts;
    opts.reference.gaze = gaze_of(a, &cam, tech)?;
    if a.rays == Rays::Footprint {
        opts.reference.gaze = footprint_of(a, &vol, &cam, tech)?;
    }
    opts.reference.refine = refine_of(a.refine.as_deref(), a.refine_levels, tech)?;
    let lut = lut_for(vol.kind(), &tf);
    if a.baseplane_npy.is_some() && opts.reference.gaze.is_some() {
        anyhow::bail!(
            "--baseplane-npy: a gaze-directed frame has one baseplane per level; drop one of them"
        );
    }
    let shape = (vol.dims(), vol.spacing());
    let prep = match (&opts.reference.gaze, tech) {
        // The gaze levels filter the volume itself, so a gaze-directed
        // slice-order frame keeps it beside the stack.
        (Some(g), Technique::Slice(_)) => {
            let prep = a.slice.prepared(&vol, &cam)?;
            let _s = Stage::start("preparing the gaze levels");
            Arc::new(prep.with_gaze_levels(&vol, &cam, &a.slice.prepare()?, g.levels)?)
        }
        _ => prepare_for(&a.slice, vol, &cam, reuse)?,
    };
    let (frame, times, leaf_level) = match &opts.reference.refine {
        Some(r) => {
            let _s = Stage::start(format!("rendering with {} refined", tech.name()));
            let (out, times) = timed(a.repeat, || {
                Ok(golden::refine::frame::render(&prep, &lut, tech, &opts, r)?)
            })?;
            let (frame, leaf_level, stats) = out.into_frame();
            (frame, times, Some((leaf_level, stats)))
        }
        None => {
            let _s = Stage::start(format!("rendering with {}", tech.name()));
            let (f, t) = timed_frames(a.repeat, || Ok(render(&prep, &lut, tech, &opts)?))?;
            (f, t, None)
        }
    };
    let time_s = median(&times);
    let vs_refine = match (&leaf_level, &opts.reference.refine) {
        (Some((leaf, st)), Some(r)) if a.compare_full => Some(super::refine::versus_full(
            a.repeat,
            &prep,
            &lut,
            tech,
            &opts,
            r,
            leaf,
            st,
            &frame.image,
        )?),
        _ => None,
    };
    let vs_full = match &opts.reference.gaze {
        _ if vs_refine.is_some() => None,
        Some(g) if a.compare_full => Some(versus_full(a, &prep, &lut, tech, &opts, g, &frame)?),
        _ if a.compare_full => anyhow::bail!("--compare-full needs --gaze or --refine"),
        _ => None,
    };
    let err = versus_reference(a, &prep, &lut, &full, &frame.image)?;
    let mut v = frame_json(
        tech.name(),
        shape,
        &prep.view,
        cam.eye,
        time_s,
        &frame,
        err.as_ref(),
    );
    v["times_s"] = serde_json::json!(times);
    if let Some(f) = &vs_full {
        v["gaze_vs_full"] = f.json();
    }
    if let Some((_, st)) = &leaf_level {
        v["refine"] = serde_json::json!(st);
    }
    if let Some(f) = &vs_refine {
        v["refine_vs_full"] = f.json();
    }
    let mut line = format!(
        "{}: {}x{} in {:.3} s, principal axis {}, D = {:.3}",
        tech.name(),
        cam.width,
        cam.height,
        time_s,
        prep.view.axes.label(),
        prep.view.d
    );
    if let Some(e) = err {
        line += &format!(
            ", vs reference: max {} /255, rmse {:.5}, psnr {:.2} dB",
            e.max_abs_255, e.rmse, e.psnr
        );
    }
    if let Some(f) = &vs_full {
        line += &f.summary(time_s, frame.samples());
    }
    if let Some(f) = &vs_refine {
        line += &f.summary(time_s);
    }
    let golden::render::Frame { image, slice, .. } = frame;
    Ok(Rendered {
        image,
        baseplane: slice.map(|o| o.baseplane),
        chip: None,
        stats: v,
        summary: line,
        notes: Vec::new(),
    })
}
