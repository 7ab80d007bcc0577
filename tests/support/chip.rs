//! The pipeline's test helpers, shared by the pipeline's and the
//! program's integration tests (`#[path]` from `tests/support/`): formats,
//! default configurations, scene tables, and the signature of a frame
//! that two paths of the model must agree on.
#![allow(dead_code)]

use glam::DVec3;
use golden::scenes::Scene;
use golden::tf::{Lut, TransferFunction};
use golden::volume::{Volume, DEFAULT_MEMORY_LIMIT};
use pipeline::config::PipelineConfig;
use pipeline::fixed::{Format, Overflow, Quant};
use std::path::Path;
use waves::Trace;

/// An unsigned saturating format of `bits` bits, `frac` of them fraction.
pub fn format(bits: u8, frac: u8, quant: Quant) -> Format {
    Format::new(bits, frac, false, quant, Overflow::Sat).expect("format")
}

/// One random case of the pipeline-against-golden bound proptests: a
/// volume and table, an eye, a configuration, and the termination
/// threshold (1 when nothing terminates).
pub struct Case {
    pub vol: Volume,
    pub tf: TransferFunction,
    pub eye: DVec3,
    pub up: DVec3,
    pub cfg: PipelineConfig,
    pub terminate: f64,
}

/// Shrunk failures print what reproduces them, not a dump of the voxels.
impl std::fmt::Debug for Case {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Case")
            .field("dims", &self.vol.dims())
            .field("value_range", &self.vol.value_range())
            .field("tf", &self.tf.points)
            .field("eye", &self.eye)
            .field("up", &self.up)
            .field("cfg", &self.cfg)
            .field("terminate", &self.terminate)
            .finish()
    }
}

/// The smooth blob and ramp both bound tests check for informativeness.
pub fn smooth_case(eye: DVec3, cfg: PipelineConfig, terminate: f64) -> Case {
    Case {
        vol: crate::scenes::blobs([24, 20, 28], &[(0.5, 0.5, 0.5, 0.35, 250.0)], 0, 1),
        tf: crate::scenes::tf(&[(20.0, [1.0, 0.6, 0.2, 0.0]), (200.0, [1.0, 1.0, 1.0, 0.6])]),
        eye,
        up: DVec3::Y,
        cfg,
        terminate,
    }
}

/// Golden `er` (nothing skipped) and the pipeline's frame of the same
/// view and table, and the pipeline's baseplane warped to the image.
pub fn er_and_pipeline(
    cfg: &PipelineConfig,
    vol: &Volume,
    lut: &Lut,
    prep: &golden::render::Prepared,
) -> (golden::render::Frame, pipeline::Frame, golden::image::Image) {
    let golden = golden::render::render(
        prep,
        lut,
        golden::render::Technique::Slice(golden::methods::Method::Er),
        &golden::render::RenderOptions::unskipped(),
    )
    .expect("golden er renders");
    let frame = pipeline::FrameRun::new(cfg, lut, vol, &prep.view)
        .run()
        .expect("pipeline frame");
    let image = golden::warp::warp(&prep.view, &frame.baseplane);
    (golden, frame, image)
}

/// The default configuration with `pes` PEs.
pub fn config(pes: u16) -> PipelineConfig {
    PipelineConfig {
        pes,
        ..PipelineConfig::default()
    }
}

/// A volume and the classification table the pipeline uses for it.
pub struct Subject {
    pub vol: Volume,
    pub lut: Lut,
    /// Edge length (the volumes are cubes).
    pub n: usize,
}

/// Builds scene `spec` with its preset transfer function, tabulated as the
/// pipeline needs it: `table_entries` entries over the data's bit range.
pub fn subject(spec: &str) -> Subject {
    let scene: Scene = spec.parse().expect("scene spec");
    let vol = scene.build(DEFAULT_MEMORY_LIMIT).expect("scene builds");
    let lut = Lut::for_bits(
        &scene.preset(),
        PipelineConfig::default().table_entries as usize,
        vol.kind().bits(),
    );
    Subject {
        vol,
        lut,
        n: scene.size(),
    }
}

/// Golden's prepared view of `vol` from `eye`, looking at the volume's
/// centre (up +y, 60 degrees), `size` pixels square: the camera of the
/// co-simulation and capture tests.
pub fn view_from(vol: &Volume, eye: [f64; 3], size: u32) -> golden::render::Prepared {
    let centre = DVec3::from_array(vol.center_world());
    let cam =
        golden::camera::Camera::new(DVec3::from_array(eye), centre, DVec3::Y, 60.0, size, size)
            .expect("camera");
    golden::render::Prepared::new(vol, &cam).expect("prepared view")
}

/// Everything a pipeline frame reports that the sampling path, the PE
/// step order or tracing could conceivably change (fields named after the
/// frame's).
#[derive(Debug, PartialEq)]
pub struct Signature {
    pub raw: Vec<[i64; 4]>,
    pub cycles: u64,
    pub stages: pipeline::array::StageCycles,
    pub pes: Vec<pipeline::pe::PeCounters>,
    pub samples_per_slice: Vec<u64>,
    pub merges: u64,
    pub quant: pipeline::fixed::QuantStats,
    pub terminated: u64,
    pub saved: u64,
    pub skipped: pipeline::skip::SkipCounts,
}

/// The [`Signature`] of a frame.
pub fn signature(f: &pipeline::Frame) -> Signature {
    Signature {
        raw: f.raw.clone(),
        cycles: f.cycles,
        stages: f.stages,
        pes: f.pes.clone(),
        samples_per_slice: f.samples_per_slice.clone(),
        merges: f.merges,
        quant: f.quant,
        terminated: f.terminated_samples,
        saved: f.cycles_saved,
        skipped: f.skipped,
    }
}

/// Every signal line of the `.gtkw` beside `vcd` names a signal of the VCD,
/// and every VCD signal is named; returns the number of signal lines.
pub fn check_gtkw(vcd: &Path) -> usize {
    let gtkw = vcd.with_extension("gtkw");
    let text = std::fs::read_to_string(&gtkw)
        .unwrap_or_else(|e| panic!("{} was not written: {e}", gtkw.display()));
    let trace = Trace::read(vcd).expect("VCD reads");
    let names: std::collections::BTreeSet<&str> = trace.names().collect();
    let mut named = std::collections::BTreeSet::new();
    for line in text.lines() {
        // `^N file` lines name a trace's translate filter file.
        if line.is_empty() || line.starts_with(['[', '*', '@', '-', '^']) {
            continue;
        }
        // `+{alias} name`: the name shown, then the signal.
        let line = match line.strip_prefix('+') {
            Some(rest) => rest.split_once("} ").map_or(rest, |(_, n)| n),
            None => line,
        };
        // Vectors carry GTKWave's `[msb:0]`; the reader's names do not.
        let name = match line.rfind('[') {
            Some(i) if line.ends_with(']') => &line[..i],
            _ => line,
        };
        assert!(
            names.contains(name),
            "{} names {line:?}, which is not in the VCD",
            gtkw.display()
        );
        named.insert(name);
    }
    assert_eq!(named, names, "the .gtkw leaves VCD signals out");
    assert!(
        // Named relative to the save file beside it.
        text.contains(&format!(
            "[dumpfile] \"{}\"",
            vcd.file_name().unwrap_or_default().to_string_lossy()
        )),
        "the .gtkw does not open {}:\n{text}",
        vcd.display()
    );
    named.len()
}

/// Golden's frame of `prep` by the method `cfg` mirrors (`er` back to
/// front, `er-ftb` front to back at `cfg`'s threshold), unskipped, with the
/// slice options `set` adds (shading, a VOI, pre-integration).
pub fn golden_twin(
    cfg: &PipelineConfig,
    prep: &golden::render::Prepared,
    lut: &Lut,
    set: impl FnOnce(&mut golden::methods::Options),
) -> golden::render::Frame {
    use golden::render::{render, RenderOptions, Technique};
    let mut o = RenderOptions::unskipped();
    set(&mut o.slice);
    // Golden er-ftb terminates by default; the pipeline's threshold rules.
    o.slice.terminate = cfg.terminate as f32;
    let m = match cfg.order {
        pipeline::config::Order::BackToFront => golden::methods::Method::Er,
        pipeline::config::Order::FrontToBack => golden::methods::Method::ErFtb,
    };
    render(prep, lut, Technique::Slice(m), &o).expect("golden renders the pipeline's twin")
}
