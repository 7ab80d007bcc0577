//! `render`: its outputs and their formats, and that the image is sensible.

use serde_json::Value;

use super::{
    assert_one_line_error, entries, ercube, f64s, num, read_json, read_npy, read_png,
    read_rgba_npy, tempdir, u64s, volume_dims,
};

// ---------------------------------------------------------------------------
// render: outputs and their formats
// ---------------------------------------------------------------------------

/// `--npy`, `--stats` and `--compare-reference` on a view straight along +z:
/// the image array's header and values, and every stats field the contract
/// names with its type and (where the geometry fixes it) its value.
#[test]
fn render_writes_npy_and_stats() {
    let dir = tempdir();
    let run = ercube(
        dir.path(),
        "render --scene checker:32 --eye 15.5,15.5,-40 --size 32x24 --method er \
         --out img.png --npy final.npy --stats stats.json --compare-reference",
    )
    .ok();
    // The summary line names the method.
    assert!(run.stdout().contains("er"), "{}", run.describe());

    // PNG: W x H as asked (non-square, so a swapped order shows).
    let png = read_png(&dir.path().join("img.png"));
    assert_eq!(png.dimensions(), (32, 24));

    // NumPy: H x W x 4, and the same picture as the PNG (over black).
    let vals = read_rgba_npy(&dir.path().join("final.npy"), 24, 32);
    assert!(vals.iter().any(|&v| v > 0.05), "image is black");
    for (k, px) in png.pixels().enumerate() {
        for c in 0..3 {
            let want = (vals[4 * k + c].clamp(0.0, 1.0) * 255.0).round() as i32;
            assert!((px[c] as i32 - want).abs() <= 1, "pixel {k} channel {c}");
        }
    }

    let s = read_json(&dir.path().join("stats.json"));
    assert_eq!(s["method"], "er");
    assert_eq!(volume_dims(&s), vec![32, 32, 32]);
    assert_eq!(f64s(&s, "eye"), vec![15.5, 15.5, -40.0]);
    // Eye at z < 0 in front of the volume: the view runs along +z, and D is
    // the distance from the eye to slice 0 (z = 0) along z.
    assert_eq!(s["principal_axis"], "+z");
    assert!((num(&s, "D") - 40.0).abs() < 1e-9, "D in {s}");
    assert!(num(&s, "time_s") >= 0.0);

    let e = &s["error_vs_reference"];
    assert!(e.is_object(), "error_vs_reference missing: {s}");
    let (max, rmse) = (num(e, "max_abs_255"), num(e, "rmse"));
    assert!((0.0..=255.0).contains(&max), "max_abs_255 {max}");
    assert!((0.0..=1.0).contains(&rmse), "rmse {rmse}");
    // ER is an approximation of the reference, not a different picture.
    assert!(rmse < 0.25, "er is far from the reference: rmse {rmse}");
    match e["psnr"].as_f64() {
        Some(p) => assert!((p - 20.0 * (1.0 / rmse).log10()).abs() < 1e-6, "psnr {p}"),
        // Only identical images have an infinite (null) PSNR.
        None => assert!(e["psnr"].is_null() && rmse == 0.0, "psnr {}", e["psnr"]),
    }

    // Counts of a slice-order method.
    let per_slice = u64s(&s, "samples_per_slice");
    assert_eq!(per_slice.len(), 32, "one count per slice (nz)");
    let total = s["samples_total"].as_u64().expect("samples_total");
    assert_eq!(total, per_slice.iter().sum::<u64>());
    assert!(total > 0);
    let regions = f64s(&s, "regions");
    assert!(regions.len() >= 2, "regions are boundaries: {regions:?}");
    assert!(regions.windows(2).all(|w| w[0] < w[1]), "{regions:?}");
    let rays = u64s(&s, "rays_per_region");
    assert_eq!(rays.len(), regions.len() - 1, "one ray count per region");
    assert!(s["merges"].as_u64().is_some(), "merges: {}", s["merges"]);
}

/// The final image is premultiplied RGBA in [0, 1], exactly: a value even
/// one ulp above 1 is outside the documented range (and `1 - alpha` turns
/// negative for anyone compositing the `.npy` further). Opaque scenes reach
/// alpha 1, where rounding would show.
#[test]
fn npy_values_lie_in_the_unit_interval() {
    let dir = tempdir();
    let mut bad = Vec::new();
    for method in ["er", "er-ftb", "under", "over", "box", "reference"] {
        let npy = format!("{method}.npy");
        ercube(
            dir.path(),
            &format!(
                "render --scene checker:32 --size 32x32 --method {method} --npy {npy} --out o.png"
            ),
        )
        .ok();
        let vals = read_npy(&dir.path().join(&npy)).values;
        let outside = vals
            .iter()
            .filter(|v| !(v.is_finite() && (0.0..=1.0).contains(*v)))
            .count();
        let max = vals.iter().copied().fold(f32::MIN, f32::max);
        if outside > 0 {
            bad.push(format!(
                "{method}: {outside} values outside [0, 1], max {max:e}"
            ));
        }
    }
    assert!(bad.is_empty(), "{}", bad.join("\n"));
}

/// The principal axis and D follow the eye to the other faces: behind the
/// volume (-z) and to its side (+x).
#[test]
fn principal_axis_and_d_follow_the_eye() {
    let dir = tempdir();
    // (eye, axis, D): the volume spans 0..=31 on each axis.
    let cases = [
        ("15.5,15.5,71", "0,1,0", "-z", 40.0),
        ("-25,15.5,15.5", "0,1,0", "+x", 25.0),
        ("15.5,50,15.5", "0,0,1", "-y", 19.0),
    ];
    for (eye, up, axis, d) in cases {
        ercube(
            dir.path(),
            &format!(
                "render --scene checker:32 --size 16x16 --eye {eye} --up {up} --stats s.json --out o.png"
            ),
        )
        .ok();
        let s = read_json(&dir.path().join("s.json"));
        assert_eq!(s["principal_axis"], axis, "eye {eye}");
        assert!((num(&s, "D") - d).abs() < 1e-9, "eye {eye}: D in {s}");
    }
}

/// The documented defaults (look at the centre, up +y, 60 degrees, 256x256)
/// give the same bits as spelling them out.
#[test]
fn defaults_equal_their_explicit_values() {
    let dir = tempdir();
    ercube(
        dir.path(),
        "render --scene checker:32 --eye 10,20,-40 --npy a.npy --stats a.json --out a.png",
    )
    .ok();
    ercube(
        dir.path(),
        "render --scene checker:32 --eye 10,20,-40 --look-at 15.5,15.5,15.5 --up 0,1,0 \
         --fov 60 --size 256x256 --npy b.npy --out b.png",
    )
    .ok();
    let a = read_rgba_npy(&dir.path().join("a.npy"), 256, 256);
    let b = read_rgba_npy(&dir.path().join("b.npy"), 256, 256);
    assert!(a == b, "defaults differ from the explicit values");
    assert_eq!(read_png(&dir.path().join("a.png")).dimensions(), (256, 256));
    assert_eq!(
        u64s(&read_json(&dir.path().join("a.json")), "image"),
        [256, 256]
    );
}

/// `--baseplane-npy` writes the baseplane as float32 H x W x 4 whose size is
/// the one the stats report; the reference has no baseplane.
#[test]
fn baseplane_npy() {
    let dir = tempdir();
    ercube(
        dir.path(),
        "render --scene sphere:24 --size 32x32 --method er --baseplane-npy base.npy \
         --stats s.json --out o.png",
    )
    .ok();
    let s = read_json(&dir.path().join("s.json"));
    let size = u64s(&s["baseplane"], "size");
    assert_eq!(size.len(), 2, "baseplane size [w, h]: {s}");
    let vals = read_rgba_npy(
        &dir.path().join("base.npy"),
        size[1] as usize,
        size[0] as usize,
    );
    // The sphere is in view, so the baseplane holds something.
    assert!(vals.iter().any(|&v| v > 0.01), "baseplane is empty");

    let run = ercube(
        dir.path(),
        "render --scene sphere:24 --size 32x32 --method reference --baseplane-npy ref_base.npy \
         --out ref.png",
    );
    assert_one_line_error(&run, "baseplane");
    assert!(!dir.path().join("ref_base.npy").exists());
}

/// A command that ends in an error should not leave its outputs behind: the
/// reference/baseplane conflict is known from the arguments alone, yet the
/// PNG is rendered and written before the error is reported.
#[test]
fn baseplane_with_reference_fails_before_writing_anything() {
    let dir = tempdir();
    let run = ercube(
        dir.path(),
        "render --scene sphere:16 --size 16x16 --method reference --baseplane-npy b.npy \
         --npy f.npy --out o.png",
    );
    assert_one_line_error(&run, "baseplane");
    assert!(
        entries(dir.path()).is_empty(),
        "a failed run left files behind: {:?}",
        entries(dir.path())
    );
}

/// `render --method mipmap` writes its PNG and stats with the samples and
/// the levels' histogram; a bad `--mip-step` or `--mip-classify` is a
/// one-line error.
#[test]
fn render_mipmap_writes_png_and_stats_and_refuses_bad_options() {
    let dir = tempdir();
    let d = dir.path();
    ercube(
        d,
        "render --scene ml:24 --eye 11.5,11.5,-200 --fov 20 --size 24x16 --method mipmap \
         --out m.png --stats m.json",
    )
    .ok();
    assert_eq!(read_png(&d.join("m.png")).dimensions(), (24, 16));
    let v: Value = serde_json::from_str(&std::fs::read_to_string(d.join("m.json")).unwrap())
        .expect("stats JSON");
    assert_eq!(v["method"], "mipmap");
    let m = &v["mipmap"];
    assert_eq!(m["classify"], "post");
    let hist: Vec<u64> = serde_json::from_value(m["level_histogram"].clone()).unwrap();
    assert_eq!(hist.len() as u64, m["levels"].as_u64().unwrap());
    assert_eq!(
        hist.iter().sum::<u64>(),
        m["samples_total"].as_u64().unwrap()
    );
    assert!(m["samples_total"].as_u64().unwrap() > 0);
    let before = entries(d);
    for (arg, keyword) in [
        ("--mip-step 0", "mip-map step"),
        ("--mip-step 9", "mip-map step"),
        ("--mip-step nan", "mip-map step"),
        ("--mip-classify sideways", "pre or post"),
    ] {
        let run = ercube(
            d,
            &format!("render --scene ml:16 --method mipmap {arg} --out x.png"),
        );
        assert_one_line_error(&run, keyword);
    }
    assert_eq!(entries(d), before, "a refused run writes nothing");
}

// ---------------------------------------------------------------------------
// render: the image is sensible
// ---------------------------------------------------------------------------

/// An impulse looked at head-on images to a spot at the image centre.
#[test]
fn impulse_is_imaged_at_the_centre() {
    let dir = tempdir();
    // impulse:16 puts its voxel at (8, 8, 8).
    ercube(
        dir.path(),
        "render --scene impulse:16 --tf impulse --method er --eye 8,8,-24 --look-at 8,8,8 \
         --size 32x32 --out imp.png",
    )
    .ok();
    let img = read_png(&dir.path().join("imp.png"));
    let (mut best, mut at) = (0u32, (0u32, 0u32));
    for (x, y, p) in img.enumerate_pixels() {
        let v = p[0] as u32 + p[1] as u32 + p[2] as u32;
        if v > best {
            (best, at) = (v, (x, y));
        }
    }
    assert!(best > 0, "the impulse is invisible");
    // The centre of a 32-pixel image lies between pixels 15 and 16.
    let (dx, dy) = (at.0 as f64 - 15.5, at.1 as f64 - 15.5);
    assert!(
        dx.hypot(dy) <= 2.0,
        "brightest pixel {at:?}, expected near the centre"
    );
}

/// A sphere in the middle of the view: visible in the middle, black in the
/// corners (the default camera leaves margin around the volume).
#[test]
fn sphere_is_in_the_middle_and_corners_are_black() {
    let dir = tempdir();
    ercube(
        dir.path(),
        "render --scene sphere:24 --size 32x32 --out s.png",
    )
    .ok();
    let img = read_png(&dir.path().join("s.png"));
    let centre = img.get_pixel(16, 16);
    assert!(
        centre.0.iter().any(|&c| c > 20),
        "centre pixel {centre:?} is black"
    );
    for (x, y) in [(0, 0), (31, 0), (0, 31), (31, 31)] {
        assert_eq!(img.get_pixel(x, y).0, [0, 0, 0], "corner ({x}, {y})");
    }
}

/// Same input, same bits, whatever the thread count, for a slice-order
/// method and for the reference.
#[test]
fn thread_count_does_not_change_the_bits() {
    let dir = tempdir();
    for method in ["er", "reference"] {
        let mut files = Vec::new();
        for threads in [1, 2] {
            let npy = format!("{method}-{threads}.npy");
            ercube(
                dir.path(),
                &format!(
                    "render --scene checker:32 --size 48x40 --method {method} --threads {threads} \
                     --npy {npy} --out {method}-{threads}.png"
                ),
            )
            .ok();
            files.push(std::fs::read(dir.path().join(npy)).unwrap());
        }
        // Not trivially equal: the image has content.
        let vals = read_rgba_npy(&dir.path().join(format!("{method}-1.npy")), 40, 48);
        assert!(vals.iter().any(|&v| v > 0.05), "{method}: black image");
        assert!(files[0] == files[1], "{method}: --threads 1 and 2 differ");
    }
}

/// Skipping is on by default and off-switchable; the image is the same
/// bits either way (float `.npy`), the stats say what was skipped, and a
/// clip plane through the volume changes the image.
#[test]
fn skipping_flags_keep_the_image_and_report_counts() {
    let dir = tempdir();
    let d = dir.path();
    let base = "render --scene sphere:48 --block 4 --size 48x40 --eye 23.5,23.5,-30 --fov 70";
    for m in ["er", "er-ftb", "over"] {
        let term = if m == "er-ftb" { " --terminate 1" } else { "" };
        ercube(
            d,
            &format!("{base} --method {m}{term} --npy on.npy --stats on.json --out on.png"),
        )
        .ok();
        ercube(
            d,
            &format!("{base} --method {m}{term} --no-skip-empty --no-cull --npy off.npy --stats off.json --out off.png"),
        )
        .ok();
        let (on, off) = (read_npy(&d.join("on.npy")), read_npy(&d.join("off.npy")));
        assert_eq!(on.values, off.values, "{m}: skipping changed the image");
        let json = |f: &str| -> Value {
            serde_json::from_str(&std::fs::read_to_string(d.join(f)).unwrap()).unwrap()
        };
        let (son, soff) = (json("on.json"), json("off.json"));
        let samples = |v: &Value| v["samples_total"].as_u64().unwrap();
        assert!(
            samples(&son) * 2 < samples(&soff),
            "{m}: {} vs {}",
            samples(&son),
            samples(&soff)
        );
        assert!(
            son["skipped"]["beams"].as_u64().unwrap() > 0,
            "{m}: {}",
            son["skipped"]
        );
        assert_eq!(soff["skipped"]["beams"].as_u64(), Some(0));
        let occ = son["skipped"]["occupied_blocks"].as_f64().unwrap();
        assert!(occ > 0.0 && occ < 1.0, "{m}: occupied {occ}");
    }
    ercube(
        d,
        &format!("{base} --clip 1,0,0,-24 --npy clip.npy --out clip.png"),
    )
    .ok();
    ercube(d, &format!("{base} --npy whole.npy --out whole.png")).ok();
    assert_ne!(
        read_npy(&d.join("clip.npy")).values,
        read_npy(&d.join("whole.npy")).values
    );
}
