//! The PE memories: the host's load of the volume into them, and their
//! keeping between frames. A camera path's frames that
//! keep the view's axis map (principal axis, its direction and the near
//! clip) find the volume already in PE memory, laid out as they need it,
//! and the host loads nothing.
//!
//! A PE's memory holds its columns of the *permuted* volume, `[z][y][l]` in
//! view space (see [`crate::pe::VoxelMem`]), so the contents depend on the
//! axis map, the mapping (which columns a PE holds, aprons included) and
//! the voxel word format. The model keeps one resident copy: a frame whose
//! axis map or configuration differs reloads all of it, as the host of a
//! chip with one copy would. Keeping three axis orders resident instead
//! (Cube-4's skewed memories read beams along any axis from one copy)
//! would be a different memory organisation, not modelled here.
//!
//! The load happens before a frame's first cycle, so [`crate::Frame::cycles`]
//! counts the same stages for a fresh and a resident frame, bit-identical;
//! [`VoxelLoad`] says what the host wrote and the cycles the load took
//! (0 for a resident frame): the bytes over the host link of
//! [`PipelineConfig::host_bandwidth`] bytes a cycle, or, if longer, the
//! busiest PE's words at one word a cycle through its memory's write port.

use std::sync::Arc;

use golden::geometry::{AxisMap, View};
use rayon::prelude::*;

use crate::config::PipelineConfig;
use crate::datapath::Datapath;
use crate::fixed::QuantStats;
use crate::host::VoxelSource;
use crate::pe::VoxelMem;

/// The PE memories a frame ran with, kept for the next frame
/// ([`crate::FrameRun::resident`]).
pub struct Resident {
    /// What the memories hold (`None`: to be loaded again, into these
    /// buffers).
    pub(crate) key: Option<Key>,
    pub(crate) mems: Vec<VoxelMem>,
    /// The host's quantisation events when it loaded them: a frame that
    /// reuses them reports them again, so its stats equal a fresh frame's
    /// (they describe the words in memory, not the act of writing them).
    pub(crate) stats: QuantStats,
    /// The datapath the frame loaded its tables into, before any unit
    /// beside it (shading, volume of interest, pre-integration), with what
    /// it was built from: a frame of the same configuration and table
    /// loads the same words, so it takes this one instead of quantising
    /// and listing them again (as golden builds its table once for its
    /// frames).
    pub(crate) unit: Option<(UnitKey, Arc<Datapath>)>,
}

impl Resident {
    /// The same memories as spare buffers: the next frame loads its
    /// volume again (a fresh frame's load, stats and cycles), into these
    /// allocations instead of new ones, as golden's repeated frames
    /// recycle their buffers. The datapath's tables stay: they depend
    /// only on the configuration and the classification table, which the
    /// next frame compares.
    pub fn stale(self) -> Resident {
        Resident { key: None, ..self }
    }

    /// Voxel words held over all PEs (aprons included).
    pub fn words(&self) -> u64 {
        self.mems.iter().map(|m| m.len() as u64).sum()
    }
}

/// What a datapath's tables and listed classification depend on: the
/// configuration and the classification table, entry by entry, bit for
/// bit.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct UnitKey {
    cfg: PipelineConfig,
    rgba: Vec<[u32; 4]>,
    per_scalar: u32,
}

impl UnitKey {
    pub(crate) fn of(cfg: &PipelineConfig, lut: &golden::tf::Lut) -> UnitKey {
        UnitKey {
            cfg: *cfg,
            rgba: lut.rgba.iter().map(|e| e.map(f32::to_bits)).collect(),
            per_scalar: lut.per_scalar.to_bits(),
        }
    }
}

/// What the memories' contents depend on.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Key {
    cfg: PipelineConfig,
    data_bits: u32,
    axes: AxisMap,
    dims: [usize; 3],
}

impl Key {
    pub(crate) fn of(cfg: &PipelineConfig, data_bits: u32, view: &View) -> Key {
        Key {
            cfg: *cfg,
            data_bits,
            axes: view.axes,
            dims: view.dims,
        }
    }
}

/// How a frame's PE memories came to hold the volume.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize)]
pub struct VoxelLoad {
    /// Whether the memories already held this view's volume (the previous
    /// frame's, same axis map and configuration): nothing was loaded.
    pub resident: bool,
    /// Voxel words the host wrote into the PE memories for this frame
    /// (every PE's columns and aprons; 0 when resident).
    pub words_loaded: u64,
    /// `words_loaded` in bytes of `voxel`-bit words.
    pub bytes_loaded: u64,
    /// Voxel words the PE memories hold.
    pub words_held: u64,
    /// `words_held` in bytes of `voxel`-bit words: what a resident frame
    /// did not load.
    pub bytes_held: u64,
    /// Cycles the load took before the frame's first cycle (0 when
    /// resident): `max(ceil(bytes_loaded / host_bandwidth), the most
    /// words one PE's memory takes)`.
    pub cycles: u64,
}

impl VoxelLoad {
    /// The load of memories holding `words` voxel words (PE by PE), or
    /// none when `resident`.
    pub(crate) fn new(cfg: &PipelineConfig, words: &[u64], resident: bool) -> VoxelLoad {
        let bytes = |w: u64| (w * u64::from(cfg.voxel.bits())).div_ceil(8);
        let words_held = words.iter().sum();
        let words_loaded = if resident { 0 } else { words_held };
        let busiest = if resident {
            0
        } else {
            words.iter().copied().max().unwrap_or(0)
        };
        let bytes_loaded = bytes(words_loaded);
        VoxelLoad {
            resident,
            words_loaded,
            bytes_loaded,
            words_held,
            bytes_held: bytes(words_held),
            cycles: bytes_loaded
                .div_ceil(u64::from(cfg.host_bandwidth))
                .max(busiest),
        }
    }
}

/// Every PE's voxel memory (PE `k` holding columns `held[k]`, ascending),
/// read from `source` a row at a time: each voxel is quantised once (its
/// events counted in `st`, as the host's) and written to every PE holding
/// its column (its owner and, under a round-robin mapping, the neighbours
/// whose aprons include it). The memories are built in `spare`'s buffers
/// where it has them (a previous frame's, [`Resident::stale`]); 8-bit
/// data loads slice by slice in parallel.
pub(super) fn load_memories(
    cfg: &PipelineConfig,
    source: VoxelSource,
    data_bits: u32,
    held: &[Vec<usize>],
    [nx, ny, nz]: [usize; 3],
    (st, spare): (&mut QuantStats, Vec<VoxelMem>),
) -> Vec<VoxelMem> {
    // The spare memories' allocations, by PE: filling pages already
    // mapped costs no page faults.
    let mut spare = spare.into_iter();
    let mut buffers = || -> (Vec<u8>, Vec<u16>) {
        let (mut b, mut w) = match spare.next() {
            Some(VoxelMem::Codes { codes, .. }) => (codes, Vec::new()),
            Some(VoxelMem::Words(w)) => (Vec::new(), w),
            None => (Vec::new(), Vec::new()),
        };
        b.clear();
        w.clear();
        (b, w)
    };
    let word = |v: u16, st: &mut QuantStats| crate::skip::voxel_word(cfg, v, data_bits, st);
    if data_bits <= 8 {
        // Each code's word and the quantisation events assigning it.
        let coded: Vec<(u16, QuantStats)> = (0..256u16)
            .map(|v| {
                let mut one = QuantStats::default();
                (word(v, &mut one), one)
            })
            .collect();
        let table: Box<[u16; 256]> = Box::new(std::array::from_fn(|v| coded[v].0));
        // A PE holding consecutive columns (a block) copies its part of a
        // row at once.
        let blocks: Vec<Option<std::ops::Range<usize>>> = held
            .iter()
            .map(|h| {
                let (&a, &b) = (h.first()?, h.last()?);
                (b - a + 1 == h.len()).then_some(a..b + 1)
            })
            .collect();
        // Slice by slice in parallel: slice `z` fills part `z` of every
        // PE's memory (`[z][y][l]`), each row read once, and counts its
        // voxels' codes.
        let mut codes: Vec<Vec<u8>> = held
            .iter()
            .map(|h| {
                let mut b = buffers().0;
                b.resize(h.len() * ny * nz, 0);
                b
            })
            .collect();
        let mut parts: Vec<Vec<&mut [u8]>> =
            (0..nz).map(|_| Vec::with_capacity(held.len())).collect();
        for (mem, h) in codes.iter_mut().zip(held) {
            // A PE holding no column has an empty memory.
            if h.is_empty() {
                parts.iter_mut().for_each(|p| p.push(&mut []));
                continue;
            }
            for (part, z) in mem.chunks_mut(h.len() * ny).zip(parts.iter_mut()) {
                z.push(part);
            }
        }
        // When every code quantises alike (its word is exact and in range,
        // say), the events are the voxels' count times one code's, and the
        // codes need no counting.
        let uniform = coded.iter().all(|(_, e)| *e == coded[0].1);
        let mut count = parts
            .into_par_iter()
            .enumerate()
            .map(|(z, mut part)| {
                let (mut row, mut buf) = (vec![0u16; nx], vec![0u8; nx]);
                // Four interleaved counts: a run of equal voxels would
                // otherwise chain every increment through one counter.
                let mut c = [[0u64; 256]; 4];
                for y in 0..ny {
                    let bytes = match source.row_bytes(y, z, nx) {
                        Some(bytes) => bytes,
                        None => {
                            source.row(y, z, &mut row);
                            // 8-bit data: every scalar is below 256.
                            for (b, &v) in buf.iter_mut().zip(&row) {
                                *b = v as u8;
                            }
                            &buf
                        }
                    };
                    if !uniform {
                        for (i, &v) in bytes.iter().enumerate() {
                            c[i & 3][usize::from(v)] += 1;
                        }
                    }
                    for ((mem, cols), block) in part.iter_mut().zip(held).zip(&blocks) {
                        let w = cols.len();
                        let out = &mut mem[y * w..(y + 1) * w];
                        match block {
                            Some(r) => out.copy_from_slice(&bytes[r.clone()]),
                            None => {
                                for (o, &x) in out.iter_mut().zip(cols) {
                                    *o = bytes[x];
                                }
                            }
                        }
                    }
                }
                let mut out = [0u64; 256];
                for (v, o) in out.iter_mut().enumerate() {
                    *o = c.iter().map(|c| c[v]).sum();
                }
                out
            })
            .reduce(
                || [0u64; 256],
                |mut a, b| {
                    for (x, y) in a.iter_mut().zip(&b) {
                        *x += y;
                    }
                    a
                },
            );
        if uniform {
            count = [0; 256];
            count[0] = (nx * ny * nz) as u64;
        }
        for ((_, one), &n) in coded.iter().zip(&count) {
            st.merge(&one.times(n));
        }
        return codes
            .into_iter()
            .map(|codes| VoxelMem::Codes {
                codes,
                words: table.clone(),
            })
            .collect();
    }
    let mut row = vec![0u16; nx];
    let mut words: Vec<Vec<u16>> = held
        .iter()
        .map(|h| {
            let mut w = buffers().1;
            w.reserve(h.len() * ny * nz);
            w
        })
        .collect();
    for z in 0..nz {
        for y in 0..ny {
            source.row(y, z, &mut row);
            for v in row.iter_mut() {
                *v = word(*v, st);
            }
            for (mem, cols) in words.iter_mut().zip(held) {
                mem.extend(cols.iter().map(|&c| row[c]));
            }
        }
    }
    words.into_iter().map(VoxelMem::Words).collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::Mapping;
    use crate::mapping::ColumnMap;
    use golden::geometry::AxisMap;
    use golden::slices::SliceStack;
    use golden::volume::{Volume, VoxelType};

    /// A permuted, flipped stack of a small volume of `kind` whose voxels
    /// all differ (modulo the type's range).
    fn stack(kind: VoxelType) -> SliceStack {
        let dims = [7, 5, 6];
        let vol = Volume::from_fn(dims, kind, u64::MAX, |x, y, z| {
            (x * 37 + y * 11 + z * 5) as u16 * if kind == VoxelType::U16 { 301 } else { 1 }
        })
        .unwrap();
        let axes = AxisMap {
            perm: [2, 0, 1],
            flip_z: true,
            index_dims: dims,
            z_first: 0,
        };
        SliceStack::new(&vol, &axes).unwrap()
    }

    /// A row read at once is the row read voxel by voxel.
    #[test]
    fn a_source_row_is_its_voxels() {
        for kind in [VoxelType::U8, VoxelType::U16] {
            let s = stack(kind);
            let src = VoxelSource::Stack(&s);
            let [nx, ny, nz] = s.dims;
            let mut row = vec![0; nx];
            for z in 0..nz {
                for y in 0..ny {
                    src.row(y, z, &mut row);
                    let one: Vec<u16> = (0..nx).map(|x| src.get(x, y, z)).collect();
                    assert_eq!(row, one, "{kind:?} row {y} of slice {z}");
                }
            }
        }
    }

    /// The row-at-a-time load fills every PE's memory, under blocks and a
    /// round-robin mapping with aprons, with each held column's words in
    /// `[z][y][l]` order, and counts each voxel's quantisation once: what
    /// quantising voxel by voxel gives.
    #[test]
    fn memories_hold_their_columns_words() {
        use crate::fixed::{Format, Overflow, Quant};
        // The default voxel word holds every scalar exactly; a 6-bit one
        // rounds some codes and not others (their events differ).
        let narrow = Format::new(6, 0, false, Quant::Rnd, Overflow::Sat).unwrap();
        let mut spare = Vec::new();
        for (kind, voxel) in [
            (VoxelType::U8, None),
            (VoxelType::U8, Some(narrow)),
            (VoxelType::U16, None),
            (VoxelType::U16, Some(narrow)),
        ] {
            let s = stack(kind);
            let src = VoxelSource::Stack(&s);
            let [nx, ny, nz] = s.dims;
            let bits = kind.bits();
            for (mapping, pes) in [
                (Mapping::Blocks, 3),
                (Mapping::Cyclic, 2),
                (Mapping::Interleave, 4),
                (Mapping::Blocks, 9),
            ] {
                let mut cfg = PipelineConfig::default();
                (cfg.mapping, cfg.pes, cfg.cyclic_width) = (mapping, pes, 2);
                if let Some(v) = voxel {
                    cfg.voxel = v;
                }
                let map = ColumnMap::of(&cfg, nx);
                let held: Vec<Vec<usize>> = (0..usize::from(pes)).map(|k| map.held(k)).collect();
                let mut st = QuantStats::default();
                // Loaded into the previous case's buffers (any sizes).
                let mems = load_memories(&cfg, src, bits, &held, s.dims, (&mut st, spare));
                let mut want_st = QuantStats::default();
                for z in 0..nz {
                    for y in 0..ny {
                        for x in 0..nx {
                            crate::skip::voxel_word(&cfg, src.get(x, y, z), bits, &mut want_st);
                        }
                    }
                }
                assert_eq!(st, want_st, "{kind:?} {voxel:?} {mapping:?}");
                assert!(
                    voxel.is_none() || want_st.inexact > 0,
                    "the narrow word rounds"
                );
                for (k, (mem, cols)) in mems.iter().zip(&held).enumerate() {
                    assert_eq!(mem.len(), cols.len() * ny * nz);
                    for z in 0..nz {
                        for y in 0..ny {
                            for (l, &c) in cols.iter().enumerate() {
                                let want = crate::skip::voxel_word(
                                    &cfg,
                                    src.get(c, y, z),
                                    bits,
                                    &mut QuantStats::default(),
                                );
                                let got = mem.get((z * ny + y) * cols.len() + l);
                                assert_eq!(
                                    got, want,
                                    "{kind:?} {voxel:?} {mapping:?} PE {k} ({c}, {y}, {z})"
                                );
                            }
                        }
                    }
                }
                spare = mems;
            }
        }
    }

    /// A load takes the host link's cycles or, when the link is faster
    /// than the PEs' write ports together, the busiest PE's words.
    #[test]
    fn a_load_takes_the_link_or_the_busiest_port() {
        let mut cfg = PipelineConfig::default();
        let words = [10, 30, 20];
        let bytes = (60 * u64::from(cfg.voxel.bits())).div_ceil(8);
        cfg.host_bandwidth = 1;
        let slow = VoxelLoad::new(&cfg, &words, false);
        assert_eq!((slow.bytes_loaded, slow.cycles), (bytes, bytes));
        cfg.host_bandwidth = 4096;
        assert_eq!(VoxelLoad::new(&cfg, &words, false).cycles, 30);
        let kept = VoxelLoad::new(&cfg, &words, true);
        assert_eq!(
            (kept.cycles, kept.words_loaded, kept.words_held),
            (0, 0, 60)
        );
    }
}
