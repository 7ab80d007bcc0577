//! `ercube cosim --stage split`: every dense split of a front-to-back
//! frame replayed into the emitted `ercube_pe_split`, one a PE
//! (`pipeline::hw::split_rtl`: the split's x and y filters and its line
//! buffer), each PE's line-buffer writes and child words with their
//! termination flags compared on every clock with the model's
//! (`pipeline::cosim::split`). The pass broadcast and the parents come from
//! the model. Exit status 1 on any mismatch.

use std::sync::{Arc, Mutex};
use std::time::Instant;

use anyhow::{anyhow, bail, Result};
use serde_json::json;

use pipeline::cosim::pass::PassKind;
use pipeline::cosim::split::{Split, SplitRecord};
use pipeline::hw::split_rtl::{emit, SplitShape, MODULE};

use super::cosim::{cache_dir, setup, simulator, CosimArgs};

/// Runs the split's co-simulation.
pub fn run(a: &CosimArgs) -> Result<()> {
    super::outputs::check_files(&[a.stats.as_deref()])?;
    a.refuse_datapath_flags("cosim --stage split")?;
    let sim = simulator(&a.simulator)?;
    let s = setup(&a.frame, "cosim")?;
    let shape = SplitShape::for_view(&s.cfg, &s.prep.view)
        .map_err(|e| anyhow!("cosim --stage split: {e}"))?;
    let module = emit(&s.cfg, &shape).map_err(|e| anyhow!("cosim --stage split: {e}"))?;
    let t = Instant::now();
    let plain = s.frame().run()?;
    let untraced_s = t.elapsed().as_secs_f64();
    let rec = Arc::new(Mutex::new(SplitRecord::default()));
    let t = Instant::now();
    let captured = s.frame().capture(rec.clone()).run()?;
    let capture_s = t.elapsed().as_secs_f64();
    if captured.raw != plain.raw || captured.cycles != plain.cycles {
        bail!("cosim --stage split: the captured frame differs from the plain one");
    }
    let passes = std::mem::take(&mut rec.lock().unwrap_or_else(|e| e.into_inner()).passes);
    if passes.is_empty() {
        bail!("cosim --stage split: the frame has no split (one region: bring the eye nearer or widen the field of view)");
    }
    let dir = tempfile::Builder::new()
        .prefix("ercube-split-cosim-")
        .tempdir()?;
    let cache = cache_dir(a.cache_dir.as_deref());
    let r = Split::simulate(&shape, &module, &passes, sim, &cache, dir.path())
        .map_err(|e| anyhow!("cosim: split: {e}"))?;
    let o = &r.outcome;
    let (lines_c, words_c) = o.compared();
    let lines = vec![
        format!(
            "cosim (split stage): {}, {} PEs, {}: {} split passes, {} clocks simulated x {} PEs (the frame's split cycles: {}); {} line-buffer writes and {} child words compared, {} mismatches",
            s.label,
            s.cfg.pes,
            sim.tool(),
            r.passes,
            o.ticks,
            s.cfg.pes,
            plain.stages.split,
            lines_c,
            words_c,
            o.mismatches()
        ),
        format!(
            "  rtl: {MODULE} {} lines x {} + testbench {} lines; line buffer {} x {} x {} bits ({} memory bits) and {} register bits a PE; {}; ran in {:.2} s ({:.0} clocks/s); the pass broadcast and the parents replayed from the model",
            r.lines[0],
            s.cfg.pes,
            r.lines[1],
            shape.rows,
            shape.width,
            4 * u32::from(shape.merge.bits()),
            shape.memory_bits(),
            shape.register_bits(),
            if r.built.cached {
                "build cached".to_owned()
            } else {
                format!("built in {:.1} s", r.built.seconds)
            },
            r.run_s,
            o.ticks as f64 / r.run_s.max(1e-9)
        ),
        format!("  model: {untraced_s:.2} s untraced, {capture_s:.2} s capturing"),
    ];
    let mut problems = r.problems();
    if o.ticks != plain.stages.split {
        problems.push(format!(
            "split: the RTL ran {} clocks of the frame's {} split cycles",
            o.ticks, plain.stages.split
        ));
    }
    super::outputs::all_or_nothing(&[], || {
        if let Some(path) = &a.stats {
            let j = json!({
                "volume": s.label,
                "pes": s.cfg.pes,
                "order": s.cfg.order.name(),
                "simulator": sim.tool(),
                "frame_cycles": plain.cycles,
                "frame_split_cycles": plain.stages.split,
                "passes": r.passes,
                "clocks": o.ticks,
                "compared": { "line_buffer_writes": lines_c, "child_words": words_c },
                "mismatches": o.mismatches(),
                "first_mismatch": o.first.as_ref().map(|m| json!({
                    "cycle": m.cycle, "pe": m.pe, "signal": m.signal, "model": m.model, "rtl": m.rtl,
                })),
                "memory_bits_per_pe": shape.memory_bits(),
                "register_bits_per_pe": shape.register_bits(),
                "rtl_lines": { "module": r.lines[0], "testbench": r.lines[1] },
                "rtl_build_s": r.built.seconds,
                "rtl_build_cached": r.built.cached,
                "rtl_run_s": r.run_s,
                "model_untraced_s": untraced_s,
                "model_capture_s": capture_s,
                "problems": problems,
            });
            super::stats::write_json(path, &j)?;
        }
        Ok(())
    })?;
    super::cosim::report_out(&lines, &problems)
}
