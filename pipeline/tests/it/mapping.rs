//! Ownership mappings (`pipeline::mapping`), migration schedules and ray
//! buffer placements: column blocks, Cube-4's interleave and round-robin
//! blocks, migrating between slices or overlapped with sampling, with the
//! rays' buffer on chip or external, give the same raw words, samples and
//! quantisation events in both orders, shaded or not, with skipping on or
//! off (proptest); round-robin PEs hold their aprons and every column's
//! owner; the clocked path agrees with the whole-slice path cycle for
//! cycle under a ring; and on a sparse view the round-robin mappings
//! shorten the sampling stage that column blocks leave idle.
//!
//! `cargo test --release -p pipeline --test it -- mapping::`

use glam::DVec3;
use golden::camera::Camera;
use golden::methods::Method;
use golden::render::Prepared;
use golden::shading::Shade;
use golden::skip::Skips;
use golden::tf::Lut;
use golden::volume::Volume;
use pipeline::array::{Array, Frame, FrameRun, Voxels};
use pipeline::config::{Mapping, Migration, Order, PipelineConfig, RayBuffer};
use pipeline::mapping::{ColumnMap, APRON_LEFT, APRON_RIGHT};
use proptest::prelude::*;
use waves::Tracer;

use crate::chip::signature;
use crate::scenes::{eye_and_look, sparse, tf};

fn lut(cfg: &PipelineConfig, threshold: f64) -> Lut {
    let t = tf(&[
        (0.0, [0.0; 4]),
        (threshold, [0.2, 0.4, 0.9, 0.0]),
        (threshold + 50.0, [1.0, 0.7, 0.3, 0.6]),
        (255.0, [1.0, 1.0, 1.0, 0.95]),
    ]);
    Lut::for_bits(&t, cfg.table_entries as usize, 8)
}

fn camera(eye: DVec3, look: DVec3, fov: f64) -> Camera {
    let f = (look - eye).normalize();
    let up = if f.y.abs() > 0.9 { DVec3::Z } else { DVec3::Y };
    Camera::new(eye, look, up, fov, 32, 28).expect("camera")
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
        .shading(shade)
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

/// The frame of `cfg` with skipping on and the sampling stage clocked cycle
/// by cycle, PEs stepped in reverse when `reversed`: what the whole-slice
/// path must agree with.
fn clocked_frame(
    cfg: &PipelineConfig,
    vol: &Volume,
    lut: &Lut,
    prep: &Prepared,
    reversed: bool,
) -> Frame {
    let layout = Method::Er.layout(&prep.view).expect("layout");
    let mm = golden::occupancy::MinMax::new(vol, usize::from(cfg.occupancy_block)).expect("blocks");
    let dp = pipeline::datapath::Datapath::new(
        *cfg,
        pipeline::tables::Tables::new(cfg, lut).expect("tables"),
    );
    let (mask, counts) = pipeline::skip::plan_mask(&dp, &mm, 8, prep, &layout, Skips::default());
    let mut a = Array::new(cfg, vol, lut, &prep.view, Tracer::disabled()).expect("array");
    a.set_skipping(mask, counts, &prep.view);
    a.set_clocked(true);
    if reversed {
        a.set_step_order((0..usize::from(cfg.pes)).rev().collect());
    }
    a.run(&prep.view).expect("clocked frame")
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
    let base = PipelineConfig {
        pes: c.pes,
        order: if c.ftb {
            Order::FrontToBack
        } else {
            Order::BackToFront
        },
        terminate: if c.ftb { 0.9 } else { 1.0 },
        occupancy_block: 4,
        ..PipelineConfig::default()
    };
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
    for ((mapping, width, migration, ray_buffer), sparse) in [
        (
            Mapping::Interleave,
            1,
            Migration::BetweenSlices,
            RayBuffer::OnChip,
        ),
        (
            Mapping::Cyclic,
            c.width,
            Migration::Overlapped,
            RayBuffer::OnChip,
        ),
        (Mapping::Blocks, 1, Migration::Overlapped, RayBuffer::OnChip),
        (
            Mapping::Interleave,
            1,
            Migration::Overlapped,
            RayBuffer::External,
        ),
        (
            Mapping::Interleave,
            1,
            Migration::Overlapped,
            RayBuffer::OnChip,
        ),
        (
            Mapping::Blocks,
            1,
            Migration::BetweenSlices,
            RayBuffer::OnChip,
        ),
        (
            Mapping::Cyclic,
            c.width,
            Migration::Overlapped,
            RayBuffer::OnChip,
        ),
    ]
    .into_iter()
    .enumerate()
    .map(|(i, (m, w, mi, rb))| ((m, w, mi, rb), i))
    {
        let cfg = PipelineConfig {
            mapping,
            cyclic_width: width,
            migration,
            ray_buffer,
            // Variant 4 leaves transparent rows off the links; 5 skips
            // transparent rays in the merge and the readout; 6 does both
            // with the links' lanes drawn.
            link_skip_empty: sparse == 4 || sparse == 6,
            pass_skip_empty: sparse >= 5,
            link_lanes: if sparse == 6 { c.lanes } else { 1 },
            ..base
        };
        let f = frame(&cfg, &vol, &lut, &prep, skips, shade.as_ref())
            .map_err(|e| TestCaseError::fail(format!("{}: {e}", mapping.name())))?;
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
            "{} (width {}, {}, {}) changed a result: raw words equal {}, samples {} vs {}",
            mapping.name(),
            width,
            migration.name(),
            ray_buffer.name(),
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
    for (mapping, width) in [(Mapping::Interleave, 1u16), (Mapping::Cyclic, 4)] {
        let cfg = PipelineConfig {
            mapping,
            cyclic_width: width,
            pes: 4,
            ..PipelineConfig::default()
        };
        let map = ColumnMap::of(&cfg, nx);
        let b = usize::from(width);
        for c in 0..nx {
            assert_eq!(map.owner(c), (c / b) % 4, "{} column {c}", mapping.name());
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
    for (mapping, width) in [
        (Mapping::Blocks, 4),
        (Mapping::Interleave, 1),
        (Mapping::Cyclic, 2),
    ] {
        let cfg = PipelineConfig {
            mapping,
            cyclic_width: width,
            pes: 8,
            occupancy_block: 4,
            ..PipelineConfig::default()
        };
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
    let interleave = PipelineConfig {
        mapping: Mapping::Interleave,
        ..blocks
    };
    let f = frame(&interleave, &vol, &lut, &prep, Skips::NONE, Some(&sh)).expect("shades");
    // The same frame as 6 PEs of two-column blocks computes.
    let two = PipelineConfig { pes: 6, ..blocks };
    let g = frame(&two, &vol, &lut, &prep, Skips::NONE, Some(&sh)).expect("shades");
    assert_eq!(f.raw, g.raw);
    assert!(f.pes.iter().all(|p| p.edge_voxels == 0));
}

/// The rays' buffer in external memory changes cycles, never bits: the
/// raw words equal the on-chip frame's under every mapping, no ray crosses
/// a link (the controller reassigns them), the channel moves each sampled
/// ray in and out once per sample, rows wait for a slow channel (memory
/// cycles) and less for a faster one, and the clocked path agrees cycle
/// for cycle.
#[test]
fn external_ray_buffer_changes_cycles_not_bits() {
    let vol = sparse([40, 36, 30], 2, 11);
    let prep = Prepared::new(
        &vol,
        &camera(
            DVec3::new(19.5, 17.5, -24.0),
            DVec3::new(19.5, 17.5, 14.5),
            60.0,
        ),
    )
    .expect("view");
    for order in [Order::BackToFront, Order::FrontToBack] {
        let on_chip = PipelineConfig {
            pes: 6,
            order,
            occupancy_block: 4,
            ..PipelineConfig::default()
        };
        let lut = lut(&on_chip, 50.0);
        let reference = frame(&on_chip, &vol, &lut, &prep, Skips::default(), None).expect("frame");
        let mut memory = Vec::new();
        for (mapping, bandwidth) in [
            (Mapping::Blocks, 8),
            (Mapping::Blocks, 512),
            (Mapping::Interleave, 8),
        ] {
            let cfg = PipelineConfig {
                mapping,
                ray_buffer: RayBuffer::External,
                ray_buffer_bandwidth: bandwidth,
                ray_buffer_latency: 20,
                ..on_chip
            };
            let f = frame(&cfg, &vol, &lut, &prep, Skips::default(), None).expect("frame");
            assert_eq!(
                f.raw,
                reference.raw,
                "{} at {bandwidth} B/cycle",
                mapping.name()
            );
            assert_eq!(f.stages.migrate, 0);
            assert!(f.pes.iter().all(|p| p.rays_sent == 0));
            let rb = f.ray_buffer.expect("external buffer stats");
            let per_ray = pipeline::stages::raybuf::ray_bytes(&cfg);
            assert_eq!(rb.ray_bytes, per_ray);
            // Every sample reads and writes its ray; the passes add theirs.
            assert!(rb.read_bytes >= f.samples * per_ray);
            assert!(rb.written_bytes >= f.samples * per_ray);
            memory.push(f.stages.memory);
            let clocked = clocked_frame(&cfg, &vol, &lut, &prep, false);
            assert_eq!(signature(&clocked), signature(&f), "{}", mapping.name());
        }
        println!("{}: memory cycles {memory:?}", order.name());
        assert!(memory[0] > 0 && memory[1] < memory[0], "{memory:?}");
    }
}

/// Overlapped migration moves the rays while slices sample: no slice
/// waits in a migration stage of its own (only the passes' migrations
/// remain), rows wait only for their own rays, the frame is shorter than
/// with migration between slices, and the clocked path agrees with the
/// whole-slice path.
#[test]
fn overlapped_migration_hides_link_time() {
    let (vol, prep) = two_blobs();
    for mapping in [Mapping::Blocks, Mapping::Interleave] {
        let between = PipelineConfig {
            mapping,
            pes: 8,
            occupancy_block: 4,
            ..PipelineConfig::default()
        };
        let overlapped = PipelineConfig {
            migration: Migration::Overlapped,
            ..between
        };
        let lut = lut(&between, 50.0);
        let b = frame(&between, &vol, &lut, &prep, Skips::default(), None).expect("frame");
        let o = frame(&overlapped, &vol, &lut, &prep, Skips::default(), None).expect("frame");
        println!(
            "{}: between slices {} cycles (migrate {}), overlapped {} (migrate {}, stall {})",
            mapping.name(),
            b.cycles,
            b.stages.migrate,
            o.cycles,
            o.stages.migrate,
            o.stages.stall
        );
        assert_eq!(o.raw, b.raw);
        assert!(o.cycles < b.cycles, "{} vs {}", o.cycles, b.cycles);
        assert!(o.stages.migrate < b.stages.migrate);
        let sent = |f: &Frame| f.pes.iter().map(|p| p.rays_sent).sum::<u64>();
        assert_eq!(sent(&o), sent(&b), "the same rays cross the links");
        let clocked = clocked_frame(&overlapped, &vol, &lut, &prep, true);
        assert_eq!(signature(&clocked), signature(&o), "{}", mapping.name());
    }
}

/// Two blobs in empty space, seen from in front at 70 degrees: most rays
/// stay transparent for most of the frame.
fn two_blobs() -> (Volume, Prepared) {
    let vol = sparse([48, 40, 44], 2, 7);
    let prep = Prepared::new(
        &vol,
        &camera(
            DVec3::new(23.5, 19.5, -30.0),
            DVec3::new(23.5, 19.5, 21.5),
            70.0,
        ),
    )
    .expect("view");
    (vol, prep)
}

/// Leaving transparent rows off the links changes no bit and no sample,
/// sends fewer rays and shortens the frame where most rays are still
/// transparent; the clocked path agrees.
#[test]
fn transparent_rows_stay_off_the_links() {
    let (vol, prep) = two_blobs();
    for order in [Order::BackToFront, Order::FrontToBack] {
        let dense = PipelineConfig {
            mapping: Mapping::Interleave,
            migration: Migration::Overlapped,
            order,
            pes: 8,
            occupancy_block: 4,
            ..PipelineConfig::default()
        };
        let sparse_cfg = PipelineConfig {
            link_skip_empty: true,
            ..dense
        };
        let lut = lut(&dense, 50.0);
        let d = frame(&dense, &vol, &lut, &prep, Skips::default(), None).expect("frame");
        let s = frame(&sparse_cfg, &vol, &lut, &prep, Skips::default(), None).expect("frame");
        let sent = |f: &Frame| f.pes.iter().map(|p| p.rays_sent).sum::<u64>();
        println!(
            "{}: rays sent {} -> {}, cycles {} -> {}",
            order.name(),
            sent(&d),
            sent(&s),
            d.cycles,
            s.cycles
        );
        assert_eq!(s.raw, d.raw);
        assert_eq!(s.samples_per_slice, d.samples_per_slice);
        assert!(sent(&s) * 2 < sent(&d), "{} vs {}", sent(&s), sent(&d));
        assert!(s.cycles < d.cycles);
        let clocked = clocked_frame(&sparse_cfg, &vol, &lut, &prep, false);
        assert_eq!(signature(&clocked), signature(&s));
    }
}

/// Skipping transparent rays in the merge, the split, the fold and the
/// readout changes no raw word, sample or rounding event and shortens
/// those stages on a sparse view; a second lane on the
/// links sends the same rays in fewer stall and migration cycles. The
/// clocked path agrees with the whole-slice path under both.
#[test]
fn transparent_rays_skip_the_merge_and_the_readout() {
    let (vol, prep) = two_blobs();
    for order in [Order::BackToFront, Order::FrontToBack] {
        let dense = PipelineConfig {
            mapping: Mapping::Interleave,
            migration: Migration::Overlapped,
            link_skip_empty: true,
            order,
            pes: 8,
            occupancy_block: 4,
            ..PipelineConfig::default()
        };
        let lut = lut(&dense, 50.0);
        let d = frame(&dense, &vol, &lut, &prep, Skips::default(), None).expect("frame");
        let cfg = PipelineConfig {
            pass_skip_empty: true,
            ..dense
        };
        let s = frame(&cfg, &vol, &lut, &prep, Skips::default(), None).expect("frame");
        println!(
            "{}: merge {} -> {}, split {} -> {}, fold {} -> {}, readout {} -> {}, cycles {} -> {}",
            order.name(),
            d.stages.merge,
            s.stages.merge,
            d.stages.split,
            s.stages.split,
            d.stages.fold,
            s.stages.fold,
            d.stages.readout,
            s.stages.readout,
            d.cycles,
            s.cycles
        );
        assert_eq!(s.raw, d.raw);
        assert_eq!(s.samples_per_slice, d.samples_per_slice);
        assert_eq!(
            (s.quant.overflows, s.quant.inexact),
            (d.quant.overflows, d.quant.inexact)
        );
        assert!(s.quant.assignments <= d.quant.assignments);
        assert!(s.stages.readout * 2 < d.stages.readout);
        assert!(d.merges > 0);
        if order == Order::BackToFront {
            assert!(s.stages.merge * 2 < d.stages.merge);
        } else {
            assert!(s.stages.split * 2 < d.stages.split);
            assert!(s.stages.fold * 2 < d.stages.fold);
        }
        assert_eq!(s.stages.sample, d.stages.sample);
        let clocked = clocked_frame(&cfg, &vol, &lut, &prep, true);
        assert_eq!(signature(&clocked), signature(&s));

        // With the rays in DDR the sparse merge reads only the non-zero
        // parents and writes only the children it computes.
        let ext = PipelineConfig {
            ray_buffer: RayBuffer::External,
            ..dense
        };
        let (de, se) = (
            frame(&ext, &vol, &lut, &prep, Skips::default(), None).expect("frame"),
            frame(
                &PipelineConfig {
                    pass_skip_empty: true,
                    ..ext
                },
                &vol,
                &lut,
                &prep,
                Skips::default(),
                None,
            )
            .expect("frame"),
        );
        assert_eq!(se.raw, de.raw);
        let (dt, st) = (de.ray_buffer.expect("stats"), se.ray_buffer.expect("stats"));
        assert!(st.read_bytes < dt.read_bytes && st.written_bytes < dt.written_bytes);

        let two = PipelineConfig {
            link_lanes: 2,
            link_skip_empty: false,
            ..cfg
        };
        let one = PipelineConfig {
            link_skip_empty: false,
            ..cfg
        };
        let a = frame(&one, &vol, &lut, &prep, Skips::default(), None).expect("frame");
        let b = frame(&two, &vol, &lut, &prep, Skips::default(), None).expect("frame");
        let sent = |f: &Frame| f.pes.iter().map(|p| p.rays_sent).sum::<u64>();
        let waited = |f: &Frame| f.stages.stall + f.stages.migrate;
        println!(
            "{}: lanes 1 -> 2: stall + migrate {} -> {}, rays sent {} -> {}",
            order.name(),
            waited(&a),
            waited(&b),
            sent(&a),
            sent(&b)
        );
        assert_eq!(b.raw, a.raw);
        assert_eq!(sent(&b), sent(&a));
        assert!(waited(&b) < waited(&a), "{} vs {}", waited(&b), waited(&a));
        let clocked = clocked_frame(&two, &vol, &lut, &prep, false);
        assert_eq!(signature(&clocked), signature(&b));
    }
}
