//! The link FIFOs' bound (`link_fifo_depth`): a PE's link FIFO never holds
//! more rows than its declared depth, and the depth changes no raw word,
//! counter or cycle, because the PE feeds the FIFO from its compositing
//! buffer ahead of each send (`pipeline::stages::migrate::LinkQueue`).
//! Checked on clocked frames (where the FIFOs step) against the untraced
//! frame at the default depth, over scenes, views, PE counts, both orders
//! and every architecture (proptest), and on a dense view where the
//! shallowest FIFO fills and its feed waits.
//!
//! `cargo test --release -p pipeline --test it -- links::`

use glam::DVec3;
use golden::camera::Camera;
use golden::render::Prepared;
use golden::skip::Skips;
use golden::tf::Lut;
use golden::volume::Volume;
use pipeline::array::Frame;
use pipeline::config::{PipelineConfig, RayBuffer};
use proptest::prelude::*;

use crate::chip::signature;
use crate::scenes::{eye_and_look, sparse};
use crate::support::{frame, lut, Arch};

fn camera(eye: DVec3, look: DVec3, fov: f64, size: u32) -> Camera {
    crate::support::camera(eye, look, fov, size, size).expect("camera")
}

/// The frame of `cfg`, skipping on; `clocked` ticks every stage cycle by
/// cycle (the migrations step the link FIFOs).
fn run(cfg: &PipelineConfig, vol: &Volume, lut: &Lut, prep: &Prepared, clocked: bool) -> Frame {
    if clocked {
        crate::support::clocked(cfg, vol, lut, prep, false)
    } else {
        frame(cfg, vol, lut, prep, Skips::default()).expect("frame")
    }
}

/// The architectures: column blocks; the interleave, sparse links; cyclic
/// blocks of 3, overlapped, sparse passes; the interleave, overlapped,
/// sparse links and passes, three lanes; column blocks, overlapped, two
/// lanes; the interleave with its rays in external memory, sparse links.
const ARCHS: [Arch; 6] = [
    Arch::BLOCKS,
    Arch::BLOCKS.interleave().sparse_links(true),
    Arch::BLOCKS.cyclic(3).overlapped().sparse_passes(true),
    Arch::BLOCKS
        .interleave()
        .overlapped()
        .sparse_links(true)
        .sparse_passes(true)
        .lanes(3),
    Arch::BLOCKS.overlapped().lanes(2),
    Arch::BLOCKS.interleave().external().sparse_links(true),
];

/// `arch`'s configuration with link FIFOs of `depth` rows.
fn config(arch: Arch, pes: u16, ftb: bool, depth: u16) -> PipelineConfig {
    PipelineConfig {
        link_fifo_depth: depth,
        ..arch.config(pes, ftb)
    }
}

/// Rays sent over the links in a frame.
fn sent(f: &Frame) -> u64 {
    f.pes.iter().map(|p| p.rays_sent).sum()
}

/// A dense view (rays half a voxel apart near the eye, columns of many
/// rows) on 2 and 9 PEs, both orders, every architecture: with one-row
/// FIFOs the clocked frame equals the untraced default-depth frame word
/// for word, counter for counter and cycle for cycle; no FIFO ever held
/// more than one row; and the bound bit wherever a front waited for its
/// write-back (its feed stalled with the FIFO full), but a FIFO deep
/// enough for every queue never stalled. With the rays in external memory
/// nothing crosses a link.
#[test]
fn one_row_fifos_change_no_word_counter_or_cycle() {
    let dims = [20, 18, 14];
    let vol = sparse(dims, 3, 7);
    let (eye, at) = eye_and_look(dims, 0, 6.0, [0.1, -0.2]);
    let prep = Prepared::new(&vol, &camera(eye, at, 80.0, 40)).expect("view");
    let (mut stalled, mut on_chip) = (0, 0);
    for pes in [2, 9] {
        for ftb in [false, true] {
            for arch in ARCHS {
                let name = format!("{arch:?}, {pes} PEs, ftb {ftb}");
                let default = config(arch, pes, ftb, 2);
                let lut = lut(&default, 40.0);
                let reference = run(&default, &vol, &lut, &prep, false);
                let shallow = run(&config(arch, pes, ftb, 1), &vol, &lut, &prep, true);
                assert_eq!(signature(&shallow), signature(&reference), "{name}");
                assert!(
                    shallow.link_fifo.peak <= 1,
                    "{name}: {:?}",
                    shallow.link_fifo
                );
                if arch.ray_buffer == RayBuffer::External {
                    assert_eq!(sent(&shallow), 0, "{name}");
                    continue;
                }
                assert!(sent(&shallow) > 0, "{name}: no ray moved");
                assert_eq!(shallow.link_fifo.peak, 1, "{name}");
                // A front that waits for its write-back with a row behind
                // it holds that row in the buffer: the feed stalls.
                let waits: u64 = shallow.pes.iter().map(|p| p.waits).sum();
                assert!(
                    waits == 0 || shallow.link_fifo.feed_stalls > 0,
                    "{name}: {waits} waits, the feed never stalled"
                );
                stalled += u32::from(shallow.link_fifo.feed_stalls > 0);
                // A deep FIFO holds more while the fronts wait, and still
                // changes nothing.
                let deep = run(&config(arch, pes, ftb, 4096), &vol, &lut, &prep, true);
                assert_eq!(signature(&deep), signature(&reference), "{name}");
                assert!(deep.link_fifo.peak >= shallow.link_fifo.peak, "{name}");
                assert_eq!(deep.link_fifo.feed_stalls, 0, "{name}");
                on_chip += 1;
            }
        }
    }
    // The bound bit in all but a frame whose rows never waited.
    assert_eq!((stalled, on_chip), (19, 20));
}

#[derive(Debug, Clone)]
struct Case {
    dims: [usize; 3],
    seed: u64,
    view: (usize, f64, [f64; 2], f64),
    pes: u16,
    ftb: bool,
    arch: usize,
    depth: u16,
}

fn cases() -> impl Strategy<Value = Case> {
    (
        (prop::array::uniform3(6usize..22), any::<u64>()),
        (
            0usize..6,
            prop_oneof![0.4..4.0f64, 4.0..40.0],
            prop::array::uniform2(-0.6..0.6f64),
            12.0..120.0f64,
        ),
        (1u16..14, any::<bool>(), 0..ARCHS.len(), 1u16..=4),
    )
        .prop_map(|((dims, seed), view, (pes, ftb, arch, depth))| Case {
            dims,
            seed,
            view,
            pes,
            ftb,
            arch,
            depth,
        })
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 40, ..ProptestConfig::default() })]

    /// Over scenes, eyes, PE counts (1 to 13), both orders and every
    /// architecture, a clocked frame with FIFOs 1 to 4 rows deep never
    /// holds more than the depth in one and equals the untraced frame at
    /// the default depth in every word, counter and cycle.
    #[test]
    fn link_fifos_never_exceed_their_depth(c in cases()) {
        let vol = sparse(c.dims, 2, c.seed);
        let (side, dist, look, fov) = c.view;
        let (eye, at) = eye_and_look(c.dims, side, dist, look);
        let prep = Prepared::new(&vol, &camera(eye, at, fov, 24))
            .map_err(|e| TestCaseError::reject(e.to_string()))?;
        let arch = ARCHS[c.arch];
        let default = config(arch, c.pes, c.ftb, 2);
        let lut = lut(&default, 50.0);
        // Views the model refuses (too few columns per PE): nothing to
        // compare.
        let reference = frame(&default, &vol, &lut, &prep, Skips::default())
            .map_err(|e| TestCaseError::reject(e.to_string()))?;
        let f = run(&config(arch, c.pes, c.ftb, c.depth), &vol, &lut, &prep, true);
        prop_assert!(u64::from(c.depth) >= f.link_fifo.peak, "{:?}", f.link_fifo);
        prop_assert_eq!(signature(&f), signature(&reference));
    }
}
