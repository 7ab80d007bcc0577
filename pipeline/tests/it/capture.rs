//! The capture of every PE's datapath issues (`pipeline::cosim::capture`),
//! without a simulator: a captured frame is the uncaptured one (raw words,
//! cycles, counters); it records exactly the frame's samples, at most one
//! per PE per cycle, each written back `latency` cycles after issue; and
//! the datapath's description (`hw::unit`'s `sample`) evaluated on every
//! captured input bundle, with the frame's tables, gives the accumulators
//! the model wrote back and the tap column. On a real frame, then, the
//! model's words are those the emitted module computes from the same
//! inputs (`tests/it/cosim.rs` runs the module itself).

use std::sync::{Arc, Mutex};

use golden::camera::Camera;
use golden::render::Prepared;
use pipeline::config::{Order, PipelineConfig};
use pipeline::cosim::capture::Recorded;
use pipeline::cosim::replay::word_of;
use pipeline::hw::unit::Unit;
use pipeline::FrameRun;

use crate::chip::{signature, subject};

fn check(order: Order, pes: u16, eye: [f64; 3]) {
    let s = subject("ml:24");
    let cfg = PipelineConfig {
        pes,
        order,
        ..PipelineConfig::default()
    };
    let centre = glam::DVec3::from_array(s.vol.center_world());
    let cam = Camera::new(
        glam::DVec3::from_array(eye),
        centre,
        glam::DVec3::Y,
        60.0,
        24,
        24,
    )
    .unwrap();
    let prep = Prepared::new(&s.vol, &cam).unwrap();
    let plain = FrameRun::new(&cfg, &s.lut, &s.vol, &prep.view)
        .run()
        .unwrap();
    let rec = Arc::new(Mutex::new(Recorded::new()));
    let captured = FrameRun::new(&cfg, &s.lut, &s.vol, &prep.view)
        .capture(rec.clone())
        .run()
        .unwrap();
    assert_eq!(signature(&captured), signature(&plain), "{order:?}");
    let rec = rec.lock().unwrap();
    assert_eq!(rec.issues.len() as u64, plain.samples, "{order:?}");
    assert_eq!(
        rec.latency,
        u64::from(pipeline::cost::datapath_latency(&cfg))
    );
    let mut last = vec![0u64; usize::from(pes)];
    for i in &rec.issues {
        assert!(i.cycle > last[i.pe], "PE {} issued twice in a cycle", i.pe);
        last[i.pe] = i.cycle;
        assert_eq!(i.input.land, i.cycle + rec.latency);
        assert!(i.cycle <= plain.cycles);
    }
    let mut unit = Unit::new(&cfg, "sample").unwrap();
    for (name, words) in &rec.tables {
        unit.load_table(name, words).unwrap();
    }
    let mut visible = 0;
    for i in &rec.issues {
        let words: Vec<i64> = unit
            .inputs()
            .iter()
            .map(|p| word_of(i, &p.name).unwrap_or_else(|| panic!("no word for {}", p.name)))
            .collect();
        let out = unit.eval(&words).unwrap();
        for (p, w) in unit.outputs().iter().zip(&out) {
            assert_eq!(
                Some(*w),
                word_of(i, &p.name),
                "{order:?}: cycle {}, PE {}, {}",
                i.cycle,
                i.pe,
                p.name
            );
        }
        visible += usize::from(i.out != i.input.acc);
    }
    assert!(
        visible > rec.issues.len() / 10,
        "few visible samples: {visible}"
    );
}

#[test]
fn captured_issues_are_the_datapaths_words() {
    check(Order::BackToFront, 3, [40.0, 30.0, -40.0]);
    check(Order::FrontToBack, 2, [-10.0, 12.0, -30.0]);
}
