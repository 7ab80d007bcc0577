//! Each PE's ray memories hold what its own declaration says: on clocked
//! frames (every migration cycle noted), the most ray columns, rows,
//! children, line-buffer entries and kept final states PE `k` held stay
//! at or under the depths [`Pe::declaration`] gives for PE `k` of the
//! frame's geometry ([`Geometry::for_view`], each PE sized from the
//! frame's plan by `pipeline::capacity`, [`Geometry::pe`]), over scenes,
//! eyes beside and outside the volume, wide fields of view, 1 to 16 PEs,
//! both orders and the architectures.
//!
//! `cargo test --release -p pipeline --test it -- occupancy::`

use glam::DVec3;
use golden::camera::Camera;
use golden::render::Prepared;
use golden::tf::Lut;
use golden::volume::Volume;
use pipeline::array::Frame;
use pipeline::config::{PipelineConfig, RayBuffer};
use pipeline::cost::inventory::Geometry;
use pipeline::pe::{Occupancy, Pe};
use proptest::prelude::*;

use crate::scenes::sparse;
use crate::support::{camera, Arch};

fn lut(cfg: &PipelineConfig) -> Lut {
    crate::support::lut(cfg, 40.0)
}

/// The clocked frame of `cfg` (skipping on): every stage ticks, so the
/// probe notes every migration cycle.
fn clocked(cfg: &PipelineConfig, vol: &Volume, lut: &Lut, prep: &Prepared) -> Frame {
    crate::support::clocked(cfg, vol, lut, prep, false)
}

/// The declared depths the probe's fields answer to: ray columns (the
/// column map), rows per column, line-buffer row, kept final rays.
#[derive(Debug, Clone, Copy)]
struct Declared {
    columns: u64,
    rows: u64,
    line: u64,
    kept: u64,
}

fn declared(cfg: &PipelineConfig, geo: &Geometry) -> Declared {
    let decl = Pe::declaration(cfg, geo);
    let find = |n: &str| decl.iter().find(|d| d.name == n);
    let map = find("column_map").expect("column map");
    let line = find("line_buffer").expect("line buffer");
    Declared {
        columns: map.depth,
        rows: geo.rays.rows,
        line: line.depth,
        // On chip or, with an external ray buffer, off chip in DDR at the
        // same depth; back to front keeps none.
        kept: find("kept_finals").map_or(0, |k| k.depth),
    }
}

/// Each PE's declared depths: PE `k` of `geo` ([`Geometry::pe`]).
fn declared_each(cfg: &PipelineConfig, geo: &Geometry) -> Vec<Declared> {
    (0..usize::from(cfg.pes))
        .map(|k| declared(cfg, &geo.pe(k)))
        .collect()
}

/// Every PE's peak against its own declaration; the first PE past a
/// depth.
fn check(o: &[Occupancy], declared: &[Declared]) -> Result<(), String> {
    if o.len() != declared.len() {
        return Err(format!("{} PEs ran, {} declared", o.len(), declared.len()));
    }
    for (k, (p, &d)) in o.iter().zip(declared).enumerate() {
        if p.columns > d.columns
            || p.children > d.columns
            || p.rows > d.rows
            || p.line > d.line
            || p.kept > d.kept
        {
            return Err(format!("PE {k}: held {p:?}, declared {d:?}"));
        }
    }
    Ok(())
}

/// Column blocks; the interleave, overlapped, sparse links and passes,
/// two lanes; cyclic blocks of 2, sparse passes; column blocks
/// overlapped, sparse links; the rays in external memory.
const ARCHS: [Arch; 5] = [
    Arch::BLOCKS,
    Arch::BLOCKS
        .interleave()
        .overlapped()
        .sparse_links(true)
        .sparse_passes(true)
        .lanes(2),
    Arch::BLOCKS.cyclic(2).sparse_passes(true),
    Arch::BLOCKS.overlapped().sparse_links(true),
    Arch::BLOCKS.external(),
];

proptest! {
    #![proptest_config(ProptestConfig { cases: 48, ..ProptestConfig::default() })]

    /// Scenes, eyes in front of, beside and outside the volume's sides,
    /// fields of view up to 150 degrees, 1 to 16 PEs, both orders and five
    /// architectures: no PE's ray memories ever hold more than declared.
    #[test]
    fn no_pe_holds_more_than_its_declaration(
        dims in prop::array::uniform3(6usize..22),
        seed in any::<u64>(),
        eye in (-1.5..2.5f64, -1.5..2.5f64, 0.3..2.0f64),
        look in (0.2..0.8f64, 0.2..0.8f64),
        fov in 20.0..150.0f64,
        pes in 1u16..=16,
        ftb in any::<bool>(),
        arch in 0usize..ARCHS.len(),
    ) {
        let vol = sparse(dims, 3, seed);
        let d = dims.map(|n| n as f64);
        let eye = DVec3::new(eye.0 * d[0], eye.1 * d[1], -eye.2 * d[2]);
        let look = DVec3::new(look.0 * d[0], look.1 * d[1], 0.5 * d[2]);
        let Some(cam) = camera(eye, look, fov, 24, 24) else { return Ok(()) };
        let Ok(prep) = Prepared::new(&vol, &cam) else { return Ok(()) };
        let cfg = ARCHS[arch].config(pes, ftb);
        if cfg.validate().is_err() || usize::from(pes) > prep.view.dims[0] {
            return Ok(());
        }
        let lut = lut(&cfg);
        let frame = clocked(&cfg, &vol, &lut, &prep);
        let geo = Geometry::for_view(&cfg, &prep.view).expect("geometry");
        let d = declared_each(&cfg, &geo);
        prop_assert!(check(&frame.occupancy, &d).is_ok(), "{}", check(&frame.occupancy, &d).unwrap_err());
    }
}

/// The frames the declaration's write-up measures (docs/pipeline.md):
/// every PE's peak against the declared depths, printed; each must fit.
/// brainsmall from (64, 64, -64) at 90 degrees, 16 PEs, 256x256 and
/// 64x64, both orders; `ml:24` on 3 PEs from (30, 20, -40).
///
/// `cargo test --release -p pipeline --test it -- occupancy::measured --ignored --nocapture`
/// (about a minute: clocked brainsmall frames).
#[test]
#[ignore = "clocked brainsmall frames, about a minute; run by hand for the figures"]
fn measured_frames_fit_their_declaration() {
    let mut cases: Vec<(String, Volume, Camera, u16)> = Vec::new();
    if let Some((vol, cam)) = crate::scenes::brainsmall_view() {
        let small = Camera::new(cam.eye, cam.look_at, DVec3::Y, 90.0, 64, 64).expect("camera");
        cases.push(("brainsmall 256x256".into(), vol.clone(), cam, 16));
        cases.push(("brainsmall 64x64".into(), vol, small, 16));
    }
    let ml = crate::scenes::scene("ml:24");
    let c = DVec3::from_array(ml.center_world());
    let cam =
        Camera::new(DVec3::new(30.0, 20.0, -40.0), c, DVec3::Y, 90.0, 64, 64).expect("camera");
    cases.push(("ml:24".into(), ml, cam, 3));
    for (name, vol, cam, pes) in &cases {
        let prep = Prepared::new(vol, cam).expect("view");
        for ftb in [false, true] {
            let cfg = ARCHS[0].config(*pes, ftb);
            let frame = clocked(&cfg, vol, &lut(&cfg), &prep);
            let geo = Geometry::for_view(&cfg, &prep.view).expect("geometry");
            let d = declared_each(&cfg, &geo);
            let peak = frame
                .occupancy
                .iter()
                .fold(Occupancy::default(), |a, o| a.max(*o));
            let last = frame.occupancy.len() - 1;
            let ends = frame.occupancy[0].max(frame.occupancy[last]);
            let mid = frame.occupancy[1..last]
                .iter()
                .fold(Occupancy::default(), |a, o| a.max(*o));
            let mid_declared = d[1..last].iter().fold((0, 0, 0, 0), |a, x| {
                (
                    a.0.max(x.columns),
                    a.1.max(x.rows),
                    a.2.max(x.line),
                    a.3.max(x.kept),
                )
            });
            eprintln!(
                "{name}, {} PEs, {}: peak {peak:?}\n  end PEs {ends:?}\n  middle PEs {mid:?}\n  declared: PE 0 {:?}, PE {last} {:?}, middle PEs at most (columns, rows, line, kept) {mid_declared:?} (view dims {:?})",
                pes,
                if ftb { "front to back" } else { "back to front" },
                d[0],
                d[last],
                prep.view.dims
            );
            check(&frame.occupancy, &d).unwrap();
        }
    }
}

/// A frame on a chip whose ray memories are shallower than its view needs
/// is refused before it runs, in one line naming both; on a chip sized
/// for the view it runs and gives the frame it gives without a chip.
#[test]
fn a_frame_past_the_declared_depths_is_refused_before_it_runs() {
    let vol = crate::scenes::scene("ml:24");
    let c = DVec3::from_array(vol.center_world());
    let cam =
        Camera::new(DVec3::new(30.0, 20.0, -40.0), c, DVec3::Y, 90.0, 32, 32).expect("camera");
    let prep = Prepared::new(&vol, &cam).expect("view");
    let cfg = ARCHS[0].config(3, false);
    let lut = lut(&cfg);
    let need = pipeline::capacity::need(&cfg, &prep.view).expect("need");
    let run = |depths| {
        pipeline::FrameRun::prepared(&cfg, &lut, &prep, pipeline::array::Voxels::Volume(&vol))
            .depths(depths)
            .run()
    };
    // One PE a column short: refused, naming that PE and its depths.
    let mut short = need.clone();
    short.0[1].columns -= 1;
    let err = run(short).expect_err("refused").to_string();
    assert!(
        !err.contains('\n') && err.contains("in PE 1, past its declared"),
        "{err}"
    );
    assert!(err.contains(&need.pe(1).columns.to_string()), "{err}");
    // Every PE as deep as the middle one: the end PEs' rays beyond the
    // volume's sides do not fit.
    assert!(need.pe(0).columns > need.pe(1).columns, "{need:?}");
    let err = run(pipeline::capacity::PeDepths::uniform(3, need.pe(1)))
        .expect_err("refused")
        .to_string();
    assert!(err.contains("in PE 0"), "{err}");
    // A declaration for another PE count.
    let err = run(pipeline::capacity::PeDepths::uniform(4, need.max()))
        .expect_err("refused")
        .to_string();
    assert!(err.contains("for 4 PEs, the array has 3"), "{err}");
    let fits = run(need).expect("a chip sized for the view runs it");
    let free =
        pipeline::FrameRun::prepared(&cfg, &lut, &prep, pipeline::array::Voxels::Volume(&vol))
            .run()
            .expect("frame");
    assert_eq!((fits.raw, fits.cycles), (free.raw, free.cycles));
}

/// With the rays in external memory, front to back, each PE's kept final
/// states are declared off chip (`kept_finals`, in DDR) at the depth the
/// view needs in that PE, and no PE ever keeps more: checked on clocked
/// frames of `ml:24` from an eye near the volume and beside it (three
/// regions; the end PEs keep the most) on 3 and 5 PEs, every PE against
/// its own declaration.
#[test]
fn an_external_buffers_kept_finals_fit_their_off_chip_declaration() {
    let vol = crate::scenes::scene("ml:24");
    let c = DVec3::from_array(vol.center_world());
    let cam =
        Camera::new(DVec3::new(30.0, 20.0, -6.0), c, DVec3::Y, 110.0, 32, 32).expect("camera");
    let prep = Prepared::new(&vol, &cam).expect("view");
    for pes in [3, 5] {
        let cfg = ARCHS[4].config(pes, true);
        assert_eq!(cfg.ray_buffer, RayBuffer::External);
        let frame = clocked(&cfg, &vol, &lut(&cfg), &prep);
        let geo = Geometry::for_view(&cfg, &prep.view).expect("geometry");
        for k in 0..usize::from(pes) {
            let decl = Pe::declaration(&cfg, &geo.pe(k));
            let kept = decl
                .iter()
                .find(|d| d.name == "kept_finals")
                .expect("kept finals declared");
            assert_eq!(kept.kind, pipeline::hw::state::StateKind::OffChip);
            assert_eq!(kept.depth, geo.pe(k).rays.kept);
            assert!(
                frame.occupancy[k].kept <= kept.depth,
                "PE {k} kept {}, declared {}",
                frame.occupancy[k].kept,
                kept.depth
            );
        }
        // The frame kept finals at all, so the check bit somewhere.
        assert!(geo.regions >= 3, "{} regions", geo.regions);
        assert!(frame.occupancy.iter().any(|o| o.kept > 0), "{pes} PEs");
        let d = declared_each(&cfg, &geo);
        check(&frame.occupancy, &d).unwrap();
    }
}
