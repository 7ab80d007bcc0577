//! Ownership mappings (`pipeline::mapping`): column blocks, Cube-4's
//! interleave and round-robin blocks, under every migration and ray
//! buffer placement, give the same raw words, samples and quantisation
//! events in both orders, shaded or not, with skipping on or off
//! (proptest); round-robin PEs hold their aprons and every column's
//! owner; the clocked path agrees with the whole-slice path cycle for
//! cycle under a ring; and on a sparse view the round-robin mappings
//! shorten the sampling stage that column blocks leave idle. How rays
//! move and where they live is in `migration`.
//!
//! `cargo test --release -p pipeline --test it -- mapping::`

use glam::DVec3;
use golden::camera::Camera;
use golden::render::Prepared;
use golden::shading::Shade;
use golden::skip::Skips;
use golden::tf::Lut;
use golden::volume::Volume;
use pipeline::array::{Frame, FrameRun, Voxels};
use pipeline::config::PipelineConfig;
use pipeline::mapping::{ColumnMap, APRON_LEFT, APRON_RIGHT};
use proptest::prelude::*;

use crate::chip::signature;
use crate::scenes::{eye_and_look, sparse};
use crate::support::{clocked as clocked_frame, lut, two_blobs, Arch};

fn camera(eye: DVec3, look: DVec3, fov: f64) -> Camera {
    crate::support::camera(eye, look, fov, 32, 28).expect("camera")
}

fn frame(
    cfg: &PipelineConfig,
    vol: &Volume,
    lut: &Lut,
    prep: &Prepared,
    skips: Skips,
    shade: Option<&Shade>,
) -> Result<Frame, pipeline::RunError> {
    FrameRun::prepared(cfg, lut, prep, Voxels::Volume(vol))
        .skips(skips)
        .unit(shade)
        .run()
}

/// What a mapping may not change: everything but where and when.
fn results(f: &Frame) -> (&[[i64; 4]], &[u64], u64, pipeline::fixed::QuantStats, u64) {
    (
        &f.raw,
        &f.samples_per_slice,
        f.merges,
        f.quant,
        f.terminated_samples,
    )
}

#[derive(Debug, Clone)]
struct Case {
    dims: [usize; 3],
    blobs: usize,
    seed: u64,
    threshold: f64,
    view: (usize, f64, [f64; 2], f64),
    pes: u16,
    width: u16,
    ftb: bool,
    shade: bool,
    skip: bool,
    lanes: u16,
}

fn cases() -> impl Strategy<Value = Case> {
    (
        (
            prop::array::uniform3(6usize..26),
            1usize..4,
            any::<u64>(),
            20.0..120.0f64,
        ),
        (
            0usize..6,
            prop_oneof![0.4..4.0f64, 4.0..50.0],
            prop::array::uniform2(-0.6..0.6f64),
            12.0..120.0f64,
        ),
        (
            1u16..10,
            1u16..9,
            any::<bool>(),
            any::<bool>(),
            any::<bool>(),
            1u16..=3,
        ),
    )
        .prop_map(
            |((dims, blobs, seed, threshold), view, (pes, width, ftb, shade, skip, lanes))| Case {
                dims,
                blobs,
                seed,
                threshold,
                view,
                pes,
                width,
                ftb,
                shade,
                skip,
                lanes,
            },
        )
}

fn check(c: &Case) -> Result<(), TestCaseError> {
    let vol = sparse(c.dims, c.blobs, c.seed);
    let (side, dist, look, fov) = c.view;
    let (eye, at) = eye_and_look(c.dims, side, dist, look);
    let prep = Prepared::new(&vol, &camera(eye, at, fov))
        .map_err(|e| TestCaseError::reject(e.to_string()))?;
    let base = Arch::BLOCKS.config(c.pes, c.ftb);
    let lut = lut(&base, c.threshold);
    let shade = c.shade.then(Shade::default);
    let skips = if c.skip {
        Skips::default()
    } else {
        Skips::NONE
    };
    let blocks = match frame(&base, &vol, &lut, &prep, skips, shade.as_ref()) {
        Ok(f) => f,
        // Column blocks too narrow to shade (a round-robin PE reads its
        // aprons instead) and views the model refuses: nothing to compare.
        Err(e) => return Err(TestCaseError::reject(e.to_string())),
    };
    let arch = Arch::BLOCKS;
    for arch in [
        arch.interleave(),
        arch.cyclic(c.width).overlapped(),
        arch.overlapped(),
        arch.interleave().overlapped().external(),
        // Transparent rows off the links; transparent rays out of the
        // merge and the readout; both, with the links' lanes drawn.
        arch.interleave().overlapped().sparse_links(true),
        arch.sparse_passes(true),
        arch.cyclic(c.width)
            .overlapped()
            .sparse_links(true)
            .sparse_passes(true)
            .lanes(c.lanes),
    ] {
        let cfg = arch.on(base);
        let f = frame(&cfg, &vol, &lut, &prep, skips, shade.as_ref())
            .map_err(|e| TestCaseError::fail(format!("{arch:?}: {e}")))?;
        // Skipping zero rays leaves out assignments, never an overflow or
        // an inexact one (the tent of zeros is exact).
        let mut quant = f.quant;
        prop_assert!(quant.assignments <= blocks.quant.assignments);
        if cfg.pass_skip_empty {
            quant.assignments = blocks.quant.assignments;
            for (q, b) in quant.by_format.0.iter_mut().zip(&blocks.quant.by_format.0) {
                q.assignments = b.assignments;
            }
        }
        prop_assert!(
            (
                &f.raw[..],
                &f.samples_per_slice[..],
                f.merges,
                quant,
                f.terminated_samples
            ) == results(&blocks),
            "{:?} changed a result: raw words equal {}, samples {} vs {}",
            arch,
            f.raw == blocks.raw,
            f.samples,
            blocks.samples
        );
        prop_assert_eq!(f.samples, blocks.samples);
        // Every sampling cycle is one PE's sample or its idle cycle.
        let busy: u64 = f.pes.iter().map(|p| p.busy).sum();
        prop_assert_eq!(busy, f.samples);
    }
    Ok(())
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 48, ..ProptestConfig::default() })]
    /// Every mapping gives column blocks' raw words, samples and
    /// quantisation events, at random sizes, views, PE counts, widths,
    /// orders, shading and skipping.
    #[test]
    fn mappings_compute_the_same_frame(c in cases()) {
        check(&c)?;
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 1024, ..ProptestConfig::default() })]
    /// The long run of [`mappings_compute_the_same_frame`].
    #[test]
    #[ignore]
    fn mappings_compute_the_same_frame_long(c in cases()) {
        check(&c)?;
    }
}

/// Each column has one owner; a round-robin PE owns blocks of the
/// configured width, one in every `P`, and its memory holds each block
/// with its apron, so its voxel memory is `(B + 3) / B` of what it owns
/// away from the volume's edges.
#[test]
fn round_robin_owners_and_aprons() {
    let nx = 64;
    for arch in [Arch::BLOCKS.interleave(), Arch::BLOCKS.cyclic(4)] {
        let cfg = arch.on(PipelineConfig {
            pes: 4,
            ..PipelineConfig::default()
        });
        let map = ColumnMap::of(&cfg, nx);
        let b = usize::from(arch.cyclic_width);
        for c in 0..nx {
            assert_eq!(map.owner(c), (c / b) % 4, "{arch:?} column {c}");
        }
        for k in 0..4 {
            let owned: Vec<usize> = map.owned(k).collect();
            assert_eq!(owned.len(), nx / 4);
            let held = map.held(k);
            for &c in &owned {
                let lo = c.saturating_sub(APRON_LEFT);
                let hi = (c + APRON_RIGHT).min(nx - 1);
                assert!((lo..=hi).all(|a| held.contains(&a)), "PE {k} column {c}");
            }
            // Interior blocks add the full apron; the edge blocks clip it.
            let blocks = nx / (4 * b);
            let most = blocks * (b + APRON_LEFT + APRON_RIGHT);
            assert!(held.len() <= most && held.len() + APRON_LEFT + APRON_RIGHT >= most);
        }
    }
    // Column blocks are today's: W = ceil(nx / P), the last PE the rest.
    let map = ColumnMap::of(&PipelineConfig::default(), 40);
    assert_eq!(map.width, 3);
    assert_eq!((map.owner(0), map.owner(3), map.owner(39)), (0, 1, 13));
    assert_eq!(map.held(13), vec![39]);
    assert!(map.held(14).is_empty());
}

/// A sparse volume with empty space around two blobs, 8 PEs: with
/// skipping on, the round-robin mappings spread each row's occupied rays
/// over the PEs, so their sampling stage is shorter than column blocks'
/// and nearer the ideal; the clocked path, PEs stepped in reverse, agrees
/// with the whole-slice path bit for bit and cycle for cycle (the ring's
/// wrap link included), and the rays crossing links are counted.
#[test]
fn round_robin_balances_skipped_rows() {
    let (vol, prep) = two_blobs();
    let mut sample_cycles = Vec::new();
    for arch in [
        Arch::BLOCKS,
        Arch::BLOCKS.interleave(),
        Arch::BLOCKS.cyclic(2),
    ] {
        let mapping = arch.mapping;
        let cfg = arch.config(8, false);
        let lut = lut(&cfg, 50.0);
        let on = frame(&cfg, &vol, &lut, &prep, Skips::default(), None).expect("frame");
        println!(
            "{}: cycles {} (sample {}, migrate {}), ideal {:.0}, rays sent {}, link queue {}, peak rays held {}",
            mapping.name(),
            on.cycles,
            on.stages.sample,
            on.stages.migrate,
            on.ideal_cycles,
            on.pes.iter().map(|p| p.rays_sent).sum::<u64>(),
            on.pes.iter().map(|p| p.link_queue).sum::<u64>(),
            on.pes.iter().map(|p| p.rays_held_peak).max().unwrap_or(0),
        );
        sample_cycles.push(on.stages.sample);
        let clocked = clocked_frame(&cfg, &vol, &lut, &prep, true);
        assert_eq!(signature(&clocked), signature(&on), "{}", mapping.name());
    }
    assert!(
        sample_cycles[1] < sample_cycles[0] && sample_cycles[2] < sample_cycles[0],
        "sampling cycles {sample_cycles:?}"
    );
}

/// Round-robin PEs read every gradient tap from their aprons, so they
/// shade at one column per PE, where column blocks refuse.
#[test]
fn round_robin_shades_where_blocks_are_too_narrow() {
    let vol = sparse([12, 14, 10], 2, 3);
    let prep = Prepared::new(
        &vol,
        &camera(DVec3::new(5.5, 6.5, -20.0), DVec3::new(5.5, 6.5, 4.5), 40.0),
    )
    .expect("view");
    let blocks = PipelineConfig {
        pes: 12,
        ..PipelineConfig::default()
    };
    let lut = lut(&blocks, 50.0);
    let sh = Shade::default();
    let e = frame(&blocks, &vol, &lut, &prep, Skips::NONE, Some(&sh)).unwrap_err();
    assert!(
        e.to_string().contains("at least 2 voxel columns per PE"),
        "{e}"
    );
    let interleave = Arch::BLOCKS.interleave().on(blocks);
    let f = frame(&interleave, &vol, &lut, &prep, Skips::NONE, Some(&sh)).expect("shades");
    // The same frame as 6 PEs of two-column blocks computes.
    let two = PipelineConfig { pes: 6, ..blocks };
    let g = frame(&two, &vol, &lut, &prep, Skips::NONE, Some(&sh)).expect("shades");
    assert_eq!(f.raw, g.raw);
    assert!(f.pes.iter().all(|p| p.edge_voxels == 0));
}
