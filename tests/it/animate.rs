//! `ercube animate`: a camera path's frames are the frames `render` draws
//! from the same eyes, reuse changes no pixel, the GIF holds every frame,
//! and bad paths are one-line errors.

use std::path::Path;

use serde_json::Value;

use crate::bin::{assert_refused, describe, ercube};

fn png(path: &Path) -> Vec<u8> {
    image::open(path)
        .unwrap_or_else(|e| panic!("{}: {e}", path.display()))
        .to_rgb8()
        .into_raw()
}

fn json(path: &Path) -> Value {
    serde_json::from_str(&std::fs::read_to_string(path).expect("stats written")).expect("JSON")
}

const VIEW: [&str; 8] = [
    "--scene",
    "ml:24",
    "--size",
    "40x32",
    "--eye",
    "11.5,11.5,-30",
    "--look-at",
    "11.5,11.5,11.5",
];

/// Animates `path` into `d/reuse` and, with `--no-reuse`, `d/fresh`.
fn both_ways(d: &Path, path: &[&str]) {
    both_ways_with(d, path, &[]);
}

/// [`both_ways`] with `extra` arguments (a method).
fn both_ways_with(d: &Path, path: &[&str], extra_args: &[&str]) {
    for (out, extra) in [("reuse", None), ("fresh", Some("--no-reuse"))] {
        let mut args: Vec<&str> = vec!["animate"];
        args.extend(VIEW);
        args.extend(extra_args);
        args.extend(path);
        args.extend(["--out-dir", out]);
        args.extend(extra);
        let o = ercube(d, &args);
        assert!(o.status.success(), "{}", describe(&args, &o));
    }
}

/// An orbit of 4 frames through 360 degrees about +y: frame 2 looks from
/// the far side, frame 1 from +x. Each frame equals `render` from that eye
/// (the orbit's geometry checked against an independent placement), with
/// and without reuse, and the GIF decodes to the same number of frames.
#[test]
fn orbit_frames_are_renders_from_the_orbit_eyes() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    both_ways(d, &["--frames", "4", "--orbit", "360"]);
    let stats = json(&d.join("reuse/animate.json"));
    assert_eq!(stats["frames"], 4);
    assert_eq!(stats["times_s"].as_array().map(Vec::len), Some(4));
    // Each quarter turn changes the principal axis (+z, +x, -z, -x), so no
    // frame can share its predecessor's slice stack.
    assert_eq!(stats["stacks_reused"], 0, "{stats}");
    assert_eq!(json(&d.join("fresh/animate.json"))["stacks_reused"], 0);
    // Orbit about the look-at point (11.5, 11.5, 11.5), arm (0, 0, -41.5),
    // turning about +y by 90 degrees a frame: -z, then -x, +z, +x.
    let eyes = [
        "11.5,11.5,-30",
        "-30,11.5,11.5",
        "11.5,11.5,53",
        "53,11.5,11.5",
    ];
    for (i, eye) in eyes.iter().enumerate() {
        let name = format!("frame_{i:04}.png");
        let reuse = png(&d.join("reuse").join(&name));
        assert_eq!(
            reuse,
            png(&d.join("fresh").join(&name)),
            "{name}: reuse changed pixels"
        );
        let mut args: Vec<&str> = vec!["render"];
        args.extend(&VIEW[..4]);
        args.extend([
            "--look-at",
            "11.5,11.5,11.5",
            "--eye",
            eye,
            "--out",
            "r.png",
        ]);
        let o = ercube(d, &args);
        assert!(o.status.success(), "{}", describe(&args, &o));
        let r = png(&d.join("r.png"));
        let diff = reuse
            .iter()
            .zip(&r)
            .map(|(a, b)| a.abs_diff(*b))
            .max()
            .unwrap_or(0);
        // The orbit's eye is the rotated float vector, the render's the
        // printed decimals: equal to rounding, so the pixels agree to one
        // grey level.
        assert!(
            diff <= 1,
            "{name} differs from render --eye {eye} by {diff}"
        );
    }
    let gif = std::fs::File::open(d.join("reuse/animation.gif")).unwrap();
    let dec = image::codecs::gif::GifDecoder::new(std::io::BufReader::new(gif)).expect("GIF");
    use image::AnimationDecoder;
    let frames = dec.into_frames().collect_frames().expect("frames");
    assert_eq!(frames.len(), 4);
}

/// A small turn keeps the principal axis, so every frame after the first
/// reuses the slice stack; the pixels are those of a fresh preparation.
#[test]
fn a_small_turn_reuses_the_slice_stack() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    both_ways(d, &["--frames", "3", "--orbit", "20"]);
    assert_eq!(json(&d.join("reuse/animate.json"))["stacks_reused"], 2);
    assert_eq!(json(&d.join("fresh/animate.json"))["stacks_reused"], 0);
    for i in 0..3 {
        let name = format!("frame_{i:04}.png");
        assert_eq!(
            png(&d.join("reuse").join(&name)),
            png(&d.join("fresh").join(&name))
        );
    }
}

/// A path file's eyes (with a moved look-at point on one line) are
/// rendered in order; bad paths and options are one-line errors.
#[test]
fn path_files_and_bad_input() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(
        d.join("p.txt"),
        "# two eyes\n11.5,11.5,-30\n\n20,11.5,-30 look 12,11.5,11.5\n",
    )
    .unwrap();
    std::fs::write(d.join("bad.txt"), "11.5,11.5,-30\n1,2\n").unwrap();
    std::fs::write(d.join("empty.txt"), "# nothing\n").unwrap();
    // Past the size cap: refused from its length, before it is read.
    std::fs::write(d.join("huge.txt"), vec![b'#'; 5 << 20]).unwrap();
    let mut args: Vec<&str> = vec!["animate"];
    args.extend(&VIEW[..4]);
    args.extend(["--path", "p.txt", "--out-dir", "p"]);
    let o = ercube(d, &args);
    assert!(o.status.success(), "{}", describe(&args, &o));
    let stats = json(&d.join("p/animate.json"));
    assert_eq!(stats["frames"], 2);
    assert_eq!(stats["eyes"][1], serde_json::json!([20.0, 11.5, -30.0]));
    for (extra, needle) in [
        ("--path bad.txt", "line 2"),
        ("--path empty.txt", "no eye"),
        ("--path huge.txt", "bytes, more than"),
        ("--path missing.txt", "missing.txt"),
        ("--frames 0", "--frames"),
        ("--orbit nan", "--orbit"),
        ("--pes 4", "--pes"),
        ("--method pipeline --substeps 2", "--substeps"),
        ("--frame-ms 0", "--frame-ms"),
    ] {
        let mut args: Vec<&str> = vec!["animate"];
        args.extend(&VIEW[..4]);
        args.extend(["--out-dir", "x"]);
        args.extend(extra.split_whitespace());
        assert_refused(&args, &ercube(d, &args), needle);
    }
}

/// The pipeline keeps the volume in PE memory while the axis map holds: an
/// orbit of 120 degrees in 4 frames looks along +z at 0 and 30 degrees and
/// along +x at 60 and 90, so frames 1 and 3 find their volume resident
/// and frames 0 and 2 load it. Every frame, resident or not, is
/// bit-identical in image and cycles to `render` from the same eye (the
/// exact eye the orbit computed, read back from the stats) and to the
/// `--no-reuse` run, in both orders, plain and pre-integrated.
#[test]
fn pipeline_frames_reuse_the_volume_in_pe_memory() {
    for (method, pre) in [
        ("pipeline", &[][..]),
        ("pipeline-ftb", &[][..]),
        ("pipeline", &["--preintegrate"][..]),
        ("pipeline-ftb", &["--preintegrate"][..]),
    ] {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        let mut opts = vec!["--method", method, "--pes", "4"];
        opts.extend(pre);
        both_ways_with(d, &["--frames", "4", "--orbit", "120"], &opts);
        let method = format!("{method} {pre:?}");
        let reuse = json(&d.join("reuse/animate.json"));
        let fresh = json(&d.join("fresh/animate.json"));
        let resident = |s: &Value| -> Vec<bool> {
            s["voxel_load"]
                .as_array()
                .expect("voxel_load")
                .iter()
                .map(|l| l["resident"].as_bool().expect("resident"))
                .collect()
        };
        assert_eq!(resident(&reuse), [false, true, false, true], "{method}");
        assert_eq!(resident(&fresh), [false; 4], "{method}");
        assert_eq!(reuse["frames_resident"], 2);
        assert_eq!(reuse["cycles"], fresh["cycles"], "{method}");
        for i in 0..4 {
            let load = &reuse["voxel_load"][i];
            let held = load["bytes_held"].as_u64().expect("bytes_held");
            // ml:24 is 24^3 8-bit voxels, at least all of them held (as
            // 12-bit words by default: 1.5 bytes each).
            assert!(held >= 24 * 24 * 24, "{method} frame {i}: {load}");
            let loaded = load["bytes_loaded"].as_u64().expect("bytes_loaded");
            assert_eq!(loaded, if i % 2 == 1 { 0 } else { held }, "{load}");
            // The load's cycles: none when resident; otherwise at least the
            // bytes over the default 32-byte host link and at least one
            // cycle per word of the busiest of the 4 PEs' memories.
            let cycles = load["cycles"].as_u64().expect("load cycles");
            if i % 2 == 1 {
                assert_eq!(cycles, 0, "{method} frame {i}: {load}");
            } else {
                let words = load["words_held"].as_u64().expect("words_held");
                assert!(cycles >= held.div_ceil(32), "{method} frame {i}: {load}");
                assert!(cycles >= words.div_ceil(4), "{method} frame {i}: {load}");
                assert_eq!(fresh["voxel_load"][i]["cycles"], load["cycles"]);
            }
            let total = reuse["cycles"][i].as_u64().expect("cycles") + cycles;
            assert_eq!(reuse["cycles_with_load"][i], total, "{method} frame {i}");
            let name = format!("frame_{i:04}.png");
            let frame = png(&d.join("reuse").join(&name));
            assert_eq!(frame, png(&d.join("fresh").join(&name)), "{method} {name}");
            let eye: Vec<String> = reuse["eyes"][i]
                .as_array()
                .expect("eye")
                .iter()
                .map(|c| format!("{}", c.as_f64().expect("coordinate")))
                .collect();
            let eye = eye.join(",");
            let mut args: Vec<&str> = vec!["render"];
            args.extend(&VIEW[..4]);
            args.extend(["--look-at", "11.5,11.5,11.5", "--eye", &eye]);
            args.extend(&opts);
            args.extend(["--out", "r.png", "--stats", "r.json"]);
            let o = ercube(d, &args);
            assert!(o.status.success(), "{}", describe(&args, &o));
            let r = png(&d.join("r.png"));
            let first = frame.iter().zip(&r).position(|(a, b)| a != b);
            assert_eq!(
                first, None,
                "{method} {name}: first differing byte vs render"
            );
            assert_eq!(frame.len(), r.len());
            let stats = json(&d.join("r.json"));
            assert_eq!(reuse["cycles"][i], stats["cycles"], "{method} {name}");
            assert_eq!(stats["voxel_load"]["resident"], false);
            assert_eq!(
                stats["voxel_load"]["cycles"],
                fresh["voxel_load"][i]["cycles"]
            );
        }
    }
}
