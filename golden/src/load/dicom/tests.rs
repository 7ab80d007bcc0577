use super::*;
use crate::load::load_auto;
use crate::load::tests::{assert_err, msg};
use crate::volume::DEFAULT_MEMORY_LIMIT;

const LIM: u64 = DEFAULT_MEMORY_LIMIT;

fn fixture_dir(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data")
        .join(name)
}

/// A copy of a fixture series in a fresh folder, its files sorted by name.
fn copy_series(name: &str) -> (tempfile::TempDir, Vec<PathBuf>) {
    let dir = tempfile::tempdir().unwrap();
    let mut out = Vec::new();
    for f in dicom_files(&fixture_dir(name), true).unwrap() {
        let to = dir.path().join(f.file_name().unwrap());
        std::fs::copy(&f, &to).unwrap();
        out.push(to);
    }
    (dir, out)
}

#[test]
fn a_folder_of_slices_loads_through_load_auto_and_ignores_other_files() {
    let (dir, _) = copy_series("dicom_i16");
    let want = read_dicom_dir(&fixture_dir("dicom_i16"), LIM).unwrap();
    std::fs::write(dir.path().join("notes.txt"), b"not a slice").unwrap();
    std::fs::write(dir.path().join(".hidden"), b"x").unwrap();
    let v = load_auto(dir.path(), None, LIM).unwrap();
    assert_eq!(
        (v.dims(), v.data()),
        (want.volume.dims(), want.volume.data())
    );
    // CT: Hounsfield units of the fixture are the i16 formula, its floor
    // -16000 (at voxel 0) maps to 0, and +1024 stored is -1024 + 1024.
    assert_eq!(v.get(0, 0, 0), 0);
}

#[test]
fn a_single_file_or_an_empty_folder_is_refused_in_one_line() {
    let (dir, files) = copy_series("dicom_u16");
    assert_err(load_auto(&files[0], None, LIM), "give the folder");
    for f in &files {
        std::fs::remove_file(f).unwrap();
    }
    std::fs::write(dir.path().join("a.dat"), [0u8; 200]).unwrap();
    assert_err(load_dicom_dir(dir.path(), LIM), "holds no DICOM files");
}

#[test]
fn every_inner_missing_slice_is_refused_and_an_end_one_is_not() {
    let mut uneven = 0;
    for k in 0..7 {
        let (dir, files) = copy_series("dicom_u16");
        std::fs::remove_file(&files[k]).unwrap();
        match load_dicom_dir(dir.path(), LIM) {
            Ok(v) => {
                assert_eq!(v.dims(), [12, 10, 6]);
                assert_eq!(v.spacing()[2], 1.25);
            }
            Err(e) => {
                let m = e.to_string();
                assert!(m.contains("uneven slice spacing"), "{m}");
                assert!(!m.contains('\n'));
                uneven += 1;
            }
        }
    }
    // Only the first and last slice leave an evenly spaced series.
    assert_eq!(uneven, 5);
}

#[test]
fn duplicate_positions_mixed_series_and_refused_syntaxes_are_one_line() {
    let (dir, files) = copy_series("dicom_u16");
    std::fs::copy(&files[2], dir.path().join("copy")).unwrap();
    assert_err(load_dicom_dir(dir.path(), LIM), "at the same position");

    let (dir, _) = copy_series("dicom_u16");
    let other = dicom_files(&fixture_dir("dicom_f32"), true).unwrap();
    std::fs::copy(&other[0], dir.path().join("zz")).unwrap();
    assert_err(load_dicom_dir(dir.path(), LIM), "holds 2 series");

    let m = msg(load_dicom_dir(&fixture_dir("dicom_j2k"), LIM));
    assert!(
        m.contains("1.2.840.10008.1.2.4.91 (JPEG 2000) is not supported"),
        "{m}"
    );
    assert!(!m.contains('\n'));
}

#[test]
fn truncated_slices_and_small_limits_are_refused() {
    let (dir, files) = copy_series("dicom_u8");
    let bytes = std::fs::read(&files[3]).unwrap();
    std::fs::write(&files[3], &bytes[..bytes.len() - 40]).unwrap();
    let m = msg(load_dicom_dir(dir.path(), LIM));
    assert!(!m.contains('\n'), "{m}");
    assert!(
        m.contains(&*files[3].file_name().unwrap().to_string_lossy()),
        "{m}"
    );
    // 12x10x7 voxels at 10 bytes each do not fit 5000 bytes.
    assert_err(
        load_dicom_dir(&fixture_dir("dicom_u16"), 5000),
        "over the memory limit",
    );
}

#[test]
fn positions_along_an_oblique_normal_sort_and_shear_is_refused() {
    let n = cross([0.6, 0.8, 0.0], [0.0, 0.0, -1.0]);
    let slice = |d: f64, shift: f64| Slice {
        path: PathBuf::from(format!("s{d}")),
        rows: 1,
        cols: 1,
        orient: [[0.6, 0.8, 0.0], [0.0, 0.0, -1.0]],
        position: [d * n[0] + shift, d * n[1], 5.0],
        pixel_spacing: [1.0, 1.0],
        bits: 16,
        signed: false,
        slope: 1.0,
        intercept: 0.0,
        series: String::new(),
        thickness: None,
        frame: 0,
        frames: 1,
    };
    let keyed = |s: Vec<Slice>| -> Vec<(f64, Slice)> {
        let mut k: Vec<_> = s.into_iter().map(|s| (dot(s.position, n), s)).collect();
        k.sort_by(|a, b| a.0.total_cmp(&b.0));
        k
    };
    let even = keyed(vec![slice(4.0, 0.0), slice(0.0, 0.0), slice(2.0, 0.0)]);
    let dz = slice_spacing(Path::new("d"), &even, n).unwrap();
    assert!((dz - 2.0).abs() < 1e-12, "{dz}");
    // Shifted along the row direction by 0.5 mm: not on the normal line.
    // (The shift changes the position along n, so keep the gaps even by
    // shifting perpendicular to n: along the column direction.)
    let mut tilted = even.clone();
    tilted[2].1.position[2] += 0.5;
    let e = slice_spacing(Path::new("d"), &tilted, n).unwrap_err();
    assert!(e.to_string().contains("gantry tilt"), "{e}");
}

#[test]
fn orientations_that_are_not_two_orthogonal_directions_are_refused() {
    assert!(orientation(&[1.0, 0.0, 0.0, 0.0, 1.0, 0.0]).is_some());
    let r = orientation(&[2.0, 0.0, 0.0, 0.0, 0.0, -3.0]).unwrap();
    assert_eq!(r, [[1.0, 0.0, 0.0], [0.0, 0.0, -1.0]]);
    assert!(orientation(&[1.0, 0.0, 0.0, 1.0, 0.1, 0.0]).is_none());
    assert!(orientation(&[0.0; 6]).is_none());
}

/// A single file's volume.
fn file_volume(path: &Path, limit: u64) -> crate::error::Result<crate::volume::Volume> {
    read_dicom_file(path, limit).map(|l| l.volume)
}

/// A copy of a fixture file in a fresh folder.
fn copy_file(name: &str) -> (tempfile::TempDir, PathBuf) {
    let dir = tempfile::tempdir().unwrap();
    let to = dir.path().join(name);
    std::fs::copy(fixture_dir(name), &to).unwrap();
    (dir, to)
}

#[test]
fn a_multi_frame_object_loads_as_a_file_or_alone_in_its_folder() {
    let want = read_dicom_dir(&fixture_dir("dicom_i16"), LIM).unwrap();
    let (dir, file) = copy_file("dicom_mf_i16.dcm");
    let by_file = read_dicom_file(&file, LIM).unwrap();
    let by_dir = read_dicom_dir(dir.path(), LIM).unwrap();
    let auto = load_auto(&file, None, LIM).unwrap();
    for v in [&by_file.volume, &by_dir.volume, &auto] {
        assert_eq!(
            (v.dims(), v.spacing(), v.data()),
            (
                want.volume.dims(),
                want.volume.spacing(),
                want.volume.data()
            )
        );
    }
    assert_eq!((by_file.origin, by_file.axes), (want.origin, want.axes));
    // The frames are stored out of position order: sorting them is what
    // makes the voxels agree.
    let z: Vec<f64> = read_header(&file, LIM)
        .unwrap()
        .iter()
        .map(|s| s.position[2])
        .collect();
    assert!(z.windows(2).any(|w| w[0] > w[1]), "{z:?}");
    // Beside other slices it is refused; a single-frame file alone is too.
    let series = dicom_files(&fixture_dir("dicom_i16"), true).unwrap();
    std::fs::copy(&series[0], dir.path().join("slice")).unwrap();
    assert_err(load_dicom_dir(dir.path(), LIM), "give it alone");
    assert_err(file_volume(&series[0], LIM), "give the folder");
}

#[test]
fn cut_multi_frame_objects_and_wrong_frame_counts_are_one_line() {
    let m = msg(file_volume(&fixture_dir("dicom_mf_badcount.dcm"), LIM));
    assert!(
        m.contains("NumberOfFrames 8 of 12x10 16-bit frames need 1920"),
        "{m}"
    );
    assert!(!m.contains('\n'));
    for name in ["dicom_mf_i16.dcm", "dicom_mf_u8.dcm"] {
        let (_dir, file) = copy_file(name);
        let bytes = std::fs::read(&file).unwrap();
        // Cut in the pixel data (over a frame short, and the last frame's
        // last bytes; the RLE object's sequence delimiter follows them), in
        // the functional groups, and in the header.
        for keep in [bytes.len() - 200, bytes.len() - 20, 900, 300] {
            std::fs::write(&file, &bytes[..keep]).unwrap();
            let m = msg(file_volume(&file, LIM));
            assert!(!m.contains('\n'), "{name} cut to {keep}: {m}");
            assert!(m.contains(name), "{name} cut to {keep}: {m}");
        }
    }
    // The sizes are checked before the pixel data is decoded.
    assert_err(
        file_volume(&fixture_dir("dicom_mf_i16.dcm"), 2000),
        "over the memory limit",
    );
}

mod fuzz {
    use super::*;
    use proptest::prelude::*;

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(120))]

        /// A series with one slice's bytes corrupted or cut loads or fails
        /// with one line, never panics, within a small memory limit.
        #[test]
        fn corrupted_slices_never_panic(
            series in 0usize..4,
            file in 0usize..7,
            edits in prop::collection::vec((any::<prop::sample::Index>(), any::<u8>()), 1..8),
            cut in any::<prop::sample::Index>(),
            do_cut in any::<bool>(),
        ) {
            let name = ["dicom_u16", "dicom_i16", "dicom_u8", "dicom_f32"][series];
            let (dir, files) = copy_series(name);
            let mut bytes = std::fs::read(&files[file]).unwrap();
            for (at, b) in edits {
                let i = at.index(bytes.len());
                bytes[i] = b;
            }
            if do_cut {
                bytes.truncate(cut.index(bytes.len() + 1));
            }
            std::fs::write(&files[file], &bytes).unwrap();
            if let Err(e) = load_dicom_dir(dir.path(), 1 << 16) {
                prop_assert!(!e.to_string().contains('\n'), "{}", e);
            }
        }

        /// A multi-frame object with bytes corrupted or cut loads or fails
        /// with one line, never panics.
        #[test]
        fn corrupted_multi_frame_objects_never_panic(
            which in 0usize..2,
            edits in prop::collection::vec((any::<prop::sample::Index>(), any::<u8>()), 1..8),
            cut in any::<prop::sample::Index>(),
            do_cut in any::<bool>(),
        ) {
            let (_dir, file) = copy_file(["dicom_mf_i16.dcm", "dicom_mf_u8.dcm"][which]);
            let mut bytes = std::fs::read(&file).unwrap();
            for (at, b) in edits {
                let i = at.index(bytes.len());
                bytes[i] = b;
            }
            if do_cut {
                bytes.truncate(cut.index(bytes.len() + 1));
            }
            std::fs::write(&file, &bytes).unwrap();
            if let Err(e) = read_dicom_file(&file, 1 << 16) {
                prop_assert!(!e.to_string().contains('\n'), "{}", e);
            }
        }

        /// Random bytes after a valid preamble and magic (so the parser,
        /// not the magic check, meets them) are refused in one line.
        #[test]
        fn random_bytes_after_the_magic_never_panic(
            body in prop::collection::vec(any::<u8>(), 0..400),
        ) {
            let dir = tempfile::tempdir().unwrap();
            let mut bytes = vec![0u8; 128];
            bytes.extend_from_slice(b"DICM");
            bytes.extend_from_slice(&body);
            std::fs::write(dir.path().join("s"), &bytes).unwrap();
            let e = load_dicom_dir(dir.path(), 1 << 16).map(|v| v.dims());
            prop_assert!(e.is_err());
            prop_assert!(!e.unwrap_err().to_string().contains('\n'));
        }
    }
}

/// `plain` (explicit VR little endian) as a deflated explicit VR little
/// endian file: the meta group with the deflate transfer syntax (and its
/// group length mended), then the data set as one raw deflate stream.
fn deflated_twin(plain: &[u8]) -> Vec<u8> {
    use std::io::Write;
    const LONG: [&[u8]; 6] = [b"OB", b"OW", b"OF", b"SQ", b"UT", b"UN"];
    let mut pos = 132;
    let mut meta: Vec<u8> = Vec::new();
    while u16::from_le_bytes([plain[pos], plain[pos + 1]]) == 0x0002 {
        let elem = u16::from_le_bytes([plain[pos + 2], plain[pos + 3]]);
        let vr = &plain[pos + 4..pos + 6];
        let (head, len) = if LONG.contains(&vr) {
            (
                12,
                u32::from_le_bytes(plain[pos + 8..pos + 12].try_into().unwrap()) as usize,
            )
        } else {
            (
                8,
                u16::from_le_bytes([plain[pos + 6], plain[pos + 7]]) as usize,
            )
        };
        match elem {
            0x0000 => {} // rewritten below
            0x0010 => {
                let uid = b"1.2.840.10008.1.2.1.99";
                meta.extend_from_slice(&plain[pos..pos + 6]);
                meta.extend_from_slice(&(uid.len() as u16).to_le_bytes());
                meta.extend_from_slice(uid);
            }
            _ => meta.extend_from_slice(&plain[pos..pos + head + len]),
        }
        pos += head + len;
    }
    let mut out = plain[..132].to_vec();
    out.extend_from_slice(&[0x02, 0x00, 0x00, 0x00, b'U', b'L', 4, 0]);
    out.extend_from_slice(&(meta.len() as u32).to_le_bytes());
    out.extend_from_slice(&meta);
    let mut z = flate2::write::DeflateEncoder::new(out, flate2::Compression::default());
    z.write_all(&plain[pos..]).unwrap();
    z.finish().unwrap()
}

/// The length of a file's meta group's end (where its data set starts).
fn data_set_start(file: &[u8]) -> usize {
    let mut pos = 132;
    while u16::from_le_bytes([file[pos], file[pos + 1]]) == 0x0002 {
        let vr = &file[pos + 4..pos + 6];
        pos += if vr == b"OB" {
            12 + u32::from_le_bytes(file[pos + 8..pos + 12].try_into().unwrap()) as usize
        } else {
            8 + u16::from_le_bytes([file[pos + 6], file[pos + 7]]) as usize
        };
    }
    pos
}

#[test]
fn a_deflated_series_loads_to_the_voxels_of_its_plain_twin() {
    let (dir, files) = copy_series("dicom_u16");
    for f in &files {
        let twin = deflated_twin(&std::fs::read(f).unwrap());
        let meta = &twin[..data_set_start(&twin)];
        assert!(meta.windows(22).any(|w| w == b"1.2.840.10008.1.2.1.99"));
        std::fs::write(f, twin).unwrap();
    }
    let plain = read_dicom_dir(&fixture_dir("dicom_u16"), LIM).unwrap();
    let deflated = read_dicom_dir(dir.path(), LIM).unwrap();
    assert_eq!(deflated.volume.dims(), plain.volume.dims());
    assert_eq!(deflated.volume.data(), plain.volume.data());
    assert_eq!(deflated.volume.spacing(), plain.volume.spacing());
    assert_eq!(deflated.origin, plain.origin);
}

/// A deflate bomb (a few hundred KB inflating to 64 MiB) is refused under
/// a 16 MiB limit before its bytes are held; a stream cut short, corrupt
/// bytes, and a forged length inside the inflated data set are refused
/// in one line too.
#[test]
fn deflate_bombs_and_cut_streams_are_refused_in_one_line() {
    use std::io::Write;
    let (dir, files) = copy_series("dicom_u8");
    let plain = std::fs::read(&files[0]).unwrap();
    for f in &files[1..] {
        std::fs::remove_file(f).unwrap();
    }
    let twin = deflated_twin(&plain);
    let start = data_set_start(&twin);
    let mut bomb = twin[..start].to_vec();
    let mut z = flate2::write::DeflateEncoder::new(Vec::new(), flate2::Compression::best());
    let zeros = vec![0u8; 1 << 20];
    for _ in 0..64 {
        z.write_all(&zeros).unwrap();
    }
    bomb.extend_from_slice(&z.finish().unwrap());
    assert!(bomb.len() < 1 << 20);
    std::fs::write(&files[0], &bomb).unwrap();
    assert_err(
        load_dicom_dir(dir.path(), 16 << 20),
        "inflates to more than the memory limit of 16.0 MiB",
    );

    std::fs::write(&files[0], &twin[..start + (twin.len() - start) / 2]).unwrap();
    assert_err(load_dicom_dir(dir.path(), LIM), "is cut off after");

    let mut corrupt = twin.clone();
    corrupt[start..].fill(0xFF);
    std::fs::write(&files[0], &corrupt).unwrap();
    assert_err(
        load_dicom_dir(dir.path(), LIM),
        "the deflated data set is corrupt",
    );

    // The plain file with one element's length forged, deflated: the
    // length is checked against the inflated bytes.
    let mut forged = plain.clone();
    let px = forged
        .windows(4)
        .rposition(|w| w == [0xE0, 0x7F, 0x10, 0x00])
        .unwrap();
    forged[px + 8..px + 12].copy_from_slice(&0xFFFF_FFF0u32.to_le_bytes());
    std::fs::write(&files[0], deflated_twin(&forged)).unwrap();
    assert_err(load_dicom_dir(dir.path(), LIM), "claims 4294967280 bytes");
}
