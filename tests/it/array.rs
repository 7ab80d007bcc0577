//! The PE array through the `ercube` program: `render --method pipeline`
//! and `pipeline-ftb` with every output, the configuration errors the
//! command line reports, and `ercube cost` on a real run. The model itself
//! is tested in `pipeline/tests/it/`.

use glam::DVec3;
use golden::camera::Camera;
use golden::render::Prepared;
use pipeline::config::PipelineConfig;
use waves::{Trace, TIME_UNITS_PER_CYCLE};

use crate::bin::{assert_refused, describe, ercube};
use crate::chip::{check_gtkw, config, subject};

/// The binary refuses the same mistakes with status 2 and exactly one
/// stderr line that names the problem.
#[test]
fn bad_configurations_are_refused_by_the_cli() {
    let dir = tempfile::tempdir().expect("temporary directory");
    std::fs::write(
        dir.path().join("unknown.toml"),
        "pes = 4\nbogus_width = 3\n",
    )
    .unwrap();
    std::fs::write(
        dir.path().join("alpha.toml"),
        "alpha = { bits = 12, frac = 20, signed = false, quant = \"RND\", overflow = \"SAT\" }\n",
    )
    .unwrap();
    std::fs::write(dir.path().join("fifo0.toml"), "link_fifo_depth = 0\n").unwrap();
    std::fs::write(
        dir.path().join("fifo_huge.toml"),
        "link_fifo_depth = 65535\n",
    )
    .unwrap();
    let base = ["render", "--scene", "sphere:16", "--size", "16x16"];
    let cases: [(&[&str], &str); 6] = [
        (&["--method", "pipeline", "--pes", "0"], "pes = 0"),
        (
            &["--method", "pipeline", "--config", "unknown.toml"],
            "bogus_width",
        ),
        (
            &["--method", "pipeline", "--config", "alpha.toml"],
            "alpha.frac = 20 exceeds alpha.bits = 12",
        ),
        (&["--method", "er", "--pes", "4"], "--pes"),
        (
            &["--method", "pipeline", "--config", "fifo0.toml"],
            "link_fifo_depth = 0 is outside 1..=4096",
        ),
        (
            &["--method", "pipeline-ftb", "--config", "fifo_huge.toml"],
            "link_fifo_depth = 65535 is outside 1..=4096",
        ),
    ];
    for (extra, needle) in cases {
        let args: Vec<&str> = base.iter().chain(extra).copied().collect();
        let out = ercube(dir.path(), &args);
        assert_refused(&args, &out, needle);
        assert!(
            !dir.path().join("render.png").exists(),
            "a refused run wrote an image"
        );
    }
}

/// `ercube render --method pipeline` with every output: the stats carry
/// the cycle counts and the configuration, the image is within 1/255 of
/// golden er, the raw words are an `<i8` `(H, W, 4)` array equal to the
/// in-process model's for the same (default) camera, and the waveform and
/// its GTKWave save file exist.
#[test]
fn cli_pipeline_render_writes_everything() {
    let dir = tempfile::tempdir().expect("temporary directory");
    let args: Vec<&str> = "render --scene sphere:24 --size 48x48 --method pipeline --pes 4 --stats s.json --raw-npy raw.npy --vcd w.vcd --trace-pes 0-1 --trace-cycles 0-500 --out p.png"
        .split_whitespace()
        .collect();
    let out = ercube(dir.path(), &args);
    assert!(out.status.success(), "{}", describe(&args, &out));
    let p = |name: &str| dir.path().join(name);
    for f in ["p.png", "s.json", "raw.npy", "w.vcd", "w.gtkw"] {
        assert!(p(f).exists(), "{f} missing: {}", describe(&args, &out));
    }

    let stats: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(p("s.json")).unwrap()).expect("JSON");
    let cycles = stats["cycles"].as_u64().expect("cycles");
    let ideal = stats["ideal_cycles"].as_f64().expect("ideal_cycles");
    let util = stats["utilization"].as_f64().expect("utilization");
    assert!(cycles > 0 && ideal > 0.0 && ideal <= cycles as f64);
    assert!(util > 0.0 && util <= 1.0, "utilization {util}");
    let stages = stats["stages"].as_object().expect("stages");
    let mut sum = 0;
    for k in [
        "migrate", "plan", "sample", "merge", "readout", "drain", "stall",
    ] {
        sum += stages[k].as_u64().unwrap_or_else(|| panic!("stages.{k}"));
    }
    assert_eq!(stages.len(), 7, "{stages:?}");
    assert_eq!(sum, cycles, "stages add up to cycles");
    let cfg_json = stats["config"].as_object().expect("config object");
    assert_eq!(cfg_json["pes"], 4, "{cfg_json:?}");
    let max = stats["error_vs_golden_er"]["max_abs_255"]
        .as_f64()
        .expect("error_vs_golden_er.max_abs_255");
    assert!(max <= 1.0, "pipeline vs golden er: {max} /255");

    // raw.npy: NumPy 1.0 header, '<i8', (H, W, 4), then the words.
    let bytes = std::fs::read(p("raw.npy")).unwrap();
    assert_eq!(&bytes[..8], b"\x93NUMPY\x01\x00", "npy magic and version");
    let hlen = u16::from_le_bytes([bytes[8], bytes[9]]) as usize;
    let header = std::str::from_utf8(&bytes[10..10 + hlen]).expect("ASCII header");
    assert!(header.contains("'descr': '<i8'"), "{header}");
    assert!(header.contains("'fortran_order': False"), "{header}");
    let shape: Vec<usize> = header
        .split("'shape': (")
        .nth(1)
        .and_then(|s| s.split(')').next())
        .expect("shape")
        .split(',')
        .map(str::trim)
        .filter(|s| !s.is_empty())
        .map(|s| s.parse().expect("dimension"))
        .collect();
    assert_eq!(shape.len(), 3, "{header}");
    assert_eq!(shape[2], 4, "{header}");
    let (h, w) = (shape[0], shape[1]);
    assert_eq!(bytes.len(), 10 + hlen + h * w * 4 * 8, "file length");
    let words: Vec<i64> = bytes[10 + hlen..]
        .chunks_exact(8)
        .map(|c| i64::from_le_bytes(c.try_into().expect("8 bytes")))
        .collect();

    // The same frame in process: the CLI's default camera for this scene.
    let s = subject("sphere:24");
    let centre = DVec3::from_array(s.vol.center_world());
    let eye = centre - DVec3::Z * (centre.z + 1.5 * s.n as f64);
    let cam = Camera::new(eye, centre, DVec3::Y, 60.0, 48, 48).expect("camera");
    let prep = Prepared::new(&s.vol, &cam).expect("view");
    let frame = pipeline::FrameRun::new(&config(4), &s.lut, &s.vol, &prep.view)
        .run()
        .expect("frame");
    assert_eq!(
        [w, h],
        frame.baseplane.grid.counts,
        "npy shape vs baseplane"
    );
    let expected: Vec<i64> = frame.raw.iter().flatten().copied().collect();
    assert!(
        words == expected,
        "raw.npy differs from the in-process frame"
    );
    assert_eq!(cycles, frame.cycles, "stats cycles vs in-process frame");

    // The window 0-500 was honoured and PEs 2, 3 were not traced.
    let trace = Trace::read(p("w.vcd")).expect("VCD reads");
    assert!(trace.end_time() <= 501 * TIME_UNITS_PER_CYCLE);
    assert!(trace.signal("top.pe_1.acc_a").is_some());
    assert!(trace.signal("top.pe_2.acc_a").is_none());
    check_gtkw(&p("w.vcd"));
}

/// `--fst` with `--trace-signals`: the FST, its save file and the stage
/// filter are written, the VCD of the same run holds exactly the selected
/// groups, and the FST is the smaller file.
#[test]
fn cli_writes_fst_and_selects_signal_groups() {
    let dir = tempfile::tempdir().expect("temporary directory");
    let args: Vec<&str> = "render --scene sphere:24 --size 32x32 --method pipeline --pes 4 --vcd w.vcd --fst f.fst --trace-signals ctrl,ports --out p.png"
        .split_whitespace()
        .collect();
    let out = ercube(dir.path(), &args);
    assert!(out.status.success(), "{}", describe(&args, &out));
    let p = |name: &str| dir.path().join(name);
    for f in [
        "w.vcd",
        "w.gtkw",
        "w.stage.txt",
        "f.fst",
        "f.gtkw",
        "f.stage.txt",
    ] {
        assert!(p(f).exists(), "{f} missing: {}", describe(&args, &out));
    }
    let fst_gtkw = std::fs::read_to_string(p("f.gtkw")).expect("f.gtkw");
    assert!(fst_gtkw.contains("f.fst\""), "{fst_gtkw}");
    let trace = Trace::read(p("w.vcd")).expect("VCD reads");
    let names: Vec<&str> = trace.names().collect();
    assert!(names.contains(&"top.ctrl.stage"));
    assert!(names.contains(&"top.pe_3.left.ray_valid"));
    assert!(!names.contains(&"top.pe_0.acc_r"), "acc is not selected");
    let size = |f: &str| std::fs::metadata(p(f)).expect("size").len();
    assert!(size("f.fst") < size("w.vcd"));
}

/// `ercube render --method pipeline-ftb` reports its error against golden
/// er-ftb at the same threshold and its termination counters, and refuses
/// a threshold outside (0, 1] with one line.
#[test]
fn cli_renders_pipeline_ftb() {
    let dir = tempfile::tempdir().unwrap();
    let run = |args: &[&str]| ercube(dir.path(), args);
    let base = [
        "render",
        "--scene",
        "checker:32",
        "--eye",
        "16,16,-12",
        "--size",
        "48x48",
        "--method",
        "pipeline-ftb",
        "--pes",
        "4",
        "--stats",
        "s.json",
        "--out",
        "f.png",
    ];
    let mut counts = Vec::new();
    for t in ["1", "0.9"] {
        let mut args = base.to_vec();
        args.extend(["--terminate", t]);
        let out = run(&args);
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        let text = std::fs::read_to_string(dir.path().join("s.json")).unwrap();
        let v: serde_json::Value = serde_json::from_str(&text).unwrap();
        assert_eq!(v["method"], "pipeline-ftb");
        assert_eq!(v["order"], "front-to-back");
        assert_eq!(v["error_vs_golden"]["method"], "er-ftb");
        assert!(v["error_vs_golden_er"].is_null());
        let max = v["error_vs_golden"]["max_abs_255"].as_f64().unwrap();
        eprintln!("terminate {t}: {max} grey levels from golden er-ftb");
        // Without termination the default widths keep within a grey level;
        // with it, a ray near the threshold may stop in one model and take
        // another sample in the other (fixed-point against float opacity),
        // which only `1 - threshold` per model bounds.
        let limit = if t == "1" {
            1.0
        } else {
            2.0 * 0.1 * 255.0 + 1.0
        };
        assert!(
            max <= limit,
            "terminate {t}: {max} grey levels from golden er-ftb"
        );
        counts.push((
            v["samples_total"].as_u64().unwrap(),
            v["terminated_samples"].as_u64().unwrap(),
            v["cycles"].as_u64().unwrap(),
        ));
    }
    assert_eq!(counts[0].1, 0);
    assert!(counts[1].1 > 0 && counts[1].0 < counts[0].0 && counts[1].2 < counts[0].2);
    assert_eq!(counts[1].0 + counts[1].1, counts[0].0);
    let mut args = base.to_vec();
    args.extend(["--terminate", "1.5"]);
    let out = run(&args);
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(err.trim().lines().count(), 1, "{err}");
    assert!(err.contains("1.5"), "{err}");
}

/// The cycles the library's pipeline takes for the scene the command test
/// uses, run directly (not through the command).
fn direct_cycles(pes: u16) -> u64 {
    use golden::camera::Camera;
    use golden::render::Prepared;
    use golden::scenes::Scene;
    use golden::tf::Lut;
    let scene: Scene = "checker:32".parse().expect("scene");
    let vol = scene.build(1 << 30).expect("volume");
    let cfg = PipelineConfig {
        pes,
        ..PipelineConfig::default()
    };
    let lut = Lut::for_bits(
        &scene.preset(),
        cfg.table_entries as usize,
        vol.kind().bits(),
    );
    let c = vol.center_world();
    let cam = Camera::new(
        glam::DVec3::new(16.0, 16.0, -16.0),
        glam::DVec3::from_array(c),
        glam::DVec3::Y,
        90.0,
        256,
        256,
    )
    .expect("camera");
    let prep = Prepared::new(&vol, &cam).expect("view");
    // The command skips as render does by default.
    let skips = golden::methods::Options::default().skips;
    pipeline::FrameRun::prepared(&cfg, &lut, &prep, pipeline::Voxels::Volume(&vol))
        .skips(skips)
        .run()
        .expect("frame")
        .cycles
}

/// The command runs the pipeline for its cycle counts (the same counts as
/// a direct run), costs the array consistently (array = P x PE +
/// controller), writes the JSON and the Verilog, and prints every section.
#[test]
fn cost_command_reports_a_real_run() {
    let dir = tempfile::tempdir().expect("temp dir");
    let d = dir.path();
    let out = ercube(
        d,
        &[
            "cost",
            "--scene",
            "checker:32",
            "--eye",
            "16,16,-16",
            "--fov",
            "90",
            "--pes",
            "4",
            "--sweep-pes",
            "2,4",
            "--target",
            "ice40",
            "--clock",
            "assumed",
            "--json",
            "r.json",
            "--verilog-dir",
            "rtl",
        ],
    );
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    for section in [
        "Per PE and array",
        "Fit (4 PEs)",
        "iCE40UP5K",
        "Throughput at 48 MHz",
        "P sweep",
        "Scaling",
        "Architectures (P = 4",
        "cyclic:4/external",
    ] {
        assert!(stdout.contains(section), "missing {section}:\n{stdout}");
    }
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(d.join("r.json")).expect("json written"))
            .expect("valid JSON");
    assert_eq!(v["target"], "ice40");
    assert_eq!(v["geometry"]["pes"], 4);
    assert_eq!(v["geometry"]["dims"], serde_json::json!([32, 32, 32]));
    let cycles = v["run"]["cycles"].as_u64().expect("cycles");
    assert_eq!(
        cycles,
        direct_cycles(4),
        "the command's run is the pipeline's"
    );
    let fps = v["run_rate"]["fps"].as_f64().expect("fps");
    assert!((fps - 48e6 / cycles as f64).abs() < 1e-6 * fps);
    // 32^3 voxels of 12 bits per frame.
    let bw = v["run_rate"]["bandwidth"].as_f64().expect("bandwidth");
    assert!((bw - fps * 32.0 * 32.0 * 32.0 * 1.5).abs() < 1e-6 * bw);
    let sweep = v["sweep"].as_array().expect("sweep");
    assert_eq!(sweep.len(), 2);
    assert_eq!(sweep[0]["pes"], 2);
    assert_eq!(sweep[0]["cycles"].as_u64(), Some(direct_cycles(2)));
    assert_eq!(sweep[1]["cycles"].as_u64(), Some(cycles));
    assert_eq!(v["scaling"].as_array().map(Vec::len), Some(24));
    // Every mapping with every placement, each from its own run; the
    // configuration's own (blocks, on chip) is the main run.
    let archs = v["architectures"].as_array().expect("architectures");
    let names: Vec<&str> = archs.iter().filter_map(|a| a["arch"].as_str()).collect();
    assert_eq!(
        names,
        [
            "blocks/on-chip",
            "blocks/external",
            "interleave/on-chip",
            "interleave/external",
            "cyclic:4/on-chip",
            "cyclic:4/external"
        ]
    );
    assert_eq!(archs[0]["cycles"].as_u64(), Some(cycles));
    assert_eq!(archs[0]["resources"], v["array"]);
    for a in archs {
        let external = a["arch"].as_str().is_some_and(|s| s.ends_with("external"));
        assert_eq!(a["ray_bytes"].as_f64().expect("ray bytes") > 0.0, external);
    }
    let n = |x: &serde_json::Value| x.as_u64().expect("count");
    let items = v["pe_items"].as_array().expect("items");
    // The array is every PE at its own ray depths: the groups of PEs
    // declaring the same depths cover the 4 PEs once, and none takes more
    // block RAM than the deepest PE the items list.
    let groups = v["pe_groups"].as_array().expect("PE groups");
    let mut pes: Vec<u64> = groups
        .iter()
        .flat_map(|g| g["pes"].as_array().expect("PEs").iter().map(n))
        .collect();
    pes.sort_unstable();
    assert_eq!(pes, [0, 1, 2, 3]);
    for key in ["dsp", "lut", "ff", "bram"] {
        let sum: u64 = items.iter().map(|i| n(&i["resources"][key])).sum();
        assert_eq!(sum, n(&v["pe"][key]), "PE {key} is the sum of its units");
        let each: u64 = groups
            .iter()
            .map(|g| {
                let one = n(&g["resources"][key]);
                if key == "bram" {
                    assert!(one <= n(&v["pe"][key]), "{key}: {g}");
                }
                one * g["pes"].as_array().map_or(0, |p| p.len() as u64)
            })
            .sum();
        assert_eq!(
            n(&v["array"][key]),
            each + n(&v["controller"][key]),
            "array {key}"
        );
    }
    let mut files: Vec<String> = std::fs::read_dir(d.join("rtl"))
        .expect("verilog dir")
        .map(|e| e.expect("entry").file_name().to_string_lossy().into_owned())
        .collect();
    files.sort();
    // The calibration units, the shading unit's square root and divider
    // among them.
    let want = [
        "add_position",
        "bilinear",
        "class_table",
        "composite",
        "divider",
        "mul_ray",
        "mul_square",
        "sqrt_norm",
    ]
    .map(|u| format!("ercube_{u}.v"));
    assert_eq!(files, want, "the Verilog written");
}

/// Bad input to `ercube cost` is one line on stderr and exit status 2.
#[test]
fn cost_command_bad_input() {
    let dir = tempfile::tempdir().expect("temp dir");
    let d = dir.path();
    std::fs::write(d.join("zero.toml"), "pes = 0\n").expect("write");
    std::fs::write(d.join("typo.toml"), "voxle = 3\n").expect("write");
    let base = ["cost", "--scene", "checker:16"];
    let cases: [(&[&str], &str); 10] = [
        (&["--target", "zynq"], "zynq"),
        (&["--archs", "some"], "--archs"),
        (&["--clock-mhz", "0"], "clock"),
        (&["--clock-mhz", "-5"], "clock"),
        (&["--clock-mhz", "nan"], "clock"),
        (&["--config", "missing.toml"], "missing.toml"),
        (&["--config", "zero.toml"], "pes"),
        (&["--config", "typo.toml"], "voxle"),
        (&["--pes", "300"], "pes"),
        (&["--sweep-pes", "0,x"], "sweep"),
    ];
    let mut bad = Vec::new();
    for (extra, keyword) in cases {
        let mut args: Vec<&str> = base.to_vec();
        args.extend_from_slice(extra);
        if !extra.contains(&"--sweep-pes") {
            args.extend_from_slice(&["--sweep-pes", "none"]);
        }
        let out = ercube(d, &args);
        let err = String::from_utf8_lossy(&out.stderr);
        let lines: Vec<&str> = err.lines().collect();
        let ok = out.status.code() == Some(2)
            && lines.len() == 1
            && lines[0].starts_with("ercube: error:")
            && lines[0].to_lowercase().contains(keyword);
        if !ok {
            bad.push(format!(
                "{}: status {:?}, stderr {err:?}",
                args.join(" "),
                out.status.code()
            ));
        }
    }
    assert!(bad.is_empty(), "{}", bad.join("\n"));
}
