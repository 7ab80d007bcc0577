//! `ercube sweep-widths`: the pipeline over a grid of datapath widths on
//! one view, each width varied alone around the base configuration,
//! writing the error against golden `er` (same classification table) and
//! against the reference beside the total datapath bits, as CSV, a plot
//! and a markdown summary.
//!
//! **Total datapath bits** is the sum of the widths of the configuration's
//! 13 register formats (voxel, position, step, weight, sample, color,
//! alpha, path, log_transmittance, opacity_corr, accum_color, accum_alpha,
//! merge), each counted once: a proxy of the datapath's register and
//! arithmetic width, not an area model.

use std::path::PathBuf;
use std::time::Instant;

use anyhow::{bail, Context, Result};
use clap::Args;

use golden::metrics::{compare, ImageError};
use golden::render::{lut_for, render, Prepared, RenderOptions, Technique};
use golden::tf::Lut;
use golden::volume::Volume;
use pipeline::config::PipelineConfig;

use crate::cli::chip::ConfigArgs;
use pipeline::fixed::Format;

use super::super::args::{with_threads, ViewArgs};
use super::progress;
use super::shard::Shard;

mod output;

pub use output::{summary, write_sweep};

/// Default values swept of each knob: from where the image visibly breaks
/// to well past each default.
pub const DEFAULT_ALPHA: &str = "4-16";
/// See [`DEFAULT_ALPHA`].
pub const DEFAULT_ACCUM: &str = "8-24";
/// See [`DEFAULT_ALPHA`].
pub const DEFAULT_POSITION: &str = "4-20";
/// See [`DEFAULT_ALPHA`].
pub const DEFAULT_WEIGHT: &str = "3-14";
/// See [`DEFAULT_ALPHA`].
pub const DEFAULT_COLOR: &str = "3-10";
/// See [`DEFAULT_ALPHA`].
pub const DEFAULT_SAMPLE: &str = "0-6";
/// The gradient's fraction bits swept with `--shade` (see [`DEFAULT_ALPHA`]).
pub const DEFAULT_GRADIENT: &str = "0-8";
/// The cosines' fraction bits swept with `--shade`.
pub const DEFAULT_NORMAL: &str = "4-14";

/// The default grid of every knob.
pub fn default_grid() -> Vec<(Knob, Vec<u8>)> {
    [
        (Knob::Alpha, DEFAULT_ALPHA),
        (Knob::Accum, DEFAULT_ACCUM),
        (Knob::Position, DEFAULT_POSITION),
        (Knob::Weight, DEFAULT_WEIGHT),
        (Knob::Color, DEFAULT_COLOR),
        (Knob::Sample, DEFAULT_SAMPLE),
    ]
    .into_iter()
    .map(|(k, r)| (k, parse_values(k.name(), r).expect("valid default range")))
    .collect()
}

/// Arguments of `ercube sweep-widths`.
#[derive(Debug, Args)]
pub struct SweepArgs {
    #[command(flatten)]
    pub view: ViewArgs,
    /// Base configuration and PE count (results do not depend on the count).
    #[command(flatten)]
    pub cfg: ConfigArgs,
    /// alpha = ufixed<B,0> for each B ("A-B", "A,B,..." or "none").
    #[arg(long, default_value = DEFAULT_ALPHA)]
    pub alpha_bits: String,
    /// accum_color = accum_alpha = ufixed<B,0>, with merge = ufixed<B+4,4>
    /// and opacity_corr's fraction cut to B when B is below it.
    #[arg(long, default_value = DEFAULT_ACCUM)]
    pub accum_bits: String,
    /// Fraction bits F of position (integer bits kept).
    #[arg(long, default_value = DEFAULT_POSITION)]
    pub position_frac: String,
    /// weight = ufixed<B,0> (interpolation and exp-table weights).
    #[arg(long, default_value = DEFAULT_WEIGHT)]
    pub weight_bits: String,
    /// Fraction bits F of the colour table entries, color = ufixed<F+1,1>.
    #[arg(long, default_value = DEFAULT_COLOR)]
    pub color_frac: String,
    /// Fraction bits F of the interpolated sample (integer bits kept).
    #[arg(long, default_value = DEFAULT_SAMPLE)]
    pub sample_frac: String,
    /// Shade (headlight, the default material) in golden, the reference
    /// and the pipeline, and sweep the shading unit's widths too.
    #[arg(long)]
    pub shade: bool,
    /// Fraction bits F of the gradient (integer bits kept); "auto" is
    /// 0-8 with --shade, none without.
    #[arg(long, default_value = "auto")]
    pub gradient_frac: String,
    /// Fraction bits F of the cosines, normal_dot = ufixed<F+1,1> (the
    /// power table's index bits capped at F); "auto" is 4-14 with
    /// --shade, none without.
    #[arg(long, default_value = "auto")]
    pub normal_frac: String,
    /// Directory for widths.csv, widths.png and widths.md.
    #[arg(long, default_value = "sweep-widths")]
    pub out_dir: PathBuf,
    /// Worker threads (default: all cores); results are identical for any count.
    #[arg(long)]
    pub threads: Option<usize>,
    /// Run only shard K of N (every N-th configuration from the K-th, the
    /// base being the first) and write its rows as DIR/shard-K-of-N.json;
    /// `ercube merge-results` joins the N shards.
    #[arg(long, value_name = "K/N")]
    pub shard: Option<Shard>,
}

/// A width that the sweep varies.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Knob {
    /// Classified opacity bits.
    Alpha,
    /// Accumulator bits (colour and opacity together).
    Accum,
    /// Position fraction bits.
    Position,
    /// Weight bits.
    Weight,
    /// Colour entry fraction bits.
    Color,
    /// Sample fraction bits.
    Sample,
    /// Gradient fraction bits (shading).
    Gradient,
    /// Cosine fraction bits (shading).
    Normal,
}

impl Knob {
    /// Every knob.
    pub const ALL: [Knob; 8] = [
        Knob::Alpha,
        Knob::Accum,
        Knob::Position,
        Knob::Weight,
        Knob::Color,
        Knob::Sample,
        Knob::Gradient,
        Knob::Normal,
    ];

    /// The knob named `name` ([`Knob::name`]).
    pub fn from_name(name: &str) -> Option<Knob> {
        Knob::ALL.into_iter().find(|k| k.name() == name)
    }

    /// Name in the CSV and the plot.
    pub fn name(self) -> &'static str {
        match self {
            Knob::Alpha => "alpha bits",
            Knob::Accum => "accumulator bits",
            Knob::Position => "position fraction bits",
            Knob::Weight => "weight bits",
            Knob::Color => "colour fraction bits",
            Knob::Sample => "sample fraction bits",
            Knob::Gradient => "gradient fraction bits",
            Knob::Normal => "cosine fraction bits",
        }
    }

    /// The knob's value in `cfg`.
    pub fn value(self, cfg: &PipelineConfig) -> u8 {
        match self {
            Knob::Alpha => cfg.alpha.bits(),
            Knob::Accum => cfg.accum_color.bits(),
            Knob::Position => cfg.position.frac(),
            Knob::Weight => cfg.weight.bits(),
            Knob::Color => cfg.color.frac(),
            Knob::Sample => cfg.sample.frac(),
            Knob::Gradient => cfg.gradient.frac(),
            Knob::Normal => cfg.normal_dot.frac(),
        }
    }

    /// `base` with this knob set to `v` (and the fields it drags along).
    pub fn apply(self, base: &PipelineConfig, v: u8) -> Result<PipelineConfig> {
        let like = |f: Format, bits: u8, frac: u8| -> Result<Format> {
            Format::new(bits, frac, f.is_signed(), f.quant(), f.overflow())
                .map_err(|e| anyhow::anyhow!("{}", e.describe(self.name())))
        };
        let mut c = *base;
        match self {
            Knob::Alpha => c.alpha = like(c.alpha, v, v)?,
            Knob::Accum => {
                c.accum_color = like(c.accum_color, v, v)?;
                c.accum_alpha = like(c.accum_alpha, v, v)?;
                let m_int = c.merge.int_bits();
                c.merge = like(c.merge, v.saturating_add(m_int), v)?;
                let oc_frac = c.opacity_corr.frac().min(v);
                let oc_int = c.opacity_corr.int_bits();
                c.opacity_corr = like(c.opacity_corr, oc_frac + oc_int, oc_frac)?;
            }
            Knob::Position => {
                let int = c.position.int_bits();
                c.position = like(c.position, int.saturating_add(v), v)?;
            }
            Knob::Weight => c.weight = like(c.weight, v, v)?,
            Knob::Color => {
                let int = c.color.int_bits();
                c.color = like(c.color, int.saturating_add(v), v)?;
            }
            Knob::Sample => {
                let int = c.sample.int_bits();
                c.sample = like(c.sample, int.saturating_add(v), v)?;
            }
            Knob::Gradient => {
                let int = c.gradient.int_bits();
                c.gradient = like(c.gradient, int.saturating_add(v), v)?;
            }
            Knob::Normal => {
                let int = c.normal_dot.int_bits();
                c.normal_dot = like(c.normal_dot, int.saturating_add(v), v)?;
                c.shade_table_bits = c.shade_table_bits.min(v.max(1));
            }
        }
        c.validate()?;
        Ok(c)
    }
}

/// The shading unit's formats, counted only when shading.
const SHADING_FORMATS: [&str; 8] = [
    "gradient",
    "grad_scale",
    "grad_norm",
    "light",
    "normal_dot",
    "specular",
    "material",
    "grad_recip",
];

/// The volume-of-interest stage's formats: the sweep renders without a
/// VOI, so they are never counted.
const VOI_FORMATS: [&str; 5] = [
    "voi_axis",
    "voi_dist",
    "voi_weight",
    "voi_gain",
    "voi_factor",
];

/// The pre-integration unit's formats: the sweep renders without it, so
/// they are never counted.
const PREINT_FORMATS: [&str; 2] = ["preint_tau", "preint_color"];

/// The sum of the widths of every register format the datapath has (see
/// the module docs): the shading unit's only when `shading`, the
/// volume-of-interest stage's never.
pub fn total_bits(c: &PipelineConfig, shading: bool) -> u32 {
    c.formats()
        .iter()
        .filter(|(name, _)| !VOI_FORMATS.contains(name) && !PREINT_FORMATS.contains(name))
        .filter(|(name, _)| shading || !SHADING_FORMATS.contains(name))
        .map(|(_, f)| u32::from(f.bits()))
        .sum()
}

/// Parses a knob's values: `A-B`, `A,B,...` or `none`.
pub fn parse_values(flag: &str, s: &str) -> Result<Vec<u8>> {
    let s = s.trim();
    if s == "none" || s.is_empty() {
        return Ok(Vec::new());
    }
    let num = |t: &str| -> Result<u8> {
        t.trim()
            .parse::<u8>()
            .ok()
            .filter(|&v| v <= 63)
            .ok_or_else(|| anyhow::anyhow!("--{flag}: '{t}' is not a width from 0 to 63"))
    };
    if let Some((a, b)) = s.split_once('-') {
        let (a, b) = (num(a)?, num(b)?);
        if a > b {
            bail!("--{flag}: range {a}-{b} runs backwards");
        }
        return Ok((a..=b).collect());
    }
    s.split(',').map(num).collect()
}

/// One run of the sweep.
#[derive(Debug, Clone)]
pub struct WidthRow {
    /// The knob varied (`None`: the base configuration).
    pub knob: Option<Knob>,
    /// Its value.
    pub value: u8,
    /// Total datapath bits.
    pub total_bits: u32,
    /// Why it did not run.
    pub skipped: Option<String>,
    /// Against golden er with the same table.
    pub vs_er: Option<ImageError>,
    /// Against the reference.
    pub vs_ref: Option<ImageError>,
    /// Assignments that overflowed (saturated or wrapped).
    pub overflows: u64,
    /// Cycles of the frame.
    pub cycles: u64,
    /// Seconds of the model's frame.
    pub time_s: f64,
}

/// Each knob the sweep varies and its values.
pub type Grid = Vec<(Knob, Vec<u8>)>;

/// A sweep on one view.
pub struct Sweep {
    /// Name of the scene and view, for titles.
    pub label: String,
    /// The base configuration.
    pub base: PipelineConfig,
    /// The values of each knob.
    pub grid: Vec<(Knob, Vec<u8>)>,
    /// Shading in golden, the reference and the pipeline.
    pub shade: Option<golden::shading::Shade>,
}

impl Sweep {
    /// Configurations run: the base, then every knob's values.
    pub fn runs(&self) -> usize {
        1 + self.grid.iter().map(|g| g.1.len()).sum::<usize>()
    }
}

/// What a sweep measured.
pub struct SweepResult {
    /// Base first, then knob by knob.
    pub rows: Vec<WidthRow>,
    /// Golden er's own error against the reference, for scale.
    pub er_vs_ref: ImageError,
}

/// Runs the sweep on a prepared view.
pub fn run_sweep(
    sw: &Sweep,
    vol: &Volume,
    tf: &golden::tf::TransferFunction,
    prep: &Prepared,
    shard: Option<Shard>,
) -> Result<SweepResult> {
    let mut opts = RenderOptions::default();
    opts.slice.shade = sw.shade;
    opts.reference.shade = sw.shade;
    let runs = (0..sw.runs())
        .filter(|&i| shard.is_none_or(|s| s.owns(i)))
        .count();
    let bar = progress(runs as u64 + 2);
    bar.set_message(format!("{}: reference", sw.label));
    let reference = render(prep, &lut_for(vol.kind(), tf), Technique::Reference, &opts)?.image;
    bar.inc(1);
    let lut = Lut::for_bits(tf, sw.base.table_entries as usize, vol.kind().bits());
    let er = render(
        prep,
        &lut,
        Technique::Slice(golden::methods::Method::Er),
        &opts,
    )?
    .image;
    bar.inc(1);
    let er_vs_ref = compare(&er, &reference)?;
    let mut jobs: Vec<(Option<Knob>, u8)> = vec![(None, 0)];
    for (k, vs) in &sw.grid {
        jobs.extend(vs.iter().map(|&v| (Some(*k), v)));
    }
    let mut rows = Vec::new();
    for (i, (knob, v)) in jobs.into_iter().enumerate() {
        if shard.is_some_and(|s| !s.owns(i)) {
            continue;
        }
        let name = knob.map_or("base", Knob::name);
        bar.set_message(format!("{}: {name} {v}", sw.label));
        let cfg = match knob {
            None => Ok(sw.base),
            Some(k) => k.apply(&sw.base, v),
        };
        let mut row = WidthRow {
            knob,
            value: knob.map_or(0, |k| k.value(&sw.base)),
            total_bits: 0,
            skipped: None,
            vs_er: None,
            vs_ref: None,
            overflows: 0,
            cycles: 0,
            time_s: 0.0,
        };
        if knob.is_some() {
            row.value = v;
        }
        match cfg {
            Err(e) => row.skipped = Some(format!("{e:#}")),
            Ok(cfg) => {
                row.total_bits = total_bits(&cfg, sw.shade.is_some());
                let t = Instant::now();
                let frame = pipeline::array::Array::new(
                    &cfg,
                    vol,
                    &lut,
                    &prep.view,
                    waves::Tracer::disabled(),
                )
                .and_then(|mut a| {
                    if let Some(sh) = &sw.shade {
                        a.set_units(&[sh], &prep.view, vol.kind().bits(), false)?;
                    }
                    a.run(&prep.view)
                });
                match frame {
                    Ok(f) => {
                        row.time_s = t.elapsed().as_secs_f64();
                        let image = golden::warp::warp(&prep.view, &f.baseplane);
                        row.vs_er = Some(compare(&image, &er)?);
                        row.vs_ref = Some(compare(&image, &reference)?);
                        row.overflows = f.quant.overflows;
                        row.cycles = f.cycles;
                    }
                    Err(e) => row.skipped = Some(e.to_string()),
                }
            }
        }
        rows.push(row);
        bar.inc(1);
    }
    bar.finish_and_clear();
    Ok(SweepResult { rows, er_vs_ref })
}

/// Loads, prepares and runs a sweep from the command line's arguments.
pub fn sweep(a: &SweepArgs) -> Result<()> {
    crate::cli::outputs::check_dirs(&[Some(&a.out_dir)])?;
    crate::cli::outputs::all_or_nothing(&[&a.out_dir], || sweep_files(a))
}

/// [`sweep`] after its output check: every file it writes is staged.
fn sweep_files(a: &SweepArgs) -> Result<()> {
    let (base, grid) = grid_of(a)?;
    with_threads(a.threads, || {
        let (vol, tf, cam) = a.view.load()?;
        let prep = Prepared::new(&vol, &cam)?;
        std::fs::create_dir_all(&a.out_dir)
            .with_context(|| format!("cannot create {}", a.out_dir.display()))?;
        let sw = sweep_of(a, base, grid);
        let res = run_sweep(&sw, &vol, &tf, &prep, a.shard)?;
        if let Some(s) = a.shard {
            return super::shard::write_widths_shard(&a.out_dir, s, &res, sw.runs());
        }
        finish_sweep(a, &sw, &res, &super::command_line())
    })
}

/// The sweep `a` describes, over `base` and `grid`.
pub(super) fn sweep_of(a: &SweepArgs, base: PipelineConfig, grid: Vec<(Knob, Vec<u8>)>) -> Sweep {
    Sweep {
        label: a.view.source.label(),
        base,
        grid,
        shade: a.shade.then(golden::shading::Shade::default),
    }
}

/// Writes a sweep's CSV, plot and summary into `a.out_dir` and prints the
/// summary (`command` is the command line it names).
pub(super) fn finish_sweep(
    a: &SweepArgs,
    sw: &Sweep,
    res: &SweepResult,
    command: &str,
) -> Result<()> {
    std::fs::create_dir_all(&a.out_dir)
        .with_context(|| format!("cannot create {}", a.out_dir.display()))?;
    write_sweep(&a.out_dir, sw, res)?;
    let md = format!(
        "# Pipeline widths on {}\n\n`{}`\n\n{}",
        sw.label,
        command,
        summary(sw, res, "")
    );
    golden::image::write_atomic(&a.out_dir.join("widths.md"), |w| w.write_all(md.as_bytes()))?;
    super::super::say(md.trim_end());
    super::super::say(&format!("wrote {}", a.out_dir.display()));
    Ok(())
}

/// The base configuration and the knobs' values `a` asks for.
pub(super) fn grid_of(a: &SweepArgs) -> Result<(PipelineConfig, Grid)> {
    let base = a.cfg.load()?;
    let grid: Vec<(Knob, Vec<u8>)> = [
        (Knob::Alpha, "alpha-bits", &a.alpha_bits),
        (Knob::Accum, "accum-bits", &a.accum_bits),
        (Knob::Position, "position-frac", &a.position_frac),
        (Knob::Weight, "weight-bits", &a.weight_bits),
        (Knob::Color, "color-frac", &a.color_frac),
        (Knob::Sample, "sample-frac", &a.sample_frac),
        (Knob::Gradient, "gradient-frac", &a.gradient_frac),
        (Knob::Normal, "normal-frac", &a.normal_frac),
    ]
    .into_iter()
    .map(|(k, flag, s)| {
        let shading_knob = matches!(k, Knob::Gradient | Knob::Normal);
        let s = match (s.as_str(), shading_knob) {
            ("auto", true) if a.shade => {
                if k == Knob::Gradient {
                    DEFAULT_GRADIENT
                } else {
                    DEFAULT_NORMAL
                }
            }
            ("auto", true) => "none",
            (v, true) if !a.shade && v != "none" => {
                bail!("--{flag} sweeps a shading width: add --shade")
            }
            (v, _) => v,
        };
        Ok((k, parse_values(flag, s)?))
    })
    .collect::<Result<Vec<_>>>()?
    .into_iter()
    .filter(|(_, v)| !v.is_empty())
    .collect();
    Ok((base, grid))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn knobs_drag_their_dependants() {
        let base = PipelineConfig::default();
        assert_eq!(total_bits(&base, false), 218);
        // The shading unit's eight formats: 20 + 16 + 20 + 16 + 13 + 13 + 16 + 24.
        assert_eq!(total_bits(&base, true), 218 + 138);
        let c = Knob::Accum.apply(&base, 12).unwrap();
        assert_eq!(c.opacity_corr.frac(), 12);
        assert_eq!(c.merge.frac(), 12);
        assert_eq!(c.merge.int_bits(), base.merge.int_bits());
        let c = Knob::Accum.apply(&base, 24).unwrap();
        assert_eq!(c.opacity_corr, base.opacity_corr);
        let c = Knob::Position.apply(&base, 8).unwrap();
        assert_eq!(c.position.int_bits(), base.position.int_bits());
        for k in [
            Knob::Alpha,
            Knob::Accum,
            Knob::Position,
            Knob::Weight,
            Knob::Color,
            Knob::Sample,
            Knob::Gradient,
            Knob::Normal,
        ] {
            assert_eq!(k.apply(&base, k.value(&base)).unwrap(), base, "{k:?}");
        }
        assert!(Knob::Alpha.apply(&base, 70).is_err());
    }

    #[test]
    fn value_lists() {
        assert_eq!(parse_values("x", "8-10").unwrap(), vec![8, 9, 10]);
        assert_eq!(parse_values("x", "8,12").unwrap(), vec![8, 12]);
        assert!(parse_values("x", "none").unwrap().is_empty());
        assert!(parse_values("x", "10-8").is_err());
        assert!(parse_values("x", "99").is_err());
    }
}
