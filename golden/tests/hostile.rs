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

// One test binary (the allocator and the limits above are its own); its
// cases live beside it.
#[path = "hostile/dicom.rs"]
mod dicom;
#[path = "hostile/forged.rs"]
mod forged;
#[path = "hostile/fuzz.rs"]
mod fuzz;

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
