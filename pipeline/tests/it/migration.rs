//! How rays move and where they live: migrating overlapped with sampling,
//! the rays' buffer in external memory, transparent rows off the links,
//! transparent rays out of the passes and the readout, and more lanes on
//! the links change cycles, never a raw word, sample or rounding event
//! (beyond the assignments a skipped zero ray leaves out), and the clocked
//! path agrees with the whole-slice path under each. The proptest that
//! every architecture computes column blocks' frame is `mapping`'s.
//!
//! `cargo test --release -p pipeline --test it -- migration::`

use glam::DVec3;
use golden::render::Prepared;
use golden::skip::Skips;
use pipeline::array::Frame;
use pipeline::config::{Order, PipelineConfig};

use crate::chip::signature;
use crate::scenes::sparse;
use crate::support::{camera, clocked as clocked_frame, frame, lut, two_blobs, Arch};

/// The architecture tests' base configuration at `order` without early
/// termination: 8 PEs, occupancy blocks of 4.
fn base(order: Order) -> PipelineConfig {
    PipelineConfig {
        order,
        pes: 8,
        occupancy_block: 4,
        ..PipelineConfig::default()
    }
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
    let cam = camera(
        DVec3::new(19.5, 17.5, -24.0),
        DVec3::new(19.5, 17.5, 14.5),
        60.0,
        32,
        28,
    )
    .expect("camera");
    let prep = Prepared::new(&vol, &cam).expect("view");
    for order in [Order::BackToFront, Order::FrontToBack] {
        let on_chip = PipelineConfig {
            pes: 6,
            ..base(order)
        };
        let lut = lut(&on_chip, 50.0);
        let reference = frame(&on_chip, &vol, &lut, &prep, Skips::default()).expect("frame");
        let mut memory = Vec::new();
        for (arch, bandwidth) in [
            (Arch::BLOCKS, 8),
            (Arch::BLOCKS, 512),
            (Arch::BLOCKS.interleave(), 8),
        ] {
            let mapping = arch.mapping;
            let cfg = PipelineConfig {
                ray_buffer_bandwidth: bandwidth,
                ray_buffer_latency: 20,
                ..arch.external().on(on_chip)
            };
            let f = frame(&cfg, &vol, &lut, &prep, Skips::default()).expect("frame");
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
    for arch in [Arch::BLOCKS, Arch::BLOCKS.interleave()] {
        let mapping = arch.mapping;
        let between = arch.config(8, false);
        let overlapped = arch.overlapped().config(8, false);
        let lut = lut(&between, 50.0);
        let b = frame(&between, &vol, &lut, &prep, Skips::default()).expect("frame");
        let o = frame(&overlapped, &vol, &lut, &prep, Skips::default()).expect("frame");
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

/// Leaving transparent rows off the links changes no bit and no sample,
/// sends fewer rays and shortens the frame where most rays are still
/// transparent; the clocked path agrees.
#[test]
fn transparent_rows_stay_off_the_links() {
    let (vol, prep) = two_blobs();
    for order in [Order::BackToFront, Order::FrontToBack] {
        let arch = Arch::BLOCKS.interleave().overlapped();
        let dense = arch.on(base(order));
        let sparse_cfg = arch.sparse_links(true).on(base(order));
        let lut = lut(&dense, 50.0);
        let d = frame(&dense, &vol, &lut, &prep, Skips::default()).expect("frame");
        let s = frame(&sparse_cfg, &vol, &lut, &prep, Skips::default()).expect("frame");
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
        let arch = Arch::BLOCKS.interleave().overlapped().sparse_links(true);
        let dense = arch.on(base(order));
        let lut = lut(&dense, 50.0);
        let d = frame(&dense, &vol, &lut, &prep, Skips::default()).expect("frame");
        let cfg = arch.sparse_passes(true).on(base(order));
        let s = frame(&cfg, &vol, &lut, &prep, Skips::default()).expect("frame");
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
        let ext = arch.external();
        let (de, se) = (
            frame(&ext.on(base(order)), &vol, &lut, &prep, Skips::default()).expect("frame"),
            frame(
                &ext.sparse_passes(true).on(base(order)),
                &vol,
                &lut,
                &prep,
                Skips::default(),
            )
            .expect("frame"),
        );
        assert_eq!(se.raw, de.raw);
        let (dt, st) = (de.ray_buffer.expect("stats"), se.ray_buffer.expect("stats"));
        assert!(st.read_bytes < dt.read_bytes && st.written_bytes < dt.written_bytes);

        let one = arch.sparse_links(false).sparse_passes(true);
        let two = one.lanes(2).on(base(order));
        let one = one.on(base(order));
        let a = frame(&one, &vol, &lut, &prep, Skips::default()).expect("frame");
        let b = frame(&two, &vol, &lut, &prep, Skips::default()).expect("frame");
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
