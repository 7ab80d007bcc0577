//! Bad configurations are refused with one-line errors by the library.

use pipeline::array::Array;
use pipeline::config::PipelineConfig;
use pipeline::fixed::{Format, Overflow, Quant};
use waves::Tracer;

use super::{prepare, Eye};
use crate::chip::{config, subject};

#[track_caller]
fn assert_one_line(msg: &str, needle: &str) {
    assert!(!msg.contains('\n'), "not one line: {msg:?}");
    assert!(msg.contains(needle), "{msg:?} does not name {needle:?}");
}

/// The library refuses, with one-line errors and without panicking, a
/// position format too narrow for the volume and an array of no PEs.
#[test]
fn bad_configurations_are_refused_by_the_library() {
    let s = subject("sphere:24");
    let prep = prepare(
        &s,
        Eye {
            axis: 2,
            positive: false,
            d: 6.0,
            off: [0.0, 0.0],
        },
    );

    // fixed<10,4>: coordinates up to 7, the volume is 24 wide. The format is
    // valid on its own; only the volume makes it too narrow.
    let narrow = PipelineConfig {
        position: Format::new(10, 6, true, Quant::Rnd, Overflow::Sat).expect("format"),
        pes: 4,
        ..PipelineConfig::default()
    };
    assert!(narrow.validate().is_ok(), "the format alone is valid");
    let e = narrow.check_extent(24).expect_err("24 > 7");
    assert_one_line(&e.to_string(), "position");
    assert_eq!(e.field(), Some("position"));
    let e = Array::new(&narrow, &s.vol, &s.lut, &prep.view, Tracer::disabled())
        .err()
        .expect("Array::new refuses a position format narrower than the volume");
    assert_eq!(
        e.to_string(),
        "position holds coordinates up to 7, below the volume extent 24"
    );

    let none = config(0);
    let e = none.validate().expect_err("no PEs");
    assert_one_line(&e.to_string(), "pes");
    assert_eq!(e.field(), Some("pes"));
    let e = Array::new(&none, &s.vol, &s.lut, &prep.view, Tracer::disabled())
        .err()
        .expect("Array::new refuses zero PEs");
    assert_one_line(&e.to_string(), "pes = 0");
    let e = pipeline::FrameRun::new(&none, &s.lut, &s.vol, &prep.view)
        .run()
        .expect_err("a frame refuses zero PEs");
    assert_one_line(&e.to_string(), "pes = 0");
}
