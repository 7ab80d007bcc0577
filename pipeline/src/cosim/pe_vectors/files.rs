//! One PE's stream as files: `pe<K>_<port>.hex` (a word a line, two's
//! complement over the port's width, row `c` clock `c`),
//! `pe<K>_writes.hex` (the memory writes), `tables.hex` (the host port's
//! rows), the two modules, `manifest.json` and the testbench
//! ([`super::tb`]).

use std::fmt::Write as _;

use serde_json::{json, Value};

use super::tb::{testbench, TOP, WRITE_ADDR_BITS, WRITE_CYCLE_BITS, WRITE_MEM_BITS};
use super::{Check, PeStream, MEMORIES};
use crate::hw::pe_sample_rtl::MODULE;

/// What a port of the sample stage carries.
pub fn meaning(name: &str) -> &'static str {
    match name {
        "bc_go" => "the controller's broadcast: this clock samples",
        "bc_first" => "the broadcast: the row's first sampling clock",
        "bc_row" => "the broadcast: the ray row in the region's buffer",
        "bc_z" => "the broadcast: the slice's parity (the slice buffer's half)",
        "bc_y0" | "bc_y1" => "the broadcast: the row's two clamped voxel rows",
        "bc_a" | "bc_t" | "bc_b" | "bc_k" | "bc_row_wy" | "bc_sy" | "bc_sz" => {
            "the broadcast: the row's words (the datapath's row inputs)"
        }
        "bc_nv" => "the broadcast names the next row whose edge voxels the PEs drive",
        "bc_nz" | "bc_ny0" | "bc_ny1" => "the broadcast's next row: slice parity, voxel rows",
        "map_we" => "the held range takes effect this clock",
        "map_lo_in" => "the held range's first ray index (0 under a round-robin mapping)",
        "map_n_in" => {
            "the held columns: the range's, or under a round-robin mapping the column map's entries"
        }
        "map_sl_in" => "the held range's first column map slot (migration keeps the slots a ring; 0 under a round-robin mapping)",
        "pl_valid" => "a run on the plan port (the controller's runs of a row)",
        "pl_first" => "the row's first run",
        "pl_lo" | "pl_hi" => "the run's ends (signed ray indices)",
        "edge_in" => {
            "the right neighbour's edge register: its first column at the row's two voxel rows"
        }
        "iss_valid" => "a sample issues into the datapath",
        "iss_m" => "the issued ray's index",
        "acc_valid" => "the accumulators of the sample issued a clock ago",
        "iss_acc_r" | "iss_acc_g" | "iss_acc_b" | "iss_acc_a" => {
            "the accumulators of the ray issued a clock ago, read from the compositing buffer"
        }
        "tap_valid" => "the taps of the sample issued the tap stage ago",
        "tap_v00" | "tap_v01" | "tap_v10" | "tap_v11" => "a voxel tap",
        "wb_valid" => "a write-back lands",
        "wb_addr" => "the write-back's buffer address (row * slots + slot)",
        "wb_data" => "the written accumulators {a, b, g, r}",
        _ => "",
    }
}

fn hex(words: impl Iterator<Item = u128>) -> String {
    let mut t = String::new();
    for w in words {
        let _ = writeln!(t, "{w:x}");
    }
    t
}

/// The files of `s` (relative path, text), the manifest among them.
pub fn files(s: &PeStream) -> (Vec<(String, String)>, Value) {
    let k = s.pe;
    let mut files = vec![
        (format!("{}.v", s.datapath.0), s.datapath.1.clone()),
        (format!("{MODULE}.v"), s.verilog.clone()),
    ];
    let mut entries = Vec::new();
    for c in &s.columns {
        let path = format!("pe{k}_{}.hex", c.port.name);
        files.push((path.clone(), hex(c.words.iter().copied())));
        let checked = match c.check {
            Check::Drive => "stimulus".to_owned(),
            Check::Always => "every cycle".to_owned(),
            Check::When(v) => format!("where {v} is 1"),
        };
        entries.push(json!({
            "path": path,
            "pe": k,
            "signal": c.port.name,
            "direction": if c.port.input { "in" } else { "out" },
            "width": c.port.bits,
            "signed": c.port.signed,
            "meaning": meaning(&c.port.name),
            "checked": checked,
            "first_cycle": 0,
            "last_cycle": s.rows - 1,
            "rows": s.rows,
        }));
    }
    let db = s.write_data_bits;
    let mut writes = String::new();
    for wr in &s.writes {
        // Every field is whole hexadecimal digits: the word is their text.
        let _ = writeln!(
            writes,
            "{:08x}{:x}{:08x}{:0dw$x}",
            wr.cycle as u32,
            wr.mem,
            wr.addr as u32,
            wr.data,
            dw = (db / 4) as usize
        );
    }
    if !s.writes.is_empty() {
        files.push((format!("pe{k}_writes.hex"), writes));
    }
    if s.table_rows.1 > 0 {
        files.push(("tables.hex".to_owned(), s.table_rows.0.clone()));
    }
    let manifest = json!({
        "module": MODULE,
        "verilog": [format!("{}.v", s.datapath.0), format!("{MODULE}.v")],
        "testbench": "pe_vectors_tb.v",
        "top": TOP,
        "stage": "pe",
        "mapping": s.mapping,
        "pe": k,
        "pes": s.pes,
        "depth": s.depth,
        "tap_stage": s.tap_stage,
        "frame_cycles": s.frame_cycles,
        "first_cycle": 0,
        "last_cycle": s.rows - 1,
        "rows": s.rows,
        "row": "row c of an input's file is the word at the rising edge that starts clock c; of an output's, the word during clock c (clock 0 the first after reset and the tables)",
        "samples": s.samples.0,
        "samples_all_pes": s.samples.1,
        "constants": s.constants.iter().map(|(d, v)| json!({
            "signal": d.name, "width": d.bits, "value": format!("{v:x}"),
        })).collect::<Vec<_>>(),
        "tied_off": ["vld_we", "vld_z", "vld_bank", "vld_row", "vld_col", "vld_data"],
        "files": entries,
        "writes": {
            "path": format!("pe{k}_writes.hex"),
            "count": s.writes.len(),
            "fields": [
                {"name": "cycle", "bits": WRITE_CYCLE_BITS},
                {"name": "mem", "bits": WRITE_MEM_BITS},
                {"name": "addr", "bits": WRITE_ADDR_BITS},
                {"name": "data", "bits": db},
            ],
            "mem": MEMORIES,
            "when": "before the rising edge that ends the write's clock, straight into the module's memory (the model counts no clock for a slice load or a word changed by migration, merges and splits); term: bit data >> 1 of row addr's word set to data & 1; cm_mx, cm_sl (a round-robin mapping's column map): entry addr's ray index (two's complement) and slot, written at the clock migration gives them; loc (its column decoder): volume column addr's local index, written with the PE's first slice load",
        },
        "tables": {
            "path": "tables.hex",
            "rows": s.table_rows.1,
            "layout": "{tbl_we, tbl_sel, tbl_addr, tbl_data}, one row a clock after reset",
        },
    });
    files.push(("pe_vectors_tb.v".to_owned(), testbench(s)));
    files.push((
        "manifest.json".to_owned(),
        serde_json::to_string_pretty(&manifest).unwrap_or_default() + "\n",
    ));
    (files, manifest)
}
