//! The fade unit (a scratch unit through the "Adding a unit" recipe): a
//! frame loaded with it composites `a k` where the plain one composites
//! `a`, and its composed sample has the unit.

use pipeline::config::PipelineConfig;
use pipeline::hw::fade::Fade;
use pipeline::FrameRun;

use crate::scenes::small_views;

#[test]
fn a_faded_frame_is_fainter() {
    let cfg = PipelineConfig::default();
    let (vol, lut, views) = small_views(cfg.table_entries as usize);
    let view = &views[0].view;
    let plain = FrameRun::new(&cfg, &lut, &vol, view).run().unwrap();
    let faded = FrameRun::new(&cfg, &lut, &vol, view)
        .unit(Some(&Fade(0.5)))
        .run()
        .unwrap();
    let a = |f: &pipeline::Frame| f.raw.iter().map(|w| w[3]).sum::<i64>();
    assert!(faded.units.fade && !plain.units.fade);
    assert!(
        a(&faded) < a(&plain) && a(&faded) > 0,
        "{} {}",
        a(&faded),
        a(&plain)
    );
    // The composed sample (and so the frame's latency) carries the unit.
    let g = pipeline::hw::compose::sample(&cfg, faded.units);
    assert!(g.find("fade.ak").is_some());
}
