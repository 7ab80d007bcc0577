//! `ercube explore`: the architecture sweep. For one volume and view it
//! runs the pipeline model at every mapping (x cyclic width) x migration
//! x ray-buffer placement x PE count and costs each configuration
//! (`pipeline::cost::design`): resources, on-chip memory, external traffic,
//! measured cycles, frames per second, and which listed parts it fits. It
//! writes the table (CSV and Markdown, printed too) and a plot of frames
//! per second against LUTs and block RAM. Configurations run in parallel; the
//! output is in sweep order whatever the thread count.

use std::fmt::Write as _;
use std::path::PathBuf;

use anyhow::{bail, Context, Result};
use clap::Args;
use rayon::prelude::*;

use golden::render::Prepared;
use golden::skip::Skips;
use pipeline::config::{Mapping, Migration, PipelineConfig, RayBuffer, MAX_PES};
use pipeline::cost::design::{design, Design};
use pipeline::cost::inventory::Geometry;
use pipeline::cost::parts::parts;
use pipeline::cost::throughput::RunSummary;
use pipeline::cost::Target;
use pipeline::{FrameRun, Voxels};

use super::args::{with_threads, ViewArgs};
use super::chip;
use super::plot::{write_charts, Chart, Kind, Series};
use super::progress::Stage;

/// Arguments of `ercube explore`.
#[derive(Debug, Args)]
pub struct ExploreArgs {
    #[command(flatten)]
    pub view: ViewArgs,
    /// Base pipeline configuration (TOML); the sweep sets its mapping,
    /// cyclic_width, migration, link_lanes, ray_buffer and pes (the rest,
    /// e.g. link_skip_empty and pass_skip_empty, it keeps).
    #[arg(long)]
    pub config: Option<PathBuf>,
    /// Mappings to sweep: blocks, interleave, cyclic.
    #[arg(long, default_value = "blocks,interleave,cyclic")]
    pub mappings: String,
    /// Ray-buffer placements to sweep: on-chip, external.
    #[arg(long, default_value = "on-chip,external")]
    pub placements: String,
    /// Migrations to sweep: between-slices, overlapped.
    #[arg(long, default_value = "between-slices,overlapped")]
    pub migrations: String,
    /// PE counts to sweep (1..=256), as `cost --sweep-pes` (--pes is
    /// accepted as an older spelling).
    #[arg(long, alias = "pes", default_value = "4,8,16,32,64")]
    pub sweep_pes: String,
    /// Cyclic block widths to sweep (1..=256; the cyclic mapping only;
    /// --widths is accepted as an older spelling).
    #[arg(long, alias = "widths", default_value = "1,2,4,8")]
    pub cyclic_widths: String,
    /// Link lanes to sweep (1..=4; the overlapped migration with the rays
    /// on chip only: between slices, or with the rays external, one lane).
    #[arg(long, default_value = "1")]
    pub lanes: String,
    /// Clock of the table's and plot's frame rates, MHz (an assumption;
    /// each part's own clock is used for its column of fits). Default:
    /// xc7's assumed 200 MHz, as cost and render.
    #[arg(long, allow_hyphen_values = true)]
    pub clock_mhz: Option<f64>,
    /// Sample empty space too.
    #[arg(long)]
    pub no_skip_empty: bool,
    /// Sample rays that cannot reach the image too.
    #[arg(long)]
    pub no_cull: bool,
    /// PEs with the gradient and shading unit (headlight, default material).
    #[arg(long)]
    pub shade: bool,
    /// Directory for explore.csv, explore.md and explore.png.
    #[arg(long, default_value = "explore")]
    pub out_dir: PathBuf,
    /// Worker threads (default: all cores); results are the same for any count.
    #[arg(long)]
    pub threads: Option<usize>,
}

/// Splits a comma-separated list, refusing empty items and an empty list.
fn items<'a>(flag: &str, s: &'a str) -> Result<Vec<&'a str>> {
    let v: Vec<&str> = s.split(',').map(str::trim).collect();
    if v.iter().any(|x| x.is_empty()) {
        bail!("{flag} '{s}': expected a comma-separated list without empty items");
    }
    Ok(v)
}

/// Parses a list of whole numbers in `lo..=hi`, duplicates dropped.
fn numbers(flag: &str, s: &str, lo: u16, hi: u16) -> Result<Vec<u16>> {
    let mut out = Vec::new();
    for t in items(flag, s)? {
        let n: u16 = t
            .parse()
            .ok()
            .filter(|n| (lo..=hi).contains(n))
            .with_context(|| format!("{flag}: '{t}' is not a whole number {lo}..={hi}"))?;
        if !out.contains(&n) {
            out.push(n);
        }
    }
    Ok(out)
}

fn mappings(s: &str) -> Result<Vec<Mapping>> {
    named("--mappings", "mapping", s, &Mapping::ALL, Mapping::name)
}

fn placements(s: &str) -> Result<Vec<RayBuffer>> {
    let all = [RayBuffer::OnChip, RayBuffer::External];
    named("--placements", "placement", s, &all, RayBuffer::name)
}

fn migrations(s: &str) -> Result<Vec<Migration>> {
    let all = [Migration::BetweenSlices, Migration::Overlapped];
    named("--migrations", "migration", s, &all, Migration::name)
}

/// The values of `all` that the comma-separated names of `flag` list
/// (case-insensitive, each once, in the order given); an unknown name is a
/// one-line error listing what `flag` takes.
fn named<T: Copy + PartialEq>(
    flag: &str,
    what: &str,
    s: &str,
    all: &[T],
    name: fn(T) -> &'static str,
) -> Result<Vec<T>> {
    let mut out = Vec::new();
    for t in items(flag, s)? {
        let v = all
            .iter()
            .copied()
            .find(|&v| name(v).eq_ignore_ascii_case(t))
            .with_context(|| {
                let names: Vec<&str> = all.iter().map(|&v| name(v)).collect();
                format!("{flag}: '{t}' is not a {what} ({})", names.join(", "))
            })?;
        if !out.contains(&v) {
            out.push(v);
        }
    }
    Ok(out)
}

/// The sweep's configurations, in output order: mapping, then width, then
/// migration, then lanes, then placement, then P. Cyclic at width 1 is the interleave and is left out
/// when the interleave is swept too.
fn configs(a: &ExploreArgs, base: &PipelineConfig) -> Result<Vec<PipelineConfig>> {
    let maps = mappings(&a.mappings)?;
    let places = placements(&a.placements)?;
    let migs = migrations(&a.migrations)?;
    let pes = numbers("--sweep-pes", &a.sweep_pes, 1, MAX_PES)?;
    let widths = numbers("--cyclic-widths", &a.cyclic_widths, 1, 256)?;
    let lanes = numbers("--lanes", &a.lanes, 1, 4)?;
    let mut out = Vec::new();
    for &mapping in &maps {
        let ws: Vec<u16> = match mapping {
            Mapping::Cyclic => widths
                .iter()
                .copied()
                .filter(|&w| !(w == 1 && maps.contains(&Mapping::Interleave)))
                .collect(),
            _ => vec![base.cyclic_width],
        };
        for &cyclic_width in &ws {
            for &migration in &migs {
                let ls = match migration {
                    Migration::Overlapped => lanes.clone(),
                    Migration::BetweenSlices => vec![1],
                };
                for &link_lanes in &ls {
                    // With the rays external nothing travels the links, so
                    // more lanes would repeat the one-lane rows.
                    for &ray_buffer in places
                        .iter()
                        .filter(|&&r| link_lanes == 1 || r == RayBuffer::OnChip)
                    {
                        for &p in &pes {
                            let c = PipelineConfig {
                                mapping,
                                cyclic_width,
                                migration,
                                link_lanes,
                                ray_buffer,
                                pes: p,
                                ..*base
                            };
                            c.validate()?;
                            out.push(c);
                        }
                    }
                }
            }
        }
    }
    Ok(out)
}

/// Runs `ercube explore`.
pub fn run(a: &ExploreArgs) -> Result<()> {
    super::outputs::check_dirs(&[Some(&a.out_dir)])?;
    super::outputs::all_or_nothing(&[&a.out_dir], || explore(a))
}

fn explore(a: &ExploreArgs) -> Result<()> {
    let clock = pipeline::cost::clock::check_mhz(
        a.clock_mhz
            .unwrap_or_else(|| pipeline::cost::clock::assumed_mhz(Target::Xc7)),
    )
    .map_err(anyhow::Error::msg)?;
    let base = match &a.config {
        Some(p) => PipelineConfig::from_toml_file(p)?,
        None => PipelineConfig::default(),
    };
    base.validate()?;
    let cfgs = configs(a, &base)?;
    let (vol, tf, cam) = a.view.load()?;
    let lut = chip::pipeline_lut(&base, &vol, &tf);
    let prep = Prepared::new(&vol, &cam)?;
    let nx = prep.view.dims[0];
    if let Some(c) = cfgs.iter().find(|c| usize::from(c.pes) > nx) {
        bail!(
            "--sweep-pes {}: more PEs than this view's {nx} voxel columns",
            c.pes
        );
    }
    let skips = Skips {
        empty: !a.no_skip_empty,
        cull: !a.no_cull,
    };
    let shade = a.shade.then(golden::shading::Shade::default);
    let label = a.view.source.label();
    let designs: Vec<Design> = with_threads(a.threads, || {
        let stage = Stage::counted("clocking configurations", cfgs.len() as u64);
        cfgs.par_iter()
            .map(|c| {
                let _done = Done(&stage);
                let frame = FrameRun::prepared(c, &lut, &prep, Voxels::Volume(&vol))
                    .skips(skips)
                    .unit(shade.as_ref())
                    .run()
                    .with_context(|| pipeline::cost::arch::label(c))?;
                let plan = pipeline::host::plan(c, &prep.view)?;
                let geo =
                    Geometry::for_view(c, &prep.view)?.with_units(pipeline::hw::compose::Units {
                        lights: a.shade.then_some(1),
                        ..Default::default()
                    });
                let run = RunSummary::new(c, label.as_str(), geo, (&frame, &plan));
                Ok(design(c, Target::Xc7, &run))
            })
            .collect::<Result<Vec<_>>>()
    })?;
    std::fs::create_dir_all(&a.out_dir)
        .with_context(|| format!("creating {}", a.out_dir.display()))?;
    let heading = format!(
        "{label}, eye ({}, {}, {}), skipping {}{}{}, {} configurations; frames/s at {} MHz (assumed clock)",
        cam.eye.x,
        cam.eye.y,
        cam.eye.z,
        match (skips.empty, skips.cull) {
            (true, true) => "empty space and culling",
            (true, false) => "empty space",
            (false, true) => "culling",
            (false, false) => "off",
        },
        if base.link_skip_empty {
            ", transparent rows off the links"
        } else {
            ""
        },
        if base.pass_skip_empty {
            ", transparent rays out of the passes and readout"
        } else {
            ""
        },
        designs.len(),
        clock
    );
    let mut md = markdown(&heading, &designs, clock);
    md.push_str(&best_per_part(&designs));
    let csv = csv(&designs, clock);
    let write = |name: &str, text: &str| {
        let p = a.out_dir.join(name);
        golden::image::write_atomic(&p, |w| w.write_all(text.as_bytes()))
            .with_context(|| format!("writing {}", p.display()))
    };
    write("explore.csv", &csv)?;
    write("explore.md", &md)?;
    plot(&a.out_dir.join("explore.png"), &heading, &designs, clock)?;
    super::say(md.trim_end());
    Ok(())
}

/// The first listed part (smallest first) a design fits, if any.
fn smallest_fit(d: &Design) -> Option<&'static str> {
    d.parts.iter().find(|p| p.fits).map(|p| p.part)
}

fn markdown(heading: &str, designs: &[Design], clock: f64) -> String {
    let mut o = String::new();
    let _ = writeln!(o, "{heading}\n");
    let _ = writeln!(
        o,
        "| mapping | migration | ray buffer | P | cycles | util | stall | memory | DSP | LUT | FF | RAMB18 | on-chip Mbit | MB/frame (voxels + rays) | frames/s | GB/s | fits (frames/s at the part's clock) |"
    );
    let _ = writeln!(
        o,
        "| --- | --- | --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | --- |"
    );
    for d in designs {
        let fps = d.fps(clock);
        let fits: Vec<String> = d
            .parts
            .iter()
            .filter(|f| f.fits)
            .map(|f| format!("{} {:.0}", f.part, f.fps))
            .collect();
        let _ = writeln!(
            o,
            "| {} | {} | {} | {} | {} | {:.3} | {} | {} | {} | {} | {} | {} | {:.2} | {:.3} + {:.3} | {:.1} | {:.2} | {} |",
            d.mapping,
            d.migration,
            d.ray_buffer,
            d.pes,
            d.cycles,
            d.utilization,
            d.stall,
            d.memory,
            d.resources.dsp,
            d.resources.lut,
            d.resources.ff,
            d.resources.bram,
            d.on_chip_bits as f64 / 1e6,
            d.voxel_bytes / 1e6,
            d.ray_bytes / 1e6,
            fps,
            d.external_bytes() * fps / 1e9,
            if fits.is_empty() { "-".to_owned() } else { fits.join(", ") }
        );
    }
    o
}

fn csv(designs: &[Design], clock: f64) -> String {
    let mut o = String::from(
        "mapping,migration,ray_buffer,pes,cycles,utilization,stall,memory,dsp,lut,ff,bram18,on_chip_bits,voxel_bytes,ray_bytes,fps,external_gbps,fits\n",
    );
    for d in designs {
        let fps = d.fps(clock);
        let _ = writeln!(
            o,
            "{},{},{},{},{},{:.4},{},{},{},{},{},{},{},{:.0},{:.0},{:.3},{:.4},{}",
            d.mapping,
            d.migration,
            d.ray_buffer,
            d.pes,
            d.cycles,
            d.utilization,
            d.stall,
            d.memory,
            d.resources.dsp,
            d.resources.lut,
            d.resources.ff,
            d.resources.bram,
            d.on_chip_bits,
            d.voxel_bytes,
            d.ray_bytes,
            fps,
            d.external_bytes() * fps / 1e9,
            d.fitting().join(" ")
        );
    }
    o
}

/// Counts a configuration done when dropped (also when it fails).
struct Done<'a>(&'a Stage);

impl Drop for Done<'_> {
    fn drop(&mut self) {
        self.0.inc();
    }
}

/// The best design each listed part holds: the most frames/s among the
/// designs that fit it (at the part's own clock), one line per part.
fn best_per_part(designs: &[Design]) -> String {
    let mut o = String::from(
        "\nBest design per part (most frames/s at the part's clock among those that fit):\n\n",
    );
    for p in parts(Target::Xc7) {
        let best = designs
            .iter()
            .filter_map(|d| {
                d.parts
                    .iter()
                    .find(|f| f.fits && f.part == p.name)
                    .map(|f| (d, f.fps))
            })
            .max_by(|a, b| a.1.total_cmp(&b.1));
        let _ = match best {
            Some((d, fps)) => writeln!(
                o,
                "- {}: {} / {} / {} at P = {}, {fps:.1} frames/s at {} MHz (assumed clock of the part)",
                p.name, d.mapping, d.migration, d.ray_buffer, d.pes, p.clock_mhz
            ),
            None => writeln!(o, "- {}: no design of the sweep fits", p.name),
        };
    }
    o
}

/// Colour `k` of `n` series, each distinct: twelve distinguishable
/// colours, or for more series hues spaced evenly around the wheel.
fn colour(k: usize, n: usize) -> plotters::style::RGBColor {
    use plotters::style::RGBColor as C;
    if n > 12 {
        return hue(k as f64 / n as f64);
    }
    const P: [C; 12] = [
        C(31, 119, 180),
        C(255, 127, 14),
        C(44, 160, 44),
        C(214, 39, 40),
        C(148, 103, 189),
        C(140, 86, 75),
        C(227, 119, 194),
        C(127, 127, 127),
        C(188, 189, 34),
        C(23, 190, 207),
        C(0, 0, 128),
        C(128, 0, 0),
    ];
    P[k % P.len()]
}

/// A saturated, mid-dark colour of hue `h` in turns (0..1).
fn hue(h: f64) -> plotters::style::RGBColor {
    let f = |n: f64| {
        let k = (n + h * 12.0) % 12.0;
        let (l, a) = (0.45, 0.7 * 0.45);
        let v = l - a * (k - 3.0).min(9.0 - k).clamp(-1.0, 1.0);
        (v * 255.0).round() as u8
    };
    plotters::style::RGBColor(f(0.0), f(8.0), f(4.0))
}

/// Frames per second against LUTs, one line per architecture over P; and
/// against block RAM, the points coloured by the smallest listed part they
/// fit (block RAM is what separates the placements).
fn plot(path: &std::path::Path, heading: &str, designs: &[Design], clock: f64) -> Result<()> {
    let mut archs: Vec<&str> = Vec::new();
    for d in designs {
        if !archs.contains(&d.arch.as_str()) {
            archs.push(&d.arch);
        }
    }
    let by_arch: Vec<Series> = archs
        .iter()
        .map(|a| {
            let pts = designs
                .iter()
                .filter(|d| d.arch == *a)
                .map(|d| (d.resources.lut as f64, d.fps(clock)))
                .collect();
            Series::new(*a, pts, Kind::LinePoints)
        })
        .enumerate()
        .map(|(k, s)| s.with_color(colour(k, archs.len())))
        .collect();
    let mut by_part: Vec<Series> = parts(Target::Xc7)
        .iter()
        .map(|p| {
            let pts = designs
                .iter()
                .filter(|d| smallest_fit(d) == Some(p.name))
                .map(|d| (d.resources.bram as f64, d.fps(clock)))
                .collect();
            Series::new(format!("fits {} first", p.name), pts, Kind::Points)
        })
        .enumerate()
        .map(|(k, s)| s.with_color(colour(k, parts(Target::Xc7).len())))
        .collect();
    by_part.push(
        Series::new(
            "fits no listed part",
            designs
                .iter()
                .filter(|d| smallest_fit(d).is_none())
                .map(|d| (d.resources.bram as f64, d.fps(clock)))
                .collect(),
            Kind::Points,
        )
        .with_color(plotters::style::RGBColor(160, 160, 160)),
    );
    by_part.retain(|s| !s.points.is_empty());
    // The smallest parts' points on top where points coincide.
    by_part.reverse();
    let title = heading.split(", eye").next().unwrap_or(heading);
    let charts = [
        Chart {
            title: format!("{title}: frames/s vs LUTs, by architecture"),
            x_label: "LUT6 (array)".into(),
            y_label: format!("frames/s at {clock} MHz"),
            x_log: true,
            y_log: true,
            series: by_arch,
        },
        Chart {
            title: "frames/s vs block RAM, by the smallest part that fits".into(),
            x_label: "RAMB18 (array, before UltraRAM takes any)".into(),
            y_label: format!("frames/s at {clock} MHz"),
            x_log: true,
            y_log: true,
            series: by_part,
        },
    ];
    write_charts(path, &charts, (900, 620))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_series_of_a_large_plot_gets_its_own_colour() {
        for n in [3, 12, 20, 40] {
            let set: std::collections::HashSet<(u8, u8, u8)> = (0..n)
                .map(|k| {
                    let c = colour(k, n);
                    (c.0, c.1, c.2)
                })
                .collect();
            assert_eq!(set.len(), n, "{n} series");
        }
    }
}
