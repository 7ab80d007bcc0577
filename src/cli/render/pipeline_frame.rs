//! `ercube render --method pipeline` or `pipeline-ftb`: the frame of the
//! cycle model of the PE array, its golden twin and its statistics.

use super::*;

/// `ercube render --method pipeline` or `pipeline-ftb`.
pub(super) fn frame_pipeline(
    a: &RenderArgs,
    given: Option<golden::volume::Volume>,
    mut reuse: Option<&mut Reuse>,
    tap: Option<pipeline::stepper::Tap>,
) -> Result<Rendered> {
    let clock = a.pipeline.clock()?;
    // The golden-only ways of choosing rays, refused rather than ignored.
    if a.gaze.is_some() || a.refine.is_some() || a.compare_full {
        anyhow::bail!(
            "--gaze, --refine and --compare-full apply to the golden methods, not {} (--rays footprint matches the pipeline's rays to the image)",
            a.method.name()
        );
    }
    let (cfg, slice) = chip::configure(&a.pipeline.cfg, a.method, &a.slice)?;
    let opts = slice.options()?;
    chip::check_options(&opts)?;
    let spec = FrameSpec {
        technique: None,
        shade: opts.slice.shade.is_some(),
        size: a.view.camera.size,
    };
    let (vol, tf, cam) = a.view.load_given(a.method.name(), &spec, given)?;
    let mut opts = opts;
    slice.apply_tf(&mut opts, &tf)?;
    let (shade, voi) = (opts.slice.shade, opts.slice.voi);
    let lut = chip::pipeline_lut(&cfg, &vol, &tf);
    let shape = (vol.dims(), vol.spacing());
    let bits = vol.kind().bits();
    // `--rays footprint`: the host prefilters the volume to the coarsest
    // level whose rays still give every pixel two across and loads the
    // PEs with that level's voxels; golden's `--rays footprint` frame
    // renders the same level, so it stays the twin. Level 0 is the plain
    // frame.
    let level = match a.rays {
        Rays::Voxels => 0,
        Rays::Footprint => footprint_level_of(&slice, &vol, &cam)?,
    };
    let prep = if level > 0 {
        let _s = Stage::start(format!("prefiltering the volume to level {level}"));
        std::sync::Arc::new(golden::ergaze::prepare_level(
            &vol,
            &cam,
            &slice.prepare()?,
            level,
        )?)
    } else {
        // The PEs load from golden's stack, which takes the volume's
        // voxels: the frame holds them once.
        prepare_for(&slice, vol, &cam, reuse.as_deref_mut())?
    };
    // Golden's own table from the same classification table: the unit
    // quantises it, and the comparison below renders golden with it.
    let preint = opts
        .slice
        .preintegrate
        .then(|| golden::preint::PreTable::with_colouring(&lut, opts.slice.pre_colouring));
    let (run, times) = {
        let _s = Stage::start(format!("clocking {} PEs", cfg.pes));
        let mut spare = reuse.as_deref_mut().and_then(|r| r.spare.take());
        let mut tap = tap;
        let out = timed(a.repeat, || {
            chip::run(
                &a.pipeline,
                &cfg,
                bits,
                &lut,
                &prep,
                (
                    opts.slice.skips,
                    shade.as_ref(),
                    voi.as_ref(),
                    preint.as_ref(),
                ),
                (&mut spare, tap.take()),
            )
        });
        if let Some(r) = reuse {
            r.spare = spare;
        }
        out?
    };
    let run = chip::PipelineRun {
        time_s: median(&times),
        ..run
    };
    // The golden twin and the bound derived from the largest difference
    // against it, unless the run skips them.
    let twin = if a.pipeline.no_golden_twin {
        None
    } else {
        let (vs_golden, max_abs) = chip::versus_golden(
            &prep,
            &lut,
            &run.image,
            &cfg,
            (shade, voi, opts.slice.preintegrate),
        )?;
        let bound = crate::cli::bound::frame_bound(
            &cfg,
            &prep,
            &lut,
            bits,
            (
                crate::cli::bound::FrameOptions {
                    shade: shade.as_ref(),
                    voi: voi.as_ref(),
                    preint: preint.as_ref(),
                },
                &run.frame.quant,
            ),
            max_abs,
        )?;
        if let Some(w) = bound.warning() {
            eprintln!("{w}");
        }
        Some((vs_golden, bound))
    };
    let err = versus_reference(a, &prep, &lut, &opts, &run.image)?;
    let extra = chip::stats_json(&cfg, &run, twin.as_ref().map(|(v, _)| v.clone()));
    let frame = golden::render::Frame {
        image: run.image,
        slice: None,
        mip: None,
        gaze: None,
        sw: None,
        er_gaze: None,
    };
    let mut v = frame_json(
        a.method.name(),
        shape,
        &prep.view,
        cam.eye,
        run.time_s,
        &frame,
        err.as_ref(),
    );
    if let (Some(o), Some(e)) = (v.as_object_mut(), extra.as_object()) {
        for (k, val) in e {
            o.insert(k.clone(), val.clone());
        }
    }
    v["regions"] = serde_json::json!(prep.view.regions().bounds);
    if a.rays == Rays::Footprint {
        // What the PEs loaded: the prefiltered level's voxels.
        v["footprint"] = serde_json::json!({
            "level": level,
            "volume": prep.stack.dims,
        });
    }
    v["clock_mhz"] = serde_json::json!(clock);
    v["clock_source"] = serde_json::json!(ClockSource::Assumed);
    v["frames_per_s"] = serde_json::json!(pipeline::cost::clock::fps(run.frame.cycles, clock));
    v["times_s"] = serde_json::json!(times);
    v["bound"] = twin
        .as_ref()
        .map_or(serde_json::Value::Null, |(_, b)| b.json());
    let f = &run.frame;
    let summary = format!(
        "{}: {} PEs, {} cycles (ideal {:.0}, utilization {:.3}), {} samples, {:.3} s; {}",
        a.method.name(),
        cfg.pes,
        f.cycles,
        f.ideal_cycles,
        f.utilization(),
        f.samples,
        run.time_s,
        match &twin {
            Some((vs_golden, bound)) => format!(
                "vs golden {}: max {} /255 ({})",
                chip::golden_method(&cfg).name(),
                vs_golden["max_abs_255"],
                bound.summary()
            ),
            None => "golden twin skipped".to_string(),
        },
    );
    let mut notes = vec![format!(
        "  frame: {}",
        pipeline::cost::clock::rate_line(f.cycles, clock, ClockSource::Assumed)
    )];
    if let Some(line) = chip::overflow_line(&f.quant) {
        notes.push(format!("  {line}"));
    }
    Ok(Rendered {
        image: frame.image,
        baseplane: None,
        chip: Some(run.frame),
        stats: v,
        summary,
        notes,
    })
}
