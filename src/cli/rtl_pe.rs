//! `ercube rtl`'s README section on the PE's sample stage
//! (`pipeline::hw::pe_sample_rtl`): what it holds and every port it
//! declares, read from the emitted port list so the table names exactly
//! what the module has.

use std::fmt::Write as _;

use pipeline::hw::pe_sample_rtl::{PeSampleRtl, PeSampleShape, MODULE};

/// The ports in the module's port list
/// (`pipeline::cosim::pe_vectors::ports`, the reader `ercube synth` and
/// `ercube vectors` use).
fn ports(v: &str) -> Vec<pipeline::cosim::pe_vectors::Decl> {
    pipeline::cosim::pe_vectors::ports(v)
}

/// What a port is, by its group.
fn meaning(name: &str) -> &'static str {
    match name {
        "clk" => "clock",
        "rst" => "synchronous reset of every register",
        "col_lo" => "this PE's first voxel column",
        "col_end" => "one past this PE's last voxel column",
        "nx_last" => "the volume's last voxel column (the taps' clamp)",
        "edge_in" => "the right neighbour's first column at the row's two voxel rows",
        "edge_out" => "this block's first column at the next row's voxel rows, to the left neighbour",
        "tap_valid" => "the taps below belong to the sample issued the datapath's tap stage ago",
        "wb_valid" | "wb_addr" | "wb_data" => {
            "the write-back into the compositing buffer (valid, ray address, {a, b, g, r})"
        }
        n if n.starts_with("tbl_") => "the datapath's table write port (host)",
        n if n.starts_with("vld_") => {
            "the host's voxel load: write, slice parity, row bank, row / 2, local column, word"
        }
        n if n.starts_with("map_") => {
            "the column map's held range (write, first ray index, count, the first's slot), written by migration"
        }
        n if n.starts_with("bc_") => {
            "the controller's broadcast for the next clock (sample, row, slice, voxel rows, row words, next row)"
        }
        n if n.starts_with("pl_") => {
            "the plan port: the controller's runs of the PlanRows broadcast, one a clock, rows in the order they issue (valid, first run of its row, first and last ray index), which comparators turn into the row plan's word (bit i set when held column map_lo + i lies in a run), kept in a FIFO of rows"
        }
        n if n.starts_with("iss_") => "what the control issues into the datapath: valid, ray index, the ray's accumulators",
        n if n.starts_with("tap_") => "the voxel taps served to the datapath",
        _ => "",
    }
}

/// The README section for `r`, emitted for a volume of `dims`.
pub fn section(s: &PeSampleShape, r: &PeSampleRtl, dims: [usize; 3]) -> String {
    let mut t = String::new();
    let w = &mut t;
    let _ = writeln!(w, "\n## {MODULE}: the PE's sample stage\n");
    let _ = writeln!(
        w,
        "From `pipeline::hw::pe_sample_rtl`, for a view-space volume of {}x{}x{} (`--dims`), \
         {}, {}: one PE's control walking a row plan's rays one a clock \
         into `ercube_sample` (instantiated inside), its row plan ({} words of {} bits: the \
         held columns each ray row samples, where empty-space skipping reaches the PE), its slice buffer (2 row banks x 2 slices x \
         {} columns x {} rows of {} bits) and edge column, its compositing buffer (2 banks x {} \
         words of {} bits, ray (slot, row) at row * {} + slot) read before issue and written \
         back. {} memory bits and {} control register bits (the datapath's are its own). \
         `ercube cosim --stage pe` checks it clock for clock against the model (docs/rtl.md).\n",
        dims[0],
        dims[1],
        dims[2],
        match s.termination {
            Some(t) => format!(
                "front to back with early ray termination (termination bits, {} words of {} bits, \
                 a ray's set by its write-back once its opacity word reaches {t}; a row issues \
                 its planned rays whose bit is clear)",
                s.rays.max_rows,
                s.slots()
            ),
            None => "without early ray termination (the datapath composites in its order)".to_owned(),
        },
        if s.round_robin {
            "a round-robin mapping (several blocks with their aprons, the taps through the column \
             decoder `loc`, the held rays in increasing index with their slots in the column map \
             `cm_mx`, `cm_sl`)"
        } else {
            "column blocks"
        },
        s.rays.max_rows,
        s.slots(),
        s.stored,
        s.half_rows,
        s.voxel_bits,
        s.rays.bank_depth,
        s.rays.buffer_width,
        s.slots(),
        s.memory_bits(),
        r.register_bits
    );
    let _ = writeln!(w, "| port | dir | width | meaning |\n|---|---|---|---|");
    for p in ports(&r.verilog) {
        let _ = writeln!(
            w,
            "| `{}` | {} | {}{} | {} |",
            p.name,
            if p.input { "in" } else { "out" },
            if p.signed { "s" } else { "u" },
            p.bits,
            meaning(&p.name)
        );
    }
    t
}
