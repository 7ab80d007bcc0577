//! Waveforms as a designer first opens them: the default trace holds the
//! busiest PEs with their left and right link ports, the save file names
//! its files relative to itself and marks the stage changes, an FST gets
//! its own save file and starts at the first traced cycle, and bad trace
//! options are refused in one line.

use std::path::Path;

use super::{entries, ercube, read_json, tempdir};

/// The PE indices whose scopes a VCD declares.
fn traced_pes(vcd: &Path) -> Vec<u32> {
    let text = std::fs::read_to_string(vcd).expect("the VCD reads");
    let head = &text[..text.find("$enddefinitions").expect("a VCD header")];
    let mut pes: Vec<u32> = head
        .lines()
        .filter_map(|l| l.trim().strip_prefix("$scope module pe_"))
        .filter_map(|l| l.split_whitespace().next()?.parse().ok())
        .collect();
    pes.sort_unstable();
    pes
}

/// With 8 PEs and no --trace-pes, the trace holds the 4 busiest PEs of
/// the frame (the stats' busy counts) and, by default, their link ports,
/// each in its own `left` or `right` scope, which the save file labels.
#[test]
fn the_default_trace_shows_the_busiest_pes_and_their_links() {
    let dir = tempdir();
    let d = dir.path();
    ercube(
        d,
        "render --scene checker:32 --eye 16,16,-16 --fov 90 --size 32x32 --method pipeline --pes 8 \
         --vcd t.vcd --stats s.json --out t.png",
    )
    .ok();
    let stats = read_json(&d.join("s.json"));
    let busy: Vec<u64> = stats["pes"]
        .as_array()
        .expect("per-PE counters")
        .iter()
        .map(|p| p["busy"].as_u64().expect("busy cycles"))
        .collect();
    assert_eq!(busy.len(), 8);
    let mut order: Vec<u32> = (0..8).collect();
    order.sort_by_key(|&k| (std::cmp::Reverse(busy[k as usize]), k));
    let mut want = order[..4].to_vec();
    want.sort_unstable();
    assert_eq!(traced_pes(&d.join("t.vcd")), want, "busy cycles {busy:?}");
    let least = *busy.iter().min().unwrap();
    assert!(
        want.iter().all(|&k| busy[k as usize] >= least),
        "no idle PE traced before a busy one"
    );
    let vcd = std::fs::read_to_string(d.join("t.vcd")).unwrap();
    assert!(
        vcd.contains("$scope module left $end"),
        "link ports traced by default"
    );
    assert!(vcd.contains("$scope module right $end"));
    assert!(
        vcd.contains("$timescale 100 ps $end"),
        "one 5 ns cycle = 50 units"
    );
    let gtkw = std::fs::read_to_string(d.join("t.gtkw")).unwrap();
    let k = want[0];
    for name in ["left_ray_valid", "right_ray_valid"] {
        assert!(
            gtkw.contains(&format!(
                "+{{{name}}} top.pe_{k}.{}",
                name.replacen('_', ".", 1)
            )),
            "{name} labelled by direction:\n{gtkw}"
        );
    }
}

/// An array of up to 4 PEs is traced whole by default.
#[test]
fn a_small_array_is_traced_whole() {
    let dir = tempdir();
    let d = dir.path();
    ercube(
        d,
        "render --scene checker:16 --size 16x16 --method pipeline --pes 3 --vcd t.vcd --out t.png",
    )
    .ok();
    assert_eq!(traced_pes(&d.join("t.vcd")), [0, 1, 2]);
}

/// The save file names its dump and filter files relative to itself, with
/// the `[savefile]` line GTKWave resolves them against, and marks stage
/// changes by name; moving the folder keeps every file it names.
#[test]
fn the_save_file_is_relative_and_marks_stages() {
    let dir = tempdir();
    let d = dir.path();
    std::fs::create_dir(d.join("run")).unwrap();
    ercube(
        d,
        "render --scene checker:16 --size 16x16 --method pipeline --pes 2 --vcd run/t.vcd --out t.png",
    )
    .ok();
    let moved = d.join("moved");
    std::fs::rename(d.join("run"), &moved).unwrap();
    let gtkw = std::fs::read_to_string(moved.join("t.gtkw")).unwrap();
    assert!(
        gtkw.contains("[dumpfile] \"t.vcd\"\n[savefile] \"t.gtkw\"\n"),
        "{gtkw}"
    );
    for line in gtkw.lines() {
        let named = match line.split_once(' ') {
            Some(("[dumpfile]", f)) => Some(f.trim_matches('"')),
            Some((n, f)) if n.starts_with('^') => Some(f),
            _ => None,
        };
        if let Some(f) = named {
            assert!(!f.starts_with('/'), "{line} is relative");
            assert!(
                moved.join(f).is_file(),
                "{line} names a file beside the save file"
            );
        }
    }
    // The frame's first stage is the row plan of the first slice, then its
    // samples.
    assert!(gtkw.contains("[markername] Aplan\n"), "{gtkw}");
    assert!(gtkw.contains("[markername] Bsample\n"), "{gtkw}");
    assert!(gtkw.contains("readout\n"), "the readout is marked:\n{gtkw}");
}

/// --vcd X.vcd --fst X.fst writes two save files, each opening its own
/// dump; the FST's header starts at the first traced cycle.
#[test]
fn an_fst_gets_its_own_save_file_and_starts_at_the_window() {
    let dir = tempdir();
    let d = dir.path();
    ercube(
        d,
        "render --scene checker:16 --size 16x16 --method pipeline --pes 2 --vcd x.vcd --fst x.fst \
         --trace-cycles 10-30 --out t.png",
    )
    .ok();
    let names = entries(d);
    for f in ["x.vcd", "x.fst", "x.gtkw", "x.fst.gtkw"] {
        assert!(names.contains(&f.to_string()), "{f} in {names:?}");
    }
    let vcd = std::fs::read_to_string(d.join("x.gtkw")).unwrap();
    let fst = std::fs::read_to_string(d.join("x.fst.gtkw")).unwrap();
    assert!(vcd.contains("[dumpfile] \"x.vcd\""), "{vcd}");
    assert!(fst.contains("[dumpfile] \"x.fst\""), "{fst}");
    let bytes = std::fs::read(d.join("x.fst")).unwrap();
    let start = u64::from_be_bytes(bytes[9..17].try_into().unwrap());
    assert_eq!(start, 10 * waves::TIME_UNITS_PER_CYCLE, "FST start time");
}

/// Trace options that name PEs outside the array, or a trace on a method
/// without one, are refused in one line with status 2 and write nothing.
#[test]
fn bad_trace_options_are_refused() {
    let dir = tempdir();
    let d = dir.path();
    let base = "render --scene checker:16 --size 16x16 --out t.png";
    for (extra, needle) in [
        (
            "--method pipeline --pes 4 --vcd t.vcd --trace-pes 2-9",
            "--trace-pes 2-9",
        ),
        (
            "--method pipeline --pes 4 --vcd t.vcd --trace-pes 20",
            "outside the array of 4 PEs",
        ),
        ("--method pipeline --vcd t.vcd --trace-pes 0,,1", "PE list"),
        ("--method er --fst t.fst", "--fst"),
    ] {
        let args = format!("{base} {extra}");
        let run = ercube(d, &args);
        crate::bin::assert_refused(&run.args, &run.out, needle);
        assert_eq!(entries(d), Vec::<String>::new(), "{args} wrote nothing");
    }
}
