//! Arguments shared by the commands: where the volume comes from, the
//! camera and the transfer function, each turned into golden-model values
//! with a one-line error for anything malformed.

use std::path::PathBuf;

use anyhow::{bail, Context, Result};
use clap::Args;
use glam::DVec3;

use golden::camera::{Camera, ImagePlane};
use golden::load::{load_placed, Loaded, RawSpec, RawType};
use golden::orient::{to_world_grid, WorldFrame};
use golden::scenes::{tf_preset, Scene};
use golden::tf::{Coverage, TransferFunction};
use golden::volume::{Volume, VoxelType, Window};

use super::memory::{frame_bytes, Budget, FrameSpec};

mod slice;
pub(crate) use slice::parse_voi;
pub use slice::SliceArgs;

/// Parses `x,y` into two finite numbers.
pub fn parse_point2(s: &str) -> std::result::Result<[f64; 2], String> {
    let v: Vec<f64> = s
        .split(',')
        .map(|t| t.trim().parse::<f64>())
        .collect::<std::result::Result<_, _>>()
        .map_err(|_| format!("'{s}' is not two comma-separated numbers x,y"))?;
    match v[..] {
        [x, y] if x.is_finite() && y.is_finite() => Ok([x, y]),
        _ => Err(format!(
            "'{s}' is not two finite comma-separated numbers x,y"
        )),
    }
}

/// Parses `x,y,z` into three finite numbers.
pub fn parse_vec3(s: &str) -> std::result::Result<DVec3, String> {
    let parts: Vec<&str> = s.split(',').collect();
    if parts.len() != 3 {
        return Err(format!("'{s}' is not three comma-separated numbers x,y,z"));
    }
    let mut v = [0.0; 3];
    for (k, p) in parts.iter().enumerate() {
        let x: f64 = p
            .trim()
            .parse()
            .map_err(|_| format!("'{p}' in '{s}' is not a number"))?;
        if !x.is_finite() {
            return Err(format!("'{p}' in '{s}' is not finite"));
        }
        v[k] = x;
    }
    Ok(DVec3::from_array(v))
}

/// Parses `WxH` into a positive image size.
pub fn parse_size(s: &str) -> std::result::Result<[u32; 2], String> {
    let (w, h) = s
        .split_once(['x', 'X'])
        .ok_or_else(|| format!("'{s}' is not a size WxH such as 256x256"))?;
    let p = |t: &str| -> std::result::Result<u32, String> {
        let n: u64 = t
            .trim()
            .parse()
            .map_err(|_| format!("'{t}' in size '{s}' is not a whole number"))?;
        if n == 0 || n > u64::from(golden::camera::MAX_IMAGE_EDGE) {
            return Err(format!(
                "image size '{s}': each side must be 1 to {}",
                golden::camera::MAX_IMAGE_EDGE
            ));
        }
        Ok(n as u32)
    };
    Ok([p(w)?, p(h)?])
}

/// Parses `X,Y,Z` voxel counts.
fn parse_dims(s: &str) -> std::result::Result<[usize; 3], String> {
    let parts: Vec<&str> = s.split(',').collect();
    if parts.len() != 3 {
        return Err(format!(
            "'{s}' is not three comma-separated dimensions X,Y,Z"
        ));
    }
    let mut d = [0; 3];
    for (k, p) in parts.iter().enumerate() {
        d[k] = p
            .trim()
            .parse()
            .map_err(|_| format!("'{p}' in '{s}' is not a whole number"))?;
    }
    Ok(d)
}

fn parse_raw_type(s: &str) -> std::result::Result<RawType, String> {
    s.parse::<RawType>().map_err(|e| e.to_string())
}

/// Where the volume comes from.
#[derive(Debug, Clone, Args)]
#[command(next_help_heading = "Volume")]
pub struct SourceArgs {
    /// Synthetic scene: checker[:N[:cube]], ml[:N], sphere[:N], ribbon[:N] or impulse[:N].
    #[arg(long, conflicts_with = "volume")]
    pub scene: Option<String>,
    /// Volume file: .den (VolPack), .nii/.nii.gz (NIfTI-1), .nrrd/.nhdr (NRRD), .mha/.mhd
    /// (MetaImage), .tif/.tiff or a folder of TIFF slices, a folder of DICOM slices, or raw
    /// with --raw-dims.
    #[arg(long)]
    pub volume: Option<PathBuf>,
    /// Raw volume dimensions X,Y,Z (x fastest).
    #[arg(long, value_parser = parse_dims, requires = "volume")]
    pub raw_dims: Option<[usize; 3]>,
    /// Raw voxel type: u8, u16le or u16be.
    #[arg(long, value_parser = parse_raw_type, default_value = "u8", requires = "raw_dims")]
    pub raw_type: RawType,
    /// Bytes to skip before the raw voxels.
    #[arg(long, default_value_t = 0, requires = "raw_dims")]
    pub raw_offset: u64,
    /// Voxel spacing x,y,z in world units (overrides the file's).
    #[arg(long, value_parser = parse_vec3, allow_hyphen_values = true)]
    pub spacing: Option<DVec3>,
    /// Window lo,hi in the file's units (after any rescale, e.g. CT
    /// Hounsfield units): lo..hi maps onto the 16-bit voxel range 0..65535,
    /// values outside clamp. Default: the file's own range (see docs/golden.md).
    #[arg(long, allow_hyphen_values = true)]
    pub window: Option<Window>,
    /// Memory a frame may take: bytes, or a number with K, M, G or T
    /// (binary units). A volume or frame estimated to need more is refused
    /// before it is allocated. Default: the tightest of the machine's
    /// available memory, the process's ulimit -v/-d and its cgroup's
    /// memory.max (the flag may not exceed the last three).
    #[arg(long, value_parser = super::memory::parse_bytes)]
    pub max_memory: Option<u64>,
    /// Let a detached header (.nhdr, .mhd) name a data file outside its own
    /// folder (an absolute path, '..', or a link leading out); refused by
    /// default.
    #[arg(long)]
    pub allow_outside_data: bool,
}

impl SourceArgs {
    /// The memory a frame may take ([`Budget`]).
    pub fn budget(&self) -> Budget {
        Budget::new(self.max_memory)
    }

    /// The memory a frame estimated to need `need` bytes may take
    /// ([`Budget::for_need`]: a recent reading of the limits serves a
    /// frame far within them).
    pub fn budget_for(&self, need: u128) -> Budget {
        Budget::for_need(self.max_memory, need)
    }

    /// A scene's dimensions and voxel type, known before it is built
    /// (`None` for a file, whose header says).
    pub fn scene_shape(&self) -> Result<Option<([usize; 3], VoxelType)>> {
        match &self.scene {
            Some(spec) => {
                let scene: Scene = spec.parse()?;
                Ok(Some((scene.dims(), scene.voxel_type())))
            }
            None => Ok(None),
        }
    }

    /// A short name for tables and file names.
    pub fn label(&self) -> String {
        match (&self.scene, &self.volume) {
            (Some(s), _) => s.clone(),
            (None, Some(p)) => p
                .file_name()
                .map(|f| f.to_string_lossy().into_owned())
                .unwrap_or_default(),
            _ => "volume".into(),
        }
    }

    /// Loads or builds the volume and names its default transfer function.
    pub fn load(&self) -> Result<(Volume, TransferFunction)> {
        let (loaded, tf) = self.load_placed()?;
        Ok((loaded.volume, tf))
    }

    /// [`SourceArgs::load`] with the file's placement in world space, if it
    /// has one (scenes, raw, `.den` and TIFF have none). `--spacing`
    /// replaces the file's spacing along its own index axes; `--window`
    /// is applied last.
    pub fn load_placed(&self) -> Result<(Loaded, TransferFunction)> {
        if self.scene.is_some() && self.raw_dims.is_some() {
            bail!(
                "--raw-dims, --raw-type and --raw-offset describe a --volume file, not a --scene"
            );
        }
        let (loaded, tf) = match (&self.scene, &self.volume) {
            (Some(spec), None) => {
                let scene: Scene = spec.parse()?;
                let volume = scene.build(self.budget().bytes)?;
                let placed = Loaded {
                    volume,
                    origin: None,
                    axes: None,
                };
                (placed, scene.preset())
            }
            (None, Some(path)) => {
                golden::load::allow_outside_data(self.allow_outside_data);
                let raw = self.raw_dims.map(|dims| RawSpec {
                    dims,
                    kind: self.raw_type,
                    offset: self.raw_offset,
                });
                (
                    load_placed(path, raw.as_ref(), self.budget().bytes)?,
                    tf_preset("grey-ramp")?,
                )
            }
            (None, None) => bail!("no volume: give --scene SPEC or --volume FILE"),
            (Some(_), Some(_)) => bail!("give either --scene or --volume, not both"),
        };
        Ok((self.override_placed(loaded)?, tf))
    }

    /// A volume given in memory (the library's route: its caller holds the
    /// voxels) as [`SourceArgs::load_placed`] returns a file's: no
    /// placement, the file default transfer function `grey-ramp`,
    /// `--spacing` and `--window` applied.
    pub fn given_placed(&self, volume: Volume) -> Result<(Loaded, TransferFunction)> {
        if self.scene.is_some() || self.volume.is_some() {
            bail!("the voxels are given; drop --scene and --volume");
        }
        let loaded = Loaded {
            volume,
            origin: None,
            axes: None,
        };
        Ok((self.override_placed(loaded)?, tf_preset("grey-ramp")?))
    }

    /// `--spacing` (along the volume's own index axes), then `--window`.
    fn override_placed(&self, mut loaded: Loaded) -> Result<Loaded> {
        if let Some(s) = self.spacing {
            loaded.volume = loaded.volume.with_spacing(s.to_array())?;
        }
        if let Some(w) = self.window {
            loaded.volume = loaded.volume.windowed(w);
        }
        Ok(loaded)
    }
}

/// Which plane the final image lies on.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum PlaneArg {
    /// An ordinary perspective image.
    Camera,
    /// The volume's front face (the paper's figures).
    Front,
}

/// One view of one volume: where the volume comes from, the camera and
/// the transfer function, which every command that renders a view takes.
#[derive(Debug, Clone, Args)]
pub struct ViewArgs {
    #[command(flatten)]
    pub source: SourceArgs,
    #[command(flatten)]
    pub camera: CameraArgs,
    #[command(flatten)]
    pub tf: TfArgs,
}

impl ViewArgs {
    /// Loads the volume, then resolves its transfer function and places
    /// the camera against it (in that order, so the first bad argument is
    /// the one reported).
    pub fn load(&self) -> Result<(Volume, TransferFunction, Camera)> {
        let (vol, tf, cam, _) = self.load_framed()?;
        Ok((vol, tf, cam))
    }

    /// [`ViewArgs::load`] for one frame `spec` describes, refused with one
    /// line when its estimated memory ([`frame_bytes`]) is over the
    /// budget: a scene before it is built, a file before anything but the
    /// volume (which its loader limits to the budget) is allocated.
    pub fn load_for(
        &self,
        method: &str,
        spec: &FrameSpec,
    ) -> Result<(Volume, TransferFunction, Camera)> {
        self.load_given(method, spec, None)
    }

    /// [`ViewArgs::load_for`], with the volume `given` in memory instead of
    /// `--scene` or `--volume` when it is `Some`.
    pub fn load_given(
        &self,
        method: &str,
        spec: &FrameSpec,
        given: Option<Volume>,
    ) -> Result<(Volume, TransferFunction, Camera)> {
        let check = |dims: [usize; 3], kind: VoxelType| {
            let need = frame_bytes(dims, kind, spec);
            let what = format!(
                "the {method} frame of a {}x{}x{} {kind:?} volume",
                dims[0], dims[1], dims[2]
            );
            self.source.budget_for(need).check(&what, need)
        };
        let (vol, tf, cam) = match given {
            Some(v) => {
                let (loaded, default_tf) = self.source.given_placed(v)?;
                let (vol, tf, cam, _) = self.place(loaded, default_tf)?;
                (vol, tf, cam)
            }
            None => {
                if let Some((dims, kind)) = self.source.scene_shape()? {
                    check(dims, kind)?;
                }
                let (loaded, default_tf) = {
                    let _s = super::progress::Stage::start("loading volume");
                    self.source.load_placed()?
                };
                // A frame over the budget is refused before the transfer
                // function is resolved, so a refused run says one line and
                // no warning about the table.
                check(loaded.volume.dims(), loaded.volume.kind())?;
                let (vol, tf, cam, _) = self.place(loaded, default_tf)?;
                (vol, tf, cam)
            }
        };
        check(vol.dims(), vol.kind())?;
        Ok((vol, tf, cam))
    }

    /// Whether a volume given in memory ([`ViewArgs::load_given`]) is
    /// rendered as it is: no `--spacing` or `--window` replacing it
    /// ([`SourceArgs::given_placed`]) and no `--space world` regridding it
    /// ([`ViewArgs::place`]).
    pub fn keeps_given(&self) -> bool {
        self.source.spacing.is_none()
            && self.source.window.is_none()
            && self.camera.space == SpaceArg::Voxel
    }

    /// [`ViewArgs::load`], and with `--space world` the volume put on the
    /// world axes ([`to_world_grid`]) and its frame (the camera is already
    /// moved into the volume's frame; the frame converts further world
    /// points, e.g. a path file's eyes).
    pub fn load_framed(&self) -> Result<(Volume, TransferFunction, Camera, Option<WorldFrame>)> {
        let (loaded, default_tf) = {
            let _s = super::progress::Stage::start("loading volume");
            self.source.load_placed()?
        };
        self.place(loaded, default_tf)
    }

    /// The volume on the axes `--space` names, its transfer function and
    /// the camera placed against it.
    fn place(
        &self,
        loaded: Loaded,
        default_tf: TransferFunction,
    ) -> Result<(Volume, TransferFunction, Camera, Option<WorldFrame>)> {
        let (vol, frame) = match self.camera.space {
            SpaceArg::Voxel => (loaded.volume, None),
            SpaceArg::World => {
                let (vol, frame) = to_world_grid(&loaded)?;
                (vol, Some(frame))
            }
        };
        let tf = self
            .tf
            .resolve(default_tf, &vol, self.source.window.is_some())?;
        let cam = self.camera.camera_in(&vol, frame.as_ref())?;
        Ok((vol, tf, cam, frame))
    }
}

/// The camera.
#[derive(Debug, Clone, Args)]
#[command(next_help_heading = "Camera")]
pub struct CameraArgs {
    /// Eye position x,y,z in world units (voxels at unit spacing).
    /// Default: in front of the volume's z = 0 face, 1.5 volume depths away.
    #[arg(long, value_parser = parse_vec3, allow_hyphen_values = true)]
    pub eye: Option<DVec3>,
    /// Point looked at (default: the volume centre).
    #[arg(long, value_parser = parse_vec3, allow_hyphen_values = true)]
    pub look_at: Option<DVec3>,
    /// Up direction (default 0,1,0 in voxel space; 0,0,1, the head, in world space).
    #[arg(long, value_parser = parse_vec3, allow_hyphen_values = true)]
    pub up: Option<DVec3>,
    /// The space --eye, --look-at and --up are given in: voxel (the volume's
    /// index axes times spacing, origin at voxel 0) or world (the file's
    /// patient space, LPS millimetres: +x left, +y posterior, +z superior;
    /// NIfTI's RAS is converted by negating x and y). See docs/golden.md.
    #[arg(long, value_enum, default_value_t = SpaceArg::Voxel)]
    pub space: SpaceArg,
    /// Vertical field of view in degrees, in (0, 180).
    #[arg(long, default_value_t = 60.0, allow_hyphen_values = true)]
    pub fov: f64,
    /// Image size WxH.
    #[arg(long, value_parser = parse_size, default_value = "256x256")]
    pub size: [u32; 2],
    /// Image plane: an ordinary camera, or the volume's front face.
    #[arg(long, value_enum, default_value_t = PlaneArg::Camera)]
    pub image_plane: PlaneArg,
}

/// Which space the camera's points are given in.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum SpaceArg {
    /// The volume's own axes: voxel index times spacing.
    Voxel,
    /// The file's patient space (LPS, mm), from its direction cosines.
    World,
}

impl CameraArgs {
    /// The camera for `vol`; with a frame, `--eye`, `--look-at` and `--up`
    /// are world (LPS) values moved into the volume's frame, and the
    /// default eye looks at the volume's centre from anterior (-y), head
    /// up (+z).
    pub fn camera_in(&self, vol: &Volume, frame: Option<&WorldFrame>) -> Result<Camera> {
        let centre = DVec3::from_array(vol.center_world());
        let depth = (0..3)
            .map(|k| vol.dims()[k] as f64 * vol.spacing()[k])
            .fold(0.0, f64::max);
        let (eye, look, up) = match frame {
            None => {
                let look = self.look_at.unwrap_or(centre);
                let eye = self
                    .eye
                    .unwrap_or_else(|| centre - DVec3::Z * (centre.z + 1.5 * depth));
                (eye, look, self.up.unwrap_or(DVec3::Y))
            }
            Some(f) => {
                let centre_w = f.point_to_world(centre);
                let look = self.look_at.unwrap_or(centre_w);
                let eye = self.eye.unwrap_or(centre_w - DVec3::Y * (2.0 * depth));
                let up = self.up.unwrap_or(DVec3::Z);
                (
                    f.point_to_volume(eye),
                    f.point_to_volume(look),
                    f.dir_to_volume(up),
                )
            }
        };
        let mut cam = Camera::new(eye, look, up, self.fov, self.size[0], self.size[1])?;
        cam.image_plane = match self.image_plane {
            PlaneArg::Camera => ImagePlane::Camera,
            PlaneArg::Front => ImagePlane::Front,
        };
        Ok(cam)
    }
}

/// The transfer function.
#[derive(Debug, Clone, Args)]
#[command(next_help_heading = "Transfer function")]
pub struct TfArgs {
    /// Named preset (checker, ml, sphere, impulse, grey-ramp, brain, ...),
    /// written for 8-bit values 0..255; on 16-bit data it spans the data's
    /// range (or the --window).
    #[arg(long, conflicts_with = "tf_file")]
    pub tf: Option<String>,
    /// TOML file of control points ([[point]] value = .. rgba = [r, g, b, a]),
    /// in raw voxel units; with `fit = [lo, hi]` the values are written
    /// against lo..hi and stretched onto the data's range like a preset's.
    #[arg(long)]
    pub tf_file: Option<PathBuf>,
}

impl TfArgs {
    /// The chosen transfer function, or `default`, in `vol`'s voxel units:
    /// a preset (or a file with `fit`) spans the data's range
    /// ([`golden::tf::data_range`]; the window's with `windowed`). Warns on
    /// stderr, in one line, when it makes none or all of `vol` visible.
    pub fn resolve(
        &self,
        default: TransferFunction,
        vol: &Volume,
        windowed: bool,
    ) -> Result<TransferFunction> {
        let tf = match (&self.tf, &self.tf_file) {
            (Some(name), _) => tf_preset(name)?,
            (None, Some(path)) => TransferFunction::from_file(path)?,
            (None, None) => default,
        };
        let tf = tf.fitted(golden::tf::data_range(vol, windowed));
        let coverage = tf.coverage(vol);
        // The range is read again only to word a warning.
        let (lo, hi) = match coverage {
            Coverage::Some => (0, 0),
            _ => vol.value_range(),
        };
        match coverage {
            Coverage::None => eprintln!(
                "ercube: warning: the transfer function makes none of the volume visible (opacity 0 \
                 at every voxel value {lo}..{hi}); check --tf, --tf-file or --window"
            ),
            Coverage::All => eprintln!(
                "ercube: warning: the transfer function makes all of the volume visible (no voxel \
                 value {lo}..{hi} is clear), so the image shows its bounding box; check --tf, \
                 --tf-file or --window"
            ),
            Coverage::Some => {}
        }
        Ok(tf)
    }
}

/// The process's thread pool of `n` workers, started on first use and
/// kept: a process that renders many frames (the Python module, the C
/// ABI) starts its workers once, not once a frame, and its frames run on
/// warm threads as a command's frames after its first do.
fn pool(n: usize) -> Result<std::sync::Arc<rayon::ThreadPool>> {
    static POOLS: std::sync::Mutex<Vec<(usize, std::sync::Arc<rayon::ThreadPool>)>> =
        std::sync::Mutex::new(Vec::new());
    let mut pools = POOLS
        .lock()
        .map_err(|_| anyhow::anyhow!("the thread pools' lock is poisoned"))?;
    if let Some((_, p)) = pools.iter().find(|(k, _)| *k == n) {
        return Ok(p.clone());
    }
    let p = std::sync::Arc::new(
        rayon::ThreadPoolBuilder::new()
            .num_threads(n)
            .build()
            .context("cannot start the thread pool")?,
    );
    pools.push((n, p.clone()));
    Ok(p)
}

/// Runs `f` on a thread pool of `threads` workers (all cores when `None`);
/// the pool of each count is kept for the process's later runs ([`pool`]).
pub fn with_threads<T: Send>(
    threads: Option<usize>,
    f: impl FnOnce() -> Result<T> + Send,
) -> Result<T> {
    match threads {
        None => f(),
        Some(0) => bail!("--threads must be at least 1"),
        Some(n) => {
            let pool = pool(n)?;
            // The run's staged outputs (see outputs::all_or_nothing) follow
            // the work onto the pool's thread and back.
            let carried = golden::image::carry();
            let (out, back) = pool.install(move || {
                golden::image::adopt(carried);
                let out = f();
                (out, golden::image::carry())
            });
            golden::image::adopt(back);
            out
        }
    }
}
