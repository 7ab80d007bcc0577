//! `ercube peer vtk`: one view rendered by ercube's methods and by a peer
//! renderer (VTK's `vtkFixedPointVolumeRayCastMapper`, driven by
//! `bench/peers/vtk.py`), each timed and compared with ercube's reference;
//! writes a table (`peer.csv`, `peer.json`, `summary.md`), an
//! error-against-time plot and every image (docs/peers.md).
//!
//! The peer sees exactly ercube's voxels (the loaded or built volume is
//! exported as raw), the same transfer function (its control points as
//! TOML) and the same camera; the script matches ercube's conventions
//! (voxel centres, cell faces, image rows, opacity per unit length) and
//! checks them with `--self-test`. Its image comes back as `.npy` and is
//! compared here, with the same metric as every other method.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Instant;

use anyhow::{bail, Context, Result};
use clap::Args;

use golden::camera::{Camera, ImagePlane};
use golden::image::Image;
use golden::metrics::{compare, ImageError};
use golden::preint::Colouring;
use golden::render::{lut_for, render, Prepared, RenderOptions, Technique};
use golden::volume::{Volume, Voxels};

use super::args::{with_threads, ViewArgs};
use super::bench::pareto;
use super::method::MethodArg;
use super::montage::write_montage;
use super::plot::{write_chart, Chart, Kind, Series};
use super::progress::Stage;
use views::PeerView;

/// The peers `ercube peer` can drive.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum PeerName {
    /// VTK 9's CPU ray caster, `vtkFixedPointVolumeRayCastMapper`.
    Vtk,
}

/// Arguments of `ercube peer`.
#[derive(Debug, Args)]
pub struct PeerArgs {
    /// The peer renderer.
    #[arg(value_enum)]
    pub peer: PeerName,
    #[command(flatten)]
    pub view: ViewArgs,
    /// Comma-separated golden methods, each NAME, NAME:SUBSTEPS
    /// (e.g. er-ftb:2 is er-ftb with --substeps 2), NAME:pre (with
    /// --preintegrate), NAME:pre-att or NAME:pre-exact (with
    /// --preintegrate --pre-colouring attenuated or exact), er:fp or
    /// er-ftb:fp (with --rays footprint); the reference is always
    /// rendered for the errors.
    #[arg(
        long,
        default_value = "reference,er,er-ftb,er-ftb:2,er-ftb:pre,er-ftb:pre-att,er-ftb:pre-exact,over"
    )]
    pub methods: String,
    /// Comma-separated views, each rendered and compared in its own
    /// folder under --out-dir (with one table of all in views.md):
    /// front (the command's camera), oblique, near, far, or all.
    #[arg(long, default_value = "front")]
    pub views: String,
    /// Timed frames per method, after one warm-up frame (the reference:
    /// one frame).
    #[arg(long, default_value_t = 5)]
    pub frames: usize,
    /// Directory for the table, plot and images.
    #[arg(long, default_value = "peer")]
    pub out_dir: PathBuf,
    /// Worker threads of ercube and of the peer (default: all cores).
    #[arg(long)]
    pub threads: Option<usize>,
    /// Python interpreter that starts the peer's script (the script makes
    /// its own venv with vtk and numpy when this one has none).
    #[arg(long, default_value = "python3")]
    pub python: PathBuf,
    /// The peer's script (default: bench/peers/vtk.py of this repository).
    #[arg(long)]
    pub script: Option<PathBuf>,
    /// The peer's ray step in world units.
    #[arg(long, default_value_t = 0.5)]
    pub sample_distance: f64,
    /// Shade every method, the reference and the peer with gradients and
    /// Blinn-Phong (VTK's `ShadeOn` with the same material and lights; a
    /// headlight unless --light is given).
    #[arg(long)]
    pub shade: bool,
    /// A directional light towards world direction dx,dy,dz, for ercube
    /// and the peer alike (repeat for up to 4; implies --shade).
    #[arg(long, value_parser = super::args::parse_vec3, allow_hyphen_values = true)]
    pub light: Vec<glam::DVec3>,
    /// Material ka,kd,ks,shininess for ercube and the peer (default VTK's
    /// 0.1,0.7,0.2,10; implies --shade).
    #[arg(long)]
    pub material: Option<String>,
}

/// The shading `--shade`, `--light` and `--material` ask for, or `None`.
/// The rest of ercube's shading options keep their defaults: gradients on
/// voxels (VTK's too), no gradient opacity (VTK's default function is 1),
/// the default normal fade.
fn peer_shade(a: &PeerArgs) -> Result<Option<golden::shading::Shade>> {
    if !(a.shade || !a.light.is_empty() || a.material.is_some()) {
        return Ok(None);
    }
    let mut sh = golden::shading::Shade::default();
    for &l in &a.light {
        sh.add_light(l)?;
    }
    if let Some(m) = &a.material {
        sh.material = golden::shading::Material::parse(m)?;
    }
    sh.validate()?;
    Ok(Some(sh))
}

/// Default options with the comparison's shading (reference and slice
/// methods alike).
fn shaded(a: &PeerArgs) -> Result<RenderOptions> {
    let mut o = RenderOptions::default();
    o.slice.shade = peer_shade(a)?;
    o.reference.shade = o.slice.shade;
    Ok(o)
}

/// One golden method of the comparison: a technique and its substeps.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct MethodSpec {
    /// The technique.
    pub tech: Technique,
    /// Samples per slice crossing (slice-order methods).
    pub substeps: u32,
    /// Pre-integrated classification (slice-order methods) and its
    /// colouring.
    pub preintegrate: Option<Colouring>,
    /// Rays matched to the image (`--rays footprint`; er and er-ftb).
    pub footprint: bool,
}

impl MethodSpec {
    /// Name in tables and plots: the method, with `:S` for substeps S > 1.
    pub fn label(&self) -> String {
        if self.footprint {
            format!("{}:fp", self.tech.name())
        } else if let Some(c) = self.preintegrate {
            let tail = match c {
                Colouring::Fast => "",
                Colouring::Attenuated => "-att",
                Colouring::Exact => "-exact",
            };
            format!("{}:pre{tail}", self.tech.name())
        } else if self.substeps > 1 {
            format!("{}:{}", self.tech.name(), self.substeps)
        } else {
            self.tech.name().to_string()
        }
    }
}

/// Parses `--methods` of `ercube peer`.
pub fn parse_peer_methods(s: &str) -> Result<Vec<MethodSpec>> {
    let mut out: Vec<MethodSpec> = Vec::new();
    for tok in s.split(',').map(str::trim).filter(|t| !t.is_empty()) {
        let footprint = tok.ends_with(":fp");
        let (name, sub, pre) = match tok.split_once(':') {
            Some((n, "fp")) => (n, 1, None),
            Some((n, "pre")) => (n, 1, Some(Colouring::Fast)),
            Some((n, "pre-att")) => (n, 1, Some(Colouring::Attenuated)),
            Some((n, "pre-exact")) => (n, 1, Some(Colouring::Exact)),
            Some((n, k)) => {
                let k: u32 = k
                    .parse()
                    .ok()
                    .filter(|&k| (1..=64).contains(&k))
                    .with_context(|| {
                        format!("--methods '{tok}': substeps must be a whole number 1 to 64")
                    })?;
                (n, k, None)
            }
            None => (tok, golden::methods::DEFAULT_SUBSTEPS, None),
        };
        let Some(tech) = MethodArg::parse(name).and_then(MethodArg::technique) else {
            bail!(
                "unknown method '{tok}' in --methods: use reference, er, er-ftb, under, over or box, optionally :SUBSTEPS, :pre, :pre-att, :pre-exact or (er, er-ftb) :fp"
            );
        };
        if footprint
            && !matches!(
                tech,
                Technique::Slice(golden::methods::Method::Er | golden::methods::Method::ErFtb)
            )
        {
            bail!("--methods '{tok}': :fp (--rays footprint) applies to er and er-ftb");
        }
        if tech == Technique::Reference && tok.contains(':') {
            bail!("--methods '{tok}': the reference takes no substeps");
        }
        let m = MethodSpec {
            tech,
            substeps: sub,
            preintegrate: pre,
            footprint,
        };
        if out.iter().any(|o| o.label() == m.label()) {
            bail!("method '{}' is listed twice in --methods", m.label());
        }
        out.push(m);
    }
    if out.is_empty() {
        bail!("--methods names no method");
    }
    Ok(out)
}

/// One row of the table.
#[derive(Debug, Clone)]
pub struct PeerRow {
    /// Method label (`vtk` for the peer).
    pub method: String,
    /// Median seconds per frame (the peer's: on its own timer).
    pub time_s: f64,
    /// How many times the peer's rate this row runs at, by the peer's own
    /// timer (`peer time / time`) and by its wall clock (when reported).
    pub speedup: [Option<f64>; 2],
    /// Frames timed.
    pub frames: usize,
    /// Error against the reference.
    pub err: ImageError,
}

/// `peer / ours`, the factor by which a row is faster than the peer.
fn ratio(peer: f64, ours: f64) -> Option<f64> {
    (peer > 0.0 && ours > 0.0).then(|| peer / ours)
}

/// Each row's speed against the peer's two timings (`mapper` and `wall`
/// seconds per frame).
pub fn set_speedups(rows: &mut [PeerRow], mapper: f64, wall: Option<f64>) {
    for r in rows {
        r.speedup = [
            ratio(mapper, r.time_s),
            wall.and_then(|w| ratio(w, r.time_s)),
        ];
    }
}

fn speedup_cell(x: Option<f64>) -> String {
    x.map_or_else(|| "-".into(), |x| format!("{x:.2}x"))
}

/// The markdown table of the rows.
pub fn markdown_table(rows: &[PeerRow]) -> String {
    let mut s = String::from(
        "| method | median s/frame | x VTK (mapper) | x VTK (wall) | frames | RMSE vs reference | max of 255 | PSNR dB |\n\
         | --- | --- | --- | --- | --- | --- | --- | --- |\n",
    );
    for r in rows {
        let psnr = if r.err.psnr.is_finite() {
            format!("{:.1}", r.err.psnr)
        } else {
            "-".into()
        };
        let _ = writeln!(
            s,
            "| {} | {:.4} | {} | {} | {} | {:.4} | {} | {psnr} |",
            r.method,
            r.time_s,
            speedup_cell(r.speedup[0]),
            speedup_cell(r.speedup[1]),
            r.frames,
            r.err.rmse,
            r.err.max_abs_255
        );
    }
    s
}

fn script_path(a: &PeerArgs) -> Result<PathBuf> {
    let p = match &a.script {
        Some(p) => p.clone(),
        None => Path::new(env!("CARGO_MANIFEST_DIR")).join("bench/peers/vtk.py"),
    };
    if !p.is_file() {
        bail!(
            "peer vtk: no script at {} (give --script bench/peers/vtk.py)",
            p.display()
        );
    }
    Ok(p)
}

/// Writes the volume's voxels as raw (u8, or u16 little-endian), x fastest.
fn write_raw(path: &Path, vol: &Volume) -> Result<&'static str> {
    let (kind, bytes): (&str, std::borrow::Cow<[u8]>) = match vol.voxels() {
        Voxels::U8(d) => ("u8", d.into()),
        Voxels::U16(d) => ("u16le", d.iter().flat_map(|v| v.to_le_bytes()).collect()),
    };
    golden::image::write_atomic(path, |w| w.write_all(&bytes))?;
    Ok(kind)
}

fn vec3(v: [f64; 3]) -> String {
    format!("{},{},{}", v[0], v[1], v[2])
}

/// Runs the peer's script on the exported view; returns its report and image.
fn run_peer(
    a: &PeerArgs,
    out_dir: &Path,
    vol: &Volume,
    cam: &Camera,
    tf_toml: &str,
    threads: usize,
) -> Result<(PeerReport, Image)> {
    let script = script_path(a)?;
    let dir = out_dir.join("peer-input");
    std::fs::create_dir_all(&dir).with_context(|| format!("cannot create {}", dir.display()))?;
    let raw = dir.join("volume.raw");
    let kind = write_raw(&raw, vol)?;
    let tf = dir.join("tf.toml");
    golden::image::write_atomic(&tf, |w| w.write_all(tf_toml.as_bytes()))?;
    let d = vol.dims();
    let npy = out_dir.join("vtk.npy");
    let mut cmd = Command::new(&a.python);
    cmd.arg(&script)
        .arg("--volume")
        .arg(&raw)
        .args(["--raw-dims", &format!("{},{},{}", d[0], d[1], d[2])])
        .args(["--raw-type", kind])
        // `--name=value`: a vector starting with a minus sign would read
        // as an option.
        .arg(format!("--spacing={}", vec3(vol.spacing())))
        .arg(format!("--eye={}", vec3(cam.eye.to_array())))
        .arg(format!("--look-at={}", vec3(cam.look_at.to_array())))
        .arg(format!("--up={}", vec3(cam.up.to_array())))
        .args(["--fov", &cam.fov_deg.to_string()])
        .args(["--size", &format!("{}x{}", cam.width, cam.height)])
        .arg("--tf-file")
        .arg(&tf)
        .args(["--frames", &a.frames.to_string()])
        .args(["--threads", &threads.to_string()])
        .args(["--sample-distance", &a.sample_distance.to_string()])
        .arg("--npy")
        .arg(&npy)
        .arg("--png")
        .arg(out_dir.join("vtk.png"));
    if let Some(sh) = peer_shade(a)? {
        let m = sh.material;
        cmd.arg("--shade").arg(format!(
            "--material={},{},{},{}",
            m.ambient, m.diffuse, m.specular, m.shininess
        ));
        for l in sh.lights() {
            cmd.arg(format!("--light={}", vec3(*l)));
        }
    }
    let out = cmd.output().with_context(|| {
        format!(
            "peer vtk: cannot run {} (give --python)",
            a.python.display()
        )
    })?;
    let stdout = String::from_utf8_lossy(&out.stdout);
    if !out.status.success() {
        let stderr = String::from_utf8_lossy(&out.stderr);
        let line = stderr
            .lines()
            .rev()
            .map(str::trim)
            .find(|l| l.contains("error"))
            .or_else(|| stderr.lines().rev().map(str::trim).find(|l| !l.is_empty()))
            .unwrap_or("no message");
        bail!("peer vtk failed ({}): {line}", out.status);
    }
    let report = parse_peer_report(&stdout)?;
    let bytes = std::fs::read(&npy).with_context(|| format!("cannot read {}", npy.display()))?;
    let img = read_npy_image(&bytes).with_context(|| format!("{}", npy.display()))?;
    if (img.width, img.height) != (cam.width as usize, cam.height as usize) {
        bail!(
            "peer vtk wrote a {}x{} image for a {}x{} view",
            img.width,
            img.height,
            cam.width,
            cam.height
        );
    }
    Ok((report, img))
}

/// Runs `ercube peer`.
pub fn run(a: &PeerArgs) -> Result<()> {
    if a.frames == 0 || a.frames > 1000 {
        bail!("--frames {} must be 1 to 1000", a.frames);
    }
    if !(a.sample_distance.is_finite() && a.sample_distance > 0.0) {
        bail!(
            "--sample-distance {} must be a positive length",
            a.sample_distance
        );
    }
    let methods = parse_peer_methods(&a.methods)?;
    peer_shade(a)?;
    let views = views::parse_views(&a.views)?;
    super::outputs::check_dirs(&[Some(&a.out_dir)])?;
    with_threads(a.threads, || compare_with_peer(a, &methods, &views))
}

fn compare_with_peer(a: &PeerArgs, methods: &[MethodSpec], views: &[PeerView]) -> Result<()> {
    let (vol, tf, given) = a.view.load()?;
    if given.image_plane != ImagePlane::Camera {
        bail!("the peer renders an ordinary camera: drop --image-plane front");
    }
    script_path(a)?;
    let cams = views
        .iter()
        .map(|v| Ok((*v, v.camera(&given)?)))
        .collect::<Result<Vec<_>>>()?;
    let mut all = Vec::new();
    for (v, cam) in cams {
        let out = if views.len() > 1 {
            a.out_dir.join(v.name())
        } else {
            a.out_dir.clone()
        };
        let rows = compare_view(a, methods, (&vol, &tf, &cam), &out)?;
        all.push((v, cam, rows));
    }
    if views.len() > 1 {
        views::write_table(a, &all)?;
    }
    Ok(())
}

/// One view's comparison, written under `out`; returns its rows.
fn compare_view(
    a: &PeerArgs,
    methods: &[MethodSpec],
    (vol, tf, cam): (&Volume, &golden::tf::TransferFunction, &Camera),
    out: &Path,
) -> Result<Vec<PeerRow>> {
    let cam = *cam;
    let threads = rayon::current_num_threads();
    let lut = lut_for(vol.kind(), tf);
    let prep = Prepared::new(vol, &cam)?;
    std::fs::create_dir_all(out).with_context(|| format!("cannot create {}", out.display()))?;

    let (reference, ref_time) = {
        let _s = Stage::start("rendering the reference");
        let t = Instant::now();
        let f = render(&prep, &lut, Technique::Reference, &shaded(a)?)?;
        (f.image, t.elapsed().as_secs_f64())
    };
    reference.write_png(&out.join("reference.png"))?;
    reference.write_npy(&out.join("reference.npy"))?;
    // `:fp`: the frame at the view's footprint level, as `ercube render
    // --rays footprint` draws it; its levels are prepared once, untimed.
    let level = golden::ergaze::footprint_level(&prep.view);
    let coarse = if level > 0 && methods.iter().any(|m| m.footprint) {
        let _s = Stage::start(format!("preparing footprint level {level}"));
        Some(prep.clone().with_gaze_levels(
            vol,
            &cam,
            &golden::render::PrepareOptions::default(),
            level,
        )?)
    } else {
        None
    };
    let mut rows = Vec::new();
    let mut images: Vec<(String, Image)> = Vec::new();
    for m in methods.iter().filter(|m| m.tech != Technique::Reference) {
        let _s = Stage::start(format!("rendering with {}", m.label()));
        let mut opts = shaded(a)?;
        opts.slice.substeps = m.substeps;
        opts.slice.preintegrate = m.preintegrate.is_some();
        opts.slice.pre_colouring = m.preintegrate.unwrap_or_default();
        opts.slice.validate()?;
        let prep = match &coarse {
            Some(c) if m.footprint => {
                opts.reference.gaze = Some(golden::gaze::Gaze::uniform(level));
                c
            }
            _ => &prep,
        };
        render(prep, &lut, m.tech, &opts)?.recycle(); // warm-up
        let mut times = Vec::with_capacity(a.frames);
        let mut last = None;
        for _ in 0..a.frames {
            let t = Instant::now();
            let f = render(prep, &lut, m.tech, &opts)?;
            times.push(t.elapsed().as_secs_f64());
            if let Some(old) = last.replace(f) {
                old.recycle();
            }
        }
        let img = last.expect("at least one frame").image;
        rows.push(PeerRow {
            method: m.label(),
            time_s: median(&mut times),
            speedup: [None; 2],
            frames: a.frames,
            err: compare(&img, &reference)?,
        });
        img.write_png(&out.join(format!("{}.png", m.label().replace(':', "-s"))))?;
        images.push((m.label(), img));
    }
    let (report, vtk_img) = {
        let _s = Stage::start("rendering with vtk");
        run_peer(a, out, vol, &cam, &tf.to_toml_string(), threads)?
    };
    rows.push(PeerRow {
        method: "vtk".into(),
        time_s: report.time_s,
        speedup: [None; 2],
        frames: a.frames,
        err: compare(&vtk_img, &reference)?,
    });
    if methods.iter().any(|m| m.tech == Technique::Reference) {
        rows.push(PeerRow {
            method: "reference".into(),
            time_s: ref_time,
            speedup: [None; 2],
            frames: 1,
            err: compare(&reference, &reference)?,
        });
    }
    set_speedups(&mut rows, report.time_s, report.wall_time_s);
    images.push(("vtk".into(), vtk_img));
    images.push(("reference".into(), reference));
    write_outputs(a, out, (vol, &cam), &rows, &report, threads, &images)?;
    Ok(rows)
}

fn median(v: &mut [f64]) -> f64 {
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n % 2 == 1 {
        v[n / 2]
    } else {
        (v[n / 2 - 1] + v[n / 2]) / 2.0
    }
}

fn write_outputs(
    a: &PeerArgs,
    out: &Path,
    (vol, cam): (&Volume, &Camera),
    rows: &[PeerRow],
    report: &PeerReport,
    threads: usize,
    images: &[(String, Image)],
) -> Result<()> {
    let label = a.view.source.label();
    let d = vol.dims();
    let view = format!(
        "{label} ({}x{}x{}, spacing {:?}), eye {:?} looking at {:?}, up {:?}, {} degrees, {}x{}",
        d[0],
        d[1],
        d[2],
        vol.spacing(),
        cam.eye.to_array(),
        cam.look_at.to_array(),
        cam.up.to_array(),
        cam.fov_deg,
        cam.width,
        cam.height
    );
    let wall = report.wall_time_s.map_or_else(String::new, |w| {
        format!(", {w:.4} s wall clock with the window's blit")
    });
    let peer = format!(
        "VTK {} `{}` ({}, offscreen), {} threads, sample distance {} world units, image sample distance 1, \
         opacity unit distance 1; timed by {} ({:.4} s a frame{wall})",
        report.vtk_version,
        report.mapper,
        report.backend,
        report.threads,
        a.sample_distance,
        if report.timer.is_empty() { "the wall clock" } else { &report.timer },
        report.time_s,
    );
    let shading = match peer_shade(a)? {
        None => "not shaded".to_string(),
        Some(sh) => {
            let m = sh.material;
            let lights = match sh.lights().len() {
                0 => "the headlight".to_string(),
                n => format!("{n} directional lights"),
            };
            format!(
                "shaded alike: Blinn-Phong ka {} kd {} ks {} power {}, {lights}",
                m.ambient, m.diffuse, m.specular, m.shininess
            )
        }
    };
    let peer = format!("{peer}; {shading}");
    let mut csv =
        String::from("method,time_s,x_vtk_mapper,x_vtk_wall,frames,rmse,max_abs_255,psnr\n");
    let num = |x: Option<f64>| x.map_or_else(String::new, |x| format!("{x:.4}"));
    for r in rows {
        writeln!(
            csv,
            "{},{:.6},{},{},{},{:.6},{},{:.3}",
            r.method,
            r.time_s,
            num(r.speedup[0]),
            num(r.speedup[1]),
            r.frames,
            r.err.rmse,
            r.err.max_abs_255,
            r.err.psnr
        )?;
    }
    golden::image::write_atomic(&out.join("peer.csv"), |w| w.write_all(csv.as_bytes()))?;
    let json = serde_json::json!({
        "view": view,
        "peer": {"name": "vtk", "version": report.vtk_version, "backend": report.backend,
                 "mapper": report.mapper, "threads": report.threads,
                 "sample_distance": a.sample_distance, "timer": report.timer,
                 "time_s": report.time_s, "times_s": report.times_s,
                 "wall_time_s": report.wall_time_s, "wall_times_s": report.wall_times_s},
        "ercube_threads": threads,
        "shading": shading,
        "rows": rows.iter().map(|r| serde_json::json!({
            "method": r.method, "time_s": r.time_s, "frames": r.frames,
            "x_vtk_mapper": r.speedup[0], "x_vtk_wall": r.speedup[1],
            "error_vs_reference": super::stats::error_json(&r.err),
        })).collect::<Vec<_>>(),
    });
    super::stats::write_json(&out.join("peer.json"), &json)?;

    // Error against time, with the Pareto front of the measured points.
    let mut series = Vec::new();
    let mut all = Vec::new();
    for r in rows.iter().filter(|r| r.err.rmse > 0.0) {
        all.push((r.time_s, r.err.rmse));
        let s = Series::new(r.method.clone(), vec![(r.time_s, r.err.rmse)], Kind::Points);
        series.push(if r.method.contains(':') {
            s.with_color(plotters::style::RGBColor(23, 190, 207))
        } else if r.method == "vtk" {
            s.with_color(plotters::style::RGBColor(227, 119, 194))
        } else {
            s
        });
    }
    let front = pareto(&all);
    if front.len() > 1 {
        series.push(
            Series::new("Pareto front", front, Kind::Line)
                .with_color(plotters::style::RGBColor(90, 90, 90)),
        );
    }
    write_chart(
        &out.join("error_vs_time.png"),
        &Chart {
            title: format!("{label}: ercube and VTK, error against time"),
            x_label: format!(
                "median seconds per frame ({} frames, {threads} threads)",
                a.frames
            ),
            y_label: "RMSE against ercube's reference".into(),
            x_log: true,
            y_log: true,
            series,
        },
        (720, 560),
    )?;
    let labelled: Vec<(String, &Image)> = images.iter().map(|(l, i)| (l.clone(), i)).collect();
    write_montage(&out.join("montage.png"), &labelled)?;

    let md = format!(
        "# {label}: ercube against VTK\n\n\
         Generated by `{}`.\n\n**View:** {view}.\n\n**Peer:** {peer}.\n\n\
         **ercube:** {threads} rayon threads; each method's median of {} frames after a warm-up \
         frame, the reference one frame; every error is against ercube's reference.\n\n{}\n\
         ![error against time](error_vs_time.png)\n",
        super::bench::command_line(),
        a.frames,
        markdown_table(rows)
    );
    golden::image::write_atomic(&out.join("summary.md"), |w| w.write_all(md.as_bytes()))?;
    super::say(&format!(
        "{view}\n{peer}\n{}",
        markdown_table(rows).trim_end()
    ));
    super::say(&format!("wrote {}", out.display()));
    Ok(())
}

mod report;
#[cfg(test)]
mod tests;
mod views;

pub use report::{parse_peer_report, read_npy_image, PeerReport};
