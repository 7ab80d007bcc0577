//! The plain sample's kernel (`pipeline::datapath::Kernel`) against the
//! general datapath it evaluates: over configurations that round with
//! `TRN` and `RND`, saturate often (narrow accumulators and opacities),
//! read 8- and 16-bit voxels, run both orders with termination and every
//! mapping, the frames with and without the kernel agree in every raw
//! word, cycle, counter and quantisation count; configurations the kernel
//! does not model run without it.
//!
//! `cargo test --release -p pipeline --test it -- kernel::`

use glam::DVec3;
use golden::camera::Camera;
use golden::render::Prepared;
use golden::tf::Lut;
use golden::volume::VoxelType;
use pipeline::array::Array;
use pipeline::config::{Mapping, Order, PipelineConfig};
use pipeline::fixed::{Format, Overflow, Quant};
use waves::Tracer;

use crate::chip::{signature, subject, Signature, Subject};
use crate::scenes::{tf, up_for, volume};

fn fmt(bits: u8, frac: u8, q: Quant) -> Format {
    Format::new(bits, frac, false, q, Overflow::Sat).expect("format")
}

/// The frame's signature with the kernel (asserting the frame has one
/// when `kernel`) and without it.
fn both(
    cfg: &PipelineConfig,
    s: &Subject,
    prep: &Prepared,
    kernel: bool,
) -> (Signature, Signature) {
    let run = |general: bool| {
        let mut a = Array::new(cfg, &s.vol, &s.lut, &prep.view, Tracer::disabled()).expect("array");
        assert_eq!(a.datapath().kernel().is_some(), kernel, "{cfg:?}");
        if general {
            a.disable_kernel();
            assert!(a.datapath().kernel().is_none());
        }
        signature(&a.run(&prep.view).expect("frame"))
    };
    (run(false), run(true))
}

fn view(s: &Subject, eye: DVec3, fov: f64) -> Prepared {
    let centre = DVec3::from_array(s.vol.center_world());
    let cam = Camera::new(eye, centre, up_for(centre - eye), fov, 36, 30).expect("camera");
    Prepared::new(&s.vol, &cam).expect("view")
}

/// A 16-bit ball of 20 voxels, brightest at the centre, with a table
/// over the 16-bit range.
fn ball16() -> Subject {
    let n = 20;
    let vol = volume([n, n, n], VoxelType::U16, |x, y, z| {
        let d = [x, y, z].map(|v| v as f64 - 9.5);
        let r = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
        (65535.0 * (1.0 - r / 10.0)).max(0.0) as u16
    });
    let table = tf(&[
        (9000.0, [0.9, 0.4, 0.1, 0.0]),
        (60000.0, [1.0, 1.0, 0.8, 0.8]),
    ]);
    let entries = PipelineConfig::default().table_entries as usize;
    let lut = Lut::for_bits(&table, entries, 16);
    Subject { vol, lut, n }
}

#[test]
fn the_kernel_is_the_general_datapath() {
    let base = PipelineConfig::default();
    let trn = PipelineConfig {
        sample: fmt(16, 4, Quant::Trn),
        color: fmt(9, 8, Quant::Trn),
        alpha: fmt(12, 12, Quant::Trn),
        path: fmt(16, 13, Quant::Trn),
        log_transmittance: fmt(20, 15, Quant::Trn),
        opacity_corr: fmt(16, 15, Quant::Trn),
        accum_color: fmt(16, 16, Quant::Trn),
        accum_alpha: fmt(16, 16, Quant::Trn),
        ..base
    };
    // Narrow words: opacities and accumulators saturate, the exp table's
    // index takes few bits, the weight is coarse.
    let narrow = PipelineConfig {
        weight: fmt(6, 6, Quant::Rnd),
        sample: fmt(14, 2, Quant::Rnd),
        alpha: fmt(8, 8, Quant::Rnd),
        opacity_corr: fmt(9, 8, Quant::Rnd),
        log_transmittance: fmt(10, 6, Quant::Trn),
        exp_table_bits: 4,
        accum_color: fmt(9, 8, Quant::Rnd),
        accum_alpha: fmt(8, 8, Quant::Trn),
        ..base
    };
    let cases = [
        ("default", base),
        ("trn", trn),
        ("narrow", narrow),
        (
            "ftb",
            PipelineConfig {
                order: Order::FrontToBack,
                terminate: 0.9,
                ..base
            },
        ),
        (
            "narrow ftb interleave",
            PipelineConfig {
                order: Order::FrontToBack,
                terminate: 0.8,
                mapping: Mapping::Interleave,
                pes: 5,
                ..narrow
            },
        ),
        (
            "cyclic",
            PipelineConfig {
                mapping: Mapping::Cyclic,
                pes: 3,
                ..trn
            },
        ),
    ];
    let mut saturated = 0;
    let mut compared = 0;
    for (spec, s) in [
        ("ml:24", subject("ml:24")),
        ("checker:24", subject("checker:24")),
        ("u16 ball", ball16()),
    ] {
        let c = s.n as f64 / 2.0;
        for (eye, fov) in [
            (DVec3::new(c + 0.6, c - 0.3, -1.5 * s.n as f64), 60.0),
            (DVec3::new(c - 2.2, c + 1.7, -0.2), 100.0),
            (DVec3::new(2.5 * s.n as f64, c + 0.4, c - 3.1), 70.0),
        ] {
            let prep = view(&s, eye, fov);
            for (name, cfg) in &cases {
                let (fast, general) = both(cfg, &s, &prep, true);
                assert!(
                    fast.quant.assignments > 0,
                    "{spec} {name}: nothing assigned"
                );
                assert!(
                    fast == general,
                    "{spec} eye {eye} {name}: the kernel differs from the general path \
                     (quantisation {:?} vs {:?}, cycles {} vs {})",
                    fast.quant,
                    general.quant,
                    fast.cycles,
                    general.cycles
                );
                saturated += u64::from(fast.quant.overflows > 0);
                compared += 1;
            }
        }
    }
    assert!(compared >= 36, "{compared} frames compared");
    assert!(saturated > 0, "no configuration saturated");
}

/// A rounding or overflow mode the kernel does not model leaves the
/// frame on the general path (and its words are the general path's by
/// construction).
#[test]
fn unmodelled_modes_take_the_general_path() {
    let s = subject("ml:16");
    let prep = view(&s, DVec3::new(8.3, 7.6, -20.0), 60.0);
    let base = PipelineConfig::default();
    for cfg in [
        PipelineConfig {
            accum_color: base.accum_color.with_quant(Quant::RndConv),
            ..base
        },
        PipelineConfig {
            opacity_corr: base.opacity_corr.with_overflow(Overflow::Wrap),
            ..base
        },
        PipelineConfig {
            sample: base.sample.with_quant(Quant::RndZero),
            ..base
        },
    ] {
        let (a, b) = both(&cfg, &s, &prep, false);
        assert!(a == b);
    }
}
