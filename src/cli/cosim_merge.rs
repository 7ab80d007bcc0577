//! `ercube cosim --stage merge`: every dense merge of a back-to-front
//! frame replayed into the emitted `ercube_pe_merge`, one a PE
//! (`pipeline::hw::merge_rtl`: the merge's x and y tents and its line
//! buffer), each PE's line-buffer writes and child words compared on every
//! clock with the model's (`pipeline::cosim::merge`). The pass broadcast,
//! the held parents and the neighbours' edge rays come from the model.
//! Exit status 1 on any mismatch.

use std::sync::{Arc, Mutex};
use std::time::Instant;

use anyhow::{anyhow, bail, Result};
use serde_json::json;

use pipeline::cosim::merge::{Merge, MergeRecord};
use pipeline::cosim::pass::PassKind;
use pipeline::hw::merge_rtl::{emit, MergeShape, MODULE};

use super::cosim::{cache_dir, setup, simulator, CosimArgs};

/// Runs the merge's co-simulation.
pub fn run(a: &CosimArgs) -> Result<()> {
    super::outputs::check_files(&[a.stats.as_deref()])?;
    a.refuse_datapath_flags("cosim --stage merge")?;
    let sim = simulator(&a.simulator)?;
    let s = setup(&a.frame, "cosim")?;
    let shape = MergeShape::for_view(&s.cfg, &s.prep.view)
        .map_err(|e| anyhow!("cosim --stage merge: {e}"))?;
    let module = emit(&s.cfg, &shape).map_err(|e| anyhow!("cosim --stage merge: {e}"))?;
    let t = Instant::now();
    let plain = s.frame().run()?;
    let untraced_s = t.elapsed().as_secs_f64();
    let rec = Arc::new(Mutex::new(MergeRecord::default()));
    let t = Instant::now();
    let captured = s.frame().capture(rec.clone()).run()?;
    let capture_s = t.elapsed().as_secs_f64();
    if captured.raw != plain.raw || captured.cycles != plain.cycles {
        bail!("cosim --stage merge: the captured frame differs from the plain one");
    }
    let passes = std::mem::take(&mut rec.lock().unwrap_or_else(|e| e.into_inner()).passes);
    if passes.is_empty() {
        bail!("cosim --stage merge: the frame has no merge (one region: bring the eye nearer or widen the field of view)");
    }
    let dir = tempfile::Builder::new()
        .prefix("ercube-merge-cosim-")
        .tempdir()?;
    let cache = cache_dir(a.cache_dir.as_deref());
    let r = Merge::simulate(&shape, &module, &passes, sim, &cache, dir.path())
        .map_err(|e| anyhow!("cosim: merge: {e}"))?;
    let o = &r.outcome;
    let (lines_c, words_c) = o.compared();
    let lines = vec![
        format!(
            "cosim (merge stage): {}, {} PEs, {}: {} merge passes, {} clocks simulated x {} PEs (the frame's merge cycles: {}); {} line-buffer writes and {} child words compared, {} mismatches",
            s.label,
            s.cfg.pes,
            sim.tool(),
            r.passes,
            o.ticks,
            s.cfg.pes,
            plain.stages.merge,
            lines_c,
            words_c,
            o.mismatches()
        ),
        format!(
            "  rtl: {MODULE} {} lines x {} + testbench {} lines; line buffer {} x {} x {} bits ({} memory bits) and {} register bits a PE; {}; ran in {:.2} s ({:.0} clocks/s); the pass broadcast, the held parents and the edge rays replayed from the model",
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
    if o.ticks != plain.stages.merge {
        problems.push(format!(
            "merge: the RTL ran {} clocks of the frame's {} merge cycles",
            o.ticks, plain.stages.merge
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
                "frame_merge_cycles": plain.stages.merge,
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
