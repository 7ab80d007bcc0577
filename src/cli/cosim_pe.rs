//! `ercube cosim --stage pe`: the frame's sample stage in the emitted PE
//! (`pipeline::hw::pe_sample_rtl`: the control, the voxel memory, the
//! compositing buffer, the datapath) driven by the controller's broadcast
//! replayed from the model, every issue, tap and write-back compared, the
//! buffers at the readout's start compared, and the readout run from the
//! RTL's buffers (`pipeline::cosim::pe_sample`). Exit status 1 on any
//! mismatch.

use std::time::Instant;

use anyhow::{anyhow, bail, Result};
use serde_json::json;

use pipeline::cosim::pe_sample::run::simulate;

use super::cosim::{cache_dir, setup, simulator, CosimArgs};

/// Runs the sample stage's co-simulation.
pub fn run(a: &CosimArgs) -> Result<()> {
    super::outputs::check_files(&[a.stats.as_deref()])?;
    a.refuse_datapath_flags("cosim --stage pe")?;
    let sim = simulator(&a.simulator)?;
    let s = setup(&a.frame, "cosim")?;
    s.refuse_preint("cosim --stage pe", "in the PE's sample stage (its pass broadcast, the ray's previous sample in the compositing buffer and slice 0's two steps in one sample are not emitted)")?;
    let t = Instant::now();
    let plain = s.frame().run()?;
    let untraced_s = t.elapsed().as_secs_f64();
    let dir = tempfile::Builder::new()
        .prefix("ercube-pe-cosim-")
        .tempdir()?;
    let cache = cache_dir(a.cache_dir.as_deref());
    let r = simulate(
        &|| s.frame(),
        &s.cfg,
        &s.prep.view,
        &s.module,
        sim,
        &cache,
        dir.path(),
        None,
    )
    .map_err(|e| anyhow!("cosim: {e}"))?;
    if let Some(why) = &r.unfit {
        bail!("cosim --stage pe: the frame does not fit the declared memories: {why}");
    }
    let o = &r.outcome;
    let mut lines = vec![format!(
        "cosim (sample stage): {}, {} PEs, {}: {} cycles simulated (the frame's {}), {} samples; {} issues, {} taps, {} write-backs compared, {} mismatches",
        s.label,
        s.cfg.pes,
        sim.tool(),
        r.cycles,
        plain.cycles,
        r.samples,
        o.compared[0],
        o.compared[1],
        o.compared[2],
        o.mismatches
    )];
    lines.push(format!(
        "  rtl: {} {} lines x {} + testbench {} lines; {} memory bits and {} control register bits a PE; {}; ran in {:.2} s ({:.0} clocks/s); {} buffer words replayed from outside the stage; {} runs driven on the plan port, {} held columns inside the slices' x ranges left out of sampled rows",
        pipeline::hw::pe_sample_rtl::MODULE,
        r.lines[0],
        s.cfg.pes,
        r.lines[1],
        r.bits[0],
        r.bits[1],
        if r.built.cached { "build cached".to_owned() } else { format!("built in {:.1} s", r.built.seconds) },
        r.seconds[1],
        r.cycles as f64 / r.seconds[1].max(1e-9),
        r.outside_words,
        r.plan_runs,
        r.skipped_in_rows
    ));
    if s.cfg.termination_raw().is_some() {
        lines.push(format!(
            "  termination: {} terminated rays left out of sampled rows by the termination bits; {} bits replayed from outside the stage",
            r.terminated_in_rows, r.outside_flags
        ));
    }
    if r.slots.0 > r.slots.1 {
        lines.push(format!(
            "  a PE holds up to {} columns at a slice's start, past the column map's declared {} slots: the column map and the compositing buffer are emitted {} slots wide",
            r.slots.0, r.slots.1, r.slots.0
        ));
    }
    if r.stored.0 > r.stored.1 {
        lines.push(format!(
            "  a PE's memory holds up to {} voxel columns (its blocks and their aprons), past the slice buffer's declared {}: the slice buffer is emitted {} columns wide",
            r.stored.0, r.stored.1, r.stored.0
        ));
    }
    lines.push(format!(
        "  model: {untraced_s:.2} s untraced, {:.2} s capturing",
        r.seconds[0]
    ));
    if let Some(b) = &r.buffers {
        lines.push(format!(
            "  buffers at the readout: {} ray words compared, {} differ",
            b.compared, b.differ
        ));
    }
    if let Some(ro) = &r.readout {
        lines.push(format!(
            "  readout from the RTL's buffers: {} clocks, {} mismatches; {} raw words compared with the model's, {} differ",
            ro.outcome.ticks,
            ro.outcome.mismatches(),
            ro.raw.0,
            ro.raw.1
        ));
    }
    let problems = r.problems();
    super::outputs::all_or_nothing(&[], || {
        if let Some(path) = &a.stats {
            let j = json!({
                "volume": s.label,
                "pes": s.cfg.pes,
                "order": s.cfg.order.name(),
                "simulator": sim.tool(),
                "frame_cycles": plain.cycles,
                "cycles": r.cycles,
                "samples": r.samples,
                "compared": { "issues": o.compared[0], "taps": o.compared[1], "write_backs": o.compared[2] },
                "mismatches": o.mismatches,
                "first_mismatch": o.first.as_ref().map(|m| json!({
                    "cycle": m.cycle, "pe": m.pe, "signal": m.signal, "model": m.model, "rtl": m.rtl,
                })),
                "buffer_words_compared": r.buffers.as_ref().map(|b| b.compared),
                "buffer_words_differing": r.buffers.as_ref().map(|b| b.differ),
                "readout_raw_compared": r.readout.as_ref().map(|x| x.raw.0),
                "readout_raw_differing": r.readout.as_ref().map(|x| x.raw.1),
                "outside_words": r.outside_words,
                "plan_runs": r.plan_runs,
                "skipped_in_rows": r.skipped_in_rows,
                "terminated_in_rows": r.terminated_in_rows,
                "outside_flags": r.outside_flags,
                "columns_held_peak": r.slots.0,
                "column_map_declared_slots": r.slots.1,
                "voxel_columns_held_peak": r.stored.0,
                "slice_buffer_declared_columns": r.stored.1,
                "memory_bits_per_pe": r.bits[0],
                "control_register_bits_per_pe": r.bits[1],
                "rtl_lines": { "pe": r.lines[0], "testbench": r.lines[1] },
                "rtl_build_s": r.built.seconds,
                "rtl_build_cached": r.built.cached,
                "rtl_run_s": r.seconds[1],
                "model_untraced_s": untraced_s,
                "model_capture_s": r.seconds[0],
                "problems": problems,
            });
            super::stats::write_json(path, &j)?;
        }
        Ok(())
    })?;
    super::cosim::report_out(&lines, &problems)
}
