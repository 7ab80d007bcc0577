//! One frame as `ercube render` renders it, in memory: the same argument
//! parsing (every default is the command line's), the same loading,
//! camera placement, rendering and statistics, with the files left
//! unwritten. The C ABI (`ercube-ffi`) and the Python module (`python/`)
//! render through here, so their images and raw words are the command
//! line's bit for bit.
//!
//! Arguments are `ercube render`'s flags as strings (`["--method",
//! "pipeline", "--size", "64x64"]`); the flags that name output files
//! (`--out`, `--npy`, `--stats`, `--raw-npy`, `--baseplane-npy`) are refused,
//! since the caller gets the values. Waveform flags (`--vcd`, `--fst`)
//! still write their files.

use std::fmt;

use clap::parser::ValueSource;
use clap::{CommandFactory, FromArgMatches, Parser};

use golden::volume::{Volume, Voxels};
use rayon::prelude::*;

use crate::cli::args::{with_threads, SourceArgs};
use crate::cli::cosim_frame::{setup_given, FrameArgs};
use crate::cli::render::{self, RenderArgs};

pub use crate::cli::render::{Frozen, Rendered, Reuse};
pub use pipeline::cosim::pe_vectors::PeStream;

/// A failure, in the one-line form the command line prints after
/// `ercube: error: `.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Error {
    /// Whether the arguments themselves were malformed (the command line's
    /// usage errors) rather than the run failing on them.
    pub usage: bool,
    /// The one-line message.
    pub message: String,
}

impl fmt::Display for Error {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.message)
    }
}

impl std::error::Error for Error {}

impl Error {
    fn usage(e: &clap::Error) -> Error {
        Error {
            usage: true,
            message: crate::cli::one_line(e),
        }
    }

    fn run(e: &anyhow::Error) -> Error {
        Error {
            usage: false,
            message: format!("{e:#}").replace('\n', " "),
        }
    }
}

/// `ercube render`'s arguments.
#[derive(Debug, Parser)]
#[command(name = "ercube render", no_binary_name = true)]
struct RenderCommand {
    #[command(flatten)]
    args: RenderArgs,
}

/// Where a volume comes from: `--scene` or `--volume` and their options.
#[derive(Debug, Parser)]
#[command(name = "ercube", no_binary_name = true)]
struct SourceCommand {
    #[command(flatten)]
    source: SourceArgs,
}

/// The frame `ercube vectors` captures: the view, the renderer's options,
/// the configuration and the order.
#[derive(Debug, Parser)]
#[command(name = "ercube vectors", no_binary_name = true)]
struct VectorsFrameCommand {
    #[command(flatten)]
    frame: FrameArgs,
}

/// The flags that name files the caller receives as values instead.
const FILE_FLAGS: [(&str, &str); 5] = [
    ("out", "--out"),
    ("npy", "--npy"),
    ("stats", "--stats"),
    ("raw_npy", "--raw-npy"),
    ("baseplane_npy", "--baseplane-npy"),
];

/// Parses `ercube render`'s flags `words`: the last call's arguments
/// again when `words` are the last call's (parsing is a function of the
/// words alone; a caller rendering frame after frame with the same flags,
/// as the Python module's loops do, skips building clap's command,
/// matching and converting).
fn parse_words(words: Vec<String>) -> Result<RenderArgs, Error> {
    static LAST: std::sync::Mutex<Option<(Vec<String>, RenderArgs)>> = std::sync::Mutex::new(None);
    if let Ok(last) = LAST.lock() {
        if let Some((_, a)) = last.as_ref().filter(|(w, _)| *w == words) {
            return Ok(a.clone());
        }
    }
    let m = RenderCommand::command()
        .try_get_matches_from(&words)
        .map_err(|e| Error::usage(&e))?;
    for (id, flag) in FILE_FLAGS {
        if m.value_source(id) == Some(ValueSource::CommandLine) {
            return Err(Error {
                usage: true,
                message: format!("{flag} names a file; the frame's values are returned instead"),
            });
        }
    }
    let a = RenderCommand::from_arg_matches(&m)
        .map_err(|e| Error::usage(&e))?
        .args;
    if let Ok(mut last) = LAST.lock() {
        *last = Some((words, a.clone()));
    }
    Ok(a)
}

/// Parses `ercube render`'s flags `args`.
pub fn parse<S: AsRef<str>>(args: &[S]) -> Result<RenderArgs, Error> {
    parse_words(args.iter().map(|s| s.as_ref().to_string()).collect())
}

/// Renders the frame `ercube render ARGS` renders, of `volume` when it is
/// given (then `args` name no `--scene` or `--volume`; its default
/// transfer function is a file's, `grey-ramp`), with the pipeline
/// configuration `config` (TOML text, as a `--config` file holds) when it
/// is given, writing no files.
pub fn render<S: AsRef<str>>(
    args: &[S],
    volume: Option<Volume>,
    config: Option<&str>,
) -> Result<Rendered, Error> {
    let mut a = parse(args)?;
    a.pipeline.cfg.toml = config.map(str::to_string);
    render::frame(&a, volume).map_err(|e| Error::run(&e))
}

/// [`render`], preparing the volume through `reuse` (see
/// [`Reuse`]): a caller rendering frame after frame of the same voxels
/// prepares them once.
pub fn render_reusing<S: AsRef<str>>(
    args: &[S],
    volume: Option<Volume>,
    config: Option<&str>,
    reuse: &mut Reuse,
) -> Result<Rendered, Error> {
    let mut a = parse(args)?;
    a.pipeline.cfg.toml = config.map(str::to_string);
    reuse.end_loan();
    render::frame_reusing(&a, volume, Some(reuse)).map_err(|e| Error::run(&e))
}

/// Voxels a caller holds (a numpy array's buffer), borrowed: x fastest,
/// then y, then z.
#[derive(Debug, Clone, Copy)]
pub enum VoxelsRef<'a> {
    /// 8-bit voxels.
    U8(&'a [u8]),
    /// 16-bit voxels.
    U16(&'a [u16]),
}

impl VoxelsRef<'_> {
    /// Whether `v` holds these voxels, value for value and of the same type
    /// (compared in slabs across the current thread pool's workers).
    fn equals(self, v: &Voxels) -> bool {
        match (self, v) {
            (VoxelsRef::U8(a), Voxels::U8(b)) => same(a, b),
            (VoxelsRef::U16(a), Voxels::U16(b)) => same(a, b),
            _ => false,
        }
    }

    /// Whether `v` holds as many voxels of the same type.
    fn same_kind(self, v: &Voxels) -> bool {
        match (self, v) {
            (VoxelsRef::U8(a), Voxels::U8(b)) => a.len() == b.len(),
            (VoxelsRef::U16(a), Voxels::U16(b)) => a.len() == b.len(),
            _ => false,
        }
    }

    /// An owned copy.
    pub fn to_voxels(self) -> Voxels {
        match self {
            VoxelsRef::U8(a) => Voxels::U8(a.to_vec()),
            VoxelsRef::U16(a) => Voxels::U16(a.to_vec()),
        }
    }
}

/// `a == b`, in slabs of 256 KiB or more compared in parallel: a
/// comparison of memory, bound by its bandwidth, which more cores share.
fn same<T: PartialEq + Sync>(a: &[T], b: &[T]) -> bool {
    let slab = (256 << 10) / std::mem::size_of::<T>().max(1);
    a.len() == b.len()
        && a.par_chunks(slab)
            .zip(b.par_chunks(slab))
            .all(|(x, y)| x == y)
}

/// [`render_reusing`] of a volume the caller holds: `dims` (x, y, z),
/// `spacing` (x, y, z) and the borrowed `voxels`, which lie at `frozen`
/// when they are in a buffer that cannot change. When `reuse` keeps a
/// volume with the same dimensions, spacing and voxels and the arguments
/// render a given volume as it is
/// (`ViewArgs::keeps_given`), the kept volume and its
/// preparation render the frame and nothing is copied; otherwise the
/// voxels are copied once into a new volume. The voxels are the same when
/// the kept volume was copied from the same place of the same unchanging
/// buffer ([`Frozen`]), else when they compare equal value for value, so
/// a caller that changed its array in place gets a frame of what it holds
/// now.
pub fn render_borrowed<S: AsRef<str>>(
    args: &[S],
    (dims, spacing, voxels): ([usize; 3], [f64; 3], VoxelsRef<'_>),
    frozen: Option<Frozen>,
    config: Option<&str>,
    reuse: &mut Reuse,
) -> Result<Rendered, Error> {
    let mut a = parse(args)?;
    a.pipeline.cfg.toml = config.map(str::to_string);
    let keeps = a.view.keeps_given();
    let known = frozen.is_some() && reuse.frozen() == frozen;
    // The comparison runs on the frame's pool (the frame's own
    // `with_threads` then runs in place), its slabs across the workers.
    let r = with_threads(a.threads, || {
        let kept = if keeps {
            reuse.lend_if(|v| {
                v.dims() == dims
                    && v.spacing() == spacing
                    && if known {
                        voxels.same_kind(v.voxels())
                    } else {
                        voxels.equals(v.voxels())
                    }
            })
        } else {
            None
        };
        let vol = match kept {
            Some(v) => v,
            None => match Volume::from_voxels(dims, voxels.to_voxels())
                .and_then(|v| v.with_spacing(spacing))
            {
                Ok(v) => v,
                Err(e) => {
                    return Ok(Err(Error {
                        usage: false,
                        message: e.to_string(),
                    }))
                }
            },
        };
        Ok(render::frame_reusing(&a, Some(vol), Some(&mut *reuse)).map_err(|e| Error::run(&e)))
    });
    reuse.end_loan();
    // A volume kept now is this frame's: the voxels given, when the
    // frame rendered them as they are.
    reuse.kept_from(frozen.filter(|_| keeps));
    r.map_err(|e| Error::run(&e))?
}

/// A pipeline frame stepped one clock at a time: what the stepper's
/// worker returns when the frame is over (the whole render, as
/// [`render`] returns it).
pub type Stepper = pipeline::stepper::Stepper<Result<Rendered, Error>>;

/// Starts the pipeline frame `ercube render ARGS` renders, of `volume`
/// when given, with the configuration `config` (TOML text) when given, to
/// be stepped one clock at a time ([`pipeline::stepper`]): the arguments
/// are checked here, the frame runs on the stepper's worker thread, and
/// [`pipeline::stepper::Stepper::finish`] returns the render, the same
/// image, raw words and statistics as [`render`]'s (the wall-clock times
/// apart). `--method` must be a pipeline's; no `--repeat`.
pub fn stepper<S: AsRef<str>>(
    args: &[S],
    volume: Option<Volume>,
    config: Option<&str>,
) -> Result<Stepper, Error> {
    let mut a = parse(args)?;
    a.pipeline.cfg.toml = config.map(str::to_string);
    if a.method.technique().is_some() {
        return Err(Error {
            usage: true,
            message: format!(
                "only the pipeline steps cycle by cycle; {} is a golden method",
                a.method.name()
            ),
        });
    }
    pipeline::stepper::Stepper::start(move |tap| {
        render::frame_tapped(&a, volume, tap).map_err(|e| Error::run(&e))
    })
    .map_err(|e| Error {
        usage: false,
        message: format!("cannot start the stepper's thread: {e}"),
    })
}

/// Checks the pipeline configuration `text` (TOML, as a `--config` file
/// holds; missing keys keep their defaults), with the command line's
/// message when it is wrong.
pub fn check_config(text: &str) -> Result<(), Error> {
    let parsed = pipeline::config::PipelineConfig::from_toml_str(text).map_err(|e| Error {
        usage: false,
        message: e.to_string(),
    })?;
    parsed.validate().map_err(|e| Error {
        usage: false,
        message: e.to_string(),
    })
}

/// Loads or builds the volume the source flags `args` name (`--scene
/// SPEC`, or `--volume FILE` with `--raw-dims` and the rest), as every
/// command does: every format the command line reads, `--spacing` and
/// `--window` applied.
pub fn volume<S: AsRef<str>>(args: &[S]) -> Result<Volume, Error> {
    let words = args.iter().map(|s| s.as_ref().to_string());
    let c = SourceCommand::try_parse_from(words).map_err(|e| Error::usage(&e))?;
    let (vol, _) = c.source.load().map_err(|e| Error::run(&e))?;
    Ok(vol)
}

/// PE `pe`'s sample stage over the frame `ercube vectors --stage pe ARGS`
/// captures (the view, renderer and `--order` flags of `ercube vectors`),
/// of `volume` when given, with the configuration `config` (TOML text)
/// when given: every port's word each clock, the memory writes and the
/// tables, the words its files hold (`pipeline::cosim::pe_vectors`),
/// nothing written.
pub fn pe_stream<S: AsRef<str>>(
    args: &[S],
    volume: Option<Volume>,
    config: Option<&str>,
    pe: usize,
) -> Result<PeStream, Error> {
    let words = args.iter().map(|s| s.as_ref().to_string());
    let mut c = VectorsFrameCommand::try_parse_from(words).map_err(|e| Error::usage(&e))?;
    c.frame.cfg.toml = config.map(str::to_string);
    let s = setup_given(&c.frame, "vectors", volume).map_err(|e| Error::run(&e))?;
    crate::cli::vectors_pe::stream(&s, pe).map_err(|e| Error::run(&e))
}

/// The raw accumulator words of a pipeline frame, row-major `H x W x 4`
/// (R, G, B, A), as `--raw-npy` writes them, with the baseplane's width and
/// height; `None` for a golden method.
pub fn raw_words(r: &Rendered) -> Option<(usize, usize, &[[i64; 4]])> {
    let f = r.chip.as_ref()?;
    let [w, h] = f.baseplane.grid.counts;
    Some((w, h, &f.raw))
}
