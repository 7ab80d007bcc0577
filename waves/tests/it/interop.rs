//! Checks against other tools: wellen as an independent VCD (and FST)
//! parser, GTKWave's `vcd2fst`, and the names used in the `.gtkw` file.

use std::path::Path;

use waves::bitvec::prelude::*;
use waves::{ScopePath, TraceConfig, TraceInfo, Tracer};

const CYCLES: u64 = 40;
const PES: u32 = 3;

fn acc(c: u64, k: u32) -> u64 {
    (c * c * 31 + u64::from(k) * 977) & 0xffff
}
fn valid(c: u64, k: u32) -> bool {
    (c / 3 + u64::from(k)).is_multiple_of(2)
}
fn state(c: u64) -> u64 {
    (c / 4) % 6
}
/// A 70-bit bus: `c` in the low bits, bit 69 set on odd cycles.
fn bus(c: u64) -> BitVec<u64, Lsb0> {
    let mut b = BitVec::repeat(false, 70);
    b[..64].store_le(c);
    b.set(69, c % 2 == 1);
    b
}

/// Msb-first text of each probe at cycle `c`, keyed by VCD path and name.
fn expected(c: u64) -> Vec<(Vec<String>, &'static str, String)> {
    let mut v = vec![
        (vec!["top".into()], "clk", "1".to_string()),
        (
            vec!["top".into(), "ctrl".into()],
            "state",
            format!("{:03b}", state(c)),
        ),
        (
            vec!["top".into()],
            "bus",
            bus(c)
                .iter()
                .by_vals()
                .rev()
                .map(|b| if b { '1' } else { '0' })
                .collect(),
        ),
    ];
    for k in 0..PES {
        let scope = vec!["top".to_string(), format!("pe_{k}")];
        v.push((scope.clone(), "acc", format!("{:016b}", acc(c, k))));
        v.push((scope, "valid", u8::from(valid(c, k)).to_string()));
    }
    v
}

fn write_trace(path: &Path) -> TraceInfo {
    write_with(TraceConfig::new(path))
}

fn write_with(config: TraceConfig) -> TraceInfo {
    let mut t = Tracer::new(config).unwrap();
    let st = t
        .register(&ScopePath::top().child("ctrl"), "state", 3)
        .unwrap();
    let bs = t.register(&ScopePath::top(), "bus", 70).unwrap();
    let ids: Vec<_> = (0..PES)
        .map(|k| {
            (
                t.register(&ScopePath::pe(k), "acc", 16).unwrap(),
                t.register(&ScopePath::pe(k), "valid", 1).unwrap(),
            )
        })
        .collect();
    for c in 0..CYCLES {
        t.sample(c, |s| {
            s.set(st, state(c));
            s.set_bits(bs, &bus(c));
            for (k, &(a, v)) in ids.iter().enumerate() {
                s.set(a, acc(c, k as u32));
                s.set_bool(v, valid(c, k as u32));
            }
        });
    }
    t.finish().unwrap().unwrap()
}

/// Loads `file` (VCD or FST) with wellen and checks every probe at every
/// cycle against the model.
fn check_with_wellen(file: &Path) {
    let mut w = wellen::simple::read(file).unwrap();
    let h = w.hierarchy();
    let mut vars = Vec::new();
    for (path, name, _) in expected(0) {
        let var = h
            .lookup_var(&path, name.to_string())
            .unwrap_or_else(|| panic!("{path:?}.{name} missing"));
        vars.push(var);
    }
    let refs: Vec<_> = vars.iter().map(|&v| h[v].signal_ref()).collect();
    let widths: Vec<_> = vars.iter().map(|&v| h[v].length(h).unwrap()).collect();
    assert_eq!(widths, [1, 3, 70, 16, 1, 16, 1, 16, 1]);
    w.load_signals(&refs);
    let times = w.time_table().to_vec();
    for c in 0..CYCLES {
        // wellen gives the value in force at a time-table entry, so look
        // up the last entry at or before the cycle's start.
        let t = c * waves::TIME_UNITS_PER_CYCLE;
        let idx = times.partition_point(|&x| x <= t) - 1;
        for (i, (path, name, want)) in expected(c).into_iter().enumerate() {
            let sig = w.get_signal(refs[i]).unwrap();
            let off = sig.get_offset(idx as u32).unwrap();
            let got = sig.get_value_at(&off, 0).to_bit_string().unwrap();
            assert_eq!(
                got,
                want,
                "{}: {path:?}.{name} at cycle {c}",
                file.display()
            );
        }
    }
    // The clock falls half-way through each cycle.
    let clk = w.get_signal(refs[0]).unwrap();
    let half = 3 * waves::TIME_UNITS_PER_CYCLE + waves::TIME_UNITS_PER_CYCLE / 2;
    let idx = times.iter().position(|&x| x == half).unwrap();
    let off = clk.get_offset(idx as u32).unwrap();
    assert_eq!(clk.get_value_at(&off, 0).to_bit_string().unwrap(), "0");
}

#[test]
fn wellen_reads_the_vcd() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("w.vcd");
    write_trace(&path);
    check_with_wellen(&path);
}

/// One tracer writes VCD and FST from the same records: wellen reads both
/// back as the model's values (so the FST equals the VCD), the FST alone
/// too, and the FST is the smaller.
#[test]
fn fst_reads_back_as_the_vcd() {
    let dir = tempfile::tempdir().unwrap();
    let (vcd, fst) = (dir.path().join("b.vcd"), dir.path().join("b.fst"));
    let info = write_with(TraceConfig::new(&vcd).with_fst(&fst));
    assert_eq!(info.vcd_path.as_deref(), Some(vcd.as_path()));
    assert_eq!(info.fst_path.as_deref(), Some(fst.as_path()));
    check_with_wellen(&vcd);
    check_with_wellen(&fst);
    let only = dir.path().join("only.fst");
    let info = write_with(TraceConfig::new_fst(&only));
    assert!(info.vcd_path.is_none());
    assert_eq!(info.dump_path(), only.as_path());
    check_with_wellen(&only);
    let size = |p: &Path| std::fs::metadata(p).unwrap().len();
    assert!(
        size(&fst) < size(&vcd),
        "FST {} >= VCD {}",
        size(&fst),
        size(&vcd)
    );
    // No temporary file is left beside them.
    let names: Vec<_> = std::fs::read_dir(dir.path())
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    assert!(names.iter().all(|n| !n.ends_with(".tmp")), "{names:?}");
}

/// Groups select signals: with no selection the groups on by default,
/// with one exactly the named groups; ungrouped signals always.
#[test]
fn groups_select_signals() {
    use waves::Group;
    const ON: Group = Group {
        name: "on",
        default: true,
    };
    const OFF: Group = Group {
        name: "off",
        default: false,
    };
    let dir = tempfile::tempdir().unwrap();
    let traced = |config: TraceConfig| -> Vec<bool> {
        let mut t = Tracer::new(config).unwrap();
        let top = ScopePath::top();
        let ids = [
            t.register(&top, "plain", 1).unwrap(),
            t.register_in(&ON, &top, "a", 1).unwrap(),
            t.register_in(&OFF, &top, "b", 1).unwrap(),
            t.register_enum_in(&OFF, &top, "e", 2, &[(0, "idle"), (1, "busy")])
                .unwrap(),
        ];
        ids.iter().map(|id| id.is_traced()).collect()
    };
    let path = dir.path().join("g.vcd");
    assert_eq!(traced(TraceConfig::new(&path)), [true, true, false, false]);
    assert_eq!(
        traced(TraceConfig::new(&path).with_groups(["off"])),
        [true, false, true, true]
    );
    // The enumeration's names go to a filter file the save file uses.
    let mut t = Tracer::new(TraceConfig::new(&path)).unwrap();
    let e = t
        .register_enum_in(&ON, &ScopePath::top(), "e", 2, &[(0, "idle"), (3, "done")])
        .unwrap();
    t.sample(0, |s| s.set(e, 3));
    let info = t.finish().unwrap().unwrap();
    let gtkw = dir.path().join("g.gtkw");
    info.write_gtkw(&gtkw).unwrap();
    let filter = std::fs::read_to_string(dir.path().join("g.e.txt")).unwrap();
    assert!(filter.ends_with("0 idle\n3 done\n"), "{filter}");
    let text = std::fs::read_to_string(&gtkw).unwrap();
    assert!(text.contains("@2022\n^1 "), "{text}");
}

#[test]
fn gtkw_names_match_the_vcd_as_other_tools_see_it() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("g.vcd");
    let info = write_trace(&path);
    let gtkw = dir.path().join("g.gtkw");
    info.write_gtkw(&gtkw).unwrap();
    let text = std::fs::read_to_string(&gtkw).unwrap();
    // Named relative to the save file, which GTKWave resolves through
    // the `[savefile]` line.
    assert!(
        text.contains("[dumpfile] \"g.vcd\"\n[savefile] \"g.gtkw\"\n"),
        "{text}"
    );

    // Every signal line must be a variable of the VCD spelled the way
    // GTKWave spells it: dotted scopes, then `name[msb:lsb]` for vectors.
    let w = wellen::simple::read(&path).unwrap();
    let h = w.hierarchy();
    let mut known: Vec<String> = h
        .all_vars()
        .map(|v| {
            let var = &h[v];
            match var.index() {
                Some(i) if var.length(h) != Some(1) => {
                    format!("{}[{}:{}]", var.full_name(h), i.msb(), i.lsb())
                }
                _ => var.full_name(h),
            }
        })
        .collect();
    let mut listed: Vec<String> = text
        .lines()
        .filter_map(|l| match l.strip_prefix('+') {
            // An alias: `+{name} top.x.y`.
            Some(rest) => rest.split_once("} ").map(|(_, n)| n),
            None => Some(l),
        })
        .filter(|l| l.starts_with("top."))
        .map(String::from)
        .collect();
    known.sort();
    listed.sort();
    assert_eq!(listed, known);
    // One open group per PE, plus ctrl, each closed.
    for g in ["ctrl", "pe_0", "pe_1", "pe_2"] {
        let open = format!("@800200\n-{g}\n");
        let close = format!("@1000200\n-{g}\n");
        let (a, b) = (text.find(&open).unwrap(), text.find(&close).unwrap());
        assert!(a < b, "{g}");
    }
}

/// GTKWave's `vcd2fst` accepts the trace silently, and the FST it writes
/// still holds the same values.
#[test]
fn vcd2fst_accepts_the_trace() {
    let dir = tempfile::tempdir().unwrap();
    let vcd = dir.path().join("in.vcd");
    write_trace(&vcd);
    if let Some(fst) = crate::tools::vcd2fst(&vcd) {
        check_with_wellen(&fst);
    }
}
