//! The array's waveforms beyond the default set: the FST holds the VCD's
//! values, the link ports show what crossed them, the signal groups
//! select, and the stage's names reach GTKWave.

use std::collections::HashMap;
use std::path::Path;

use glam::DVec3;
use golden::camera::Camera;
use golden::render::Prepared;
use pipeline::array::{Array, Frame};
use pipeline::config::PipelineConfig;
use pipeline::probes::{Stage, GROUPS};
use waves::{Trace, TraceConfig, Tracer};

use crate::chip::{check_gtkw, config, signature, subject, Subject};
use crate::scenes::up_for;

/// A close eye on `ml:24` (D = 6, so the frame merges twice).
fn merging_view(s: &Subject) -> Prepared {
    let c = (s.n as f64 - 1.0) / 2.0;
    let eye = DVec3::new(c + 1.6, c - 0.8, -6.0);
    let centre = DVec3::from_array(s.vol.center_world());
    let cam = Camera::new(eye, centre, up_for(centre - eye), 60.0, 32, 32).expect("camera");
    let prep = Prepared::new(&s.vol, &cam).expect("view");
    assert!(prep.view.regions().count() >= 2, "the view must merge");
    prep
}

fn run(cfg: &PipelineConfig, s: &Subject, prep: &Prepared, tracer: Tracer) -> Frame {
    Array::new(cfg, &s.vol, &s.lut, &prep.view, tracer)
        .and_then(|a| a.run(&prep.view))
        .unwrap_or_else(|e| panic!("run: {e}"))
}

/// Every group, VCD and FST from one run.
fn traced(dir: &Path) -> (Frame, Frame) {
    let s = subject("ml:24");
    let prep = merging_view(&s);
    let cfg = config(4);
    let tc = TraceConfig::new(dir.join("all.vcd"))
        .with_fst(dir.join("all.fst"))
        .with_groups(GROUPS.iter().map(|g| g.name));
    let on = run(&cfg, &s, &prep, Tracer::new(tc).expect("tracer"));
    let off = run(&cfg, &s, &prep, Tracer::disabled());
    (on, off)
}

/// The FST that the tracer writes beside the VCD holds, read back by
/// wellen, the same value of every signal at every cycle as the VCD.
#[test]
fn fst_holds_the_same_values_as_the_vcd() {
    let dir = tempfile::tempdir().expect("temporary directory");
    let (on, off) = traced(dir.path());
    assert_eq!(signature(&on), signature(&off), "tracing changed the frame");
    let vcd = dir.path().join("all.vcd");
    let fst = dir.path().join("all.fst");
    let mut a = wellen::simple::read(&vcd).expect("wellen reads the VCD");
    let mut b = wellen::simple::read(&fst).expect("wellen reads the FST");
    let names = |w: &wellen::simple::Waveform| -> Vec<String> {
        let h = w.hierarchy();
        h.all_vars().map(|v| h[v].full_name(h)).collect()
    };
    let (na, nb) = (names(&a), names(&b));
    assert_eq!(na, nb, "the same signals, in the same order");
    assert!(
        na.iter().any(|n| n == "top.pe_1.left.parent_valid"),
        "{na:?}"
    );
    let refs = |w: &wellen::simple::Waveform| -> Vec<_> {
        let h = w.hierarchy();
        h.all_vars().map(|v| h[v].signal_ref()).collect()
    };
    let (ra, rb) = (refs(&a), refs(&b));
    a.load_signals(&ra);
    b.load_signals(&rb);
    let (ta, tb) = (a.time_table().to_vec(), b.time_table().to_vec());
    let at = |w: &wellen::simple::Waveform, times: &[u64], r, t: u64| -> String {
        let idx = times.partition_point(|&x| x <= t);
        let sig = w.get_signal(r).expect("loaded");
        match idx.checked_sub(1).and_then(|i| sig.get_offset(i as u32)) {
            Some(off) => sig
                .get_value_at(&off, 0)
                .to_bit_string()
                .unwrap_or_default(),
            None => String::from("-"),
        }
    };
    let mut compared = 0u64;
    for c in 0..=on.cycles + 1 {
        let t = c * waves::TIME_UNITS_PER_CYCLE;
        for (i, (&x, &y)) in ra.iter().zip(&rb).enumerate() {
            let (va, vb) = (at(&a, &ta, x, t), at(&b, &tb, y, t));
            // Before the first cycle the VCD has no value and the FST its
            // initial frame, all `x`.
            if va == "-" {
                assert!(vb.chars().all(|c| c == 'x') || vb == "-", "{}: {vb}", na[i]);
                continue;
            }
            assert_eq!(va, vb, "{} at cycle {c}", na[i]);
            compared += 1;
        }
    }
    eprintln!(
        "{compared} values compared over {} cycles; VCD {} bytes, FST {} bytes",
        on.cycles,
        std::fs::metadata(&vcd).expect("vcd").len(),
        std::fs::metadata(&fst).expect("fst").len()
    );
    check_gtkw(&vcd);
    // Both dumps get a save file.
    let fst_gtkw = std::fs::read_to_string(dir.path().join("all.gtkw")).expect("gtkw");
    assert!(
        fst_gtkw.contains("all.vcd"),
        "one save file, opening the VCD"
    );
    crate::tools::vcd2fst(&vcd);
}

/// During a merge each PE drives its edge rays on its ports: the
/// neighbour's port shows `parent_valid` with the parent's index and
/// words, and those are the words the model held for that ray and row
/// (the last accumulator the ray's PE traced for it while sampling).
#[test]
fn merge_parents_cross_the_links() {
    let dir = tempfile::tempdir().expect("temporary directory");
    traced(dir.path());
    let trace = Trace::read(dir.path().join("all.vcd")).expect("VCD reads");
    let sig = |n: &str| {
        trace
            .signal(n)
            .unwrap_or_else(|| panic!("{n} is not traced"))
    };
    let stage = sig("top.ctrl.stage");
    let drive = sig("top.ctrl.drive_row");
    let drive_valid = sig("top.ctrl.drive_valid");
    let end = trace.end_time() / waves::TIME_UNITS_PER_CYCLE;
    // (mx, row) -> accumulator words, from busy sampling cycles, replayed
    // in time order so that each merge sees the latest words.
    let mut held: HashMap<(u64, u64), [u64; 4]> = HashMap::new();
    let (mut checked, mut migrating, mut edges, mut adjacent) = (0, 0, 0, 0);
    for c in 0..end {
        let Some(st) = stage.u64_at_cycle(c) else {
            continue;
        };
        for k in 0..4 {
            let pe = |n: &str| sig(&format!("top.pe_{k}.{n}")).u64_at_cycle(c);
            if st == Stage::Sample as u64 && pe("busy") == Some(1) {
                let acc = ["acc_r", "acc_g", "acc_b", "acc_a"].map(|n| pe(n).expect("acc"));
                let key = (pe("ray_mx").expect("mx"), pe("ray_row").expect("row"));
                held.insert(key, acc);
            }
            for side in ["left", "right"] {
                let port = |n: &str| pe(&format!("{side}.{n}")).expect("port signal");
                migrating += port("ray_valid");
                edges += port("edge_valid");
                if st != Stage::Merge as u64 || port("parent_valid") == 0 {
                    continue;
                }
                // The row driven now is the x pass's next cycle's.
                assert_eq!(drive_valid.u64_at_cycle(c), Some(1), "cycle {c}");
                let r = drive.u64_at_cycle(c).expect("drive row");
                let key = (port("parent_mx"), r);
                let words = ["parent_r", "parent_g", "parent_b", "parent_a"].map(port);
                if let Some(want) = held.get(&key) {
                    assert_eq!(
                        &words, want,
                        "cycle {c}: PE {k}'s {side} port, parent {key:?}"
                    );
                    checked += 1;
                }
            }
        }
        // Across each link the two edge parents are neighbours in the ray
        // grid: PE k's last held column and PE k + 1's first.
        if st == Stage::Merge as u64 {
            for k in 0..3 {
                let at = |k: usize, n: &str| {
                    sig(&format!("top.pe_{k}.{n}"))
                        .u64_at_cycle(c)
                        .expect("port signal")
                };
                if at(k, "right.parent_valid") == 1 && at(k + 1, "left.parent_valid") == 1 {
                    assert_eq!(
                        (at(k, "right.parent_mx") + 1) & 0xffff,
                        at(k + 1, "left.parent_mx"),
                        "cycle {c}: the link between PEs {k} and {}",
                        k + 1
                    );
                    adjacent += 1;
                }
            }
        }
        // A merge replaces the rays: forget the words of the region behind.
        if st == Stage::Merge as u64 && stage.u64_at_cycle(c + 1) != Some(st) {
            held.clear();
        }
    }
    eprintln!(
        "{checked} parent cycles matched; {migrating} ray and {edges} edge-voxel port cycles"
    );
    assert!(checked > 0, "no merge parent crossed a traced link");
    assert!(adjacent > 0, "no link carried parents both ways");
    assert!(migrating > 0, "no ray crossed a link");
    assert!(edges > 0, "no edge voxels crossed a link");
}

/// The default groups trace the controller, the datapath, the
/// accumulators and the link ports; `ports` alone keeps only the ports;
/// the stage's names are in the filter file the save file uses for
/// `top.ctrl.stage`.
#[test]
fn groups_select_and_stage_names_reach_gtkwave() {
    let s = subject("sphere:16");
    let prep = merging_view(&s);
    let cfg = config(2);
    let dir = tempfile::tempdir().expect("temporary directory");
    let count = |name: &str, tc: TraceConfig| -> Vec<String> {
        run(&cfg, &s, &prep, Tracer::new(tc).expect("tracer"));
        let t = Trace::read(dir.path().join(name)).expect("VCD reads");
        t.names().map(String::from).collect()
    };
    let default = count("d.vcd", TraceConfig::new(dir.path().join("d.vcd")));
    // The clock, the controller's 10 and each PE's 11 and ports.
    assert_eq!(default.len(), 1 + 10 + 2 * (11 + 2 * 16 + 7), "{default:?}");
    let ports = count(
        "p.vcd",
        TraceConfig::new(dir.path().join("p.vcd")).with_groups(["ports"]),
    );
    // Per PE two link ports of 16 and the host port's 7.
    assert_eq!(ports.len(), 1 + 2 * (2 * 16 + 7), "{ports:?}");
    assert!(ports.iter().all(|n| n == "top.clk"
        || n.contains("left.")
        || n.contains("right.")
        || n.contains("host.")));
    let regs = count(
        "r.vcd",
        TraceConfig::new(dir.path().join("r.vcd")).with_groups(["regs"]),
    );
    assert_eq!(regs.len(), 1 + 2 * 9, "{regs:?}");
    assert!(regs.iter().any(|n| n == "top.pe_1.fifo_left"), "{regs:?}");

    let filter = dir.path().join("d.stage.txt");
    let text = std::fs::read_to_string(&filter).expect("the stage filter file is written");
    for st in Stage::ALL {
        let line = format!("{:X} {}", st as u64, st.name());
        assert!(text.lines().any(|l| l == line), "{line:?} missing:\n{text}");
    }
    let gtkw = std::fs::read_to_string(dir.path().join("d.gtkw")).expect("gtkw");
    // The filter named relative to the save file beside it.
    let want = "^1 d.stage.txt\n+{stage} top.ctrl.stage[3:0]\n";
    assert!(gtkw.contains(want), "{want:?} not in\n{gtkw}");
    check_gtkw(&dir.path().join("d.vcd"));
    // Surfer's way: the VCD carries the names as an enum table on the
    // stage, which wellen (Surfer's reader) attaches to the variable.
    let w = wellen::simple::read(dir.path().join("d.vcd")).expect("wellen reads the VCD");
    let h = w.hierarchy();
    let var = h
        .all_vars()
        .find(|&v| h[v].full_name(h) == "top.ctrl.stage")
        .expect("the stage is traced");
    let (table, names) = h[var].enum_type(h).expect("the stage has an enum table");
    assert_eq!(table, "stage");
    for st in Stage::ALL {
        let bits = format!("{:04b}", st as u64);
        assert!(
            names.contains(&(bits.as_str(), st.name())),
            "{bits} -> {} missing from {names:?}",
            st.name()
        );
    }
    // GTKWave's vcd2fst accepts the attributes (it drops them: an FST,
    // ours or its, has no enum table, see docs/pipeline.md).
    crate::tools::vcd2fst(&dir.path().join("d.vcd"));

    let e = Array::new(
        &cfg,
        &s.vol,
        &s.lut,
        &prep.view,
        Tracer::new(TraceConfig::new(dir.path().join("e.vcd")).with_groups(["bogus"]))
            .expect("tracer"),
    )
    .err()
    .expect("an unknown group is an error");
    assert!(e.to_string().contains("bogus"), "{e}");
}
