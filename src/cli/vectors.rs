//! `ercube vectors`: a frame's per-PE, per-port stimulus and expected
//! responses of the emitted datapath as `$readmemh` files, with a JSON
//! manifest and a plain Verilog testbench that replays them
//! (`pipeline::cosim::vectors`), from the same capture as `ercube cosim`.

use std::path::PathBuf;
use std::sync::{Arc, Mutex};

use anyhow::{anyhow, bail, Result};
use clap::Args;

use pipeline::cosim::capture::Recorded;
use pipeline::cosim::replay::Replay;
use pipeline::cosim::vectors::vectors;

use super::cosim::{setup, FrameArgs};

/// Words (rows times ports times PEs) a run may write.
const MAX_WORDS: u64 = 50_000_000;

/// Samples a run may keep in memory.
const MAX_SAMPLES: usize = 5_000_000;

/// Arguments of `ercube vectors`.
#[derive(Debug, Args)]
pub struct VectorsArgs {
    #[command(flatten)]
    pub frame: FrameArgs,
    /// The samples issued in cycles A-B (inclusive, the frame's cycles
    /// count from 1); the files run on until each is written back.
    /// Default: the whole frame.
    #[arg(long, value_parser = parse_cycles)]
    pub cycles: Option<(u64, u64)>,
    /// Folder the files go to (created if missing).
    #[arg(long)]
    pub out_dir: PathBuf,
    /// What the vectors drive: every PE's datapath (`datapath`,
    /// `ercube_sample`) or one PE's sample stage (`pe`,
    /// `ercube_pe_sample`: the broadcast, the plan port, the slice loads
    /// and the expected issues, taps and write-backs of the whole frame).
    #[arg(long, default_value = "datapath", value_parser = ["datapath", "pe"])]
    pub stage: String,
    /// With `--stage pe`: the PE (0 is the leftmost).
    #[arg(long)]
    pub pe: Option<usize>,
}

/// `A-B` with `1 <= A <= B`.
fn parse_cycles(s: &str) -> std::result::Result<(u64, u64), String> {
    let bad = || format!("'{s}': expected A-B, first and last cycle (from 1, A <= B)");
    let (a, b) = s.split_once('-').ok_or_else(bad)?;
    let (a, b): (u64, u64) = (
        a.trim().parse().map_err(|_| bad())?,
        b.trim().parse().map_err(|_| bad())?,
    );
    if a == 0 || a > b {
        return Err(bad());
    }
    Ok((a, b))
}

/// Runs `ercube vectors`.
pub fn run(a: &VectorsArgs) -> Result<()> {
    super::outputs::check_dirs(&[Some(a.out_dir.as_path())])?;
    if a.stage == "pe" {
        return super::vectors_pe::run(a);
    }
    if a.pe.is_some() {
        bail!("vectors: --pe is for --stage pe (the datapath's vectors hold every PE)");
    }
    let s = setup(&a.frame, "vectors")?;
    s.refuse_preint("vectors", "written as vectors")?;
    let (first, last) = a.cycles.unwrap_or((1, u64::MAX));
    let rec = Arc::new(Mutex::new(Recorded::window(first, last).limit(MAX_SAMPLES)));
    let frame = s.frame().capture(rec.clone()).run()?;
    let rec = std::mem::take(
        &mut *rec
            .lock()
            .map_err(|_| anyhow!("vectors: capture poisoned"))?,
    );
    if first > frame.cycles {
        bail!(
            "--cycles {first}-{last}: the frame has {} cycles",
            frame.cycles
        );
    }
    let last = last.min(frame.cycles);
    if rec.overflow {
        bail!("--cycles {first}-{last}: more than {MAX_SAMPLES} samples; give a narrower window");
    }
    let mut replay = Replay::new(s.module.clone(), rec.latency)?;
    replay.frame = rec.frame.clone();
    let p = usize::from(s.cfg.pes);
    let rows = last - first + 1 + u64::from(s.module.depth);
    let words = rows * p as u64 * (replay.fields.len() as u64 + 2);
    if words > MAX_WORDS {
        bail!(
            "--cycles {first}-{last}: {rows} rows of {} ports for {p} PEs are {words} words, over {MAX_WORDS}; give a narrower window (--cycles A-B)",
            replay.fields.len() + 2
        );
    }
    let v = vectors(
        &replay,
        &s.module.verilog,
        (&rec.issues, p),
        &rec.tables,
        (first, last),
        rec.latency,
    );
    let dir = &a.out_dir;
    super::outputs::all_or_nothing(&[dir], || {
        std::fs::create_dir_all(dir)
            .map_err(|e| anyhow!("cannot create {}: {e}", dir.display()))?;
        for (name, text) in &v.files {
            golden::image::write_atomic(&dir.join(name), |w| w.write_all(text.as_bytes()))?;
        }
        Ok(())
    })?;
    super::say(&format!(
        "{}: {} PEs, samples issued in cycles {first}-{last} ({} of them), {} cycles of vectors ({first}-{}), {} files; manifest.json; vectors_tb.v: iverilog -g2005 -o tb {}.v vectors_tb.v && vvp tb",
        dir.display(),
        p,
        rec.issues.len(),
        v.rows,
        first + v.rows - 1,
        v.files.len(),
        s.module.name
    ));
    if rec.latency != u64::from(s.module.depth) {
        super::say(&format!(
            "  note: the model writes back {} clocks after issue, the module {}; the expected responses are at the module's",
            rec.latency, s.module.depth
        ));
    }
    Ok(())
}
