//! Running a benchmark case: the camera for each distance, a seeded
//! order of the methods within each frame, timed frames of every method
//! against one reference render per distance.

use std::collections::BTreeMap;
use std::io::IsTerminal;
use std::time::{Duration, Instant};

use anyhow::{Context, Result};
use glam::DVec3;
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};

use golden::camera::{Camera, ImagePlane};
use golden::metrics::compare;
use golden::render::{lut_for, render, Prepared, RenderOptions, Technique};
use golden::tf::Lut;
use golden::volume::Volume;
use pipeline::config::Order;

use super::shard::Shard;
use super::{BenchMethod, Case, CaseResult, PerSlice, Row};

/// A small, fast, seedable generator (SplitMix64) for the run order.
pub struct SplitMix(u64);

impl SplitMix {
    /// Seeds the generator.
    pub fn new(seed: u64) -> SplitMix {
        SplitMix(seed)
    }
    /// The next 64 random bits.
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    }
    /// Shuffles `v` (Fisher-Yates).
    pub fn shuffle<T>(&mut self, v: &mut [T]) {
        for i in (1..v.len()).rev() {
            let j = (self.next_u64() % (i as u64 + 1)) as usize;
            v.swap(i, j);
        }
    }
}

/// A progress bar on stderr, drawn only when stdout is a terminal.
pub fn progress(len: u64) -> ProgressBar {
    let bar = if std::io::stdout().is_terminal() {
        ProgressBar::with_draw_target(Some(len), ProgressDrawTarget::stderr())
    } else {
        ProgressBar::with_draw_target(Some(len), ProgressDrawTarget::hidden())
    };
    bar.set_style(
        ProgressStyle::with_template("{bar:32} {pos}/{len} {msg} [{elapsed} < {eta}]")
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    bar.enable_steady_tick(Duration::from_millis(200));
    bar
}

/// The bench camera: the eye on the centre line, `d` voxels in front of
/// slice 0, looking at the centre.
pub fn bench_camera(
    vol: &Volume,
    d: f64,
    fov: Option<f64>,
    size: [u32; 2],
    plane: ImagePlane,
) -> Result<(Camera, f64)> {
    let c = DVec3::from_array(vol.center_world());
    let s = vol.spacing();
    let eye = DVec3::new(c.x, c.y, -d * s[2]);
    // Fit: the front face (the larger of its two extents) fills the
    // vertical field of view.
    let extent = (vol.dims()[0] as f64 * s[0]).max(vol.dims()[1] as f64 * s[1]);
    let fov = fov.unwrap_or_else(|| 2.0 * (extent / (2.0 * d * s[2])).atan().to_degrees());
    let mut cam = Camera::new(eye, c, DVec3::Y, fov, size[0], size[1])?;
    cam.image_plane = plane;
    Ok((cam, fov))
}

/// Is this golden error "too large to render" (recorded as skipped)?
fn too_large(e: &golden::Error) -> bool {
    matches!(e, golden::Error::TooLarge { .. })
}

/// Renders every method of `case` at every distance.
pub fn run_case(case: &Case) -> Result<CaseResult> {
    run_case_in(case, None)
}

/// [`run_case`] for one shard's distances only ([`Shard::owns`]); the
/// method order of every frame is the unsharded run's (the shuffle still
/// walks the other shards' distances), so only the timings can differ.
pub fn run_case_in(case: &Case, shard: Option<Shard>) -> Result<CaseResult> {
    let mut opts = RenderOptions::default();
    opts.slice.shade = case.shade;
    opts.reference.shade = case.shade;
    // Each shaded frame is followed by the same method's unshaded frame.
    let plain = RenderOptions::default();
    let lut = lut_for(case.vol.kind(), &case.tf);
    let timed_methods = case
        .methods
        .iter()
        .filter(|m| !matches!(m, BenchMethod::Golden(Technique::Reference)))
        .count();
    let pipes = case
        .methods
        .iter()
        .filter(|m| matches!(m, BenchMethod::Pipeline { .. }))
        .count();
    let per_d = 1 + pipes + case.frames * timed_methods;
    let owned = (0..case.distances.len())
        .filter(|&i| shard.is_none_or(|s| s.owns(i)))
        .count();
    let bar = progress((per_d * owned) as u64);
    let mut rows = Vec::new();
    let mut per_slice = None;
    let mut rng = SplitMix::new(case.seed);
    let (mut area, mut nz) = (0.0, 0);
    let mut pipeline_matches_er: Option<bool> = None;
    let mut table_luts: BTreeMap<u32, Lut> = BTreeMap::new();
    for (i, (&d, &fov)) in case.distances.iter().zip(&case.fovs).enumerate() {
        if shard.is_some_and(|s| !s.owns(i)) {
            for _ in 0..case.frames {
                rng.shuffle(&mut (0..case.methods.len()).collect::<Vec<_>>());
            }
            continue;
        }
        let (cam, fov) = bench_camera(&case.vol, d, fov, case.size, case.plane)?;
        let mut prep = Prepared::new(&case.vol, &cam)?;
        if case
            .methods
            .iter()
            .any(|m| matches!(m, BenchMethod::Gaze(Technique::Slice(_))))
        {
            // ER's coarse levels belong to the volume and camera, as the
            // mip-map does: prepared untimed.
            prep = prep.with_gaze_levels(
                &case.vol,
                &cam,
                &golden::render::PrepareOptions::default(),
                2,
            )?;
        }
        if case.shade.is_some() {
            // The voxel gradients belong to the stack, as the pyramid to
            // the volume: built untimed, kept from frame to frame.
            prep.gradients();
        }
        let vd = prep.view.d;
        area = (prep.view.dims[0] * prep.view.dims[1]) as f64;
        nz = prep.view.dims[2];
        bar.set_message(format!("{} D={d}: reference", case.label));
        let t = Instant::now();
        let reference = render(&prep, &lut, Technique::Reference, &opts)?.image;
        let ref_time = t.elapsed().as_secs_f64();
        bar.inc(1);
        if case.methods.iter().any(|m| {
            matches!(
                m,
                BenchMethod::Golden(Technique::MipMap)
                    | BenchMethod::Gaze(Technique::MipMap)
                    | BenchMethod::Refine {
                        tech: Technique::MipMap,
                        ..
                    }
            )
        }) {
            // The pyramid is cached per volume and table, as a renderer
            // drawing frame after frame keeps it: build it untimed.
            prep.mipmap_of(&lut, &opts.mip())?;
        }
        if case
            .methods
            .iter()
            .any(|m| matches!(m, BenchMethod::Golden(Technique::ShearWarp)))
        {
            // The classified runs likewise (per volume, axis and table).
            prep.classified_for(&lut)?;
        }
        let row = |method: &str, run: usize| Row {
            d: vd,
            fov,
            method: method.to_string(),
            run,
            skipped: None,
            time_s: None,
            samples: None,
            regions: None,
            cycles: None,
            utilization: None,
            err: None,
            vs_er: None,
            unshaded_time_s: None,
        };
        // Golden er with each pipeline's table, untimed, for the
        // pipeline's bit-level comparison.
        let mut er_for: BTreeMap<String, golden::image::Image> = BTreeMap::new();
        for m in &case.methods {
            if let BenchMethod::Pipeline { label, cfg } = m {
                let plut = table_luts.entry(cfg.table_entries).or_insert_with(|| {
                    Lut::for_bits(&case.tf, cfg.table_entries as usize, case.vol.kind().bits())
                });
                bar.set_message(format!("{} D={d}: golden er for {label}", case.label));
                // The golden method the pipeline mirrors (er-ftb at its
                // threshold, front to back).
                let mut o = opts;
                o.slice.terminate = cfg.terminate as f32;
                let er = render(
                    &prep,
                    plut,
                    Technique::Slice(crate::cli::chip::golden_method(cfg)),
                    &o,
                )?;
                er_for.insert(label.clone(), er.image);
                bar.inc(1);
            }
        }
        let mut got: BTreeMap<String, Vec<Row>> = BTreeMap::new();
        let mut spans: BTreeMap<String, Vec<u64>> = BTreeMap::new();
        if case
            .methods
            .iter()
            .any(|m| matches!(m, BenchMethod::Golden(Technique::Reference)))
        {
            let mut r = row("reference", 0);
            r.time_s = Some(ref_time);
            got.entry("reference".into()).or_default().push(r);
        }
        let mut skipped: BTreeMap<String, String> = BTreeMap::new();
        for run in 0..case.frames {
            let mut order: Vec<usize> = (0..case.methods.len()).collect();
            rng.shuffle(&mut order);
            for &i in &order {
                let m = &case.methods[i];
                let label = m.label();
                if matches!(m, BenchMethod::Golden(Technique::Reference)) {
                    continue;
                }
                bar.set_message(format!("{} D={d}: {label} frame {}", case.label, run + 1));
                if skipped.contains_key(&label) {
                    bar.inc(1);
                    continue;
                }
                let mut r = row(&label, run);
                match m {
                    BenchMethod::Golden(t)
                    | BenchMethod::Gaze(t)
                    | BenchMethod::Refine { tech: t, .. } => {
                        let mut o = opts;
                        if matches!(m, BenchMethod::Refine { .. }) {
                            o.reference.refine = Some(golden::refine::Refine {
                                threshold: golden::refine::Refine::DEFAULT_THRESHOLD,
                                levels: golden::refine::Refine::DEFAULT_LEVELS,
                            });
                        }
                        if m.gazes() {
                            let [w, h] = case.size;
                            let at = [f64::from(w) * 0.5, f64::from(h) * 0.5];
                            o.reference.gaze = Some(golden::gaze::Gaze::around(at, w, h));
                        }
                        let t0 = Instant::now();
                        match render(&prep, &lut, *t, &o) {
                            Ok(f) => {
                                r.time_s = Some(t0.elapsed().as_secs_f64());
                                if case.shade.is_some() {
                                    let mut p = plain;
                                    p.reference.gaze = o.reference.gaze;
                                    p.reference.refine = o.reference.refine;
                                    let t1 = Instant::now();
                                    render(&prep, &lut, *t, &p)
                                        .context(format!("{label} unshaded at D = {d}"))?;
                                    r.unshaded_time_s = Some(t1.elapsed().as_secs_f64());
                                }
                                r.err = Some(compare(&f.image, &reference)?);
                                r.samples = f.samples();
                                if let Some(o) = &f.slice {
                                    r.regions = Some(o.stats.regions.len().saturating_sub(1));
                                    if run == 0 {
                                        spans.insert(
                                            label.clone(),
                                            o.stats.samples_per_slice.clone(),
                                        );
                                    }
                                }
                            }
                            Err(e) if too_large(&e) => {
                                skipped.insert(label.clone(), e.to_string());
                                r.skipped = Some(e.to_string());
                            }
                            Err(e) => return Err(e).context(format!("{label} at D = {d}")),
                        }
                    }
                    BenchMethod::Pipeline { cfg, .. } => {
                        let plut = &table_luts[&cfg.table_entries];
                        // Shaded, the array runs through the prepared view,
                        // skipping nothing as a frame of the bare view
                        // does, and so does its unshaded frame.
                        let frame = |shade: Option<&golden::shading::Shade>| match shade {
                            None if case.shade.is_none() => {
                                pipeline::FrameRun::new(cfg, plut, &case.vol, &prep.view).run()
                            }
                            _ => pipeline::FrameRun::prepared(
                                cfg,
                                plut,
                                &prep,
                                pipeline::Voxels::Volume(&case.vol),
                            )
                            .skips(golden::skip::Skips::NONE)
                            .unit(shade)
                            .run(),
                        };
                        let t0 = Instant::now();
                        let res = frame(case.shade.as_ref());
                        match res {
                            Ok(f) => {
                                let image = golden::warp::warp(&prep.view, &f.baseplane);
                                r.time_s = Some(t0.elapsed().as_secs_f64());
                                if case.shade.is_some() {
                                    let t1 = Instant::now();
                                    frame(None).context(format!("{label} unshaded at D = {d}"))?;
                                    r.unshaded_time_s = Some(t1.elapsed().as_secs_f64());
                                }
                                r.err = Some(compare(&image, &reference)?);
                                r.vs_er = Some(compare(&image, &er_for[&label])?);
                                r.samples = Some(f.samples);
                                r.cycles = Some(f.cycles);
                                r.utilization = Some(f.utilization());
                                r.regions = Some(prep.view.regions().count());
                                if run == 0 {
                                    spans.insert(label.clone(), f.samples_per_slice.clone());
                                }
                            }
                            Err(pipeline::RunError::Plan(e)) => {
                                skipped.insert(label.clone(), e.to_string());
                                r.skipped = Some(e.to_string());
                            }
                            Err(e) => return Err(e).context(format!("{label} at D = {d}")),
                        }
                    }
                }
                got.entry(label).or_default().push(r);
                bar.inc(1);
            }
        }
        // Rows in method order, then run order: independent of the shuffle.
        for m in &case.methods {
            rows.extend(got.remove(&m.label()).unwrap_or_default());
        }
        if let Some(er) = spans.get("er") {
            for m in &case.methods {
                if let BenchMethod::Pipeline { label, cfg } = m {
                    if cfg.order != Order::BackToFront {
                        continue;
                    }
                    if let Some(p) = spans.get(label) {
                        let same = p == er;
                        pipeline_matches_er = Some(pipeline_matches_er.unwrap_or(true) && same);
                    }
                }
            }
        }
        if d == case.slices_at {
            let measured = case
                .methods
                .iter()
                .filter_map(|m| {
                    let l = m.label();
                    spans.get(&l).map(|v| (l, v.clone()))
                })
                .collect();
            per_slice = Some(PerSlice {
                d: vd,
                area,
                nz,
                measured,
            });
        }
    }
    bar.finish_and_clear();
    Ok(CaseResult {
        rows,
        per_slice,
        area,
        nz,
        pipeline_matches_er,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shuffle_is_seeded() {
        let mut a: Vec<u32> = (0..10).collect();
        let mut b = a.clone();
        SplitMix::new(7).shuffle(&mut a);
        SplitMix::new(7).shuffle(&mut b);
        assert_eq!(a, b);
        let mut s = a.clone();
        s.sort();
        assert_eq!(s, (0..10).collect::<Vec<_>>());
    }

    #[test]
    fn fit_opens_the_paper_views() {
        let vol = golden::scenes::Scene::Sphere { n: 256 }
            .build(golden::volume::DEFAULT_MEMORY_LIMIT)
            .unwrap();
        let (_, fov) = bench_camera(&vol, 64.0, None, [8, 8], ImagePlane::Front).unwrap();
        assert!((fov - 126.87).abs() < 0.01, "{fov}");
        let (_, fov) = bench_camera(&vol, 128.0, None, [8, 8], ImagePlane::Front).unwrap();
        assert!((fov - 90.0).abs() < 1e-9, "{fov}");
    }
}
