//! `ercube cosim --stage split|merge|fold`: every dense boundary pass of a
//! frame replayed into its emitted module, one a PE, each PE's
//! line-buffer writes and child words compared on every clock with the
//! model's (`pipeline::cosim::pass`). The split (front to back,
//! `pipeline::hw::split_rtl`: the x and y filters and the line buffer)
//! also compares the termination flags; the merge (back to front,
//! `pipeline::hw::merge_rtl`: the x and y tents and the line buffer) takes
//! the held parents and the neighbours' edge rays from the model; the fold
//! (front to back, `pipeline::hw::fold_rtl`: the differences, the x and y
//! tents, the line buffer and the adds of the kept finals) takes the held
//! results and inherited states, the left edge difference and the kept
//! finals from the model. The pass broadcast and the parents come from the
//! model. Exit status 1 on any
//! mismatch.

use std::sync::{Arc, Mutex};
use std::time::Instant;

use anyhow::{anyhow, bail, Result};
use serde_json::json;

use pipeline::cosim::pass::PassRecord;

use super::cosim::{cache_dir, setup, simulator, CosimArgs};
use super::pass::CliPass;

/// Runs the co-simulation of pass `K`.
pub fn run<K: CliPass>(a: &CosimArgs) -> Result<()> {
    let st = K::STAGE;
    let cmd = format!("cosim --stage {st}");
    super::outputs::check_files(&[a.stats.as_deref()])?;
    a.refuse_datapath_flags(&cmd)?;
    let sim = simulator(&a.simulator)?;
    let s = setup(&a.frame, "cosim")?;
    let shape = K::shape_for_view(&s.cfg, &s.prep.view).map_err(|e| anyhow!("{cmd}: {e}"))?;
    let module = K::emit(&s.cfg, &shape).map_err(|e| anyhow!("{cmd}: {e}"))?;
    let t = Instant::now();
    let plain = s.frame().run()?;
    let untraced_s = t.elapsed().as_secs_f64();
    let rec = Arc::new(Mutex::new(PassRecord::<K>::default()));
    let t = Instant::now();
    let captured = s.frame().capture(rec.clone()).run()?;
    let capture_s = t.elapsed().as_secs_f64();
    if captured.raw != plain.raw || captured.cycles != plain.cycles {
        bail!("{cmd}: the captured frame differs from the plain one");
    }
    let passes = std::mem::take(&mut rec.lock().unwrap_or_else(|e| e.into_inner()).passes);
    if passes.is_empty() {
        bail!("{cmd}: the frame has no {st} (one region: bring the eye nearer or widen the field of view)");
    }
    let dir = tempfile::Builder::new()
        .prefix(&format!("ercube-{st}-cosim-"))
        .tempdir()?;
    let cache = cache_dir(a.cache_dir.as_deref());
    let r = K::simulate(&shape, &module, &passes, sim, &cache, dir.path())
        .map_err(|e| anyhow!("cosim: {st}: {e}"))?;
    let o = &r.outcome;
    let (lines_c, words_c) = o.compared();
    let frame_cycles = K::cycles(&plain.stages);
    let f = K::dims(&shape);
    let lines = vec![
        format!(
            "cosim ({st} stage): {}, {} PEs, {}: {} {st} passes, {} clocks simulated x {} PEs (the frame's {st} cycles: {}); {} line-buffer writes and {} child words compared, {} mismatches",
            s.label,
            s.cfg.pes,
            sim.tool(),
            r.passes,
            o.ticks,
            s.cfg.pes,
            frame_cycles,
            lines_c,
            words_c,
            o.mismatches()
        ),
        format!(
            "  rtl: {} {} lines x {} + testbench {} lines; line buffer {} x {} x {} bits ({} memory bits) and {} register bits a PE; {}; ran in {:.2} s ({:.0} clocks/s); {} replayed from the model",
            K::MODULE,
            r.lines[0],
            s.cfg.pes,
            r.lines[1],
            f.rows,
            f.width,
            4 * u32::from(f.merge.bits()),
            f.memory_bits,
            f.register_bits,
            if r.built.cached {
                "build cached".to_owned()
            } else {
                format!("built in {:.1} s", r.built.seconds)
            },
            r.run_s,
            o.ticks as f64 / r.run_s.max(1e-9),
            K::REPLAYED
        ),
        format!("  model: {untraced_s:.2} s untraced, {capture_s:.2} s capturing"),
    ];
    let mut problems = r.problems();
    if o.ticks != frame_cycles {
        problems.push(format!(
            "{st}: the RTL ran {} clocks of the frame's {frame_cycles} {st} cycles",
            o.ticks
        ));
    }
    super::outputs::all_or_nothing(&[], || {
        if let Some(path) = &a.stats {
            let mut j = json!({
                "volume": s.label,
                "pes": s.cfg.pes,
                "order": s.cfg.order.name(),
                "simulator": sim.tool(),
                "frame_cycles": plain.cycles,
                "passes": r.passes,
                "clocks": o.ticks,
                "compared": { "line_buffer_writes": lines_c, "child_words": words_c },
                "mismatches": o.mismatches(),
                "first_mismatch": o.first.as_ref().map(|m| json!({
                    "cycle": m.cycle, "pe": m.pe, "signal": m.signal, "model": m.model, "rtl": m.rtl,
                })),
                "memory_bits_per_pe": f.memory_bits,
                "register_bits_per_pe": f.register_bits,
                "rtl_lines": { "module": r.lines[0], "testbench": r.lines[1] },
                "rtl_build_s": r.built.seconds,
                "rtl_build_cached": r.built.cached,
                "rtl_run_s": r.run_s,
                "model_untraced_s": untraced_s,
                "model_capture_s": capture_s,
                "problems": problems,
            });
            j[format!("frame_{st}_cycles")] = json!(frame_cycles);
            super::stats::write_json(path, &j)?;
        }
        Ok(())
    })?;
    super::cosim::report_out(&lines, &problems)
}
