//! `ercube animate`: a camera path rendered frame by frame with one golden
//! method, reusing across frames what the camera does not change (seed
//! 001's caching): the loaded volume and its classification table are
//! built once, the min-max blocks and the occupancy map once per volume
//! and table, and the permuted slice stack once per principal axis
//! ([`golden::render::Prepared::moved`]). `--no-reuse` prepares every frame
//! from scratch, which is what the reuse is measured against.
//!
//! The path is an orbit (`--orbit DEG`: the eye turns about the look-at
//! point around the up vector, `DEG` over the whole path, in `--frames`
//! equal steps) or a file of eyes (`--path F`, one `x,y,z` per line, or
//! `x,y,z look x,y,z` to move the look-at point too; `#` starts a comment).
//! The output folder gets one PNG per frame and an animated GIF of them.
//!
//! The pipeline methods (`pipeline`, `pipeline-ftb`) keep what the chip
//! would keep: the volume in PE memory. A frame with the previous frame's
//! axis map (principal axis, direction, near clip) starts from the PE
//! memories as they were and the host loads nothing; a frame that changes
//! it reloads them ([`pipeline::FrameRun::resident`]). A frame's cycles are
//! the same either way; the load's cycles come before them
//! (`voxel_load.cycles`, 0 when resident), and the stats give each frame's
//! cycles, its load and both together (`cycles_with_load`).

use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{bail, Context, Result};
use clap::Args;
use glam::{DMat3, DVec3};
use golden::camera::Camera;
use golden::orient::WorldFrame;
use golden::render::{lut_for, render, Prepared, Technique};
use golden::warp::warp;
use image::codecs::gif::{GifEncoder, Repeat};
use image::{Delay, Frame, RgbaImage};
use pipeline::config::PipelineConfig;
use pipeline::{FrameRun, Voxels};

use super::args::{parse_vec3, with_threads, SliceArgs, ViewArgs};
use super::bench::progress;
use super::chip::{self, ConfigArgs};
use super::method::MethodArg;
use super::stats::{median, write_json};

/// Most frames one path may have (a path file's lines count too).
const MAX_FRAMES: usize = 10_000;
/// Largest path file read (checked before reading it).
const MAX_PATH_BYTES: u64 = 4 << 20;

/// Arguments of `ercube animate`.
#[derive(Debug, Args)]
pub struct AnimateArgs {
    #[command(flatten)]
    pub view: ViewArgs,
    /// Method: a golden one, or the PE array (`pipeline`, `pipeline-ftb`),
    /// which keeps the volume in PE memory while the axis map holds.
    #[arg(long, value_enum, default_value = "er")]
    pub method: MethodArg,
    /// The pipeline's configuration (pipeline methods only).
    #[command(flatten)]
    pub pipeline: ConfigArgs,
    /// Degrees the eye orbits about the look-at point, around the up
    /// vector, over the whole path (default 360 unless --path is given).
    #[arg(long, allow_hyphen_values = true, conflicts_with = "path")]
    pub orbit: Option<f64>,
    /// A file of eyes, one `x,y,z` (or `x,y,z look x,y,z`) per line.
    #[arg(long)]
    pub path: Option<PathBuf>,
    /// Frames of an orbit.
    #[arg(long, default_value_t = 36)]
    pub frames: usize,
    /// Folder for the frames (frame_0000.png, ...), the GIF and the stats.
    #[arg(long, default_value = "animate")]
    pub out_dir: PathBuf,
    /// Milliseconds each frame shows in the GIF.
    #[arg(long, default_value_t = 80)]
    pub frame_ms: u32,
    /// Prepare every frame from scratch, and for the pipeline reload its
    /// PE memories every frame (to measure what reuse saves).
    #[arg(long)]
    pub no_reuse: bool,
    #[command(flatten)]
    pub slice: SliceArgs,
    /// Worker threads (default: all cores); frames are identical for any count.
    #[arg(long)]
    pub threads: Option<usize>,
}

/// The eyes (and look-at points) of the path, in the volume's frame (a
/// path file's points are in the `--space` of the camera flags, moved into
/// the volume's frame by `frame` under `--space world`).
fn path_of(
    a: &AnimateArgs,
    first: &Camera,
    frame: Option<&WorldFrame>,
) -> Result<Vec<(DVec3, DVec3)>> {
    let to_volume = |p: DVec3| frame.map_or(p, |f| f.point_to_volume(p));
    if let Some(p) = &a.path {
        let len = std::fs::metadata(p)
            .with_context(|| format!("cannot read --path {}", p.display()))?
            .len();
        if len > MAX_PATH_BYTES {
            bail!(
                "--path {} has {len} bytes, more than {MAX_PATH_BYTES} ({MAX_FRAMES} eyes fit in far less)",
                p.display()
            );
        }
        let text = std::fs::read_to_string(p)
            .with_context(|| format!("cannot read --path {}", p.display()))?;
        let mut out = Vec::new();
        for (n, line) in text.lines().enumerate() {
            let line = line.split('#').next().unwrap_or("").trim();
            if line.is_empty() {
                continue;
            }
            let bad = |e: String| anyhow::anyhow!("{} line {}: {e}", p.display(), n + 1);
            let (eye, look) = match line.split_once(" look ") {
                Some((e, l)) => (
                    to_volume(parse_vec3(e.trim()).map_err(bad)?),
                    to_volume(parse_vec3(l.trim()).map_err(bad)?),
                ),
                None => (to_volume(parse_vec3(line).map_err(bad)?), first.look_at),
            };
            out.push((eye, look));
            if out.len() > MAX_FRAMES {
                bail!("{} holds more than {MAX_FRAMES} eyes", p.display());
            }
        }
        if out.is_empty() {
            bail!("{} holds no eye", p.display());
        }
        return Ok(out);
    }
    if a.frames == 0 || a.frames > MAX_FRAMES {
        bail!("--frames {} must be 1 to {MAX_FRAMES}", a.frames);
    }
    let deg = a.orbit.unwrap_or(360.0);
    if !deg.is_finite() || deg.abs() > 36_000.0 {
        bail!("--orbit {deg} must be a finite angle of at most 36000 degrees");
    }
    let axis = first.up.normalize();
    let arm = first.eye - first.look_at;
    Ok((0..a.frames)
        .map(|i| {
            let turn = (deg * i as f64 / a.frames as f64).to_radians();
            (
                first.look_at + DMat3::from_axis_angle(axis, turn) * arm,
                first.look_at,
            )
        })
        .collect())
}

/// Runs `ercube animate`.
pub fn run(a: &AnimateArgs) -> Result<()> {
    if !(1..=10_000).contains(&a.frame_ms) {
        bail!("--frame-ms {} must be 1 to 10000", a.frame_ms);
    }
    super::outputs::check_dirs(&[Some(&a.out_dir)])?;
    super::outputs::all_or_nothing(&[&a.out_dir], || with_threads(a.threads, || animate(a)))
}

/// How the frames are drawn: a golden technique, or the PE array with the
/// memories it keeps between frames.
enum Renderer {
    Golden(Technique),
    Pipeline(Box<Chip>),
}

/// The PE array's configuration and the memories it keeps.
struct Chip {
    cfg: PipelineConfig,
    resident: Option<pipeline::Resident>,
}

/// What the pipeline did in each frame, for the stats.
#[derive(Default)]
struct ChipFrames {
    cycles: Vec<u64>,
    loads: Vec<pipeline::VoxelLoad>,
}

fn animate(a: &AnimateArgs) -> Result<()> {
    let (mut renderer, slice) = match a.method.technique() {
        Some(t) => {
            if a.pipeline.config.is_some() || a.pipeline.pes.is_some() {
                bail!("--config and --pes apply only to --method pipeline or pipeline-ftb");
            }
            (Renderer::Golden(t), a.slice.clone())
        }
        None => {
            let (cfg, slice) = chip::configure(&a.pipeline, a.method, &a.slice)?;
            let renderer = Renderer::Pipeline(Box::new(Chip {
                cfg,
                resident: None,
            }));
            (renderer, slice)
        }
    };
    let mut opts = slice.options()?;
    if let Renderer::Pipeline(_) = renderer {
        chip::check_options(&opts)?;
    }
    let prep_opts = slice.prepare()?;
    let t0 = Instant::now();
    let (vol, tf, first, frame) = a.view.load_framed()?;
    slice.apply_tf(&mut opts, &tf)?;
    let lut = match &renderer {
        Renderer::Golden(_) => lut_for(vol.kind(), &tf),
        Renderer::Pipeline(c) => chip::pipeline_lut(&c.cfg, &vol, &tf),
    };
    // The pipeline's pre-integration table, once for every frame (the
    // classification does not change along the path).
    let preint = (matches!(renderer, Renderer::Pipeline(_)) && opts.slice.preintegrate)
        .then(|| golden::preint::PreTable::with_colouring(&lut, opts.slice.pre_colouring));
    let load_s = t0.elapsed().as_secs_f64();
    let path = path_of(a, &first, frame.as_ref())?;
    std::fs::create_dir_all(&a.out_dir)
        .with_context(|| format!("cannot create {}", a.out_dir.display()))?;
    let bar = progress(path.len() as u64);
    let mut prev: Option<Prepared> = None;
    // Frames go into the GIF as they are drawn, so a long path holds one
    // frame in memory, not all of them.
    let mut gif = GifWriter::new(&a.out_dir.join("animation.gif"), a.frame_ms)?;
    let mut times = Vec::with_capacity(path.len());
    let mut prepare_times = Vec::with_capacity(path.len());
    let mut stacks_reused = 0;
    let mut chip_frames = ChipFrames::default();
    for (i, &(eye, look)) in path.iter().enumerate() {
        let t = Instant::now();
        // Camera::new validates each eye (an eye on the look-at point, or
        // one looking along the up vector, is refused for that frame).
        let mut cam = Camera::new(
            eye,
            look,
            first.up,
            first.fov_deg,
            first.width,
            first.height,
        )
        .with_context(|| format!("frame {i}"))?;
        cam.image_plane = first.image_plane;
        let prep = match (&prev, a.no_reuse) {
            (Some(p), false) => p.moved(&vol, &cam, &prep_opts)?,
            _ => Prepared::with(&vol, &cam, &prep_opts)?,
        };
        if prev.as_ref().is_some_and(|p| p.shares_stack(&prep)) {
            stacks_reused += 1;
        }
        prepare_times.push(t.elapsed().as_secs_f64());
        let image = match &mut renderer {
            Renderer::Golden(tech) => {
                render(&prep, &lut, *tech, &opts)
                    .with_context(|| format!("frame {i}"))?
                    .image
            }
            Renderer::Pipeline(c) => {
                let Chip { cfg, resident } = &mut **c;
                if a.no_reuse {
                    *resident = None;
                }
                let stack = Voxels::Stack {
                    data_bits: vol.kind().bits(),
                };
                let frame = FrameRun::prepared(cfg, &lut, &prep, stack)
                    .skips(opts.slice.skips)
                    .resident(resident);
                let f = match &preint {
                    Some(pt) => frame.unit(Some(pt)),
                    None => frame
                        .unit(opts.slice.shade.as_ref())
                        .unit(opts.slice.voi.as_ref()),
                }
                .run()
                .with_context(|| format!("frame {i}"))?;
                chip_frames.cycles.push(f.cycles);
                chip_frames.loads.push(f.voxel_load);
                warp(&prep.view, &f.baseplane)
            }
        };
        times.push(t.elapsed().as_secs_f64());
        image.write_png(&a.out_dir.join(format!("frame_{i:04}.png")))?;
        gif.push(&image)?;
        prev = Some(prep);
        bar.inc(1);
    }
    bar.finish_and_clear();
    gif.finish()?;
    let rest = &times[1.min(times.len())..];
    let mut stats = serde_json::json!({
        "method": a.method.name(),
        "frames": path.len(),
        "reuse": !a.no_reuse,
        "load_s": load_s,
        "first_frame_s": times[0],
        "median_frame_s": if rest.is_empty() { times[0] } else { median(rest) },
        "median_prepare_s": median(&prepare_times),
        "stacks_reused": stacks_reused,
        "times_s": times,
        "eyes": path.iter().map(|(e, _)| e.to_array()).collect::<Vec<_>>(),
    });
    let mut chip_note = String::new();
    if let Renderer::Pipeline(c) = &renderer {
        let cfg = &c.cfg;
        let resident = chip_frames.loads.iter().filter(|l| l.resident).count();
        let not_loaded: u64 = chip_frames
            .loads
            .iter()
            .filter(|l| l.resident)
            .map(|l| l.bytes_held)
            .sum();
        let loaded: u64 = chip_frames.loads.iter().map(|l| l.bytes_loaded).sum();
        stats["order"] = serde_json::json!(cfg.order.name());
        stats["pes"] = serde_json::json!(cfg.pes);
        stats["cycles"] = serde_json::json!(chip_frames.cycles);
        let with_load: Vec<u64> = (chip_frames.cycles.iter().zip(&chip_frames.loads))
            .map(|(c, l)| c + l.cycles)
            .collect();
        let load_cycles: u64 = chip_frames.loads.iter().map(|l| l.cycles).sum();
        stats["cycles_with_load"] = serde_json::json!(with_load);
        stats["load_cycles"] = serde_json::json!(load_cycles);
        stats["voxel_load"] = serde_json::json!(chip_frames.loads);
        stats["frames_resident"] = serde_json::json!(resident);
        stats["voxel_bytes_loaded"] = serde_json::json!(loaded);
        stats["voxel_bytes_not_loaded"] = serde_json::json!(not_loaded);
        chip_note = format!(
            "; {resident} of {} frames found the volume in PE memory ({not_loaded} bytes not loaded, {loaded} loaded in {load_cycles} cycles)",
            path.len()
        );
    }
    write_json(&a.out_dir.join("animate.json"), &stats)?;
    super::say(&format!(
        "{}: {} frames, first {:.3} s, then median {:.3} s a frame (prepare {:.4} s; {} of {} slice stacks reused{chip_note}) -> {}",
        a.method.name(),
        path.len(),
        stats["first_frame_s"].as_f64().unwrap_or(f64::NAN),
        stats["median_frame_s"].as_f64().unwrap_or(f64::NAN),
        stats["median_prepare_s"].as_f64().unwrap_or(f64::NAN),
        stacks_reused,
        path.len().saturating_sub(1),
        a.out_dir.display()
    ));
    Ok(())
}

/// A looping animated GIF written frame by frame into a temporary file
/// beside its path and renamed over it once complete (atomic, like every
/// other output).
struct GifWriter {
    path: PathBuf,
    delay: Delay,
    tmp: tempfile::NamedTempFile,
    /// Over a second handle of `tmp`, unbuffered, so a failed write shows
    /// in the frame that made it (the encoder cannot be unwrapped to flush
    /// a buffer with its error).
    enc: GifEncoder<std::fs::File>,
}

impl GifWriter {
    fn new(path: &Path, frame_ms: u32) -> Result<GifWriter> {
        let dir = path.parent().unwrap_or(Path::new("."));
        let tmp = tempfile::NamedTempFile::new_in(dir)
            .with_context(|| format!("cannot write {}", path.display()))?;
        let file = tmp
            .as_file()
            .try_clone()
            .with_context(|| format!("cannot write {}", path.display()))?;
        let mut enc = GifEncoder::new_with_speed(file, 10);
        enc.set_repeat(Repeat::Infinite)
            .with_context(|| format!("cannot write {}", path.display()))?;
        Ok(GifWriter {
            path: path.to_owned(),
            delay: Delay::from_numer_denom_ms(frame_ms, 1),
            tmp,
            enc,
        })
    }

    fn push(&mut self, img: &golden::image::Image) -> Result<()> {
        let rgba: Vec<u8> = img
            .to_rgb8()
            .chunks_exact(3)
            .flat_map(|p| [p[0], p[1], p[2], 255])
            .collect();
        let buf =
            RgbaImage::from_raw(img.width as u32, img.height as u32, rgba).context("frame size")?;
        self.enc
            .encode_frame(Frame::from_parts(buf, 0, 0, self.delay))
            .with_context(|| format!("cannot write {}", self.path.display()))
    }

    fn finish(self) -> Result<()> {
        let GifWriter { path, tmp, enc, .. } = self;
        let err = |e: std::io::Error| anyhow::anyhow!("cannot write {}: {e}", path.display());
        // Dropping the encoder writes the GIF trailer.
        drop(enc);
        tmp.as_file().sync_all().map_err(err)?;
        // A temporary file is private (0600); the GIF should have the
        // permissions of an ordinarily created file, as the PNGs do.
        #[cfg(unix)]
        {
            use std::os::unix::fs::PermissionsExt;
            tmp.as_file()
                .set_permissions(std::fs::Permissions::from_mode(0o644))
                .map_err(err)?;
        }
        golden::image::place(tmp, &path).map_err(err)?;
        Ok(())
    }
}
