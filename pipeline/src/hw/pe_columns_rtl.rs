//! Where a PE's sample stage finds its columns, by mapping
//! ([`super::pe_sample_rtl`]): the issuing ray's index and buffer slot,
//! the column map and column decoder, and under column blocks the edge
//! register the left neighbour reads (the taps' addresses from these
//! columns are [`super::pe_taps_rtl`]'s).
//!
//! Under column blocks a PE holds one consecutive block: held column
//! `map_lo + i` is ray `map_lo + i` in slot `mx` modulo the slots, a tap
//! column `c` is local column `c - col_lo`, and the column right of the
//! block comes from the right neighbour's edge register. Under a
//! round-robin mapping (the interleave, the cyclic mapping:
//! [`crate::mapping::ColumnMap`]) a PE holds several blocks, each with its
//! apron (one column left, two right), so every tap is in its own memory:
//! the column decoder `loc` (the model's `Pe::local`, the host's load
//! order) gives a held column's local index; and its rays are the ones
//! whose columns lie in its blocks in the current slice, from across the
//! slice, so the column map lists them in increasing index (`cm_mx`),
//! each with the slot migration gave it (`cm_sl`,
//! [`crate::cosim::pe_sample::slots`]): plan bit `i` is the column map's
//! entry `i`, and the control issues a row's set bits lowest first, in
//! increasing ray index as the model's `Pe::sample_step` does.
//!
//! Golden twin: `golden::sampling::sample_region` (the taps each ray
//! reads), through [`crate::pe::Pe::sample_step`].

use std::fmt::Write as _;

use super::pe_sample_shape::PeSampleShape;
use crate::cost::inventory::addr_bits;

/// Bits of a round-robin column map entry's slot.
pub(super) fn slot_bits(s: &PeSampleShape) -> u32 {
    addr_bits(s.slots())
}

/// Under a round-robin mapping, the column map (`cm_mx`, `cm_sl`, `map_n`
/// entries in increasing ray index, written by migration) and the column
/// decoder (`loc`, written by the host with the voxels); nothing under
/// column blocks.
pub(super) fn declarations(s: &PeSampleShape) -> String {
    if !s.round_robin {
        return String::new();
    }
    format!(
        "  // The column map, held rays in increasing index: ray cm_mx[i] in slot cm_sl[i].
  reg signed [{ib1}:0] cm_mx [0:{s1}];
  reg [{tb1}:0] cm_sl [0:{s1}];
  // The column decoder: a held voxel column's local index in the slice buffer.
  reg [{lb1}:0] loc [0:{nxm}];
",
        ib1 = s.index_bits - 1,
        s1 = s.slots() - 1,
        tb1 = slot_bits(s) - 1,
        lb1 = addr_bits(s.stored) - 1,
        nxm = s.nx - 1,
    )
}

/// The plan port's comparators: `pl_bits[i]` set when the ray plan bit
/// `i` stands for is held (`i < map_n`) and lies in the run `pl_lo ..=
/// pl_hi`. Under column blocks that ray is `map_lo + i`, so the run is
/// moved to the range once (two subtractors) and compared with every
/// bit's constant `i` at once (thermometer codes of the run's ends); under a
/// round-robin mapping each entry's index
/// `cm_mx[i]` is compared with the run at the index's width.
pub(super) fn plan_compare(s: &PeSampleShape) -> String {
    let (n, ib) = (s.slots(), s.index_bits);
    if s.round_robin {
        format!(
            "  genvar pl_i;
  generate
    for (pl_i = 0; pl_i < {n}; pl_i = pl_i + 1) begin : pl_cmp
      wire signed [{ib1}:0] pl_mx = cm_mx[pl_i];
      assign pl_bits[pl_i] = pl_i < map_n && pl_mx >= pl_lo && pl_mx <= pl_hi;
    end
  endgenerate",
            ib1 = ib - 1
        )
    } else {
        format!(
            "  // The run moved to the range, and each bit's three tests as thermometer
  // codes of the run's ends and the count (i >= lo, i <= hi, i < map_n).
  wire signed [{ib}:0] pl_lo_r = pl_lo - map_lo;
  wire signed [{ib}:0] pl_hi_r = pl_hi - map_lo;
  wire [{s1}:0] pl_all = {{{n}{{1'b1}}}};
  wire [{s1}:0] pl_ge = pl_lo_r < 0 ? pl_all : pl_lo_r > {s1} ? {n}'d0 : pl_all << pl_lo_r[{tb1}:0];
  wire [{s1}:0] pl_le = pl_hi_r < 0 ? {n}'d0 : pl_hi_r > {s1} ? pl_all : pl_all >> ({s1} - pl_hi_r[{tb1}:0]);
  wire [{s1}:0] pl_in = ~(pl_all << map_n);
  assign pl_bits = pl_ge & pl_le & pl_in;",
            s1 = n - 1,
            tb1 = slot_bits(s) - 1
        )
    }
}

/// The index `idx` of the one-hot word `one` (the row's lowest bit not
/// issued): bit `b` of the index is the OR of the word's bits whose index
/// has bit `b` set, a tree of ORs rather than a priority chain.
pub(super) fn encoder(s: &PeSampleShape) -> String {
    let n = s.slots();
    (0..slot_bits(s))
        .map(|b| {
            let mask: String = (0..n)
                .rev()
                .map(|i| if (i >> b) & 1 == 1 { '1' } else { '0' })
                .collect();
            format!("  assign idx[{b}] = |(one & {n}'b{mask});")
        })
        .collect::<Vec<_>>()
        .join("\n")
}

/// `x * k` as a sum of `x`'s shifts, one a set bit of the constant `k`
/// (no multiplier: the row's base address in the compositing buffer, a
/// slice row's in the slice buffer).
pub(super) fn times(k: u64, x: &str) -> String {
    let terms: Vec<String> = (0..64)
        .filter(|b| (k >> b) & 1 == 1)
        .map(|b| {
            if b == 0 {
                x.to_owned()
            } else {
                format!("({x} << {b})")
            }
        })
        .collect();
    if terms.is_empty() {
        "0".to_owned()
    } else {
        terms.join(" + ")
    }
}

/// What the clock needs of the column map, taken in the pick's
/// clock so that a column map the next slice's migration writes in the
/// issue's clock does not reach it: under a round-robin mapping the
/// entry's ray index `mx` (the datapath takes it at issue, registered as
/// `iss_m`) and slot `pk_sl`; under column blocks the held range's first
/// slot (and its first column, [`pick_registers`]'s `k_lo`).
pub(super) fn mx(s: &PeSampleShape) -> String {
    let tb1 = slot_bits(s) - 1;
    if s.round_robin {
        format!("  wire signed [31:0] mx = cm_mx[idx];\n  wire [{tb1}:0] pk_sl = cm_sl[idx];")
    } else {
        format!("  wire [{tb1}:0] pk_sl = map_sl;")
    }
}

/// The pick's registers (`k_sl`; under column blocks also the plan bit
/// `k_idx` and the held range's first column `k_lo`, from which the issue's
/// clock adds the ray index, off the pick's path): their declarations and
/// clocked loads, and their bits.
pub(super) fn pick_registers(s: &PeSampleShape) -> (String, u64) {
    let tb = slot_bits(s);
    let ib = s.index_bits;
    // (register, its range, its bits, what it takes)
    let slot = ("k_sl", format!("[{}:0]", tb - 1), tb, "pk_sl");
    let regs: Vec<(&str, String, u32, &str)> = if s.round_robin {
        vec![slot]
    } else {
        vec![
            slot,
            ("k_idx", format!("[{}:0]", tb - 1), tb, "idx"),
            ("k_lo", format!("signed [{}:0]", ib - 1), ib, "map_lo"),
        ]
    };
    let mut t = String::new();
    for (r, rng, _, _) in &regs {
        t += &format!("  reg {rng} {r};\n");
    }
    t += "  always @(posedge clk) begin\n    if (rst) begin\n";
    for (r, _, _, _) in &regs {
        t += &format!("      {r} <= 0;\n");
    }
    t += "    end else begin\n";
    for (r, _, _, src) in &regs {
        t += &format!("      {r} <= {src};\n");
    }
    t += "    end\n  end";
    (t, regs.iter().map(|r| u64::from(r.2)).sum())
}

/// The issuing ray's buffer slot `slot`, in the clock, from the
/// registered pick; under column blocks also the ray index the datapath
/// takes (`iss_m`, `k_lo + k_idx` while an issue is valid). Under column
/// blocks the slot is the range's first slot plus the plan bit, wrapped
/// once (the bit is below the slots): migration keeps the column map's
/// slots a ring, so no modulo is built.
pub(super) fn slot(s: &PeSampleShape) -> String {
    let tb = slot_bits(s);
    if s.round_robin {
        format!("  wire [{tb1}:0] slot = k_sl;", tb1 = tb - 1)
    } else {
        format!(
            "  wire [{tb}:0] sl_sum = k_sl + k_idx;
  wire [{tb1}:0] slot = sl_sum >= {slots} ? sl_sum - {slots} : sl_sum;
  wire signed [31:0] k_mx = k_lo + $signed({{1'b0, k_idx}});
  assign iss_m = iss_valid ? k_mx : 0;",
            tb1 = tb - 1,
            slots = s.slots()
        )
    }
}

/// Front to back, the row's termination bits (`dead_s`, by slot) in the
/// plan's order (`dead`, bit `i` for plan bit `i`).
pub(super) fn dead_by_plan(s: &PeSampleShape) -> String {
    let n = s.slots();
    if s.round_robin {
        format!(
            "  wire [{s1}:0] dead;
  genvar dg;
  generate
    for (dg = 0; dg < {n}; dg = dg + 1) begin : dead_g
      assign dead[dg] = dead_s[cm_sl[dg]];
    end
  endgenerate",
            s1 = n - 1
        )
    } else {
        format!(
            "  wire [{d1}:0] dead_2 = {{dead_s, dead_s}} >> map_sl;
  wire [{s1}:0] dead = dead_2[{s1}:0];",
            d1 = 2 * n - 1,
            s1 = n - 1
        )
    }
}

/// Bits of the round-robin column map and column decoder (none under
/// column blocks).
pub(super) fn memory_bits(s: &PeSampleShape) -> u64 {
    if !s.round_robin {
        return 0;
    }
    s.slots() * u64::from(s.index_bits + slot_bits(s)) + s.nx * u64::from(addr_bits(s.stored))
}

/// The edge register: this block's first column at the next row's two
/// voxel rows, read when the broadcast names a next row and held
/// otherwise (the left neighbour's `edge_in`); returns its register bits.
pub(super) fn edge_register(w: &mut String, s: &PeSampleShape) -> u64 {
    let (yb, v, half) = (s.row_bits(), s.voxel_bits, s.half_rows);
    let ebw = addr_bits(2 * half);
    let _ = writeln!(
        w,
        "  // The edge register: this block's first column at the next row's two voxel
  // rows, read when the broadcast names a next row and held otherwise.
  reg e_v, e_z;
  reg [{yb1}:0] e_y0, e_y1;
  always @(posedge clk) begin
    if (rst) begin
      e_v <= 1'b0;
      e_z <= 1'b0;
      e_y0 <= 0;
      e_y1 <= 0;
    end else begin
      e_v <= bc_nv;
      e_z <= bc_nz;
      e_y0 <= bc_ny0;
      e_y1 <= bc_ny1;
    end
  end
  wire [{yb1}:0] er0 = e_y0[0] ? e_y1 : e_y0;
  wire [{yb1}:0] er1 = e_y0[0] ? e_y0 : e_y1;
  wire [31:0] ea0 = (e_z ? {half} : 0) + (er0 >> 1);
  wire [31:0] ea1 = (e_z ? {half} : 0) + (er1 >> 1);
  reg [{v1}:0] eq0, eq1;
  reg ep0, ep1;
  always @(posedge clk) begin
    if (rst) begin
      eq0 <= 0;
      eq1 <= 0;
      ep0 <= 1'b0;
      ep1 <= 1'b0;
    end else if (e_v) begin
      eq0 <= ec0[ea0[{ebw1}:0]];
      eq1 <= ec1[ea1[{ebw1}:0]];
      ep0 <= e_y0[0];
      ep1 <= e_y1[0];
    end
  end
  assign edge_out = {{ep1 ? eq1 : eq0, ep0 ? eq1 : eq0}};",
        yb1 = yb - 1,
        v1 = v - 1,
        ebw1 = ebw - 1,
    );
    2 + 2 * u64::from(yb) + 2 * u64::from(v) + 2
}
