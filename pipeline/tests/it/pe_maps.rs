//! The emitted sample stage under the round-robin mappings (the
//! interleave and the cyclic mapping: several blocks a PE, each with its
//! apron, the taps all from the PE's own memory through its column
//! decoder, the rays in the slots its column map names) against the
//! model, clock for clock, as `pe_sample` checks column blocks; a control
//! that addresses a ray by its column map entry instead of its slot, and
//! a decoder read at the wrong column, are caught.
//!
//! `cargo test --release -p pipeline --test it -- pe_maps::`

use pipeline::config::{Mapping, Migration, Order, PipelineConfig};
use pipeline::cosim::build::Simulator;

use crate::pe_sample::{assert_matches, run, Shot};
use crate::tools::have;

const SHOT: Shot = ("ml:24", [16.0, 10.0, -60.0], 12);

/// The README's sparse interleave (overlapped migration, two lanes,
/// transparent rays off the links and the passes) on `pes` PEs.
fn sparse_interleave(pes: u16) -> PipelineConfig {
    PipelineConfig {
        pes,
        order: Order::BackToFront,
        mapping: Mapping::Interleave,
        migration: Migration::Overlapped,
        link_lanes: 2,
        link_skip_empty: true,
        pass_skip_empty: true,
        ..PipelineConfig::default()
    }
}

/// Icarus: the sparse interleave on 3 PEs and the cyclic mapping (blocks
/// of 2) on 3 PEs: 0 mismatches, every issue, tap and write-back
/// compared, the buffers and the readout clean; the rays a PE holds are
/// not one consecutive block (what column blocks' slots rely on).
#[test]
fn round_robin_mappings_match_the_model_in_icarus() {
    if !have("iverilog", "iverilog", "the round-robin sample stage cosim") {
        return;
    }
    let cyclic = PipelineConfig {
        pes: 3,
        order: Order::BackToFront,
        mapping: Mapping::Cyclic,
        cyclic_width: 2,
        ..PipelineConfig::default()
    };
    for (c, what) in [
        (sparse_interleave(3), "sparse interleave"),
        (cyclic, "cyclic"),
    ] {
        let r = run(&c, SHOT, None, Simulator::Icarus, None);
        assert_matches(&r, what);
        assert!(
            r.stored.0 > 4,
            "{what}: a PE holds {} voxel columns",
            r.stored.0
        );
    }
}

/// Mutations of the new addressing, each reported as a mismatch: the
/// buffer addressed by the column map entry (the ray's rank among the
/// held ones) instead of the slot migration gave it, and the right tap
/// read through the decoder at the left tap's column.
#[test]
fn a_broken_round_robin_addressing_is_caught() {
    if !have("iverilog", "iverilog", "the round-robin mutations") {
        return;
    }
    let c = sparse_interleave(3);
    let by_rank = |v: &str| {
        assert!(v.contains("pk_sl = cm_sl[idx];"));
        v.replace("pk_sl = cm_sl[idx];", "pk_sl = idx;")
    };
    let r = run(&c, SHOT, None, Simulator::Icarus, Some(&by_rank));
    assert!(r.outcome.mismatches > 0, "a rank-addressed buffer passed");
    let wrong_tap = |v: &str| {
        assert!(v.contains("wire [31:0] l1 = {1'b0, loc[c1]};"));
        v.replace(
            "wire [31:0] l1 = {1'b0, loc[c1]};",
            "wire [31:0] l1 = {1'b0, loc[c0]};",
        )
    };
    let r = run(&c, SHOT, None, Simulator::Icarus, Some(&wrong_tap));
    let first = r.outcome.first.as_ref().expect("a mismatch");
    assert!(
        first.signal.starts_with("v0") || first.signal.starts_with("v1"),
        "the first mismatch is a tap: {first}"
    );
}
