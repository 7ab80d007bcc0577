//! The emitted readout stage (`pipeline::hw::readout_rtl`: each PE's
//! compositing buffer and column map as RAMs, the readout's cursor as a
//! state machine, the array of P PEs with their host ports) against the
//! model, clock for clock: each PE's buffer and map loaded as the model
//! held them at `BeginReadout`, then every PE's host port and `done` line
//! compared on every readout clock, and the baseplane the host assembles
//! from the RTL's stream compared word for word with the frame's raw
//! words. Both orders, `pass_skip_empty` on and off, the block, interleave
//! (overlapped, two lanes) and cyclic mappings, in Verilator and Icarus; a
//! cursor that turns to the next column one row early is caught. The
//! modules lint clean and synthesize (generic, iCE40, Xilinx) without a
//! latch. Without the tools the tests print one line and skip
//! (`ERCUBE_REQUIRE_TOOLS=1` makes that a failure).
//!
//! `cargo test --release -p pipeline --test it -- readout_rtl::`

use std::path::PathBuf;
use std::sync::{Arc, Mutex};

use pipeline::config::{Mapping, Migration, Order, PipelineConfig};
use pipeline::cosim::build::Simulator;
use pipeline::cosim::readout::{simulate, ReadoutRecord, StageRun};
use pipeline::cost::inventory::Geometry;
use pipeline::hw::readout_rtl::{emit, ReadoutRtl, ReadoutShape, PE_MODULE};
use pipeline::FrameRun;

use crate::chip::{subject, view_from};
use crate::tools::have;

/// A frame's readout as the model ran it, and the emitted stage for it.
struct Readout {
    rtl: ReadoutRtl,
    rec: ReadoutRecord,
    raw: Vec<[i64; 4]>,
    cycles: u64,
    readout_cycles: u64,
}

fn frame(cfg: &PipelineConfig, scene: &str, eye: [f64; 3], size: u32) -> Readout {
    let s = subject(scene);
    let prep = view_from(&s.vol, eye, size);
    let rec = Arc::new(Mutex::new(ReadoutRecord::default()));
    let f = FrameRun::new(cfg, &s.lut, &s.vol, &prep.view)
        .capture(rec.clone())
        .run()
        .unwrap();
    let rtl = emit(&ReadoutShape::for_view(cfg, &prep.view).unwrap());
    let rec = rec.lock().unwrap().clone();
    Readout {
        rtl,
        rec,
        raw: f.raw.clone(),
        cycles: f.cycles,
        readout_cycles: f.stages.readout,
    }
}

fn cache() -> PathBuf {
    PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("readout-cosim")
}

fn run(r: &Readout, pe: &str, sim: Simulator) -> StageRun {
    let dir = tempfile::tempdir().unwrap();
    let start = r.rec.start.as_ref().expect("the readout was captured");
    simulate(
        &r.rtl,
        pe,
        start,
        &r.rec.ticks,
        &r.raw,
        sim,
        &cache(),
        dir.path(),
        false,
    )
    .unwrap()
}

/// 0 mismatches, every model clock simulated, every raw word compared
/// and equal, and at least one word streamed.
fn assert_matches(r: &Readout, s: &StageRun, what: &str) {
    let p = s.problems();
    assert!(p.is_empty(), "{what}: {p:?}");
    assert_eq!(s.outcome.ticks, r.readout_cycles, "{what}");
    assert_eq!(r.rec.ticks.len() as u64, r.readout_cycles, "{what}");
    assert_eq!(s.raw.0, r.raw.len() as u64, "{what}");
    assert_eq!(s.raw.1, 0, "{what}");
    let nonzero = r.raw.iter().filter(|w| **w != [0; 4]).count() as u64;
    assert!(nonzero > 0, "{what}: an empty frame checks nothing");
    // Dense, every held ray is streamed; sparse, exactly the non-zero
    // ones (a ray held by two PEs counts twice).
    assert!(s.outcome.words() >= nonzero, "{what}");
    assert!(r.cycles > r.readout_cycles, "{what}");
}

fn cfg(pes: u16, order: Order, sparse: bool) -> PipelineConfig {
    PipelineConfig {
        pes,
        order,
        pass_skip_empty: sparse,
        ..PipelineConfig::default()
    }
}

/// Verilator (one build): both orders with zero rays skipped, under the
/// block mapping, on a sphere (most rays zero).
#[test]
fn readout_matches_the_model_in_verilator() {
    if !have("verilator", "verilator", "the readout cosim in Verilator") {
        return;
    }
    for order in [Order::BackToFront, Order::FrontToBack] {
        let r = frame(&cfg(3, order, true), "sphere:24", [16.0, 10.0, -36.0], 24);
        let s = run(&r, &r.rtl.pe, Simulator::Verilator);
        assert_matches(&r, &s, &format!("{order:?} sparse"));
        assert!(
            s.outcome.words() * 2 < s.raw.0,
            "sparse: zero rays left off"
        );
    }
}

/// Icarus: every ray streamed back to front (two scenes) and front to back
/// on one PE; zero rays skipped under the interleave with the overlapped
/// migration and two lanes (front to back) and under the cyclic mapping
/// (back to front).
#[test]
fn readout_matches_the_model_in_icarus() {
    if !have("iverilog", "iverilog", "the readout cosim in Icarus") {
        return;
    }
    let c = cfg(3, Order::BackToFront, false);
    for (scene, eye) in [
        ("ml:24", [16.0, 10.0, -36.0]),
        ("sphere:24", [20.0, 20.0, -30.0]),
    ] {
        let r = frame(&c, scene, eye, 24);
        let s = run(&r, &r.rtl.pe, Simulator::Icarus);
        assert_matches(&r, &s, &format!("btf dense {scene} {eye:?}"));
        assert_eq!(s.outcome.words(), s.raw.0, "dense: one word a ray");
    }
    let r = frame(
        &cfg(1, Order::FrontToBack, false),
        "ml:24",
        [12.0, -30.0, 12.0],
        16,
    );
    let s = run(&r, &r.rtl.pe, Simulator::Icarus);
    assert_matches(&r, &s, "ftb dense one PE");
    let c = PipelineConfig {
        mapping: Mapping::Interleave,
        migration: Migration::Overlapped,
        link_lanes: 2,
        ..cfg(4, Order::FrontToBack, true)
    };
    let r = frame(&c, "sphere:24", [16.0, 10.0, -36.0], 24);
    let s = run(&r, &r.rtl.pe, Simulator::Icarus);
    assert_matches(&r, &s, "ftb sparse interleave");
    assert!(
        s.outcome.words() * 2 < s.raw.0,
        "sparse: zero rays left off"
    );
    let c = PipelineConfig {
        mapping: Mapping::Cyclic,
        cyclic_width: 4,
        ..cfg(3, Order::BackToFront, true)
    };
    let r = frame(&c, "sphere:24", [8.0, 14.0, -30.0], 20);
    let s = run(&r, &r.rtl.pe, Simulator::Icarus);
    assert_matches(&r, &s, "btf sparse cyclic");
    assert!(
        s.outcome.words() * 2 < s.raw.0,
        "sparse: zero rays left off"
    );
}

/// The oblique frame whose PE 2 held 20 columns against the former 17
/// slots fits the memories sized for its view.
#[test]
fn an_oblique_frame_fits_the_memories_sized_for_its_view() {
    let r = frame(
        &cfg(3, Order::BackToFront, false),
        "ml:24",
        [30.0, 20.0, -40.0],
        24,
    );
    let start = r.rec.start.as_ref().unwrap();
    let counts = pipeline::cosim::readout::counts(&r.rtl.shape, start).expect("fits");
    assert_eq!(counts, [(17, 49), (16, 49), (20, 49)]);
}

/// The state machine stepping two rows where it should step one (the
/// emitted `next_row` off by one) is reported at its first clock, PE and
/// signal, and the baseplane differs.
#[test]
fn a_state_machine_that_skips_a_row_is_caught() {
    if !have("iverilog", "iverilog", "the readout mutation test") {
        return;
    }
    let r = frame(
        &cfg(2, Order::BackToFront, false),
        "ml:24",
        [12.0, 12.0, -40.0],
        16,
    );
    let good = "wire [RB:0] next_row = row_now + BITS'd1;";
    let rb = r.rtl.shape.row_bits();
    let good = good
        .replace("RB", &(rb - 1).to_string())
        .replace("BITS", &rb.to_string());
    assert!(r.rtl.pe.contains(&good), "{good}");
    let bad = r.rtl.pe.replace(&good, &good.replace("'d1;", "'d2;"));
    let s = run(&r, &bad, Simulator::Icarus);
    let m = s.outcome.first.clone().expect("the mutation is caught");
    let start = r.rec.start.as_ref().unwrap();
    let ncols = start.pes[m.pe].mx.len() as u64;
    // Row 0 reads in clocks 2 ..= ncols + 1 and the last of them reads
    // row 2's valid word in place of row 1's: row 2's first ray is read
    // next and on the host port the clock after.
    assert_eq!(m.cycle, start.cycle + ncols + 3, "{m}");
    assert_eq!(m.signal, "host_row", "{m}");
    assert_eq!((m.model.as_str(), m.rtl.as_str()), ("1", "2"), "{m}");
    assert!(s.raw.1 > 0, "the baseplane differs");
    let p = s.problems();
    assert!(
        p[0].contains(&format!("cycle {}, PE {}, host_row", m.cycle, m.pe)),
        "{p:?}"
    );
}

/// `verilator --lint-only -Wall` and `iverilog -Wall` print nothing on
/// the PE module and the array (their waivers named in the file); yosys
/// `synth -top`, `synth_ice40` and `synth_xilinx` of the PE module finish
/// without error and leave no latch.
#[test]
fn readout_modules_lint_and_synthesize_without_latches() {
    let geo = Geometry::new([16, 16, 16], 4);
    let rtl = emit(&ReadoutShape::new(&cfg(4, Order::BackToFront, true), &geo).unwrap());
    let dir = tempfile::tempdir().unwrap();
    let pe = dir.path().join(format!("{PE_MODULE}.v"));
    let array = dir.path().join("ercube_readout_array.v");
    std::fs::write(&pe, &rtl.pe).unwrap();
    std::fs::write(&array, &rtl.array).unwrap();
    let quiet = |prog: &str, args: &[&str]| {
        crate::tools::assert_quiet(prog, args, &[&pe, &array], "the readout modules")
    };
    if have("verilator", "verilator", "the readout lint") {
        quiet("verilator", &["--lint-only", "-Wall"]);
    }
    if have("iverilog", "iverilog", "the readout compile") {
        quiet("iverilog", &["-g2005", "-Wall", "-o", "/dev/null"]);
    }
    if !have("yosys", "yosys", "the readout synthesis") {
        return;
    }
    for flow in [
        format!("synth -top {PE_MODULE}"),
        format!("synth_ice40 -top {PE_MODULE}"),
        format!("synth_xilinx -top {PE_MODULE}"),
    ] {
        let script = format!(
            "read_verilog {}; {flow}; select -assert-none t:$dlatch t:$adlatch t:$dlatchsr t:$_DLATCH* t:LD* t:SB_LATCH*",
            pe.display()
        );
        let out = std::process::Command::new("yosys")
            .args(["-q", "-p", &script])
            .output()
            .expect("yosys runs");
        assert!(
            out.status.success(),
            "yosys {flow}: {}",
            String::from_utf8_lossy(&out.stderr)
        );
    }
}
