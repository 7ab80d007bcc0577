//! Integration tests of the `ercube` command line: the real binary, run in
//! temporary directories, against the contract of `render`, `compare` and
//! `demo` (outputs, file formats, loaders, the one-line error rule, atomic
//! writes and thread-count independence).
//!
//! Scenes and images are kept small (the reference renderer is the slow
//! part) so the whole file runs in a few seconds in release.

use std::path::Path;
use std::process::Output;

use serde_json::Value;

// ---------------------------------------------------------------------------
// Helpers
// ---------------------------------------------------------------------------

/// One finished run of the binary.
struct Run {
    args: Vec<String>,
    out: Output,
}

impl Run {
    fn stdout(&self) -> String {
        String::from_utf8_lossy(&self.out.stdout).into_owned()
    }

    fn stderr(&self) -> String {
        String::from_utf8_lossy(&self.out.stderr).into_owned()
    }

    /// Describes the run for assertion messages.
    fn describe(&self) -> String {
        crate::bin::describe(&self.args, &self.out)
    }

    /// Asserts the run succeeded and returns it.
    #[track_caller]
    fn ok(self) -> Run {
        assert!(
            self.out.status.success(),
            "expected success:\n{}",
            self.describe()
        );
        self
    }
}

/// Runs `ercube` with whitespace-separated `args` in `dir`. Arguments are
/// relative file names, so the temporary directory's path never needs
/// quoting.
fn ercube(dir: &Path, args: &str) -> Run {
    ercube_args(dir, args.split_whitespace().map(String::from).collect())
}

/// Runs `ercube` with exactly `args` (for paths that may hold spaces).
fn ercube_args(dir: &Path, args: Vec<String>) -> Run {
    let out = crate::bin::ercube(dir, &args);
    Run { args, out }
}

fn tempdir() -> tempfile::TempDir {
    tempfile::tempdir().expect("temporary directory")
}

/// Names of the entries of `dir`, sorted.
fn entries(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .expect("readable directory")
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    v.sort();
    v
}

/// A parsed `.npy` file: its shape and float32 values.
struct Npy {
    shape: Vec<usize>,
    values: Vec<f32>,
}

/// Reads a float32 `.npy` file, checking the header byte by byte against the
/// NumPy format specification (version 1.0).
#[track_caller]
fn read_npy(path: &Path) -> Npy {
    let bytes = std::fs::read(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    assert!(bytes.len() >= 10, "{}: too short for .npy", path.display());
    assert_eq!(&bytes[..6], b"\x93NUMPY", "magic string");
    assert_eq!((bytes[6], bytes[7]), (1, 0), "format version 1.0");
    let hlen = u16::from_le_bytes([bytes[8], bytes[9]]) as usize;
    let start = 10 + hlen;
    assert!(
        bytes.len() >= start,
        "header length {hlen} runs past the file"
    );
    // The spec pads the header so the data starts 64-byte aligned.
    assert_eq!(start % 64, 0, "data offset {start} is not 64-byte aligned");
    let header = std::str::from_utf8(&bytes[10..start]).expect("ASCII header");
    assert!(
        header.ends_with('\n'),
        "header ends with a newline: {header:?}"
    );
    assert!(
        header.contains("'descr': '<f4'"),
        "little-endian float32: {header}"
    );
    assert!(
        header.contains("'fortran_order': False"),
        "C order: {header}"
    );
    let shape_text = header
        .split("'shape': (")
        .nth(1)
        .and_then(|s| s.split(')').next())
        .unwrap_or_else(|| panic!("no shape in {header}"));
    let shape: Vec<usize> = shape_text
        .split(',')
        .map(str::trim)
        .filter(|s| !s.is_empty())
        .map(|s| s.parse().expect("shape entries are integers"))
        .collect();
    let count: usize = shape.iter().product();
    assert_eq!(
        bytes.len() - start,
        count * 4,
        "data length for shape {shape:?}"
    );
    let values = bytes[start..]
        .chunks_exact(4)
        .map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]]))
        .collect();
    Npy { shape, values }
}

/// Checks that an `.npy` is an `h x w x 4` RGBA image of finite values in
/// [0, 1] and returns its values. One float32 ulp of slack above 1 is
/// allowed here so that tests about other things are not masked by the
/// rounding defect that `npy_values_lie_in_the_unit_interval` pins down.
#[track_caller]
fn read_rgba_npy(path: &Path, h: usize, w: usize) -> Vec<f32> {
    let npy = read_npy(path);
    assert_eq!(npy.shape, vec![h, w, 4], "{}: shape", path.display());
    for (k, v) in npy.values.iter().enumerate() {
        assert!(
            v.is_finite() && (0.0..=1.0 + 1e-6).contains(v),
            "{}: value {v} at {k} outside [0, 1]",
            path.display()
        );
    }
    npy.values
}

#[track_caller]
fn read_json(path: &Path) -> Value {
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    serde_json::from_str(&text).unwrap_or_else(|e| panic!("{}: {e}\n{text}", path.display()))
}

#[track_caller]
fn num(v: &Value, key: &str) -> f64 {
    v[key]
        .as_f64()
        .unwrap_or_else(|| panic!("'{key}' is not a number in {v}"))
}

#[track_caller]
fn u64s(v: &Value, key: &str) -> Vec<u64> {
    v[key]
        .as_array()
        .unwrap_or_else(|| panic!("'{key}' is not an array in {v}"))
        .iter()
        .map(|x| {
            x.as_u64()
                .unwrap_or_else(|| panic!("'{key}' holds {x}, not a count"))
        })
        .collect()
}

#[track_caller]
fn f64s(v: &Value, key: &str) -> Vec<f64> {
    v[key]
        .as_array()
        .unwrap_or_else(|| panic!("'{key}' is not an array in {v}"))
        .iter()
        .map(|x| x.as_f64().unwrap_or_else(|| panic!("'{key}' holds {x}")))
        .collect()
}

/// The stats `volume` field as dimensions.
#[track_caller]
fn volume_dims(stats: &Value) -> Vec<u64> {
    u64s(stats, "volume")
}

/// Decodes a PNG written by the CLI.
#[track_caller]
fn read_png(path: &Path) -> image::RgbImage {
    image::open(path)
        .unwrap_or_else(|e| panic!("{}: {e}", path.display()))
        .to_rgb8()
}

/// Checks the one-line error contract for a failed run and returns the
/// message; `keyword` (case-blind) must occur in it. Returns a description
/// of every broken rule rather than panicking, so a table of cases reports
/// all failures at once.
fn error_problems(run: &Run, keyword: &str) -> Vec<String> {
    let mut problems = Vec::new();
    let err = run.stderr();
    match run.out.status.code() {
        None => problems.push("killed by a signal".to_string()),
        Some(0) => problems.push("exit code 0".to_string()),
        Some(_) => {}
    }
    let msg = err.strip_suffix('\n').unwrap_or(&err);
    if msg.trim().is_empty() {
        problems.push("empty stderr".into());
    }
    if msg.contains('\n') {
        problems.push(format!("{} lines on stderr", msg.lines().count()));
    }
    if err.contains("panicked") || err.contains("RUST_BACKTRACE") {
        problems.push("panic text on stderr".into());
    }
    if !msg.to_lowercase().contains(&keyword.to_lowercase()) {
        problems.push(format!("message does not mention '{keyword}'"));
    }
    problems
}

/// Asserts the one-line error contract for a single run.
#[track_caller]
fn assert_one_line_error(run: &Run, keyword: &str) {
    let p = error_problems(run, keyword);
    assert!(p.is_empty(), "{}:\n{}", p.join("; "), run.describe());
}

/// A small u8 test volume: a bright ball (200) in a faint gradient, so the
/// default grey-ramp transfer function shows structure and a mis-read
/// layout (wrong axis order, byte order or offset) changes the image.
fn ball(dims: [usize; 3]) -> Vec<u8> {
    let c = dims.map(|n| (n as f64 - 1.0) / 2.0);
    let mut v = Vec::with_capacity(dims.iter().product());
    for z in 0..dims[2] {
        for y in 0..dims[1] {
            for x in 0..dims[0] {
                let d = ((x as f64 - c[0]).powi(2)
                    + (y as f64 - c[1]).powi(2)
                    + (z as f64 - c[2]).powi(2))
                .sqrt();
                v.push(if d < 3.5 { 200 } else { (x * 3 + y * 2) as u8 });
            }
        }
    }
    v
}

/// A VolPack `.den` file: the 62-byte little-endian header, then the voxels.
fn den_file(dims: [usize; 3], voxels: &[u8]) -> Vec<u8> {
    let d = dims.map(|n| n as i16);
    let mut b = Vec::new();
    b.extend(1i16.to_le_bytes()); // version
                                  // orig_min, orig_max, orig_len, extr_min, extr_max, extr_len,
                                  // map_min, map_max, map_len.
    let zero = [0i16; 3];
    let max = d.map(|n| n - 1);
    for triple in [zero, max, d, zero, max, d, zero, max, d] {
        for v in triple {
            b.extend(v.to_le_bytes());
        }
    }
    b.extend(0i16.to_le_bytes()); // map_warps
    b.extend((voxels.len() as i32).to_le_bytes()); // map_length
    assert_eq!(b.len(), 62);
    b.extend_from_slice(voxels);
    b
}

/// A single-file NIfTI-1 `.nii` of uint8 voxels with unit spacing: the
/// 348-byte header, the 4-byte extension flag, then the voxels at 352.
fn nifti_u8(dims: [usize; 3], voxels: &[u8]) -> Vec<u8> {
    let mut h = vec![0u8; 348];
    h[0..4].copy_from_slice(&348i32.to_le_bytes()); // sizeof_hdr
    let dim = [
        3,
        dims[0] as i16,
        dims[1] as i16,
        dims[2] as i16,
        1,
        1,
        1,
        1,
    ];
    for (k, d) in dim.iter().enumerate() {
        h[40 + 2 * k..42 + 2 * k].copy_from_slice(&d.to_le_bytes());
    }
    h[70..72].copy_from_slice(&2i16.to_le_bytes()); // datatype: uint8
    h[72..74].copy_from_slice(&8i16.to_le_bytes()); // bitpix
    for k in 0..8 {
        h[76 + 4 * k..80 + 4 * k].copy_from_slice(&1.0f32.to_le_bytes()); // pixdim
    }
    h[108..112].copy_from_slice(&352.0f32.to_le_bytes()); // vox_offset
    h[112..116].copy_from_slice(&1.0f32.to_le_bytes()); // scl_slope
    h[344..348].copy_from_slice(b"n+1\0");
    h.extend([0u8; 4]);
    h.extend_from_slice(voxels);
    h
}

// ---------------------------------------------------------------------------
// Help
// ---------------------------------------------------------------------------

/// `--help` is a request, not an error: exit 0 with usage on stdout, for the
/// program and each command.
#[test]
fn help_exits_zero() {
    let dir = tempdir();
    for args in ["--help", "render --help", "compare --help", "demo --help"] {
        let run = ercube(dir.path(), args).ok();
        assert!(run.stdout().contains("Usage"), "{}", run.describe());
    }
    // Help must not render anything.
    assert!(entries(dir.path()).is_empty());
}

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

// ---------------------------------------------------------------------------
// render: loaders
// ---------------------------------------------------------------------------

/// Renders `volume_args` with stats and an `.npy`, returning both.
#[track_caller]
fn render_file(dir: &Path, volume_args: &str, tag: &str) -> (Value, Vec<u8>) {
    ercube(
        dir,
        &format!(
            "render {volume_args} --size 24x24 --stats {tag}.json --npy {tag}.npy --out {tag}.png"
        ),
    )
    .ok();
    (
        read_json(&dir.join(format!("{tag}.json"))),
        std::fs::read(dir.join(format!("{tag}.npy"))).unwrap(),
    )
}

/// Raw u8 with a header offset, VolPack `.den` and NIfTI-1 `.nii` holding
/// the same voxels load to the same dimensions and render the same bits;
/// raw u16 in either byte order renders the same as the other.
#[test]
fn loaders_through_the_cli() {
    let dir = tempdir();
    let d = dir.path();
    let dims = [16, 12, 10];
    let vox = ball(dims);

    // Raw u8 after a 7-byte header we ask the loader to skip.
    let mut raw = b"HEADER!".to_vec();
    raw.extend_from_slice(&vox);
    std::fs::write(d.join("vol.raw"), &raw).unwrap();
    let (s_raw, img_raw) = render_file(
        d,
        "--volume vol.raw --raw-dims 16,12,10 --raw-type u8 --raw-offset 7",
        "raw",
    );
    assert_eq!(volume_dims(&s_raw), [16, 12, 10]);
    let vals = read_rgba_npy(&d.join("raw.npy"), 24, 24);
    assert!(
        vals.iter().any(|&v| v > 0.05),
        "raw u8 volume renders black"
    );

    std::fs::write(d.join("vol.den"), den_file(dims, &vox)).unwrap();
    let (s_den, img_den) = render_file(d, "--volume vol.den", "den");
    assert_eq!(volume_dims(&s_den), [16, 12, 10]);
    assert!(
        img_den == img_raw,
        ".den and raw u8 of the same voxels differ"
    );

    std::fs::write(d.join("vol.nii"), nifti_u8(dims, &vox)).unwrap();
    let (s_nii, img_nii) = render_file(d, "--volume vol.nii", "nii");
    assert_eq!(volume_dims(&s_nii), [16, 12, 10]);
    assert!(
        img_nii == img_raw,
        ".nii and raw u8 of the same voxels differ"
    );

    // 16-bit raw, both byte orders, values 0..=200 scaled to span the range.
    let wide: Vec<u16> = vox.iter().map(|&v| v as u16 * 300).collect();
    let le: Vec<u8> = wide.iter().flat_map(|v| v.to_le_bytes()).collect();
    let be: Vec<u8> = wide.iter().flat_map(|v| v.to_be_bytes()).collect();
    std::fs::write(d.join("le.raw"), le).unwrap();
    std::fs::write(d.join("be.raw"), be).unwrap();
    let (s_le, img_le) = render_file(
        d,
        "--volume le.raw --raw-dims 16,12,10 --raw-type u16le",
        "le",
    );
    let (s_be, img_be) = render_file(
        d,
        "--volume be.raw --raw-dims 16,12,10 --raw-type u16be",
        "be",
    );
    assert_eq!(volume_dims(&s_le), [16, 12, 10]);
    assert_eq!(volume_dims(&s_be), [16, 12, 10]);
    let vals = read_rgba_npy(&d.join("le.npy"), 24, 24);
    assert!(
        vals.iter().any(|&v| v > 0.05),
        "raw u16 volume renders black"
    );
    // A byte-order mix-up would read different values and change the image.
    assert!(
        img_le == img_be,
        "u16le and u16be of the same values differ"
    );
}

/// The real `brainsmall.den` loads as a `.den` and, with its header skipped,
/// as raw bytes: same dimensions, same image.
#[test]
fn brainsmall_as_den_and_as_raw() {
    let Some(path) = crate::scenes::brainsmall() else {
        eprintln!("note: shared/data/brainsmall.den absent, skipping");
        return;
    };
    let dir = tempdir();
    let path = path.to_string_lossy().into_owned();
    let mut runs = Vec::new();
    for (tag, extra) in [
        ("den", vec![]),
        (
            "raw",
            vec!["--raw-dims", "128,128,84", "--raw-offset", "62"],
        ),
    ] {
        let mut args: Vec<String> = ["render", "--volume", &path]
            .iter()
            .map(|s| s.to_string())
            .collect();
        args.extend(extra.iter().map(|s| s.to_string()));
        for a in [
            "--size",
            "32x32",
            "--stats",
            &format!("{tag}.json"),
            "--npy",
            &format!("{tag}.npy"),
            "--out",
            &format!("{tag}.png"),
        ] {
            args.push(a.to_string());
        }
        ercube_args(dir.path(), args).ok();
        let s = read_json(&dir.path().join(format!("{tag}.json")));
        assert_eq!(volume_dims(&s), [128, 128, 84], "{tag}");
        let vals = read_rgba_npy(&dir.path().join(format!("{tag}.npy")), 32, 32);
        assert!(
            vals.iter().any(|&v| v > 0.05),
            "{tag}: the brain renders black"
        );
        runs.push(std::fs::read(dir.path().join(format!("{tag}.npy"))).unwrap());
    }
    assert!(runs[0] == runs[1], "brainsmall as .den and as raw differ");
}

// ---------------------------------------------------------------------------
// Bad input: one line, non-zero, no panic
// ---------------------------------------------------------------------------

/// Every malformed input of the contract exits non-zero with one line on
/// stderr naming the problem, and writes no image. All cases run before the
/// test fails, so one report lists every offender.
#[test]
fn bad_input_gives_one_line_errors() {
    let dir = tempdir();
    let d = dir.path();
    // Files for the loader and transfer-function cases.
    std::fs::write(d.join("short.raw"), [7u8; 100]).unwrap();
    std::fs::write(d.join("bad.toml"), "[[point]]\nvalue = \"x\"\n").unwrap();
    std::fs::write(d.join("junk.toml"), "garbage [[[").unwrap();
    std::fs::write(
        d.join("range.toml"),
        "[[point]]\nvalue = 0\nrgba = [1, 1, 1, 2]\n",
    )
    .unwrap();
    std::fs::write(d.join("bad.den"), [0xffu8; 62]).unwrap();
    std::fs::write(d.join("vol.xyz"), [0u8; 8]).unwrap();
    let before = entries(d);

    let s = "render --scene checker:16 --size 16x16";
    // (arguments after `ercube`, keyword the message must contain)
    let cases: Vec<(String, &str)> = vec![
        ("render --scene foo --size 16x16".into(), "scene"),
        ("render --scene sphere:x --size 16x16".into(), "scene"),
        ("render --scene checker:1 --size 16x16".into(), "size"),
        ("render --scene checker:16:0 --size 16x16".into(), "cube"),
        ("render --size 16x16".into(), "volume"),
        (format!("{s} --eye 1,2"), "eye"),
        (format!("{s} --eye a,b,c"), "eye"),
        (format!("{s} --fov abc"), "fov"),
        ("render --scene checker:16 --size 0x10".into(), "size"),
        (
            "render --scene checker:16 --size 100000x100000".into(),
            "size",
        ),
        ("render --scene checker:16 --size 10".into(), "size"),
        (format!("{s} --eye nan,0,0"), "finite"),
        (format!("{s} --fov NaN"), "field of view"),
        (format!("{s} --fov 0"), "field of view"),
        (format!("{s} --fov 180"), "field of view"),
        (format!("{s} --fov -5"), "field of view"),
        (format!("{s} --fov 200"), "field of view"),
        (
            format!("{s} --method pipeline --pes 4 --vcd w.vcd --trace-signals ctrl,bogus"),
            "signal group",
        ),
        (format!("{s} --block 3"), "block size"),
        (format!("{s} --block 128"), "block size"),
        (format!("{s} --clip 1,2,3"), "clip plane"),
        (format!("{s} --clip 0,0,0,1"), "clip plane"),
        (format!("{s} --clip 0,0,1,inf"), "clip plane"),
        (format!("{s} {}", "--clip 0,0,1,0 ".repeat(7)), "at most 6"),
        (format!("{s} --near 0"), "near"),
        (format!("{s} --near nan"), "near"),
        (format!("{s} --eye 3,4,-20 --look-at 3,4,-20"), "look-at"),
        // The default eye is straight in front of the volume along z.
        (format!("{s} --up 0,0,1"), "parallel"),
        (format!("{s} --up 0,0,0"), "up"),
        (
            "render --volume /nonexistent.den --size 16x16".into(),
            "nonexistent.den",
        ),
        (
            "render --volume short.raw --raw-dims 16,12,10 --size 16x16".into(),
            "truncated",
        ),
        (
            "render --volume short.raw --raw-dims 10,10,1 --raw-type f32 --size 16x16".into(),
            "raw",
        ),
        (
            "render --volume short.raw --raw-dims 0,10,10 --size 16x16".into(),
            "zero",
        ),
        ("render --volume bad.den --size 16x16".into(), "den"),
        ("render --volume vol.xyz --size 16x16".into(), "raw-dims"),
        (format!("{s} --tf-file bad.toml"), "transfer function"),
        (format!("{s} --tf-file junk.toml"), "transfer function"),
        (format!("{s} --tf-file range.toml"), "rgba"),
        (format!("{s} --tf-file missing.toml"), "missing.toml"),
        (format!("{s} --tf nope"), "preset"),
        (format!("{s} --method nope"), "method"),
        (format!("{s} --threads 0"), "threads"),
        (format!("{s} --terminate 2"), "terminat"),
        (format!("{s} --substeps 0"), "substeps"),
        (format!("{s} --image-plane sideways"), "image-plane"),
        (
            "compare --scene checker:16 --size 16x16 --methods er,nope --out-dir cmp".into(),
            "method",
        ),
        (
            "compare --scene checker:16 --size 16x16 --fov 0 --out-dir cmp".into(),
            "field of view",
        ),
    ];
    let mut failures = Vec::new();
    for (args, keyword) in &cases {
        // `render` gets an explicit output, which must not appear.
        let args = if args.starts_with("render") {
            format!("{args} --out o.png")
        } else {
            args.clone()
        };
        let run = ercube(d, &args);
        let mut problems = error_problems(&run, keyword);
        if entries(d) != before {
            problems.push(format!("left files behind: {:?}", entries(d)));
        }
        if !problems.is_empty() {
            failures.push(format!(
                "{}\n    => {}",
                run.describe(),
                problems.join("; ")
            ));
        }
        // Start the next case from the same directory contents.
        for name in entries(d) {
            if !before.contains(&name) {
                let p = d.join(&name);
                if p.is_dir() {
                    std::fs::remove_dir_all(p).unwrap();
                } else {
                    std::fs::remove_file(p).unwrap();
                }
            }
        }
    }
    assert!(
        failures.is_empty(),
        "{} of {} bad inputs broke the error contract:\n{}",
        failures.len(),
        cases.len(),
        failures.join("\n")
    );
}

/// A missing required argument is bad input like any other: the one line
/// must say which argument is missing. (`--raw-type` requires `--raw-dims`.)
#[test]
fn missing_required_argument_is_named() {
    let dir = tempdir();
    std::fs::write(dir.path().join("v.raw"), [0u8; 64]).unwrap();
    let run = ercube(
        dir.path(),
        "render --volume v.raw --raw-type u16le --size 16x16 --out o.png",
    );
    assert_one_line_error(&run, "raw-dims");
}

/// `--raw-dims` describes a `--volume` file; given with `--scene` it can
/// only be a mistake, and silently ignoring it hides the mistake.
#[test]
fn raw_flags_with_a_scene_are_refused() {
    let dir = tempdir();
    let run = ercube(
        dir.path(),
        "render --scene checker:16 --raw-dims 4,4,4 --size 16x16 --out o.png",
    );
    assert_one_line_error(&run, "raw-dims");
    assert!(!dir.path().join("o.png").exists());
}

/// File errors state the OS error once and name the user's path, not the
/// temporary file used for the atomic write. All three cases are checked
/// before the test fails.
#[test]
fn file_errors_are_stated_once() {
    let dir = tempdir();
    std::fs::create_dir(dir.path().join("adir")).unwrap();
    let cases = [
        (
            "render --volume /nonexistent.den --size 16x16 --out o.png",
            "/nonexistent.den",
            "No such file or directory",
        ),
        (
            "render --scene checker:16 --size 16x16 --out nodir/o.png",
            "nodir/o.png",
            "No such file or directory",
        ),
        (
            "render --scene checker:16 --size 16x16 --out adir",
            "adir",
            "Is a directory",
        ),
    ];
    let mut failures = Vec::new();
    for (args, path, os_error) in cases {
        let run = ercube(dir.path(), args);
        let mut problems = error_problems(&run, path);
        let err = run.stderr();
        if err.matches(os_error).count() != 1 {
            problems.push(format!("'{os_error}' is not stated exactly once"));
        }
        if err.contains(".tmp") {
            problems.push("names a temporary file".into());
        }
        if !problems.is_empty() {
            failures.push(format!(
                "{}\n    => {}",
                run.describe(),
                problems.join("; ")
            ));
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

// ---------------------------------------------------------------------------
// Atomic writes
// ---------------------------------------------------------------------------

/// Failed writes leave nothing behind: no output, no temporary file, no
/// created directory; an existing output survives a failed run untouched.
#[test]
fn failed_writes_leave_no_partial_files() {
    let dir = tempdir();
    let d = dir.path();

    // Output into a directory that does not exist.
    let run = ercube(
        d,
        "render --scene checker:16 --size 16x16 --out nodir/o.png",
    );
    assert_one_line_error(&run, "nodir");
    assert!(entries(d).is_empty(), "left behind: {:?}", entries(d));

    // Output path that is a directory: it stays an empty directory.
    std::fs::create_dir(d.join("adir")).unwrap();
    let run = ercube(d, "render --scene checker:16 --size 16x16 --out adir");
    assert_one_line_error(&run, "adir");
    assert!(d.join("adir").is_dir());
    assert!(entries(&d.join("adir")).is_empty());
    assert_eq!(entries(d), ["adir"], "stray files");

    // The same for the stats and npy writers, which run after the PNG.
    for flag in ["--stats", "--npy"] {
        let run = ercube(
            d,
            &format!("render --scene checker:16 --size 16x16 --out ok.png {flag} adir"),
        );
        assert_one_line_error(&run, "adir");
        assert!(entries(&d.join("adir")).is_empty());
        assert!(
            entries(d).iter().all(|n| n == "adir" || n == "ok.png"),
            "{flag}: stray files {:?}",
            entries(d)
        );
    }

    // An existing output is not truncated by a run that fails.
    std::fs::write(d.join("keep.png"), b"precious").unwrap();
    let run = ercube(
        d,
        "render --scene checker:16 --size 16x16 --fov 0 --out keep.png",
    );
    assert_one_line_error(&run, "field of view");
    assert_eq!(std::fs::read(d.join("keep.png")).unwrap(), b"precious");
}

/// A successful run replaces an existing output whole and leaves no
/// temporary files.
#[test]
fn successful_writes_replace_outputs_cleanly() {
    let dir = tempdir();
    let d = dir.path();
    std::fs::write(d.join("o.png"), vec![b'x'; 100_000]).unwrap();
    ercube(
        d,
        "render --scene sphere:16 --size 16x16 --out o.png --npy o.npy --stats o.json",
    )
    .ok();
    // A truncating in-place write of a shorter file would leave x's or fail
    // to decode.
    assert_eq!(read_png(&d.join("o.png")).dimensions(), (16, 16));
    read_rgba_npy(&d.join("o.npy"), 16, 16);
    read_json(&d.join("o.json"));
    assert_eq!(entries(d), ["o.json", "o.npy", "o.png"]);
}

/// Outputs are ordinary files: their permissions follow the umask like any
/// other file the user creates, rather than the 0600 of a temporary file.
#[cfg(unix)]
#[test]
fn outputs_have_ordinary_permissions() {
    use std::os::unix::fs::PermissionsExt;
    let dir = tempdir();
    let d = dir.path();
    ercube(
        d,
        "render --scene sphere:16 --size 16x16 --out o.png --stats o.json",
    )
    .ok();
    // What this process's umask gives a newly created file.
    std::fs::write(d.join("plain"), b"").unwrap();
    let mode = |n: &str| std::fs::metadata(d.join(n)).unwrap().permissions().mode() & 0o777;
    for name in ["o.png", "o.json"] {
        assert_eq!(
            format!("{:o}", mode(name)),
            format!("{:o}", mode("plain")),
            "{name}: permissions differ from a plainly created file"
        );
    }
}

// ---------------------------------------------------------------------------
// compare and demo
// ---------------------------------------------------------------------------

/// One parsed row of `compare.csv`.
struct CsvRow {
    method: String,
    time_s: f64,
    samples: Option<u64>,
    max_abs_255: f64,
    rmse: f64,
    psnr: f64,
}

#[track_caller]
fn read_compare_csv(path: &Path) -> Vec<CsvRow> {
    let text = std::fs::read_to_string(path).unwrap();
    let mut lines = text.lines();
    assert_eq!(
        lines.next(),
        Some("method,time_s,samples,max_abs_255,rmse,psnr"),
        "CSV header"
    );
    lines
        .map(|line| {
            let f: Vec<&str> = line.split(',').collect();
            assert_eq!(f.len(), 6, "CSV row {line:?}");
            let n = |s: &str| -> f64 { s.parse().unwrap_or_else(|_| panic!("{s:?} in {line:?}")) };
            CsvRow {
                method: f[0].to_string(),
                time_s: n(f[1]),
                samples: (f[2] != "-").then(|| f[2].parse().expect("sample count")),
                max_abs_255: n(f[3]),
                rmse: n(f[4]),
                psnr: n(f[5]),
            }
        })
        .collect()
}

/// `compare` writes each method's image, the montage, the CSV and JSON
/// tables and prints a row per method; its numbers agree with `render`.
#[test]
fn compare_writes_images_and_tables() {
    let dir = tempdir();
    let d = dir.path();
    let run = ercube(
        d,
        "compare --scene sphere:16 --size 32x32 --methods er,under,reference --out-dir D",
    )
    .ok();
    let out = d.join("D");
    for name in ["er", "under", "reference"] {
        assert_eq!(
            read_png(&out.join(format!("{name}.png"))).dimensions(),
            (32, 32),
            "{name}.png"
        );
        assert!(
            run.stdout()
                .lines()
                .any(|l| l.trim_start().starts_with(name)),
            "no table row for {name}:\n{}",
            run.stdout()
        );
    }
    // Three labelled panels side by side.
    let montage = read_png(&out.join("montage.png"));
    assert!(montage.width() > 3 * 32 && montage.width() > montage.height());

    let rows = read_compare_csv(&out.join("compare.csv"));
    let names: Vec<&str> = rows.iter().map(|r| r.method.as_str()).collect();
    assert_eq!(names, ["er", "under", "reference"]);
    for r in &rows {
        assert!(r.time_s >= 0.0, "{}: time {}", r.method, r.time_s);
        assert!((0.0..=255.0).contains(&r.max_abs_255), "{}", r.method);
        assert!(
            (0.0..=1.0).contains(&r.rmse),
            "{}: rmse {}",
            r.method,
            r.rmse
        );
        // Slice-order methods count samples; the reference does not.
        assert_eq!(r.samples.is_some(), r.method != "reference", "{}", r.method);
    }
    let reference = &rows[2];
    assert_eq!((reference.max_abs_255, reference.rmse), (0.0, 0.0));
    assert!(reference.psnr.is_infinite());
    for r in &rows[..2] {
        assert!(
            r.rmse > 0.0 && r.psnr.is_finite(),
            "{}: rmse {}",
            r.method,
            r.rmse
        );
        assert!(r.samples.unwrap() > 0);
    }

    let json = read_json(&out.join("compare.json"));
    let arr = json.as_array().expect("compare.json is an array");
    let jnames: Vec<&str> = arr.iter().map(|o| o["method"].as_str().unwrap()).collect();
    assert_eq!(jnames, names);
    for (o, r) in arr.iter().zip(&rows) {
        let e = &o["error_vs_reference"];
        assert!((num(e, "rmse") - r.rmse).abs() < 1e-6, "{}", r.method);
        assert_eq!(o["samples"].as_u64(), r.samples, "{}", r.method);
    }

    // The same view through `render` counts the same samples and finds the
    // same error.
    ercube(
        d,
        "render --scene sphere:16 --size 32x32 --method er --compare-reference --stats er.json \
         --out er.png",
    )
    .ok();
    let s = read_json(&d.join("er.json"));
    assert_eq!(s["samples_total"].as_u64(), rows[0].samples);
    assert!((num(&s["error_vs_reference"], "rmse") - rows[0].rmse).abs() < 1e-5);
}

/// `demo` needs no input files and writes its montage and table into the
/// directory given, nowhere else.
#[test]
fn demo_runs_without_inputs() {
    let dir = tempdir();
    let d = dir.path();
    let run = ercube(d, "demo --out-dir D").ok();
    assert_eq!(entries(d), ["D"], "demo wrote outside its directory");
    let montage = read_png(&d.join("D/montage.png"));
    assert!(montage.width() > montage.height());
    let rows = read_compare_csv(&d.join("D/compare.csv"));
    let names: Vec<&str> = rows.iter().map(|r| r.method.as_str()).collect();
    for m in ["er", "reference"] {
        assert!(names.contains(&m), "no {m} row in {names:?}");
        assert!(run.stdout().contains(m), "no {m} in the printed table");
    }
    // The demo's image is the checkerboard room, not an empty frame.
    let er = read_png(&d.join("D/er.png"));
    assert!(er.pixels().filter(|p| p.0 != [0, 0, 0]).count() > 1000);
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
