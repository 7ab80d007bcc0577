//! Sweeps that outgrow one machine: `ercube bench --shard K/N` runs every
//! N-th eye distance (the K-th of each N), `ercube sweep-widths --shard
//! K/N` every N-th configuration, and each writes its rows as
//! `shard-K-of-N.json`; `ercube merge-results` joins the N shard files
//! into the CSV, plots and summary the unsharded run writes (the same
//! rows in the same order; only the timings differ, as between any two
//! runs). A shard file records the command's arguments, so the merge
//! rebuilds the case exactly as the shards saw it.

use std::path::{Path, PathBuf};

use anyhow::{bail, Context, Result};
use clap::{Args, Parser};
use serde::{Deserialize, Serialize};

use golden::metrics::ImageError;

use super::widths::{self, Knob, SweepArgs, SweepResult, WidthRow};
use super::{BenchArgs, CaseResult, PerSlice, Row};

/// Shard `k` (1-based) of `n`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct Shard {
    /// Which shard, 1..=n.
    pub k: usize,
    /// How many shards.
    pub n: usize,
}

/// Most shards a sweep is split into.
const MAX_SHARDS: usize = 100_000;

impl Shard {
    /// Whether this shard runs the sweep's point `i` (0-based).
    pub fn owns(self, i: usize) -> bool {
        i % self.n == self.k - 1
    }

    /// The shard file's name in its output folder.
    pub fn file_name(self) -> String {
        format!("shard-{}-of-{}.json", self.k, self.n)
    }
}

impl std::str::FromStr for Shard {
    type Err = String;
    fn from_str(s: &str) -> std::result::Result<Shard, String> {
        let bad = || format!("shard '{s}' is not K/N with 1 <= K <= N (e.g. 2/8)");
        let (k, n) = s.split_once('/').ok_or_else(bad)?;
        let (k, n): (usize, usize) = (
            k.trim().parse().map_err(|_| bad())?,
            n.trim().parse().map_err(|_| bad())?,
        );
        if k == 0 || k > n || n > MAX_SHARDS {
            return Err(bad());
        }
        Ok(Shard { k, n })
    }
}

/// An error figure with an infinite PSNR (identical images) kept as
/// `None`, since JSON has no infinity.
#[derive(Debug, Clone, Copy, Serialize, Deserialize)]
struct ErrJson {
    max_abs_255: f64,
    rmse: f64,
    psnr: Option<f64>,
}

impl ErrJson {
    fn of(e: ImageError) -> ErrJson {
        ErrJson {
            max_abs_255: e.max_abs_255,
            rmse: e.rmse,
            psnr: e.psnr.is_finite().then_some(e.psnr),
        }
    }
    fn error(self) -> ImageError {
        ImageError {
            max_abs_255: self.max_abs_255,
            rmse: self.rmse,
            psnr: self.psnr.unwrap_or(f64::INFINITY),
        }
    }
}

/// One row as a shard file keeps it.
#[derive(Debug, Clone, Serialize, Deserialize)]
struct RowJson {
    d: f64,
    fov: f64,
    method: String,
    run: usize,
    skipped: Option<String>,
    time_s: Option<f64>,
    samples: Option<u64>,
    regions: Option<usize>,
    cycles: Option<u64>,
    utilization: Option<f64>,
    err: Option<ErrJson>,
    vs_er: Option<ErrJson>,
    #[serde(default)]
    unshaded_time_s: Option<f64>,
}

impl RowJson {
    fn of(r: &Row) -> RowJson {
        RowJson {
            d: r.d,
            fov: r.fov,
            method: r.method.clone(),
            run: r.run,
            skipped: r.skipped.clone(),
            time_s: r.time_s,
            samples: r.samples,
            regions: r.regions,
            cycles: r.cycles,
            utilization: r.utilization,
            err: r.err.map(ErrJson::of),
            vs_er: r.vs_er.map(ErrJson::of),
            unshaded_time_s: r.unshaded_time_s,
        }
    }
    fn row(self) -> Row {
        Row {
            d: self.d,
            fov: self.fov,
            method: self.method,
            run: self.run,
            skipped: self.skipped,
            time_s: self.time_s,
            samples: self.samples,
            regions: self.regions,
            cycles: self.cycles,
            utilization: self.utilization,
            err: self.err.map(ErrJson::error),
            vs_er: self.vs_er.map(ErrJson::error),
            unshaded_time_s: self.unshaded_time_s,
        }
    }
}

/// Samples per slice, as a shard file keeps them.
#[derive(Debug, Clone, Serialize, Deserialize)]
struct PerSliceJson {
    d: f64,
    area: f64,
    nz: usize,
    measured: Vec<(String, Vec<u64>)>,
}

/// What one shard of a bench ran.
#[derive(Debug, Serialize, Deserialize)]
struct ShardFile {
    /// `bench`.
    kind: String,
    /// Which shard.
    shard: Shard,
    /// The bench's arguments, without `--shard` and `--out-dir`.
    args: Vec<String>,
    /// The rows of each distance the shard ran, by the distance's index.
    points: Vec<(usize, Vec<RowJson>)>,
    per_slice: Option<PerSliceJson>,
    area: f64,
    nz: usize,
    pipeline_matches_er: Option<bool>,
}

/// The bench's own arguments, as typed after `ercube bench`, without
/// `--shard` and `--out-dir` (and their values): what shards of one sweep
/// share.
fn sweep_args() -> Vec<String> {
    let argv: Vec<String> = std::env::args().skip(2).collect();
    let mut out = Vec::new();
    let mut it = argv.into_iter();
    while let Some(a) = it.next() {
        match a.as_str() {
            "--shard" | "--out-dir" => {
                it.next();
            }
            _ if a.starts_with("--shard=") || a.starts_with("--out-dir=") => {}
            _ => out.push(a),
        }
    }
    out
}

/// Writes shard `shard`'s result `res` into `dir`.
pub fn write_shard(dir: &Path, shard: Shard, res: &CaseResult, distances: usize) -> Result<()> {
    // Rows come distance by distance; a distance's rows share its `d`.
    let mut points: Vec<(usize, Vec<RowJson>)> = Vec::new();
    let owned: Vec<usize> = (0..distances).filter(|&i| shard.owns(i)).collect();
    let mut ds: Vec<f64> = Vec::new();
    for r in &res.rows {
        if !ds.contains(&r.d) {
            ds.push(r.d);
        }
        let at = ds.iter().position(|&d| d == r.d).expect("just pushed");
        if points.len() <= at {
            points.push((owned[at], Vec::new()));
        }
        points[at].1.push(RowJson::of(r));
    }
    let file = ShardFile {
        kind: "bench".into(),
        shard,
        args: sweep_args(),
        points,
        per_slice: res.per_slice.as_ref().map(|p| PerSliceJson {
            d: p.d,
            area: p.area,
            nz: p.nz,
            measured: p.measured.clone(),
        }),
        area: res.area,
        nz: res.nz,
        pipeline_matches_er: res.pipeline_matches_er,
    };
    let path = dir.join(shard.file_name());
    let text = serde_json::to_string(&file)?;
    golden::image::write_atomic(&path, |w| w.write_all(text.as_bytes()))?;
    super::super::say(&format!("wrote {}", path.display()));
    Ok(())
}

/// Arguments of `ercube merge-results`.
#[derive(Debug, Args)]
pub struct MergeArgs {
    /// The shard files (`shard-K-of-N.json`), all N of one sweep, any order.
    #[arg(required = true)]
    pub shards: Vec<PathBuf>,
    /// Directory for the merged bench.csv, plots and summary.md.
    #[arg(long, default_value = "bench-results")]
    pub out_dir: PathBuf,
    /// Worker threads for rebuilding the case (the volume).
    #[arg(long)]
    pub threads: Option<usize>,
}

/// `ercube bench`'s arguments parsed on their own.
#[derive(Debug, Parser)]
#[command(name = "ercube bench")]
struct BenchCli {
    #[command(flatten)]
    a: BenchArgs,
}

/// Reads the shard files `paths` of one kind, checks that they are shards
/// 1..=N of one sweep, and returns them in shard order.
fn read_shards<T: serde::de::DeserializeOwned>(
    paths: &[PathBuf],
    kind: &str,
    id: impl Fn(&T) -> (Shard, &Vec<String>),
) -> Result<Vec<T>> {
    let mut files: Vec<T> = Vec::new();
    for p in paths {
        let text =
            std::fs::read_to_string(p).with_context(|| format!("cannot read {}", p.display()))?;
        let f: T = serde_json::from_str(&text)
            .map_err(|e| anyhow::anyhow!("{} is not a {kind} shard file: {e}", p.display()))?;
        files.push(f);
    }
    let (first, args0) = id(&files[0]);
    let n = first.n;
    for (f, p) in files.iter().zip(paths) {
        let (s, args) = id(f);
        if s.n != n || args != args0 {
            bail!(
                "{} is a shard of another sweep than {} (arguments or shard count differ)",
                p.display(),
                paths[0].display()
            );
        }
    }
    files.sort_by_key(|f| id(f).0.k);
    let ks: Vec<usize> = files.iter().map(|f| id(f).0.k).collect();
    if ks != (1..=n).collect::<Vec<_>>() {
        bail!("merge-results needs each of shards 1..={n} once; got {ks:?}");
    }
    Ok(files)
}

/// Runs `ercube merge-results`.
pub fn merge(m: &MergeArgs) -> Result<()> {
    crate::cli::outputs::check_dirs(&[Some(&m.out_dir)])?;
    crate::cli::outputs::all_or_nothing(&[&m.out_dir], || merge_files(m))
}

/// [`merge`] after its output check: every file it writes is staged.
fn merge_files(m: &MergeArgs) -> Result<()> {
    let first = &m.shards[0];
    let text = std::fs::read_to_string(first)
        .with_context(|| format!("cannot read {}", first.display()))?;
    let kind = serde_json::from_str::<serde_json::Value>(&text)
        .ok()
        .and_then(|v| v["kind"].as_str().map(String::from));
    match kind.as_deref() {
        Some("bench") => merge_bench(m),
        Some("sweep-widths") => merge_widths(m),
        _ => bail!(
            "{} is not a shard file of bench or sweep-widths",
            first.display()
        ),
    }
}

/// `merge-results` for `bench` shards.
fn merge_bench(m: &MergeArgs) -> Result<()> {
    let files: Vec<ShardFile> =
        read_shards(&m.shards, "bench", |f: &ShardFile| (f.shard, &f.args))?;
    let mut argv = vec!["bench".to_string()];
    argv.extend(files[0].args.iter().cloned());
    argv.extend(["--out-dir".into(), m.out_dir.display().to_string()]);
    let mut a = BenchCli::try_parse_from(&argv)
        .map_err(|e| anyhow::anyhow!("the shards' bench arguments do not parse: {e}"))?
        .a;
    a.threads = m.threads;
    let command = format!("ercube {}", argv.join(" "));
    super::with_threads(a.threads, || {
        let case = super::case_of(&a)?;
        let mut points: Vec<(usize, Vec<RowJson>)> = Vec::new();
        let mut res = CaseResult {
            rows: Vec::new(),
            per_slice: None,
            area: files[0].area,
            nz: files[0].nz,
            pipeline_matches_er: None,
        };
        for f in &files {
            points.extend(f.points.iter().cloned());
            if let Some(p) = &f.per_slice {
                res.per_slice = Some(PerSlice {
                    d: p.d,
                    area: p.area,
                    nz: p.nz,
                    measured: p.measured.clone(),
                });
            }
            if let Some(b) = f.pipeline_matches_er {
                res.pipeline_matches_er = Some(res.pipeline_matches_er.unwrap_or(true) && b);
            }
        }
        points.sort_by_key(|p| p.0);
        let want: Vec<usize> = (0..case.distances.len()).collect();
        let got: Vec<usize> = points.iter().map(|p| p.0).collect();
        if got != want {
            bail!("the shards hold distances {got:?}, the sweep has {want:?}");
        }
        res.rows = points
            .into_iter()
            .flat_map(|(_, rows)| rows.into_iter().map(RowJson::row))
            .collect();
        super::finish(&a, &case, &res, &command)
    })
}

/// One sweep-widths row as a shard file keeps it.
#[derive(Debug, Clone, Serialize, Deserialize)]
struct WidthRowJson {
    knob: Option<String>,
    value: u8,
    total_bits: u32,
    skipped: Option<String>,
    vs_er: Option<ErrJson>,
    vs_ref: Option<ErrJson>,
    overflows: u64,
    cycles: u64,
    time_s: f64,
}

/// What one shard of a width sweep ran.
#[derive(Debug, Serialize, Deserialize)]
struct WidthsShardFile {
    /// `sweep-widths`.
    kind: String,
    shard: Shard,
    /// The sweep's arguments, without `--shard` and `--out-dir`.
    args: Vec<String>,
    /// Each configuration's row, by its index in the sweep.
    rows: Vec<(usize, WidthRowJson)>,
    er_vs_ref: ErrJson,
}

/// Writes shard `shard` of a `runs`-configuration width sweep into `dir`.
pub fn write_widths_shard(dir: &Path, shard: Shard, res: &SweepResult, runs: usize) -> Result<()> {
    let owned = (0..runs).filter(|&i| shard.owns(i));
    let rows = owned
        .zip(&res.rows)
        .map(|(i, r)| {
            let row = WidthRowJson {
                knob: r.knob.map(|k| k.name().to_string()),
                value: r.value,
                total_bits: r.total_bits,
                skipped: r.skipped.clone(),
                vs_er: r.vs_er.map(ErrJson::of),
                vs_ref: r.vs_ref.map(ErrJson::of),
                overflows: r.overflows,
                cycles: r.cycles,
                time_s: r.time_s,
            };
            (i, row)
        })
        .collect();
    let file = WidthsShardFile {
        kind: "sweep-widths".into(),
        shard,
        args: sweep_args(),
        rows,
        er_vs_ref: ErrJson::of(res.er_vs_ref),
    };
    let path = dir.join(shard.file_name());
    let text = serde_json::to_string(&file)?;
    golden::image::write_atomic(&path, |w| w.write_all(text.as_bytes()))?;
    super::super::say(&format!("wrote {}", path.display()));
    Ok(())
}

/// `ercube sweep-widths`'s arguments parsed on their own.
#[derive(Debug, Parser)]
#[command(name = "ercube sweep-widths")]
struct WidthsCli {
    #[command(flatten)]
    a: SweepArgs,
}

/// `merge-results` for `sweep-widths` shards.
fn merge_widths(m: &MergeArgs) -> Result<()> {
    let files: Vec<WidthsShardFile> =
        read_shards(&m.shards, "sweep-widths", |f: &WidthsShardFile| {
            (f.shard, &f.args)
        })?;
    let mut argv = vec!["sweep-widths".to_string()];
    argv.extend(files[0].args.iter().cloned());
    argv.extend(["--out-dir".into(), m.out_dir.display().to_string()]);
    let a = WidthsCli::try_parse_from(&argv)
        .map_err(|e| anyhow::anyhow!("the shards' sweep-widths arguments do not parse: {e}"))?
        .a;
    let (base, grid) = widths::grid_of(&a)?;
    let sw = widths::sweep_of(&a, base, grid);
    let mut rows: Vec<(usize, WidthRowJson)> =
        files.iter().flat_map(|f| f.rows.iter().cloned()).collect();
    rows.sort_by_key(|r| r.0);
    let got: Vec<usize> = rows.iter().map(|r| r.0).collect();
    if got != (0..sw.runs()).collect::<Vec<_>>() {
        bail!(
            "the shards hold configurations {got:?} of the sweep's {}",
            sw.runs()
        );
    }
    let rows = rows
        .into_iter()
        .map(|(_, r)| {
            let knob = match &r.knob {
                None => None,
                Some(name) => Some(
                    Knob::from_name(name)
                        .ok_or_else(|| anyhow::anyhow!("unknown knob '{name}' in a shard file"))?,
                ),
            };
            Ok(WidthRow {
                knob,
                value: r.value,
                total_bits: r.total_bits,
                skipped: r.skipped,
                vs_er: r.vs_er.map(ErrJson::error),
                vs_ref: r.vs_ref.map(ErrJson::error),
                overflows: r.overflows,
                cycles: r.cycles,
                time_s: r.time_s,
            })
        })
        .collect::<Result<Vec<_>>>()?;
    let res = SweepResult {
        rows,
        er_vs_ref: files[0].er_vs_ref.error(),
    };
    widths::finish_sweep(&a, &sw, &res, &format!("ercube {}", argv.join(" ")))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shards_parse_and_split_the_points() {
        let s: Shard = "2/3".parse().unwrap();
        assert_eq!(s, Shard { k: 2, n: 3 });
        let owned: Vec<usize> = (0..8).filter(|&i| s.owns(i)).collect();
        assert_eq!(owned, [1, 4, 7]);
        for bad in ["0/3", "4/3", "3", "a/b", "1/0", "1/1000000"] {
            assert!(bad.parse::<Shard>().is_err(), "{bad}");
        }
        // Every point belongs to exactly one shard.
        for i in 0..20 {
            let n = 6;
            let owners = (1..=n).filter(|&k| Shard { k, n }.owns(i)).count();
            assert_eq!(owners, 1);
        }
    }

    #[test]
    fn errors_round_trip_with_an_infinite_psnr() {
        let e = ImageError {
            max_abs_255: 0.0,
            rmse: 0.0,
            psnr: f64::INFINITY,
        };
        let text = serde_json::to_string(&ErrJson::of(e)).unwrap();
        let back: ErrJson = serde_json::from_str(&text).unwrap();
        assert_eq!(back.error(), e);
    }
}
