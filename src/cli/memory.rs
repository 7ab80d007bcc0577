//! The memory check: a frame's peak memory, estimated from the volume's
//! dimensions, voxel type, the method and its options, against the memory
//! the process may still take (the tightest of `MemAvailable`, its
//! `RLIMIT_AS`/`RLIMIT_DATA` and its cgroup's limit, see [`Limits`]; or
//! `--max-memory`), before the volume or the frame's arrays are allocated.
//! A scene too big for the machine is refused with one line rather than
//! killed by the kernel halfway through.
//!
//! The estimate is an upper bound on the arrays that scale with the volume
//! (measured peaks are in docs/benchmarks.md#memory): it counts the volume
//! and its slice stack apart even where a view lays the stack in the
//! volume's own buffer.

use std::sync::Mutex;
use std::time::{Duration, Instant};

use anyhow::{bail, Result};

use golden::render::Technique;
use golden::volume::VoxelType;

/// Memory assumed free when /proc/meminfo cannot be read (not Linux).
const UNKNOWN_AVAILABLE: u64 = golden::volume::DEFAULT_MEMORY_LIMIT;

/// The program, its tables, thread stacks and per-row scratch: what a
/// frame takes besides the arrays [`frame_bytes`] counts (a 64^3 frame
/// peaks at about 20 MB).
const OVERHEAD: u128 = 64 << 20;

/// How long a reading of the [`Limits`] may stand in for a new one
/// ([`Limits::recent`]).
const RECENT_FOR: Duration = Duration::from_secs(1);

/// A reading stands in for a new one only for a frame needing at most
/// this fraction (one over it) of the room the reading showed.
const RECENT_SHARE: u128 = 8;

/// Parses a byte count: a whole number of bytes, or a number with a binary
/// suffix `K`, `M`, `G` or `T` (KiB, MiB, GiB, TiB; `1.5G` is allowed).
pub fn parse_bytes(s: &str) -> std::result::Result<u64, String> {
    let t = s.trim();
    let (num, scale) = match t.char_indices().last() {
        Some((i, c)) if c.is_ascii_alphabetic() => {
            let shift = match c.to_ascii_uppercase() {
                'K' => 10,
                'M' => 20,
                'G' => 30,
                'T' => 40,
                _ => {
                    return Err(format!(
                        "memory size '{s}': the suffix must be K, M, G or T"
                    ))
                }
            };
            (&t[..i], (1u64 << shift) as f64)
        }
        _ => (t, 1.0),
    };
    let v: f64 = num
        .parse()
        .map_err(|_| format!("memory size '{s}' is not a number of bytes (e.g. 512M, 8G)"))?;
    let bytes = v * scale;
    if !(bytes.is_finite() && bytes >= 1.0 && bytes < u64::MAX as f64) {
        return Err(format!("memory size '{s}' must be at least 1 byte"));
    }
    Ok(bytes as u64)
}

/// `MemAvailable` from /proc/meminfo, in bytes.
fn mem_available() -> Option<u64> {
    let text = std::fs::read_to_string("/proc/meminfo").ok()?;
    kib_field(&text, "MemAvailable:")
}

/// A `Name:   123 kB` field of /proc/meminfo or /proc/self/status, in bytes.
fn kib_field(text: &str, name: &str) -> Option<u64> {
    let line = text.lines().find(|l| l.starts_with(name))?;
    let kb: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    kb.checked_mul(1024)
}

/// What limits this process's memory, each as the bytes still free under
/// it: the machine (`MemAvailable`), the address-space and data-segment
/// limits (`RLIMIT_AS`, `RLIMIT_DATA`, as `ulimit -v`/`-d` or `prlimit`
/// set them) minus what the process already maps (`VmSize`, `VmData`),
/// and its cgroup's limit (v2 `memory.max`, v1 `memory.limit_in_bytes`,
/// as a container or a batch job gets) minus the cgroup's usage.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Limits {
    /// The machine's available memory.
    pub available: Option<u64>,
    /// Bytes left under `RLIMIT_AS`.
    pub address_space: Option<u64>,
    /// Bytes left under `RLIMIT_DATA`.
    pub data: Option<u64>,
    /// Bytes left under the cgroup's memory limit.
    pub cgroup: Option<u64>,
}

impl Limits {
    /// Reads the limits now in force.
    pub fn read() -> Limits {
        let (address_space, data) = (rlimit(libc::RLIMIT_AS), rlimit(libc::RLIMIT_DATA));
        // What the process maps matters only under a limit; without one
        // the status file (slow to make for a process of many threads and
        // mappings) is not read.
        let status = if address_space.is_some() || data.is_some() {
            std::fs::read_to_string("/proc/self/status").unwrap_or_default()
        } else {
            String::new()
        };
        let left = |limit: Option<u64>, used: &str| {
            limit.map(|l| l.saturating_sub(kib_field(&status, used).unwrap_or(0)))
        };
        Limits {
            available: mem_available(),
            address_space: left(address_space, "VmSize:"),
            data: left(data, "VmData:"),
            cgroup: cgroup_left(),
        }
    }

    /// The limits for a frame estimated to need `need` bytes: the last
    /// reading when it is under [`RECENT_FOR`] old and `need` is at most
    /// one [`RECENT_SHARE`]th of the room it showed, else a new reading
    /// (kept for the next frame).
    ///
    /// A limit moves while the process runs (other processes take and give
    /// back memory, a cgroup's usage moves, `prlimit` changes a ulimit), so
    /// any reading is a snapshot that the frame's allocations follow. A
    /// reading under a second old decides as a new one would unless seven
    /// eighths of the room it showed went within that second; a frame
    /// nearer its limits, and any frame a second later, reads them again.
    /// Reading them takes about 0.1 ms (`/proc/meminfo` is generated on
    /// each read, the cgroup's files are opened by path), which a caller
    /// rendering frame after frame in one process (the Python module)
    /// would otherwise pay on every frame.
    pub fn recent(need: u128) -> Limits {
        static LAST: Mutex<Option<(Instant, Limits)>> = Mutex::new(None);
        if let Ok(last) = LAST.lock() {
            if let Some((at, l)) = *last {
                if l.stands_in(at.elapsed(), need) {
                    return l;
                }
            }
        }
        let l = Limits::read();
        if let Ok(mut last) = LAST.lock() {
            *last = Some((Instant::now(), l));
        }
        l
    }

    /// Whether this reading, `age` old, stands in for a new one for a
    /// frame needing `need` bytes ([`Limits::recent`]).
    fn stands_in(&self, age: Duration, need: u128) -> bool {
        let room = self.tightest().map_or(UNKNOWN_AVAILABLE, |(b, _)| b);
        age < RECENT_FOR && need <= u128::from(room) / RECENT_SHARE
    }

    /// The tightest limit and its name, if any is known.
    pub fn tightest(&self) -> Option<(u64, &'static str)> {
        [
            (self.available, "available memory (MemAvailable)"),
            (
                self.address_space,
                "address-space limit (RLIMIT_AS, ulimit -v)",
            ),
            (self.data, "data-segment limit (RLIMIT_DATA, ulimit -d)"),
            (self.cgroup, "cgroup memory limit (memory.max)"),
        ]
        .into_iter()
        .filter_map(|(v, name)| v.map(|v| (v, name)))
        .min_by_key(|&(v, _)| v)
    }
}

/// The soft limit `resource`, if one is set.
fn rlimit(resource: libc::__rlimit_resource_t) -> Option<u64> {
    let mut r = libc::rlimit {
        rlim_cur: 0,
        rlim_max: 0,
    };
    // SAFETY: getrlimit writes the struct it is given and nothing else.
    let ok = unsafe { libc::getrlimit(resource, &mut r) } == 0;
    (ok && r.rlim_cur != libc::RLIM_INFINITY).then_some(r.rlim_cur)
}

/// Bytes left under this process's cgroup memory limit (v2, else v1).
fn cgroup_left() -> Option<u64> {
    let own = std::fs::read_to_string("/proc/self/cgroup").ok()?;
    let read_u64 =
        |p: String| -> Option<u64> { std::fs::read_to_string(p).ok()?.trim().parse().ok() };
    for line in own.lines() {
        let mut parts = line.splitn(3, ':');
        let (_, controllers, path) = (parts.next()?, parts.next()?, parts.next()?);
        let (limit, usage) = if controllers.is_empty() {
            let dir = format!("/sys/fs/cgroup{path}");
            (
                read_u64(format!("{dir}/memory.max")),
                read_u64(format!("{dir}/memory.current")),
            )
        } else if controllers.split(',').any(|c| c == "memory") {
            let dir = format!("/sys/fs/cgroup/memory{path}");
            (
                read_u64(format!("{dir}/memory.limit_in_bytes")),
                read_u64(format!("{dir}/memory.usage_in_bytes")),
            )
        } else {
            continue;
        };
        // v1 writes "no limit" as a huge number; v2 writes "max" (unparsed).
        if let Some(l) = limit.filter(|&l| l < 1 << 60) {
            return Some(l.saturating_sub(usage.unwrap_or(0)));
        }
    }
    None
}

/// How much memory a frame may take, and where that figure came from.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Budget {
    /// Bytes the frame may take.
    pub bytes: u64,
    /// Whether `--max-memory` set it (else the process's limits).
    from_flag: bool,
    /// Which limit set it, for messages.
    source: &'static str,
}

impl Budget {
    /// `--max-memory` when given (but never past an address-space, data or
    /// cgroup limit), else the tightest of the process's [`Limits`].
    pub fn new(max_memory: Option<u64>) -> Budget {
        Budget::under(max_memory, Limits::read())
    }

    /// [`Budget::new`] for a frame estimated to need `need` bytes, from
    /// the [`Limits::recent`] for it.
    pub fn for_need(max_memory: Option<u64>, need: u128) -> Budget {
        Budget::under(max_memory, Limits::recent(need))
    }

    /// [`Budget::new`] under the limits `limits`.
    fn under(max_memory: Option<u64>, limits: Limits) -> Budget {
        match max_memory {
            // The flag may go past the machine's free memory (swap, other
            // jobs ending) but not past a limit the kernel enforces.
            Some(bytes) => {
                let hard = Limits {
                    available: None,
                    ..limits
                }
                .tightest()
                .filter(|&(h, _)| h < bytes);
                match hard {
                    Some((bytes, source)) => Budget {
                        bytes,
                        from_flag: false,
                        source,
                    },
                    None => Budget {
                        bytes,
                        from_flag: true,
                        source: "--max-memory",
                    },
                }
            }
            None => {
                let (bytes, source) = limits
                    .tightest()
                    .unwrap_or((UNKNOWN_AVAILABLE, "assumed memory (no limit could be read)"));
                Budget {
                    bytes,
                    from_flag: false,
                    source,
                }
            }
        }
    }

    /// Refuses `what`, needing about `need` bytes, when that is over the
    /// budget.
    pub fn check(&self, what: &str, need: u128) -> Result<()> {
        if need <= self.bytes as u128 {
            return Ok(());
        }
        let limit = if self.from_flag {
            format!("the {} --max-memory allows", human(self.bytes as u128))
        } else {
            format!(
                "the {} left under this process's {}; --max-memory lowers it",
                human(self.bytes as u128),
                self.source
            )
        };
        bail!(
            "{what} needs about {} of memory, more than {limit}",
            human(need)
        )
    }
}

/// `b` bytes for people (three significant digits, binary units).
fn human(b: u128) -> String {
    golden::error::human_bytes(b)
}

/// What a frame computes, as far as its memory goes.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FrameSpec {
    /// The golden technique, or `None` for the pipeline model (which also
    /// renders golden's mirror method for its comparison).
    pub technique: Option<Technique>,
    /// Shading (voxel gradients).
    pub shade: bool,
    /// Image width and height.
    pub size: [u32; 2],
}

/// An upper bound on the peak bytes of one frame of a `dims` volume of
/// `voxel` scalars rendered as `spec` says.
pub fn frame_bytes(dims: [usize; 3], voxel: VoxelType, spec: &FrameSpec) -> u128 {
    let [nx, ny, nz] = dims.map(|n| n as u128);
    let voxels = nx * ny * nz;
    let padded = (nx + 2) * (ny + 2) * (nz + 2);
    let k = u128::from(voxel.bits() / 8);
    // The volume and its permuted, padded slice stack, in the file's type.
    let mut b = k * voxels + k * padded;
    // The empty-space map: a (min, max) pair of u16 per default block.
    b += 4 * voxels / (golden::occupancy::DEFAULT_BLOCK as u128).pow(3);
    if spec.shade {
        // Three f32 gradient components per padded voxel.
        b += 12 * padded;
    }
    b += match spec.technique {
        // RGBA f32 per voxel and the pyramid above it (an eighth, a
        // sixty-fourth, ...).
        Some(Technique::MipMap) => 16 * voxels * 8 / 7,
        // The classified RGBA f32 stack and its runs.
        Some(Technique::ShearWarp) => 16 * voxels + 8 * ny * nz,
        Some(Technique::Slice(_) | Technique::Reference) => 0,
        // The PE memories, loaded from the stack: the data's bytes per
        // voxel (8-bit data stays bytes), once under column blocks and up
        // to four times under the interleave (each column with its
        // three-column apron).
        None => 4 * k * voxels,
    };
    // Baseplanes (up to the largest face, RGBA f32, two buffers) and the
    // image with its copies.
    let face = [(nx, ny), (ny, nz), (nx, nz)]
        .iter()
        .map(|&(a, c)| (a + 2) * (c + 2))
        .max()
        .unwrap_or(0);
    let pixels = u128::from(spec.size[0]) * u128::from(spec.size[1]);
    b + 32 * face + 64 * pixels + OVERHEAD
}

#[cfg(test)]
mod tests {
    use super::*;
    use golden::methods::Method;

    #[test]
    fn byte_counts_parse_with_binary_suffixes() {
        assert_eq!(parse_bytes("1000"), Ok(1000));
        assert_eq!(parse_bytes("1M"), Ok(1 << 20));
        assert_eq!(parse_bytes("8g"), Ok(8 << 30));
        assert_eq!(parse_bytes("1.5K"), Ok(1536));
        for bad in ["", "M", "-1G", "0", "3X", "1e400", "lots"] {
            assert!(parse_bytes(bad).is_err(), "{bad}");
        }
    }

    #[test]
    fn estimates_grow_with_the_volume_the_voxel_type_and_the_method() {
        let spec = |technique, shade| FrameSpec {
            technique,
            shade,
            size: [256, 256],
        };
        let er = spec(Some(Technique::Slice(Method::Er)), false);
        let n = 1024;
        let g8 = frame_bytes([n; 3], VoxelType::U8, &er);
        // A gigavoxel of bytes: volume and stack, about 2 GiB, plus images.
        assert!(g8 > 2 << 30 && g8 < (2 << 30) + (256 << 20), "{g8}");
        assert!(frame_bytes([n; 3], VoxelType::U16, &er) > g8 + (2 << 30) - 1);
        let pipe = frame_bytes([n; 3], VoxelType::U8, &spec(None, false));
        assert_eq!(pipe - g8, 4 << 30);
        assert!(frame_bytes([n; 3], VoxelType::U8, &spec(Some(Technique::MipMap), false)) > pipe);
        assert!(
            frame_bytes(
                [n; 3],
                VoxelType::U8,
                &spec(Some(Technique::Slice(Method::Er)), true)
            ) > g8
        );
        assert!(frame_bytes([64; 3], VoxelType::U8, &er) < 128 << 20);
    }

    #[test]
    fn the_tightest_process_limit_sets_the_budget_and_names_itself() {
        let l = Limits {
            available: Some(8 << 30),
            address_space: Some(3 << 30),
            data: None,
            cgroup: Some(4 << 30),
        };
        assert_eq!(
            l.tightest(),
            Some((3 << 30, "address-space limit (RLIMIT_AS, ulimit -v)"))
        );
        let none = Limits {
            available: None,
            address_space: None,
            data: None,
            cgroup: None,
        };
        assert_eq!(none.tightest(), None);
        assert_eq!(
            kib_field("Name: x\nVmSize:\t  1024 kB\n", "VmSize:"),
            Some(1 << 20)
        );
        // This process's own limits read as positive figures.
        let own = Limits::read();
        assert!(own.available.is_none_or(|b| b > 0));
    }

    #[test]
    fn a_reading_stands_in_only_when_recent_and_far_from_the_frame_need() {
        let l = Limits {
            available: Some(8 << 30),
            address_space: None,
            data: None,
            cgroup: Some(4 << 30),
        };
        let young = Duration::from_millis(200);
        // The room is the cgroup's 4 GiB: an eighth of it is 512 MiB.
        assert!(l.stands_in(young, 512 << 20));
        assert!(!l.stands_in(young, (512 << 20) + 1));
        assert!(!l.stands_in(RECENT_FOR, 1));
        // Nothing read: the assumed memory is the room.
        let none = Limits {
            available: None,
            cgroup: None,
            ..l
        };
        assert!(none.stands_in(young, u128::from(UNKNOWN_AVAILABLE) / 8));
        assert!(!none.stands_in(young, u128::from(UNKNOWN_AVAILABLE) / 8 + 1));
    }

    #[test]
    fn the_budget_refuses_what_does_not_fit_in_one_line() {
        let b = Budget::new(Some(1 << 20));
        assert!(b.check("x", 1 << 20).is_ok());
        let e = b
            .check("a 64x64x64 frame", (1 << 20) + 1)
            .unwrap_err()
            .to_string();
        assert!(!e.contains('\n'), "{e}");
        assert!(e.contains("1.00 MiB --max-memory allows"), "{e}");
        // The machine's own figure is positive wherever it is read.
        assert!(Budget::new(None).bytes > 0);
    }
}
