//! Reading the sample stage's capture (`bus.txt`, `plan.txt`,
//! `pe<K>.{map,ev,vol,cfg,I,T,W}`, and under a round-robin mapping
//! `pe<K>.{cm,loc}`) back into one PE's per-clock port
//! words, with the clock conventions of the co-simulation's testbench
//! ([`crate::cosim::pe_sample::bench`]).

use std::path::Path;

use super::{Check, Column, MemWrite, PeStream};
use crate::cosim::pe_sample::Widths;
use crate::hw::pe_sample_rtl::{PeSampleShape, MODULE};

/// A port in the module's port list.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Decl {
    /// The name.
    pub name: String,
    /// An input (else an output).
    pub input: bool,
    /// Bits.
    pub bits: u32,
    /// Two's complement.
    pub signed: bool,
}

/// The ports of `ercube_pe_sample`'s port list, in order (read by
/// [`crate::synth::wrap::ports`]; none when the text has no such module).
pub fn ports(verilog: &str) -> Vec<Decl> {
    use crate::synth::wrap::{ports, Dir};
    ports(verilog, MODULE)
        .unwrap_or_default()
        .into_iter()
        .map(|p| Decl {
            input: p.dir == Dir::In,
            bits: p.bits,
            signed: p.signed,
            name: p.name,
        })
        .collect()
}

/// The lines of a capture file, each split into hexadecimal words.
fn hex_lines(path: &Path) -> Result<Vec<Vec<u128>>, String> {
    let text = std::fs::read_to_string(path).map_err(|e| format!("{}: {e}", path.display()))?;
    text.lines()
        .filter(|l| !l.trim().is_empty())
        .map(|l| {
            l.split_whitespace()
                .filter(|w| !matches!(*w, "I" | "T" | "W"))
                .map(|w| u128::from_str_radix(w, 16))
                .collect::<Result<Vec<_>, _>>()
                .map_err(|e| format!("{}: '{l}': {e}", path.display()))
        })
        .collect()
}

/// The broadcast's fields in `bus.txt`'s order after the clock, by port.
const BUS: [&str; 17] = [
    "bc_go",
    "bc_first",
    "bc_row",
    "bc_z",
    "bc_y0",
    "bc_y1",
    "bc_a",
    "bc_t",
    "bc_b",
    "bc_k",
    "bc_row_wy",
    "bc_sy",
    "bc_sz",
    "bc_nv",
    "bc_nz",
    "bc_ny0",
    "bc_ny1",
];

/// Ports that fall to zero on a clock with no broadcast (the rest hold).
const BUS_PULSES: [&str; 3] = ["bc_go", "bc_first", "bc_nv"];

/// A PE's held columns and its voxels `[z][y][l]` (`pe<K>.cfg`,
/// `pe<K>.vol`), its slice loads (`pe<K>.ev` kind 1) and, under a
/// round-robin mapping, its column map's entries (`pe<K>.cm`: clock,
/// entry, ray index, slot) and column decoder (`pe<K>.loc`, a local index
/// a volume column).
struct Voxels {
    cfg: Vec<u128>,
    vol: Vec<u128>,
    events: Vec<Vec<u128>>,
    cm: Vec<Vec<u128>>,
    loc: Vec<u128>,
}

fn voxels(dir: &Path, s: &PeSampleShape, k: usize) -> Result<Voxels, String> {
    let cfg = hex_lines(&dir.join(format!("pe{k}.cfg")))?
        .into_iter()
        .next()
        .unwrap_or_default();
    if cfg.len() != 4 {
        return Err(format!("pe{k}.cfg: expected 4 words"));
    }
    let vol = hex_lines(&dir.join(format!("pe{k}.vol")))?
        .into_iter()
        .map(|l| l.first().copied().unwrap_or(0))
        .collect();
    let events = hex_lines(&dir.join(format!("pe{k}.ev")))?;
    if events.iter().any(|e| e.len() != 5) {
        return Err(format!("pe{k}.ev: expected 5 words a line"));
    }
    let (mut cm, mut loc) = (Vec::new(), Vec::new());
    if s.round_robin {
        cm = hex_lines(&dir.join(format!("pe{k}.cm")))?;
        if cm.iter().any(|e| e.len() != 4) {
            return Err(format!("pe{k}.cm: expected 4 words a line"));
        }
        loc = hex_lines(&dir.join(format!("pe{k}.loc")))?
            .into_iter()
            .map(|l| l.first().copied().unwrap_or(0))
            .collect();
    }
    Ok(Voxels {
        cfg,
        vol,
        events,
        cm,
        loc,
    })
}

/// The writes of a slice load (`z` into parity `zp`, clock `cycle`): the
/// row banks and, from column 0, the edge column, as the co-simulation's
/// testbench writes them.
fn load(v: &Voxels, s: &PeSampleShape, (cycle, z, zp): (u64, u64, u64), out: &mut Vec<MemWrite>) {
    let (ny, half, stored) = (s.ny, s.half_rows, s.stored);
    let cw = v.cfg[0] as u64;
    for yy in 0..ny {
        for ll in 0..cw {
            let data = v
                .vol
                .get(((z * ny + yy) * cw + ll) as usize)
                .copied()
                .unwrap_or(0);
            let bank = (yy % 2) as u8;
            out.push(MemWrite {
                cycle,
                mem: bank,
                addr: (zp * half + yy / 2) * stored + ll,
                data,
            });
            if ll == 0 {
                out.push(MemWrite {
                    cycle,
                    mem: 2 + bank,
                    addr: zp * half + yy / 2,
                    data,
                });
            }
        }
    }
}

/// Every write into PE `k`'s memories, in the order applied: under a
/// round-robin mapping the column decoder first, with the PE's first
/// slice load (the host writes it with the voxels), and the column map's
/// entries at the clock migration gives them.
fn writes(v: &Voxels, s: &PeSampleShape) -> Vec<MemWrite> {
    let mut out = Vec::new();
    let first_load = v
        .events
        .iter()
        .find(|e| e[1] == 1)
        .map_or(0, |e| e[0] as u64);
    for (c, &l) in v.loc.iter().enumerate() {
        out.push(MemWrite {
            cycle: first_load,
            mem: 9,
            addr: c as u64,
            data: l,
        });
    }
    for e in &v.cm {
        let (cycle, entry) = (e[0] as u64, e[1] as u64);
        // The ray index as two's complement over the entry's width.
        out.push(MemWrite {
            cycle,
            mem: 7,
            addr: entry,
            data: e[2] & mask(s.index_bits),
        });
        out.push(MemWrite {
            cycle,
            mem: 8,
            addr: entry,
            data: e[3],
        });
    }
    for e in &v.events {
        let cycle = e[0] as u64;
        match e[1] {
            1 => load(v, s, (cycle, e[2] as u64, e[3] as u64), &mut out),
            5 => out.push(MemWrite {
                cycle,
                mem: 6,
                addr: e[2] as u64,
                data: (e[3] << 1) | (e[4] & 1),
            }),
            _ => out.push(MemWrite {
                cycle,
                mem: 4 + (e[2] % 2) as u8,
                addr: (e[2] / 2) as u64,
                data: e[4],
            }),
        }
    }
    out.sort_by_key(|w| w.cycle);
    out
}

/// The edge register of a PE with voxels `v` during each clock
/// `0..rows`, from the broadcast's next row (`nv`, `nz`, `ny0`, `ny1` by
/// row, as held at each rising edge): the emitted register latches the
/// broadcast at the edge starting clock `d`, and at the edge ending it,
/// when the broadcast named a next row, reads both row banks of its edge
/// column (the writes of clocks up to `d` in), holding otherwise.
fn edge_out(v: &Voxels, s: &PeSampleShape, next: &[[u128; 4]], bits: u32) -> Vec<u128> {
    let half = s.half_rows;
    let mut ec = [
        vec![0u128; (2 * half) as usize],
        vec![0u128; (2 * half) as usize],
    ];
    let mut loads = Vec::new();
    writes(v, s)
        .into_iter()
        .filter(|w| w.mem == 2 || w.mem == 3)
        .for_each(|w| loads.push(w));
    let mut at = 0;
    let (mut eq, mut ep) = ([0u128; 2], [0u128; 2]);
    let mut out = Vec::with_capacity(next.len());
    for (d, n) in next.iter().enumerate() {
        out.push(
            ((if ep[1] == 1 { eq[1] } else { eq[0] }) << bits)
                | if ep[0] == 1 { eq[1] } else { eq[0] },
        );
        while at < loads.len() && loads[at].cycle <= d as u64 {
            let w = loads[at];
            if let Some(x) = ec[usize::from(w.mem - 2)].get_mut(w.addr as usize) {
                *x = w.data;
            }
            at += 1;
        }
        let [nv, nz, y0, y1] = *n;
        if nv == 1 {
            let (r0, r1) = if y0 & 1 == 1 { (y1, y0) } else { (y0, y1) };
            let a0 = (nz as u64 * half + (r0 >> 1) as u64) as usize;
            let a1 = (nz as u64 * half + (r1 >> 1) as u64) as usize;
            eq = [
                ec[0].get(a0).copied().unwrap_or(0),
                ec[1].get(a1).copied().unwrap_or(0),
            ];
            ep = [y0 & 1, y1 & 1];
        }
    }
    out
}

/// PE `pe`'s stream from the capture in `dir` (the tables, the Verilog
/// and the counts are the caller's to fill).
pub(super) fn stream(
    dir: &Path,
    s: &PeSampleShape,
    w: &Widths,
    decls: &[Decl],
    pe: usize,
    pes: usize,
    tap_stage: u64,
) -> Result<PeStream, String> {
    let decl = |n: &str| {
        decls
            .iter()
            .find(|d| d.name == n)
            .cloned()
            .ok_or_else(|| format!("{MODULE} has no port {n}"))
    };
    let iss = hex_lines(&dir.join(format!("pe{pe}.I")))?;
    let taps = hex_lines(&dir.join(format!("pe{pe}.T")))?;
    let wbs = hex_lines(&dir.join(format!("pe{pe}.W")))?;
    let last = iss
        .iter()
        .map(|l| l[0] as u64)
        .chain(taps.iter().map(|l| l[0] as u64 + tap_stage))
        .chain(wbs.iter().map(|l| l[0] as u64))
        .max()
        .unwrap_or(0);
    let rows = last + 2;
    let n = rows as usize;
    let mut cols: Vec<Column> = Vec::new();
    // The broadcast: row c is bus.txt's line of clock c; without one the
    // pulses are low and the words hold.
    let bus_cols: Vec<usize> = BUS
        .iter()
        .map(|b| Ok::<_, String>(col_in(&mut cols, &decl(b)?, Check::Drive, n)))
        .collect::<Result<_, _>>()?;
    let mut bus = vec![None; n];
    for l in hex_lines(&dir.join("bus.txt"))? {
        // The clock, the broadcast's fields, then the volume of
        // interest's row position and slice (the files carry no VOI).
        if l.len() != 20 {
            return Err("bus.txt: expected 20 words a line".into());
        }
        if let Some(r) = bus.get_mut(l[0] as usize) {
            *r = Some(l);
        }
    }
    let mut held = [0u128; 17];
    for (r, line) in bus.iter().enumerate() {
        for (i, b) in BUS.iter().enumerate() {
            match line {
                Some(l) => held[i] = l[i + 1],
                None if BUS_PULSES.contains(b) => held[i] = 0,
                None => {}
            }
        }
        for (i, &c) in bus_cols.iter().enumerate() {
            let bits = cols[c].port.bits;
            cols[c].words[r] = held[i] & mask(bits);
        }
    }
    let next: Vec<[u128; 4]> = (0..n)
        .map(|r| [13, 14, 15, 16].map(|i| cols[bus_cols[i]].words[r]))
        .collect();
    // The held range: pe<K>.map's line of clock c takes effect in it.
    let map = [
        col_in(&mut cols, &decl("map_we")?, Check::Drive, n),
        col_in(&mut cols, &decl("map_lo_in")?, Check::Drive, n),
        col_in(&mut cols, &decl("map_n_in")?, Check::Drive, n),
        col_in(&mut cols, &decl("map_sl_in")?, Check::Drive, n),
    ];
    let mut by_row = vec![None; n];
    for l in hex_lines(&dir.join(format!("pe{pe}.map")))? {
        if let Some(r) = by_row.get_mut(l[0] as usize) {
            *r = Some(l);
        }
    }
    fill(&mut cols, &map, &by_row);
    // The plan port: plan.txt's run of clock c is taken at the edge
    // ending it (its row goes nowhere: the PE keeps its rows in the order
    // they come).
    let plan = [
        col_in(&mut cols, &decl("pl_valid")?, Check::Drive, n),
        col_in(&mut cols, &decl("pl_first")?, Check::Drive, n),
        col_in(&mut cols, &decl("pl_lo")?, Check::Drive, n),
        col_in(&mut cols, &decl("pl_hi")?, Check::Drive, n),
    ];
    let mut by_row = vec![None; n];
    for l in hex_lines(&dir.join("plan.txt"))? {
        if let Some(r) = by_row.get_mut(l[0] as usize + 1) {
            *r = Some(
                l.iter()
                    .enumerate()
                    .filter(|&(i, _)| i != 2)
                    .map(|(_, &w)| w)
                    .collect(),
            );
        }
    }
    fill(&mut cols, &plan, &by_row);
    // The right neighbour's edge register, a clock behind.
    let e = col_in(&mut cols, &decl("edge_in")?, Check::Drive, n);
    if pe + 1 < pes {
        let right = voxels(dir, s, pe + 1)?;
        let during = edge_out(&right, s, &next, s.voxel_bits);
        cols[e].words[1..n].copy_from_slice(&during[..n - 1]);
    }
    // The expected outputs.
    let out = |cols: &mut Vec<Column>, names: &[&str], valid: &'static str| {
        let mut idx = vec![col_in(cols, &decl(valid)?, Check::Always, n)];
        for &nm in names {
            idx.push(col_in(cols, &decl(nm)?, Check::When(valid), n));
        }
        Ok::<_, String>(idx)
    };
    // An issue's accumulators reach the datapath a clock after it.
    let iss_cols = out(&mut cols, &["iss_m"], "iss_valid")?;
    let acc_cols = out(
        &mut cols,
        &["iss_acc_r", "iss_acc_g", "iss_acc_b", "iss_acc_a"],
        "acc_valid",
    )?;
    for l in &iss {
        put(&mut cols, &iss_cols, l[0] as usize, &l[1..2]);
        put(&mut cols, &acc_cols, l[0] as usize + 1, &l[2..]);
    }
    let tap_cols = out(
        &mut cols,
        &["tap_v00", "tap_v01", "tap_v10", "tap_v11"],
        "tap_valid",
    )?;
    for l in &taps {
        put(
            &mut cols,
            &tap_cols,
            (l[0] as u64 + tap_stage) as usize,
            &l[1..],
        );
    }
    let wb_cols = out(&mut cols, &["wb_addr", "wb_data"], "wb_valid")?;
    for l in &wbs {
        if l.len() != 6 {
            return Err(format!("pe{pe}.W: expected 6 words a line"));
        }
        let mut packed = 0u128;
        let mut at = 0;
        for (i, &v) in l[2..6].iter().enumerate() {
            packed |= v << at;
            at += if i == 3 { w.alpha } else { w.color };
        }
        put(&mut cols, &wb_cols, l[0] as usize, &[l[1], packed]);
    }
    let me = voxels(dir, s, pe)?;
    let constants = ["col_lo", "col_end", "nx_last"]
        .iter()
        .enumerate()
        .map(|(i, n)| Ok((decl(n)?, me.cfg[i + 1])))
        .collect::<Result<Vec<_>, String>>()?;
    let writes = writes(&me, s);
    // Whole hexadecimal digits (the writes file's fields are).
    let write_data_bits = s.rays.buffer_width.max(s.voxel_bits).max(33).div_ceil(4) * 4;
    Ok(PeStream {
        pe,
        pes,
        rows,
        columns: cols,
        constants,
        writes,
        write_data_bits,
        table_rows: (String::new(), 0),
        tables: Vec::new(),
        verilog: String::new(),
        datapath: (String::new(), String::new()),
        depth: 0,
        tap_stage,
        samples: (0, 0),
        frame_cycles: 0,
        mapping: "",
        shape: *s,
    })
}

fn mask(bits: u32) -> u128 {
    if bits >= 128 {
        u128::MAX
    } else {
        (1u128 << bits) - 1
    }
}

/// Adds a column of `n` rows for port `d`; its index.
fn col_in(cols: &mut Vec<Column>, d: &Decl, check: Check, n: usize) -> usize {
    cols.push(Column {
        port: d.clone(),
        check,
        words: vec![0; n],
    });
    cols.len() - 1
}

/// A valid and its words in row `r` of columns `idx` (the valid first).
fn put(cols: &mut [Column], idx: &[usize], r: usize, words: &[u128]) {
    if r >= cols[idx[0]].words.len() {
        return;
    }
    cols[idx[0]].words[r] = 1;
    for (&c, &v) in idx[1..].iter().zip(words) {
        let bits = cols[c].port.bits;
        cols[c].words[r] = v & mask(bits);
    }
}

/// A strobed port group (`idx[0]` the strobe): row `r` holds line `r`'s
/// words after its clock, the strobe low and the words held where there
/// is none.
fn fill(cols: &mut [Column], idx: &[usize], by_row: &[Option<Vec<u128>>]) {
    let mut held = vec![0u128; idx.len()];
    for (r, line) in by_row.iter().enumerate() {
        match line {
            Some(l) => {
                held[0] = 1;
                for (i, h) in held.iter_mut().enumerate().skip(1) {
                    *h = l.get(i).copied().unwrap_or(0);
                }
            }
            None => held[0] = 0,
        }
        for (i, &c) in idx.iter().enumerate() {
            let bits = cols[c].port.bits;
            cols[c].words[r] = held[i] & mask(bits);
        }
    }
}
