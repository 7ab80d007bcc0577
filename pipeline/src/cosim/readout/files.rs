//! The readout co-simulation's input files: the host's load words
//! (each PE's counts, column map, compositing buffer and valid bits)
//! and, per clock, the host ports and `done` lines the model drove.

use std::fmt::Write as _;
use std::path::Path;

use crate::cosim::capture::{ReadoutStart, ReadoutTick};
use crate::cost::shapes::RAY_INDEX_BITS;
use crate::hw::readout_rtl::{ReadoutShape, SEL_BUFFER, SEL_COUNTS, SEL_MAP, SEL_VALID};

/// Each PE's `(ncols, rows)`: the counts the readout module is loaded
/// with. Refused in one line where a PE's rays do not fit the module: held
/// columns of different row counts, more columns or rays than declared, an
/// index wider than the column map's.
pub fn counts(shape: &ReadoutShape, start: &ReadoutStart) -> Result<Vec<(u64, u64)>, String> {
    if start.pes.len() != shape.pes {
        return Err(format!(
            "the readout module has {} PEs, the frame {}",
            shape.pes,
            start.pes.len()
        ));
    }
    let half = 1i64 << (RAY_INDEX_BITS - 1);
    let mut out = Vec::new();
    for (k, pe) in start.pes.iter().enumerate() {
        let rows = pe.rows.first().copied().unwrap_or(0) as u64;
        if pe.rows.iter().any(|&r| r as u64 != rows) {
            return Err(format!(
                "PE {k} holds columns of different row counts at the readout"
            ));
        }
        let ncols = pe.mx.len() as u64;
        if ncols > shape.map_depth || ncols * rows > 2 * shape.bank_depth || rows > shape.max_rows {
            return Err(format!(
                "PE {k} holds {ncols} columns of {rows} rows, past the declared {} slots of {} rays",
                shape.map_depth,
                2 * shape.bank_depth
            ));
        }
        if let Some(mx) = pe.mx.iter().find(|&&m| !(-half..half).contains(&m)) {
            return Err(format!(
                "PE {k}'s ray index {mx} is wider than {RAY_INDEX_BITS} bits"
            ));
        }
        out.push((ncols, rows));
    }
    Ok(out)
}

/// `fields` (value, bits), the first at bit 0, as one hexadecimal word
/// (two's complement within each field's bits).
fn pack(fields: &[(i64, u32)]) -> String {
    let mut bits: Vec<bool> = Vec::new();
    for &(v, n) in fields {
        for i in 0..n {
            bits.push(i < 64 && (v >> i) & 1 == 1);
        }
    }
    if bits.is_empty() {
        return "0".into();
    }
    let mut s = String::new();
    for chunk in bits.chunks(4).rev() {
        let d = chunk
            .iter()
            .enumerate()
            .fold(0u32, |a, (i, &b)| a | (u32::from(b) << i));
        s.push(char::from_digit(d, 16).unwrap_or('0'));
    }
    s
}

/// The accumulators' fields of `w` as the buffer packs them.
fn acc_fields(shape: &ReadoutShape, w: &[i64; 4]) -> [(i64, u32); 4] {
    let (c, a) = (shape.color_bits, shape.alpha_bits);
    [(w[0], c), (w[1], c), (w[2], c), (w[3], a)]
}

/// Writes `load.hex` (the host's load words: PE, select, address, data)
/// and `expect.hex` (per clock, per PE: host port fields and `done`) into
/// `dir`.
pub fn write_files(
    shape: &ReadoutShape,
    start: &ReadoutStart,
    ticks: &[ReadoutTick],
    dir: &Path,
) -> Result<(), String> {
    let counts = counts(shape, start)?;
    let rb = shape.row_bits();
    let mut load = String::new();
    for (k, (pe, &(ncols, rows))) in start.pes.iter().zip(&counts).enumerate() {
        let _ = writeln!(
            load,
            "{k:x} {SEL_COUNTS:x} 0 {}",
            pack(&[(rows as i64, rb), (ncols as i64, shape.slot_bits())])
        );
        for (s, &mx) in pe.mx.iter().enumerate() {
            let valid = i64::from(pe.rows[s] > 0);
            let _ = writeln!(
                load,
                "{k:x} {SEL_MAP:x} {s:x} {}",
                pack(&[(mx, RAY_INDEX_BITS), (valid, 1)])
            );
        }
        // Ray (c, r) at r * slots + c; the start lists them column after
        // column.
        let rows_n = rows as usize;
        for (i, w) in pe.words.iter().enumerate() {
            let (c, r) = (i / rows_n.max(1), i % rows_n.max(1));
            let a = r as u64 * shape.map_depth + c as u64;
            let _ = writeln!(
                load,
                "{k:x} {SEL_BUFFER:x} {a:x} {}",
                pack(&acc_fields(shape, w))
            );
        }
        if shape.sparse {
            for r in 0..rows_n {
                let bits: Vec<(i64, u32)> = (0..pe.mx.len())
                    .map(|c| (i64::from(pe.words[c * rows_n + r] != [0; 4]), 1))
                    .collect();
                let _ = writeln!(load, "{k:x} {SEL_VALID:x} {r:x} {}", pack(&bits));
            }
        }
    }
    let mut expect = String::new();
    for (i, t) in ticks.iter().enumerate() {
        if t.cycle != start.cycle + i as u64 + 1 || t.host.len() != shape.pes {
            return Err(format!(
                "the readout's clock {} is not the frame's cycle {} of {} PEs",
                i + 1,
                start.cycle + i as u64 + 1,
                shape.pes
            ));
        }
        for (h, &done) in t.host.iter().zip(&t.done) {
            let (v, mx, row, w) = match h {
                Some(o) => (1, o.mx, i64::from(o.row), o.acc.raw),
                None => (0, 0, 0, [0; 4]),
            };
            let f = acc_fields(shape, &w);
            let _ = writeln!(
                expect,
                "{v} {} {} {} {} {} {} {}",
                pack(&[(mx, RAY_INDEX_BITS)]),
                pack(&[(row, rb)]),
                pack(&f[0..1]),
                pack(&f[1..2]),
                pack(&f[2..3]),
                pack(&f[3..4]),
                u8::from(done)
            );
        }
    }
    let err = |e: std::io::Error| format!("cosim readout files in {}: {e}", dir.display());
    std::fs::write(dir.join("load.hex"), load).map_err(err)?;
    std::fs::write(dir.join("expect.hex"), expect).map_err(err)?;
    Ok(())
}
