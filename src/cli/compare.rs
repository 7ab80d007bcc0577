//! `ercube compare` and `ercube demo`: every chosen method on one view, its
//! image, a labelled montage, and a table of time, samples and error
//! against the reference (stdout and CSV).

use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{Context, Result};
use clap::Args;
use glam::DVec3;

use golden::metrics::{compare, ImageError};
use golden::render::{lut_for, render, Frame, Prepared, Technique};

use super::args::{with_threads, CameraArgs, PlaneArg, SliceArgs, SourceArgs, TfArgs, ViewArgs};
use super::memory::FrameSpec;
use super::method::MethodArg;
use super::montage::write_montage;
use super::progress::Stage;
use super::stats::{error_json, write_json};

/// What `compare` and `demo` render unless told otherwise: every golden
/// method.
const DEFAULT_METHODS: &str = "er,er-ftb,under,over,box,reference";

/// Arguments of `ercube compare`.
#[derive(Debug, Args)]
pub struct CompareArgs {
    #[command(flatten)]
    pub view: ViewArgs,
    /// Comma-separated golden methods (the reference is always rendered
    /// for the errors).
    #[arg(long, value_enum, value_delimiter = ',', default_value = DEFAULT_METHODS)]
    pub methods: Vec<MethodArg>,
    /// Directory for the images, montage, CSV and JSON.
    #[arg(long, default_value = "compare")]
    pub out_dir: PathBuf,
    #[command(flatten)]
    pub slice: SliceArgs,
    /// Worker threads (default: all cores).
    #[arg(long)]
    pub threads: Option<usize>,
    /// Also render every listed method that takes a gaze (reference,
    /// mipmap, er, er-ftb) with the paper's gaze profile around pixel x,y,
    /// as rows `NAME+gaze`.
    #[arg(long, value_parser = super::args::parse_point2, allow_hyphen_values = true)]
    pub gaze: Option<[f64; 2]>,
}

/// Whether `tech` takes a gaze profile.
fn takes_gaze(tech: Technique) -> bool {
    use golden::methods::Method;
    matches!(
        tech,
        Technique::Reference | Technique::MipMap | Technique::Slice(Method::Er | Method::ErFtb)
    )
}

/// Arguments of `ercube demo`.
#[derive(Debug, Args)]
pub struct DemoArgs {
    /// Directory for the demo's images, montage and table.
    #[arg(long, default_value = "ercube-demo")]
    pub out_dir: PathBuf,
}

/// One row of the comparison table.
struct Row {
    name: String,
    time_s: f64,
    samples: Option<u64>,
    err: ImageError,
}

/// Runs `ercube compare`.
pub fn run(a: &CompareArgs) -> Result<()> {
    super::outputs::check_dirs(&[Some(&a.out_dir)])?;
    let techs = a
        .methods
        .iter()
        .map(|m| {
            m.technique().with_context(|| {
                format!(
                    "compare runs the golden methods; render {} with `ercube render --method {}`",
                    m.name(),
                    m.name()
                )
            })
        })
        .collect::<Result<Vec<_>>>()?;
    super::outputs::all_or_nothing(&[&a.out_dir], || {
        with_threads(a.threads, || compare_views(a, &techs))
    })
}

fn compare_views(a: &CompareArgs, techs: &[Technique]) -> Result<()> {
    let mut opts = a.slice.options()?;
    // The method needing the most memory sizes the check (every method
    // shares the slice stack; the mip-map and shear-warp add their own).
    let hungriest = [Technique::MipMap, Technique::ShearWarp]
        .into_iter()
        .find(|t| techs.contains(t))
        .unwrap_or(Technique::Reference);
    let spec = FrameSpec {
        technique: Some(hungriest),
        shade: opts.slice.shade.is_some(),
        size: a.view.camera.size,
    };
    let (vol, tf, cam) = a.view.load_for("compare", &spec)?;
    a.slice.apply_tf(&mut opts, &tf)?;
    let lut = lut_for(vol.kind(), &tf);
    let mut prep = a.slice.prepared(&vol, &cam)?;
    let gaze = match a.gaze {
        Some(at) => {
            if !techs.iter().any(|&t| takes_gaze(t)) {
                anyhow::bail!("--gaze needs one of reference, mipmap, er or er-ftb in --methods");
            }
            let g = golden::gaze::Gaze::around(at, cam.width, cam.height);
            g.validate()?;
            if techs
                .iter()
                .any(|t| matches!(t, Technique::Slice(_)) && takes_gaze(*t))
            {
                prep = prep.with_gaze_levels(&vol, &cam, &a.slice.prepare()?, g.levels)?;
            }
            Some(g)
        }
        None => None,
    };
    std::fs::create_dir_all(&a.out_dir)
        .with_context(|| format!("cannot create {}", a.out_dir.display()))?;

    let reference = {
        let _s = Stage::start("rendering the reference");
        let t = Instant::now();
        let f = render(&prep, &lut, Technique::Reference, &opts)?;
        (f, t.elapsed().as_secs_f64())
    };
    if techs.contains(&Technique::MipMap) {
        // Built once per volume and table (cached in `prep`), so not part
        // of the frame time below; said apart.
        let t = Instant::now();
        let m = prep.mipmap_of(&lut, &opts.mip())?;
        super::say(&format!(
            "mipmap: {} levels, {} voxels, built in {:.3} s (cached per volume and table, not in the frame time)",
            m.levels.len(),
            m.voxels(),
            t.elapsed().as_secs_f64()
        ));
    }
    if techs.contains(&Technique::ShearWarp) {
        // Like the pyramid: classified and run-length encoded once per
        // volume, principal axis and table.
        let t = Instant::now();
        let c = prep.classified_for(&lut)?;
        super::say(&format!(
            "shear-warp: {} runs, {:.1}% of voxels visible, classified in {:.3} s (cached per volume, axis and table, not in the frame time)",
            c.run_count(),
            100.0 * c.occupied_fraction(),
            t.elapsed().as_secs_f64()
        ));
    }
    let mut frames: Vec<(String, Frame, f64)> = Vec::new();
    for &tech in techs {
        if tech != Technique::Reference {
            let _s = Stage::start(format!("rendering with {}", tech.name()));
            let t = Instant::now();
            let f = render(&prep, &lut, tech, &opts)?;
            frames.push((tech.name().to_string(), f, t.elapsed().as_secs_f64()));
        }
        if let (Some(g), true) = (gaze, takes_gaze(tech)) {
            let name = format!("{}+gaze", tech.name());
            let _s = Stage::start(format!("rendering with {name}"));
            let mut o = opts;
            o.reference.gaze = Some(g);
            let t = Instant::now();
            let f = render(&prep, &lut, tech, &o)?;
            frames.push((name, f, t.elapsed().as_secs_f64()));
        }
    }
    let mut rows = Vec::new();
    for (name, f, time_s) in &frames {
        rows.push(Row {
            name: name.clone(),
            time_s: *time_s,
            samples: f.samples(),
            err: compare(&f.image, &reference.0.image)?,
        });
    }
    if techs.contains(&Technique::Reference) {
        rows.push(Row {
            name: "reference".into(),
            time_s: reference.1,
            samples: None,
            err: compare(&reference.0.image, &reference.0.image)?,
        });
    }
    for (name, f, _) in &frames {
        f.image.write_png(&a.out_dir.join(format!("{name}.png")))?;
    }
    reference
        .0
        .image
        .write_png(&a.out_dir.join("reference.png"))?;

    let mut labelled: Vec<(String, &golden::image::Image)> = frames
        .iter()
        .zip(&rows)
        .map(|((name, f, _), r)| (format!("{name} rmse {:.4}", r.err.rmse), &f.image))
        .collect();
    if techs.contains(&Technique::Reference) {
        labelled.push(("reference".into(), &reference.0.image));
    }
    write_montage(&a.out_dir.join("montage.png"), &labelled)?;
    write_table(&a.out_dir, &rows, &a.view.source.label(), &prep, cam.eye)?;
    Ok(())
}

/// What the table's and the montage's error figures are, and why the
/// slice-order methods never reach the reference on thin surfaces.
const NOTE: &str = "rmse: root-mean-square error against the reference image (RGBA in 0..1; the \
montage labels it too); max/255: the largest channel difference in 8-bit levels. Slice-order \
methods (er, er-ftb, under, over, box) take one sample per slice crossing, so a surface \
thinner than the step, such as the reference's thin skin, is missed or blurred: --substeps N \
samples N times per slice.";

fn write_table(dir: &Path, rows: &[Row], label: &str, prep: &Prepared, eye: DVec3) -> Result<()> {
    let mut csv = String::from("method,time_s,samples,max_abs_255,rmse,psnr\n");
    let mut table = format!(
        "{label}: eye {:?}, principal axis {}, D = {:.3}, {}x{}\n{:<10} {:>10} {:>12} {:>8} {:>10} {:>8}\n",
        eye.to_array(),
        prep.view.axes.label(),
        prep.view.d,
        prep.view.size[0],
        prep.view.size[1],
        "method",
        "time_s",
        "samples",
        "max/255",
        "rmse",
        "psnr"
    );
    let mut json = Vec::new();
    for r in rows {
        let samples = r
            .samples
            .map(|s| s.to_string())
            .unwrap_or_else(|| "-".into());
        writeln!(
            csv,
            "{},{:.6},{},{},{:.6},{:.3}",
            r.name, r.time_s, samples, r.err.max_abs_255, r.err.rmse, r.err.psnr
        )?;
        writeln!(
            table,
            "{:<10} {:>10.4} {:>12} {:>8} {:>10.5} {:>8.2}",
            r.name, r.time_s, samples, r.err.max_abs_255, r.err.rmse, r.err.psnr
        )?;
        json.push(serde_json::json!({
            "method": r.name, "time_s": r.time_s, "samples": r.samples, "error_vs_reference": error_json(&r.err),
        }));
    }
    golden::image::write_atomic(&dir.join("compare.csv"), |w| w.write_all(csv.as_bytes()))?;
    write_json(&dir.join("compare.json"), &serde_json::Value::Array(json))?;
    super::say(table.trim_end());
    super::say(NOTE);
    super::say(&format!("wrote {}", dir.display()));
    Ok(())
}

/// Runs `ercube demo`: the paper's 127-degree view of the checkerboard at
/// 128^3 with the image on the volume's front face.
pub fn demo(a: &DemoArgs) -> Result<()> {
    let args = CompareArgs {
        view: ViewArgs {
            source: SourceArgs {
                scene: Some("checker:128".into()),
                volume: None,
                raw_dims: None,
                raw_type: golden::load::RawType::U8,
                raw_offset: 0,
                spacing: None,
                window: None,
                max_memory: None,
                allow_outside_data: false,
            },
            camera: CameraArgs {
                eye: Some(DVec3::new(64.0, 64.0, -32.0)),
                look_at: Some(DVec3::new(64.0, 64.0, 64.0)),
                up: Some(DVec3::Y),
                space: super::args::SpaceArg::Voxel,
                fov: 127.0,
                size: [256, 256],
                image_plane: PlaneArg::Front,
            },
            tf: TfArgs {
                tf: None,
                tf_file: None,
            },
        },
        methods: DEFAULT_METHODS
            .split(',')
            .filter_map(MethodArg::parse)
            .collect(),
        out_dir: a.out_dir.clone(),
        slice: SliceArgs::default(),
        threads: None,
        gaze: None,
    };
    run(&args)
}
