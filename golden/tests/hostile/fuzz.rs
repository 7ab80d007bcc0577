//! Every fixture's header bytes, length fields and series members
//! corrupted at random (proptest), and the fixtures themselves under the
//! limits.

use super::*;

/// Every fixture, by the name it loads under.
fn fixtures() -> Vec<(String, Vec<u8>)> {
    let mut out = Vec::new();
    for e in std::fs::read_dir(data("")).unwrap() {
        let p = e.unwrap().path();
        let name = p.file_name().unwrap().to_string_lossy().into_owned();
        if p.is_file() && !name.ends_with(".py") {
            out.push((name, std::fs::read(&p).unwrap()));
        }
    }
    out.sort();
    out
}

/// The series folders, each a list of (name, bytes).
fn series() -> Vec<Vec<(String, Vec<u8>)>> {
    [
        "dicom_u8",
        "dicom_u16",
        "dicom_i16",
        "dicom_f32",
        "vol_u8_pages",
    ]
    .iter()
    .map(|s| {
        let mut v: Vec<_> = std::fs::read_dir(data(s))
            .unwrap()
            .map(|e| {
                let p = e.unwrap().path();
                let n = p.file_name().unwrap().to_string_lossy().into_owned();
                (n, std::fs::read(&p).unwrap())
            })
            .collect();
        v.sort();
        v
    })
    .collect()
}

/// Writes a fixture (and, for a detached header, its data file) into
/// `dir`, the header last, and returns the path to load.
fn place(dir: &Path, all: &[(String, Vec<u8>)], which: usize, bytes: &[u8]) -> PathBuf {
    for (name, b) in all {
        if name.ends_with(".raw") || name.ends_with(".zraw") || name.ends_with(".gz") {
            write(dir, name, b);
        }
    }
    write(dir, &all[which].0, bytes)
}

/// Offsets of the element-length fields of a DICOM file, found by walking
/// its headers the way the parser does (good enough for the fixtures).
fn length_fields(b: &[u8]) -> Vec<(usize, usize)> {
    let mut out = Vec::new();
    let mut i = 132;
    while i + 8 <= b.len() {
        let vr = &b[i + 4..i + 6];
        let long = [b"OB", b"OW", b"SQ", b"UN", b"UT", b"OF"]
            .iter()
            .any(|v| vr == *v);
        if b[i..i + 2] == [0xFE, 0xFF] {
            out.push((i + 4, 4));
            i += 8;
        } else if vr.iter().all(|c| c.is_ascii_uppercase()) {
            if long {
                out.push((i + 8, 4));
                i += 12;
            } else {
                out.push((i + 6, 2));
                i += 8;
            }
            continue;
        } else {
            out.push((i + 4, 4));
            i += 8;
        }
        // Skip nothing: values are walked as if they were elements, which
        // still lands on every header of the fixtures' small values.
    }
    out
}

/// Cases per fuzz test: 160 in CI, `ERCUBE_FUZZ_CASES` for a longer run.
fn cases() -> u32 {
    std::env::var("ERCUBE_FUZZ_CASES")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(160)
}

proptest! {
    // The cases live beside `hostile.rs` (the default, beside a `lib.rs`
    // or `main.rs`, finds none for a test in a subfolder and saves nothing).
    #![proptest_config(ProptestConfig {
        cases: cases(),
        failure_persistence: Some(Box::new(proptest::test_runner::FileFailurePersistence::Direct(
            "tests/hostile.proptest-regressions",
        ))),
        ..ProptestConfig::default()
    })]

    /// Header bytes of every fixture (NIfTI, NRRD, MetaImage, TIFF, DICOM,
    /// gzip, zlib) overwritten: a volume or one line, within the peak goal.
    #[test]
    fn corrupted_headers_of_every_format(
        which in any::<prop::sample::Index>(),
        edits in prop::collection::vec((0usize..600, any::<u8>()), 1..6),
        tail in any::<bool>(),
    ) {
        let _g = serial();
        let all = fixtures();
        let which = which.index(all.len());
        let mut b = all[which].1.clone();
        let n = b.len();
        for (at, v) in edits {
            // Near the start (headers, IFDs, DICOM elements) or the end
            // (gzip trailers, TIFF IFDs written last).
            let i = if tail { n.saturating_sub(1 + at % n.max(1)) } else { at % n.max(1) };
            if i < n {
                b[i] = v;
            }
        }
        let dir = tempfile::tempdir().unwrap();
        load_small(&place(dir.path(), &all, which, &b));
    }

    /// Forged 32-bit sizes where they matter most: every DICOM element
    /// length, and the words of RLE headers and TIFF entries.
    #[test]
    fn forged_lengths_and_counts(
        which in any::<prop::sample::Index>(),
        field in any::<prop::sample::Index>(),
        value in prop_oneof![
            Just(u32::MAX), Just(0xFFFF_FFF0u32), Just(0x7FFF_FFFF), Just(0),
            any::<u32>(), 0u32..4096
        ],
    ) {
        let _g = serial();
        let all = fixtures();
        let dicoms: Vec<usize> = (0..all.len())
            .filter(|&k| all[k].0.ends_with(".dcm") || all[k].0.ends_with(".tif"))
            .collect();
        let which = dicoms[which.index(dicoms.len())];
        let mut b = all[which].1.clone();
        let fields = if all[which].0.ends_with(".dcm") {
            length_fields(&b)
        } else {
            (8..b.len().saturating_sub(4)).step_by(4).map(|i| (i, 4)).collect()
        };
        let (at, width) = fields[field.index(fields.len())];
        if width == 2 {
            b[at..at + 2].copy_from_slice(&(value as u16).to_le_bytes());
        } else {
            b[at..at + 4].copy_from_slice(&value.to_le_bytes());
        }
        let dir = tempfile::tempdir().unwrap();
        load_small(&write(dir.path(), &all[which].0, &b));
    }

    /// One slice of a series (DICOM folders, a TIFF folder) corrupted or
    /// its lengths forged.
    #[test]
    fn corrupted_series_members(
        which in any::<prop::sample::Index>(),
        member in any::<prop::sample::Index>(),
        edits in prop::collection::vec((any::<prop::sample::Index>(), any::<u8>()), 1..6),
        forge in any::<Option<(prop::sample::Index, u32)>>(),
    ) {
        let _g = serial();
        let all = series();
        let files = &all[which.index(all.len())];
        let m = member.index(files.len());
        let dir = tempfile::tempdir().unwrap();
        for (k, (name, bytes)) in files.iter().enumerate() {
            let mut b = bytes.clone();
            if k == m {
                for (at, v) in &edits {
                    let i = at.index(b.len().min(1024));
                    b[i] = *v;
                }
                if let Some((f, v)) = forge {
                    let fields = length_fields(&b);
                    if !fields.is_empty() {
                        let (at, w) = fields[f.index(fields.len())];
                        if w == 4 {
                            b[at..at + 4].copy_from_slice(&v.to_le_bytes());
                        }
                    }
                }
            }
            write(dir.path(), name, &b);
        }
        load_small(dir.path());
    }
}

/// A valid volume still loads here (the allocator and the limit do not
/// refuse ordinary work).
#[test]
fn the_fixtures_load_under_the_limits() {
    let _g = serial();
    let v: Volume = load_auto(&data("vol_u16.nrrd"), None, LIMIT).unwrap();
    assert_eq!(v.dims(), [12, 10, 7]);
    assert_eq!(load_small(&data("dicom_i16")), None);
    assert_eq!(load_small(&data("vol_u8_pages")), None);
}
