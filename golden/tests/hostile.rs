//! Hostile files against every loader: forged headers, forged lengths and
//! segment counts, cut or corrupted compressed streams, data files outside
//! the header's folder, folder members that are no files, and nonsense
//! physical values. Each gives a volume or one line, never an abort, and
//! costs little memory.
//!
//! The test binary runs under an address-space limit (`RLIMIT_AS`, 1 GiB
//! above what it maps at start) and an allocator that refuses any single
//! allocation over [`CAP`] (256 MiB): a loader that trusted a forged size
//! would abort this binary. The allocator also records the peak bytes held
//! while a case loads ([`measure`]), and every case must stay under
//! [`PEAK_GOAL`] (64 MiB). `ERCUBE_FUZZ_PEAK=1` prints the largest peak
//! seen (the figure in docs/golden.md); `ERCUBE_FUZZ_CASES=N` runs N cases
//! per fuzz test instead of 160.

use std::alloc::{GlobalAlloc, Layout, System};
use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::{Mutex, MutexGuard, Once};

use golden::load::{allow_outside_data, load_auto, load_placed};
use golden::volume::Volume;
use proptest::prelude::*;

/// Largest single allocation the binary allows.
const CAP: usize = 256 << 20;
/// Largest peak a case of under 1 MB may cause.
const PEAK_GOAL: usize = 64 << 20;
/// The loaders' memory limit in these tests: far above anything a case
/// should take, so only the size-before-allocation checks stop a forged
/// header, not the limit.
const LIMIT: u64 = 1 << 40;

struct Tracking;

static HELD: AtomicUsize = AtomicUsize::new(0);
static PEAK: AtomicUsize = AtomicUsize::new(0);
static LARGEST: AtomicUsize = AtomicUsize::new(0);
static WORST: AtomicUsize = AtomicUsize::new(0);

fn note(size: usize) {
    LARGEST.fetch_max(size, Ordering::Relaxed);
}

fn add(size: usize) {
    let now = HELD.fetch_add(size, Ordering::Relaxed) + size;
    PEAK.fetch_max(now, Ordering::Relaxed);
}

// SAFETY: every call forwards to the system allocator; the counters only
// observe sizes.
unsafe impl GlobalAlloc for Tracking {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        note(layout.size());
        if layout.size() > CAP {
            return std::ptr::null_mut();
        }
        let p = System.alloc(layout);
        if !p.is_null() {
            add(layout.size());
        }
        p
    }

    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        note(layout.size());
        if layout.size() > CAP {
            return std::ptr::null_mut();
        }
        let p = System.alloc_zeroed(layout);
        if !p.is_null() {
            add(layout.size());
        }
        p
    }

    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        System.dealloc(ptr, layout);
        HELD.fetch_sub(layout.size(), Ordering::Relaxed);
    }

    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        note(new_size);
        if new_size > CAP {
            return std::ptr::null_mut();
        }
        let p = System.realloc(ptr, layout, new_size);
        if !p.is_null() {
            HELD.fetch_sub(layout.size(), Ordering::Relaxed);
            add(new_size);
        }
        p
    }
}

#[global_allocator]
static ALLOC: Tracking = Tracking;

/// One case at a time (the counters are process-wide), with the
/// address-space limit set once.
fn serial() -> MutexGuard<'static, ()> {
    static LOCK: Mutex<()> = Mutex::new(());
    static LIMIT_AS: Once = Once::new();
    LIMIT_AS.call_once(|| {
        let status = std::fs::read_to_string("/proc/self/status").unwrap_or_default();
        let mapped: u64 = status
            .lines()
            .find(|l| l.starts_with("VmSize:"))
            .and_then(|l| l.split_whitespace().nth(1)?.parse().ok())
            .map_or(0, |kb: u64| kb * 1024);
        let r = libc::rlimit {
            rlim_cur: mapped + (1 << 30),
            rlim_max: libc::RLIM_INFINITY,
        };
        // SAFETY: setrlimit reads the struct it is given.
        unsafe { libc::setrlimit(libc::RLIMIT_AS, &r) };
    });
    LOCK.lock().unwrap_or_else(|e| e.into_inner())
}

/// Peak bytes held above the start, and the largest single allocation
/// asked for, while `f` runs.
fn measure<T>(f: impl FnOnce() -> T) -> (T, usize, usize) {
    let base = HELD.load(Ordering::Relaxed);
    PEAK.store(base, Ordering::Relaxed);
    LARGEST.store(0, Ordering::Relaxed);
    let out = f();
    let peak = PEAK.load(Ordering::Relaxed).saturating_sub(base);
    WORST.fetch_max(peak, Ordering::Relaxed);
    (out, peak, LARGEST.load(Ordering::Relaxed))
}

/// Loads `path` (both ways), which must give a volume or one line, within
/// the peak goal; returns the error message, if any.
fn load_small(path: &Path) -> Option<String> {
    let ((a, b), peak, largest) = measure(|| {
        (
            load_auto(path, None, LIMIT).map(|v| v.dims()),
            load_placed(path, None, LIMIT).map(|l| l.volume.dims()),
        )
    });
    for r in [&a, &b] {
        if let Err(e) = r {
            let m = e.to_string();
            assert!(!m.contains('\n'), "{}: {m}", path.display());
        }
    }
    assert!(
        peak < PEAK_GOAL && largest < PEAK_GOAL,
        "{}: peak {peak} bytes, largest allocation {largest} bytes",
        path.display()
    );
    if std::env::var_os("ERCUBE_FUZZ_PEAK").is_some() {
        eprintln!(
            "largest peak so far: {} bytes",
            WORST.load(Ordering::Relaxed)
        );
    }
    a.err().map(|e| e.to_string())
}

fn refused(path: &Path, needle: &str) {
    let m = load_small(path).unwrap_or_else(|| panic!("{} loaded", path.display()));
    assert!(m.contains(needle), "{m:?} should mention {needle:?}");
}

fn data(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data")
        .join(name)
}

fn fixture(name: &str) -> Vec<u8> {
    std::fs::read(data(name)).unwrap()
}

fn gzip(bytes: &[u8]) -> Vec<u8> {
    let mut e = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::fast());
    e.write_all(bytes).unwrap();
    e.finish().unwrap()
}

fn zlib(bytes: &[u8]) -> Vec<u8> {
    let mut e = flate2::write::ZlibEncoder::new(Vec::new(), flate2::Compression::fast());
    e.write_all(bytes).unwrap();
    e.finish().unwrap()
}

/// A 352-byte little-endian NIfTI-1 header: `dims`, int16, `pixdim`.
fn nifti_header(dims: [i16; 3], pixdim: [f32; 3]) -> Vec<u8> {
    let mut h = vec![0u8; 352];
    h[0..4].copy_from_slice(&348i32.to_le_bytes());
    for (k, d) in [3, dims[0], dims[1], dims[2], 1, 1, 1, 1]
        .iter()
        .enumerate()
    {
        h[40 + 2 * k..42 + 2 * k].copy_from_slice(&d.to_le_bytes());
    }
    h[70..72].copy_from_slice(&4i16.to_le_bytes());
    h[72..74].copy_from_slice(&16i16.to_le_bytes());
    for (k, p) in [1.0, pixdim[0], pixdim[1], pixdim[2]].iter().enumerate() {
        h[76 + 4 * k..80 + 4 * k].copy_from_slice(&p.to_le_bytes());
    }
    h[108..112].copy_from_slice(&352f32.to_le_bytes());
    h[344..348].copy_from_slice(b"n+1\0");
    h
}

fn write(dir: &Path, name: &str, bytes: &[u8]) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, bytes).unwrap();
    p
}

#[test]
fn headers_promising_more_than_the_file_are_refused_before_allocating() {
    let _g = serial();
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // 2048x2048x1024 int16 (8 GiB) in the 352 bytes of a header.
    let nii = nifti_header([2048, 2048, 1024], [1.0; 3]);
    refused(&write(d, "big.nii", &nii), "truncated");
    let mut padded = nii.clone();
    padded.extend_from_slice(&[0; 4096]);
    refused(&write(d, "big.nii.gz", &gzip(&padded)), "truncated");
    // The same size in a MetaImage with 1 KiB of zlib data.
    let mut mha = b"ObjectType = Image\nNDims = 3\nDimSize = 2048 2048 1024\n\
ElementType = MET_SHORT\nCompressedData = True\nElementDataFile = LOCAL\n"
        .to_vec();
    mha.extend_from_slice(&zlib(&[7; 1024]));
    refused(&write(d, "big.mha", &mha), "truncated");
    let mut nrrd = b"NRRD0004\ntype: short\ndimension: 3\nsizes: 2048 2048 1024\n\
endian: little\nencoding: gzip\n\n"
        .to_vec();
    nrrd.extend_from_slice(&gzip(&[7; 1024]));
    refused(&write(d, "big.nrrd", &nrrd), "truncated");
}

/// A little-endian TIFF of `pages` pages of `w`x`h` 16-bit greyscale, each
/// one strip of `strip` (stored as-is) under `compression`, the strip at
/// `offset` if given (else where it was written) with byte count `count`
/// if given.
fn tiff(
    w: u32,
    h: u32,
    pages: usize,
    compression: u16,
    strip: &[u8],
    offset: Option<u32>,
    count: Option<u32>,
) -> Vec<u8> {
    let mut f = b"II*\0".to_vec();
    f.extend_from_slice(&0u32.to_le_bytes());
    let mut next_at = 4usize;
    for _ in 0..pages {
        let data_at = f.len() as u32;
        f.extend_from_slice(strip);
        if f.len() % 2 == 1 {
            f.push(0);
        }
        let ifd_at = f.len() as u32;
        f[next_at..next_at + 4].copy_from_slice(&ifd_at.to_le_bytes());
        let entries: [(u16, u16, u32); 9] = [
            (256, 4, w),
            (257, 4, h),
            (258, 3, 16),
            (259, 3, compression as u32),
            (262, 3, 1),
            (273, 4, offset.unwrap_or(data_at)),
            (277, 3, 1),
            (278, 4, h),
            (279, 4, count.unwrap_or(strip.len() as u32)),
        ];
        f.extend_from_slice(&(entries.len() as u16).to_le_bytes());
        for (tag, ty, v) in entries {
            f.extend_from_slice(&tag.to_le_bytes());
            f.extend_from_slice(&ty.to_le_bytes());
            f.extend_from_slice(&1u32.to_le_bytes());
            if ty == 3 {
                f.extend_from_slice(&(v as u16).to_le_bytes());
                f.extend_from_slice(&[0, 0]);
            } else {
                f.extend_from_slice(&v.to_le_bytes());
            }
        }
        next_at = f.len();
        f.extend_from_slice(&0u32.to_le_bytes());
    }
    f
}

#[test]
fn tiff_pages_and_strips_that_cannot_hold_the_page_are_refused() {
    let _g = serial();
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // Two deflate pages of 8192x8192 (256 MiB) in a few hundred bytes.
    let bomb = tiff(8192, 8192, 2, 8, &zlib(&[0; 4096]), None, None);
    refused(
        &write(d, "bomb.tif", &bomb),
        "too few for a 8192x8192 16-bit page",
    );
    // An uncompressed 4x4 page (32 bytes) whose strip is misplaced or short.
    let px = [1u8; 32];
    let ok = tiff(4, 4, 1, 1, &px, None, None);
    assert_eq!(load_small(&write(d, "ok.tif", &ok)), None);
    for (name, offset, count, needle) in [
        ("off0.tif", Some(0), None, "does not lie in the file"),
        ("count0.tif", None, Some(0), "does not lie in the file"),
        ("count1.tif", None, Some(1), "its strips hold 1 bytes"),
        ("past.tif", Some(1 << 20), None, "does not lie in the file"),
    ] {
        refused(
            &write(d, name, &tiff(4, 4, 1, 1, &px, offset, count)),
            needle,
        );
    }
    // A directory entry whose value count is forged to two million: the
    // decoder would size a table by it.
    let mut forged = ok.clone();
    let entry = forged
        .windows(4)
        .position(|w| w == [23, 1, 4, 0])
        .expect("the StripByteCounts entry (tag 279, LONG)");
    forged[entry + 4..entry + 8].copy_from_slice(&0x0020_0001u32.to_le_bytes());
    refused(
        &write(d, "forged.tif", &forged),
        "tag 279 claims 2097153 values",
    );
    // A chain of pages that loops back to the first.
    let mut looped = tiff(4, 4, 2, 1, &px, None, None);
    let first = u32::from_le_bytes([looped[4], looped[5], looped[6], looped[7]]);
    let n = looped.len();
    looped[n - 4..].copy_from_slice(&first.to_le_bytes());
    refused(&write(d, "loop.tif", &looped), "the chain of pages loops");
}

/// Makes a folder member that is no file at the given path.
type MakeMember = fn(&Path);

#[test]
fn tiff_folder_members_that_are_no_files_are_refused_by_name() {
    let _g = serial();
    let page = tiff(4, 4, 1, 1, &[1u8; 32], None, None);
    let cases: [(&str, MakeMember); 3] = [
        ("b.tif", |p| std::fs::create_dir(p).unwrap()),
        ("b.tif", |p| {
            std::os::unix::fs::symlink(p.with_file_name("gone.tif"), p).unwrap()
        }),
        ("b.tif", |p| {
            std::os::unix::fs::symlink(p.with_file_name("c.tif"), p).unwrap();
            std::os::unix::fs::symlink(p, p.with_file_name("c.tif")).unwrap();
        }),
    ];
    for (k, (name, make)) in cases.iter().enumerate() {
        let dir = tempfile::tempdir().unwrap();
        write(dir.path(), "a.tif", &page);
        write(dir.path(), "d.tif", &page);
        make(&dir.path().join(name));
        let m = load_small(dir.path()).unwrap_or_else(|| panic!("case {k} loaded"));
        assert!(m.contains("b.tif"), "case {k}: {m}");
        let want = if k == 0 {
            "is a folder"
        } else {
            "leads nowhere"
        };
        assert!(m.contains(want), "case {k}: {m}");
    }
}

#[test]
fn detached_data_files_stay_in_the_header_folder() {
    let _g = serial();
    let dir = tempfile::tempdir().unwrap();
    let sub = dir.path().join("sub");
    std::fs::create_dir(&sub).unwrap();
    std::fs::copy(data("vol_u8_det.raw"), dir.path().join("outside.raw")).unwrap();
    std::fs::copy(data("vol_u8_det.raw"), sub.join("inside.raw")).unwrap();
    let nhdr = |file: &str| {
        format!(
            "NRRD0004\ntype: uint8\ndimension: 3\nsizes: 12 10 7\nencoding: raw\ndata file: {file}\n"
        )
    };
    let mhd = |file: &str| {
        format!("NDims = 3\nDimSize = 12 10 7\nElementType = MET_UCHAR\nElementDataFile = {file}\n")
    };
    let outside = dir.path().join("outside.raw");
    let outside = outside.to_str().unwrap();
    for (name, text, needle) in [
        ("a.nhdr", nhdr("../outside.raw"), "steps out with '..'"),
        ("b.nhdr", nhdr(outside), "is an absolute path"),
        ("c.mhd", mhd("../outside.raw"), "steps out with '..'"),
        ("d.mhd", mhd(outside), "is an absolute path"),
        ("e.nhdr", nhdr("/etc/passwd"), "is an absolute path"),
    ] {
        let p = write(&sub, name, text.as_bytes());
        refused(&p, needle);
        if !name.starts_with('e') {
            allow_outside_data(true);
            let loaded = load_small(&p);
            allow_outside_data(false);
            assert_eq!(loaded, None, "{name} with outside data allowed");
        }
    }
    std::os::unix::fs::symlink(dir.path().join("outside.raw"), sub.join("link.raw")).unwrap();
    refused(
        &write(&sub, "f.nhdr", nhdr("link.raw").as_bytes()),
        "leads out",
    );
    assert_eq!(
        load_small(&write(&sub, "g.nhdr", nhdr("inside.raw").as_bytes())),
        None
    );
}

#[test]
fn spacings_outside_the_one_rule_are_refused_in_every_format() {
    let _g = serial();
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    for (k, s) in ["nan", "0", "-1", "inf", "1e-150", "1e30"]
        .iter()
        .enumerate()
    {
        let v: f64 = s.parse().unwrap();
        let nrrd = format!(
            "NRRD0004\ntype: uint8\ndimension: 3\nsizes: 2 2 2\nspacings: 1 {s} 1\nencoding: raw\n\n"
        );
        let mut nrrd = nrrd.into_bytes();
        nrrd.extend_from_slice(&[1; 8]);
        refused(&write(d, &format!("{k}.nrrd"), &nrrd), "spacings");
        let mut mha = format!(
            "NDims = 3\nDimSize = 2 2 2\nElementType = MET_UCHAR\nElementSpacing = {s} 1 1\n\
ElementDataFile = LOCAL\n"
        )
        .into_bytes();
        mha.extend_from_slice(&[1; 8]);
        refused(&write(d, &format!("{k}.mha"), &mha), "ElementSpacing");
        let mut nii = nifti_header([2, 2, 2], [1.0, 1.0, v as f32]);
        nii.extend_from_slice(&[1; 16]);
        refused(&write(d, &format!("{k}.nii"), &nii), "pixdim");
    }
    // The ends of the range load.
    let mut nii = nifti_header([2, 2, 2], [2e-6, 1e6, 1.0]);
    nii.extend_from_slice(&[1; 16]);
    assert_eq!(load_small(&write(d, "ends.nii", &nii)), None);
}

#[test]
fn compressed_streams_are_read_to_their_checksums() {
    let _g = serial();
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let mut nii = nifti_header([2, 2, 2], [1.0; 3]);
    nii.extend_from_slice(&[1; 16]);
    let gz = gzip(&nii);
    assert_eq!(load_small(&write(d, "ok.nii.gz", &gz)), None);
    // The gzip trailer is CRC-32 then length: zero the CRC.
    let mut bad = gz.clone();
    let n = bad.len();
    bad[n - 8..n - 4].fill(0);
    refused(&write(d, "crc.nii.gz", &bad), "unreadable data");
    for (name, ext) in [
        ("vol_u8_gz.nrrd", "nrrd"),
        ("vol_u8_detgz.raw.gz", "raw.gz"),
    ] {
        let mut b = fixture(name);
        let n = b.len();
        b[n - 8..n - 4].iter_mut().for_each(|x| *x ^= 0xff);
        write(d, &format!("vol_u8_detgz.{ext}"), &b);
    }
    refused(&d.join("vol_u8_detgz.nrrd"), "unreadable data");
    std::fs::copy(data("vol_u8_detgz.nhdr"), d.join("vol_u8_detgz.nhdr")).unwrap();
    refused(&d.join("vol_u8_detgz.nhdr"), "unreadable data");
    // zlib's trailer is the Adler-32 of the data.
    let mut z = fixture("vol_u8_z.zraw");
    let n = z.len();
    z[n - 1] ^= 0xff;
    write(d, "vol_u8_z.zraw", &z);
    std::fs::copy(data("vol_u8_z.mhd"), d.join("vol_u8_z.mhd")).unwrap();
    refused(&d.join("vol_u8_z.mhd"), "unreadable data");
}

/// Byte offset of the first `tag` (group, element; little endian) after the
/// 132-byte preamble.
fn find_tag(b: &[u8], group: u16, elem: u16) -> usize {
    let mut t = group.to_le_bytes().to_vec();
    t.extend_from_slice(&elem.to_le_bytes());
    132 + b[132..]
        .windows(4)
        .position(|w| w == t)
        .expect("tag present")
}

/// A copy of the fixture series `name` with the file `victim` replaced by
/// `edit` of its bytes.
fn edited_series(name: &str, edit: impl Fn(&mut Vec<u8>)) -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    let mut files: Vec<_> = std::fs::read_dir(data(name))
        .unwrap()
        .map(|e| e.unwrap().path())
        .collect();
    files.sort();
    for (k, f) in files.iter().enumerate() {
        let mut b = std::fs::read(f).unwrap();
        if k == 0 {
            edit(&mut b);
        }
        std::fs::write(dir.path().join(f.file_name().unwrap()), b).unwrap();
    }
    dir
}

#[test]
fn dicom_lengths_segment_counts_and_attributes_are_checked() {
    let _g = serial();
    // Explicit VR: PixelData (OW) length after 2 reserved bytes.
    for len in [0xFFFF_FFF0u32, 0x7FFF_FFFF] {
        let dir = edited_series("dicom_u16", |b| {
            let at = find_tag(b, 0x7FE0, 0x0010);
            b[at + 8..at + 12].copy_from_slice(&len.to_le_bytes());
        });
        refused(
            dir.path(),
            &format!("element (7FE0,0010) claims {len} bytes"),
        );
    }
    // Implicit VR: an ordinary element's length off by a few bytes.
    let dir = edited_series("dicom_i16", |b| {
        let at = find_tag(b, 0x0028, 0x0004);
        b[at + 4..at + 8].copy_from_slice(&0x2000_0000u32.to_le_bytes());
    });
    refused(dir.path(), "element (0028,0004) claims");
    let attr = |tag: (u16, u16), value: &[u8], needle: &str| {
        let dir = edited_series("dicom_i16", |b| {
            let at = find_tag(b, tag.0, tag.1) + 8;
            b[at..at + value.len()].copy_from_slice(value);
        });
        refused(dir.path(), needle);
    };
    attr((0x0028, 0x1053), b"nan ", "RescaleSlope NaN");
    attr(
        (0x0028, 0x0004),
        b"RGB         ",
        "PhotometricInterpretation RGB",
    );
    attr((0x0028, 0x0101), &[17, 0], "BitsStored 17");
    attr((0x0028, 0x0102), &[99, 0], "HighBit 99");
    // RLE: a segment count of 0xFFFFFFFF (the decoder would allocate 16
    // GiB of offsets) and a first fragment of garbage.
    let rle = fixture("dicom_mf_u8.dcm");
    let header = [1u8, 0, 0, 0, 64, 0, 0, 0];
    let at = rle
        .windows(8)
        .position(|w| w == header)
        .expect("an RLE header");
    let dir = tempfile::tempdir().unwrap();
    let mut b = rle.clone();
    b[at..at + 4].copy_from_slice(&u32::MAX.to_le_bytes());
    refused(&write(dir.path(), "count.dcm", &b), "4294967295 segments");
    let mut b = rle.clone();
    b[at..at + 64]
        .iter_mut()
        .enumerate()
        .for_each(|(i, x)| *x = (i * 97 + 13) as u8);
    let m = load_small(&write(dir.path(), "garbage.dcm", &b)).expect("refused");
    assert!(m.contains("RLE fragment 1"), "{m}");
}

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
    #![proptest_config(ProptestConfig::with_cases(cases()))]

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
