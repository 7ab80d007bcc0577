//! `ercube.Chip` stepped one clock at a time against the command line:
//! `ercube render --vcd` traces a small frame (every signal group), the
//! waveform's values at a few cycles (a busy sampling cycle, a migration,
//! a merge, the readout) go to `tests/check_chip.py`, which steps the same
//! frame through `Chip.begin`/`step` and requires `Chip.ports()` and
//! `Chip.broadcast()` to hold those values at those cycles, then steps to
//! the end and requires the cycles to be the statistics' and `finish()`'s
//! raw words `--raw-npy`'s (and `run_frame`'s). `ports()` is a numpy
//! structured array (a record per PE, a field per signal of the signal's
//! width and signedness); `Chip.run`'s trace of the same frame holds
//! `ports()`'s values at those cycles.

use std::collections::BTreeMap;
use std::process::{Command, ExitCode};

use serde_json::{json, Value};
use waves::Trace;

use super::{installed, root};

/// The frame both sides render: `ml:24` seen from close (merges), 4 PEs.
const FRAME: [&str; 14] = [
    "--method",
    "pipeline",
    "--pes",
    "4",
    "--tf",
    "ml",
    "--size",
    "32x32",
    "--eye",
    "13.1,10.7,-6",
    "--fov",
    "60",
    "--up",
    "0,1,0",
];

#[test]
fn the_python_chip_steps_the_waveforms_cycles() {
    let Some(py) = installed() else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let (vcd, raw, stats, png) = (
        d.join("f.vcd"),
        d.join("raw.npy"),
        d.join("stats.json"),
        d.join("f.png"),
    );
    let mut argv = vec!["ercube", "render", "--scene", "ml:24"];
    argv.extend(FRAME);
    for (flag, p) in [
        ("--vcd", &vcd),
        ("--raw-npy", &raw),
        ("--stats", &stats),
        ("--out", &png),
    ] {
        argv.extend([flag, p.to_str().unwrap()]);
    }
    argv.extend(["--trace-signals", "all"]);
    assert_eq!(ercube::cli::run_with(argv), ExitCode::SUCCESS);
    let trace = Trace::read(&vcd).unwrap();
    let at = |name: &str, c: u64| trace.signal(name).and_then(|s| s.u64_at_cycle(c));
    let end = trace.end_time() / waves::TIME_UNITS_PER_CYCLE;
    // The first cycle of each kind: a PE busy sampling, a ray on a link,
    // a merge parent on a link, a word on the host port.
    let mut picked = Vec::new();
    for probe in [
        "busy",
        "right.ray_valid",
        "right.parent_valid",
        "host.valid",
    ] {
        let c = (1..=end)
            .find(|&c| (0..4).any(|k| at(&format!("top.pe_{k}.{probe}"), c) == Some(1)))
            .unwrap_or_else(|| panic!("no cycle with {probe}"));
        picked.push(c);
    }
    picked.sort_unstable();
    picked.dedup();
    let mut expect = Vec::new();
    for &c in &picked {
        let mut pes = vec![BTreeMap::new(); 4];
        let mut ctrl = BTreeMap::new();
        for name in trace.names() {
            let v = at(name, c).unwrap_or_else(|| panic!("{name} has no value at {c}"));
            if let Some(rest) = name.strip_prefix("top.ctrl.") {
                ctrl.insert(rest.to_string(), v);
            } else if let Some(rest) = name.strip_prefix("top.pe_") {
                let (k, sig) = rest.split_once('.').unwrap();
                pes[k.parse::<usize>().unwrap()].insert(sig.to_string(), v);
            }
        }
        expect.push(json!({"cycle": c, "ctrl": ctrl, "pes": pes}));
    }
    let case = json!({
        "kwargs": {"method": "pipeline", "pes": 4, "tf": "ml", "size": [32, 32],
            "eye": [13.1, 10.7, -6.0], "fov": 60.0, "up": [0.0, 1.0, 0.0]},
        "scene": "ml:24",
        "cycles": expect,
        "raw": raw,
        "stats": stats,
    });
    let file = d.join("chip.json");
    std::fs::write(&file, serde_json::to_string(&case).unwrap()).unwrap();
    let t = std::time::Instant::now();
    let out = Command::new(&py)
        .arg(root().join("python/tests/check_chip.py"))
        .arg(&file)
        .output()
        .unwrap();
    eprintln!("check_chip.py: {:.1} s", t.elapsed().as_secs_f64());
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "check_chip.py failed:\n{text}\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert_eq!(
        text.matches("equal to the VCD").count(),
        picked.len(),
        "{text}"
    );
    assert!(text.contains("raw words equal --raw-npy's"), "{text}");
    assert!(text.contains("Chip.run traced"), "{text}");
    assert!(text.contains("the stats' samples_total"), "{text}");
    let _: Value = serde_json::from_str(&std::fs::read_to_string(&stats).unwrap()).unwrap();
}
