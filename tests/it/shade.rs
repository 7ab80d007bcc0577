//! Shading through the program: a transfer function's `[material]` turns
//! shading on with that material, `--no-shade` turns it off bit for bit,
//! `--material` overrides the table's, and the pipeline shades a shaded
//! table too (refusing in one line what its unit does not build).

use std::path::Path;

use crate::bin::{assert_refused, describe, ercube, read_npy};

const POINTS: &str = "[[point]]\nvalue = 0\nrgba = [1, 0.8, 0.6, 0]\n\n\
                      [[point]]\nvalue = 120\nrgba = [1, 0.8, 0.6, 0.3]\n\n\
                      [[point]]\nvalue = 255\nrgba = [1, 1, 1, 0.9]\n";

fn npy(dir: &Path, tf: &str, extra: &[&str]) -> Vec<u8> {
    let mut args = vec![
        "render",
        "--scene",
        "sphere:24",
        "--size",
        "24x24",
        "--method",
        "er",
        "--tf-file",
        tf,
        "--out",
        "i.png",
        "--npy",
        "i.npy",
    ];
    args.extend_from_slice(extra);
    let out = ercube(dir, &args);
    assert!(out.status.success(), "{}", describe(&args, &out));
    std::fs::read(dir.join("i.npy")).expect("npy written")
}

#[test]
fn a_tables_material_shades() {
    let dir = tempfile::tempdir().expect("temporary directory");
    let d = dir.path();
    std::fs::write(d.join("plain.toml"), POINTS).unwrap();
    let material = "\n[material]\nambient = 0.2\ndiffuse = 0.6\nspecular = 0.4\nshininess = 30\n";
    std::fs::write(d.join("lit.toml"), format!("{POINTS}{material}")).unwrap();
    let plain = npy(d, "plain.toml", &[]);
    let lit = npy(d, "lit.toml", &[]);
    assert_ne!(plain, lit, "the table's material shades");
    assert_eq!(
        npy(d, "lit.toml", &["--no-shade"]),
        plain,
        "--no-shade is unshaded"
    );
    assert_eq!(
        npy(d, "plain.toml", &["--material", "0.2,0.6,0.4,30"]),
        lit,
        "the same material from the command line"
    );
    assert_ne!(
        npy(d, "lit.toml", &["--material", "0.1,0.7,0.2,10"]),
        lit,
        "--material overrides the table's"
    );

    let args = [
        "render",
        "--scene",
        "sphere:16",
        "--size",
        "16x16",
        "--method",
        "pipeline",
        "--tf-file",
        "lit.toml",
        "--out",
        "p.png",
        "--npy",
        "p.npy",
        "--pes",
        "4",
    ];
    let out = ercube(d, &args);
    assert!(out.status.success(), "{}", describe(&args, &out));
    let shaded = std::fs::read(d.join("p.npy")).expect("npy written");
    let mut flat = args.to_vec();
    flat.push("--no-shade");
    let out = ercube(d, &flat);
    assert!(out.status.success(), "{}", describe(&flat, &out));
    assert_ne!(
        std::fs::read(d.join("p.npy")).unwrap(),
        shaded,
        "the pipeline shades with the table's material"
    );
    // 16 PEs over 16 columns: blocks of one column cannot shade.
    let mut narrow = args.to_vec();
    let last = narrow.len() - 1;
    narrow[last] = "16";
    assert_refused(&narrow, &ercube(d, &narrow), "2 voxel columns per PE");

    std::fs::write(
        d.join("bad.toml"),
        format!("{POINTS}\n[material]\nambient = 0.2\n"),
    )
    .unwrap();
    let args = [
        "render",
        "--scene",
        "sphere:16",
        "--size",
        "16x16",
        "--tf-file",
        "bad.toml",
        "--out",
        "b.png",
    ];
    assert_refused(&args, &ercube(d, &args), "material");
}

/// The shading, volume-of-interest and gaze flags refuse bad values, and
/// the methods that lack them, in one line each.
#[test]
fn bad_flags_are_one_line_errors() {
    let dir = tempfile::tempdir().expect("temporary directory");
    let s = "render --scene checker:16 --size 16x16";
    // (arguments after `ercube`, keyword the message must contain)
    let cases: Vec<(String, &str)> = vec![
        (format!("{s} --light 0,0,0"), "light"),
        (format!("{s} --light 1,0"), "light"),
        (format!("{s} --material 0.1,0.7,0.2"), "material"),
        (format!("{s} --material 0.1,0.7,0.2,0"), "shininess"),
        (format!("{s} --gradient-opacity -1"), "gradient opacity"),
        (format!("{s} --gradient bogus"), "gradient"),
        (
            format!("{s} --method box --gaze 3,3"),
            "reference, mipmap, er or er-ftb",
        ),
        (
            format!("{s} --gaze 3,3 --gaze-levels 4"),
            "fewer --gaze-levels",
        ),
        (format!("{s} --compare-full"), "--compare-full needs --gaze"),
        (
            format!("{s} --gaze 3,3 --baseplane-npy b.npy"),
            "one baseplane per level",
        ),
        (format!("{s} --method reference --gaze 3"), "gaze"),
        (
            format!("{s} --method reference --gaze 3,3 --gaze-radii 5,2"),
            "radii",
        ),
        (
            format!("{s} --method reference --gaze 3,3 --gaze-levels 9"),
            "levels",
        ),
        (format!("{s} --method reference --gaze-radii 5,9"), "--gaze"),
        (format!("{s} --voi box:1,2,3"), "volume of interest"),
        (format!("{s} --voi sphere:4,4,4,0"), "radius"),
        (format!("{s} --voi sphere:4,4,4,3 --voi-scale -1"), "scale"),
        (format!("{s} --voi sphere:4,4,4,3 --voi-ramp -2"), "ramp"),
        (
            format!("{s} --method pipeline --voi sphere:4,4,4,3 --voi-ramp 0.001"),
            "voi_axis",
        ),
        (
            format!("{s} --method mipmap --voi sphere:4,4,4,3 --voi-scale 200"),
            "scale",
        ),
        (format!("{s} --no-shade --light 1,0,0"), "no-shade"),
        (
            format!("{s} --method pipeline --pes 4 --shade --gradient samples"),
            "differences on voxels",
        ),
    ];
    for (line, needle) in &cases {
        let args: Vec<&str> = line.split_whitespace().collect();
        assert_refused(&args, &ercube(dir.path(), &args), needle);
    }
}

/// `--gaze` on ER renders one frame per level: the stats carry the levels,
/// and `--compare-full` reports the sweet spot (bit for bit the full frame)
/// and the periphery separately.
#[test]
fn er_gaze_reports_levels_and_the_sweet_spot() {
    let dir = tempfile::tempdir().expect("temporary directory");
    let d = dir.path();
    for m in ["er", "er-ftb", "reference", "mipmap"] {
        let line = format!(
            "render --scene ml:24 --size 48x40 --method {m} --gaze 20,18 --compare-full --out i.png --stats s.json"
        );
        let args: Vec<&str> = line.split_whitespace().collect();
        let out = ercube(d, &args);
        assert!(
            out.status.success(),
            "{}",
            crate::bin::describe(&args, &out)
        );
        let v: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(d.join("s.json")).expect("stats"))
                .expect("json");
        let f = &v["gaze_vs_full"];
        assert_eq!(f["inside"]["rmse"], 0.0, "{m}: {f}");
        assert!(f["inside"]["pixels"].as_u64().unwrap() > 0, "{m}: {f}");
        assert!(f["outside"]["rmse"].as_f64().unwrap() > 0.0, "{m}: {f}");
        assert_eq!(
            f["inside"]["pixels"].as_u64().unwrap() + f["outside"]["pixels"].as_u64().unwrap(),
            48 * 40
        );
        if m.starts_with("er") {
            assert_eq!(v["er_gaze"]["levels"].as_array().unwrap().len(), 3, "{m}");
        }
    }
}

/// `compare --gaze` adds a `NAME+gaze` row for every method that takes a
/// gaze, and `bench` runs `er+gaze`; neither takes it for other methods.
#[test]
fn compare_and_bench_take_er_gaze() {
    let dir = tempfile::tempdir().expect("temporary directory");
    let d = dir.path();
    let line =
        "compare --scene ml:24 --size 32x32 --methods er,under,reference --gaze 16,16 --out-dir c";
    let args: Vec<&str> = line.split_whitespace().collect();
    let out = ercube(d, &args);
    assert!(out.status.success(), "{}", describe(&args, &out));
    let csv = std::fs::read_to_string(d.join("c/compare.csv")).expect("csv");
    let names: Vec<&str> = csv
        .lines()
        .skip(1)
        .filter_map(|l| l.split(',').next())
        .collect();
    assert_eq!(
        names,
        ["er", "er+gaze", "under", "reference+gaze", "reference"],
        "{csv}"
    );
    let line = "bench --scene ml:24 --size 32x32 --distances 8 --frames 1 --methods reference,er+gaze,er-ftb+gaze --out-dir b";
    let args: Vec<&str> = line.split_whitespace().collect();
    let out = ercube(d, &args);
    assert!(out.status.success(), "{}", describe(&args, &out));
    let csv = std::fs::read_to_string(d.join("b/bench.csv")).expect("csv");
    assert!(
        csv.contains("er+gaze") && csv.contains("er-ftb+gaze"),
        "{csv}"
    );
    for (line, needle) in [
        (
            "compare --scene ml:24 --size 32x32 --methods under --gaze 3,3",
            "--gaze needs",
        ),
        (
            "bench --scene ml:24 --size 32x32 --methods box+gaze",
            "er-ftb+gaze take a gaze",
        ),
    ] {
        let args: Vec<&str> = line.split_whitespace().collect();
        assert_refused(&args, &ercube(d, &args), needle);
    }
}

/// Runs `ercube` on the words of `line` in `dir`, which must succeed and
/// write its stats to `s.json`; returns them.
fn stats_of(dir: &Path, line: &str) -> serde_json::Value {
    let args: Vec<&str> = line.split_whitespace().collect();
    let out = ercube(dir, &args);
    assert!(out.status.success(), "{}", describe(&args, &out));
    serde_json::from_str(&std::fs::read_to_string(dir.join("s.json")).expect("stats"))
        .expect("json")
}

/// `--rays footprint`: a view as fine as the voxels renders ER's own frame
/// byte for byte; a far one renders one coarse level (in the stats) with
/// at most a quarter of the samples; the flag is refused beside `--gaze`
/// and for other methods.
#[test]
fn rays_footprint_follows_the_image() {
    let dir = tempfile::tempdir().expect("temporary directory");
    let d = dir.path();
    let run = |line: &str| stats_of(d, line);
    for m in ["er", "er-ftb"] {
        let near = format!("render --scene ml:24 --size 96x96 --method {m} --stats s.json");
        run(&format!("{near} --out voxels.png"));
        let v = run(&format!("{near} --rays footprint --out footprint.png"));
        assert!(v["er_gaze"].is_null(), "{m}: {}", v["er_gaze"]);
        assert_eq!(
            std::fs::read(d.join("voxels.png")).unwrap(),
            std::fs::read(d.join("footprint.png")).unwrap(),
            "{m}"
        );
        let far =
            format!("render --scene ml:24 --size 32x32 --eye 12,12,-300 --fov 20 --method {m} --stats s.json --out o.png");
        let full = run(&far)["samples_total"].as_u64().unwrap();
        let v = run(&format!("{far} --rays footprint"));
        let levels = v["er_gaze"]["levels"].as_array().expect("levels");
        let used: Vec<u64> = levels
            .iter()
            .filter(|l| l["samples"].as_u64().unwrap() > 0)
            .map(|l| l["level"].as_u64().unwrap())
            .collect();
        assert_eq!(used.len(), 1, "{m}: one level renders: {levels:?}");
        assert!(used[0] >= 1, "{m}: {used:?}");
        let samples = v["er_gaze"]["samples_total"].as_u64().unwrap();
        assert!(4 * samples <= full, "{m}: {samples} samples against {full}");
    }
    let cases = [
        (
            "render --scene ml:24 --size 32x32 --method er --rays footprint --gaze 4,4 --out o.png",
            "--rays footprint and --gaze",
        ),
        (
            "render --scene ml:24 --size 32x32 --method reference --rays footprint --out o.png",
            "--rays footprint applies to --method er, er-ftb, pipeline",
        ),
    ];
    for (line, needle) in cases {
        let args: Vec<&str> = line.split_whitespace().collect();
        assert_refused(&args, &ercube(d, &args), needle);
    }
}

/// `--rays footprint` in the pipeline: the host loads the PEs with the
/// prefiltered level golden's `--rays footprint` frame renders. Near, the
/// level is 0 and the frame is the plain one word for word; far, the PEs
/// clock a coarse level (in the stats) in at most a third of the cycles,
/// and the image stays within the frame's derived bound of golden er's own
/// `--rays footprint` image, in both orders. `--gaze` is refused rather
/// than ignored.
#[test]
fn pipeline_rays_footprint_loads_the_prefiltered_level() {
    let dir = tempfile::tempdir().expect("temporary directory");
    let d = dir.path();
    let run = |line: &str| stats_of(d, line);
    let read = |name: &str| std::fs::read(d.join(name)).expect(name);
    // Front to back without early termination: the bound is derived
    // for that (`--terminate 1`).
    for (m, twin, opts) in [
        ("pipeline", "er", ""),
        ("pipeline-ftb", "er-ftb", "--terminate 1"),
    ] {
        let near = format!(
            "render --scene ml:24 --size 96x96 --method {m} --pes 4 --stats s.json --out o.png"
        );
        run(&format!("{near} --raw-npy voxels.npy"));
        let v = run(&format!("{near} --rays footprint --raw-npy footprint.npy"));
        assert_eq!(v["footprint"]["level"], 0, "{m}: {}", v["footprint"]);
        assert_eq!(read("voxels.npy"), read("footprint.npy"), "{m}");

        let far = format!(
            "--scene ml:24 --size 32x32 --eye 12,12,-300 --fov 20 --stats s.json --out o.png {opts}"
        );
        let full = run(&format!("render {far} --method {m} --pes 4"));
        let v = run(&format!(
            "render {far} --method {m} --pes 4 --rays footprint --npy chip.npy"
        ));
        assert!(
            v["footprint"]["level"].as_u64().unwrap() >= 1,
            "{m}: {}",
            v["footprint"]
        );
        let (c, c_full) = (
            v["cycles"].as_u64().unwrap(),
            full["cycles"].as_u64().unwrap(),
        );
        assert!(3 * c <= c_full, "{m}: {c} cycles against {c_full}");
        let bound = v["bound"]["value_255"].as_f64().expect("a derived bound");
        run(&format!(
            "render {far} --method {twin} --rays footprint --npy golden.npy"
        ));
        let (chip, gold) = (
            read_npy(&d.join("chip.npy")),
            read_npy(&d.join("golden.npy")),
        );
        assert_eq!((chip.0, chip.1), (gold.0, gold.1), "{m}");
        let (chip, gold) = (chip.2, gold.2);
        let max = chip
            .iter()
            .zip(&gold)
            .map(|(a, b)| f64::from((a - b).abs()) * 255.0)
            .fold(0.0, f64::max);
        assert!(
            max <= bound,
            "{m}: {max} /255 from golden {twin}'s footprint frame, bound {bound}"
        );
    }
    let line = "render --scene ml:24 --size 32x32 --method pipeline --gaze 4,4 --out o.png";
    let args: Vec<&str> = line.split_whitespace().collect();
    assert_refused(
        &args,
        &ercube(d, &args),
        "--gaze, --refine and --compare-full apply to the golden methods",
    );
}
