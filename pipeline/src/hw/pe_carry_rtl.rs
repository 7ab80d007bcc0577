//! What travels with a sample down the PE's datapath to its write-back
//! (`super::pe_sample_rtl`): the ray's buffer address, and front to back
//! its row and slot for the termination bit's write
//! (`super::pe_term_rtl`). Each is registered once a clock, from the
//! issue's clock (where the buffer's address and the slot are found) to
//! the clock the datapath's outputs land.
//!
//! Golden twin: the ray a sample composites into, as
//! `golden::sampling::sample_region` addresses it.

use super::pe_sample_shape::PeSampleShape;
use crate::cost::inventory::addr_bits;
use std::fmt::Write as _;

/// The ray's `ab`-bit buffer address carried to its write-back, `depth`
/// clocks after issue: registered a clock after issue (`s_addr`, the
/// first stage, `wa_1`) and then once a clock to `wa_<depth>`; returns the
/// register bits it adds to `s_addr`.
pub(super) fn address_line(w: &mut String, ab: u32, depth: u32) -> u64 {
    let _ = writeln!(
        w,
        "  // The ray's address, carried to its write-back.\n  wire [{}:0] wa_1 = s_addr;",
        ab - 1
    );
    for i in 2..=depth {
        let _ = writeln!(w, "  reg [{}:0] wa_{i};", ab - 1);
    }
    let _ = writeln!(w, "  always @(posedge clk) begin\n    if (rst) begin");
    for i in 2..=depth {
        let _ = writeln!(w, "      wa_{i} <= 0;");
    }
    let _ = writeln!(w, "    end else begin");
    for i in 2..=depth {
        let _ = writeln!(w, "      wa_{i} <= wa_{};", i - 1);
    }
    let _ = writeln!(w, "    end\n  end");
    u64::from(depth - 1) * u64::from(ab)
}

/// The issuing ray's row and slot carried to its write-back beside its
/// address (the termination bits' write, [`super::pe_term_rtl::termination_bits`]), from the
/// issue's clock, where the slot is found; returns the register bits.
pub(super) fn termination_line(w: &mut String, s: &PeSampleShape, depth: u32) -> u64 {
    let _ = writeln!(
        w,
        "  // The ray's row and slot, carried to its write-back.\n  always @(posedge clk) begin\n    if (rst) begin"
    );
    for i in 1..=depth {
        let _ = writeln!(w, "      tr_{i} <= 0;\n      ts_{i} <= 0;");
    }
    let _ = writeln!(
        w,
        "    end else begin\n      tr_1 <= k_row;\n      ts_1 <= slot;"
    );
    for i in 2..=depth {
        let _ = writeln!(
            w,
            "      tr_{i} <= tr_{p};\n      ts_{i} <= ts_{p};",
            p = i - 1
        );
    }
    let _ = writeln!(w, "    end\n  end");
    u64::from(depth) * u64::from(s.rays.row_bits() + addr_bits(s.slots()))
}
