//! The units' ports of the PE's sample stage ([`super::pe_sample_rtl`])
//! when its datapath is the composed sample ([`super::compose`]): where
//! each port of a unit the sample does not compute comes from in the PE.
//!
//! - **The volume of interest** ([`super::voi`]): its row position
//!   `voi.y` and slice `voi.z` are words of the controller's broadcast,
//!   like the row's `a`, `t`, ... (`bc_voi_y`, `bc_voi_z`: the row's y
//!   position in `position`, the slice index), taken at issue with the
//!   sample; the model's are the broadcast's ([`crate::stages::sample`]'s
//!   `SampleBus::yp` and the slice's `z`). Its per-frame constants
//!   (`voi.centre.*`, `axis.*`, `half.*`, `radius`, `radius2`, `gain`,
//!   `sphere`, `step`, `outside`) are **frame registers**: one register a
//!   port (`frm_<port>`, reset to zero), written by the host through the
//!   register port (`frm_we`, `frm_sel`, `frm_data`: register `frm_sel`
//!   takes `frm_data`'s low bits in the clock `frm_we` is high), as the
//!   tables are through the table port, before the frame; the model's are
//!   [`crate::voi::VoiUnit::port_words`].
//!
//! Golden twin of the units: `golden::voi::ViewVoi::factor` (through
//! [`crate::voi::VoiUnit`]).
//!
//! The shading unit's 16 other voxel taps and the pre-integration unit's
//! ports have no place here: the stage refuses them in one line.

use std::fmt::Write as _;

use super::pipeline_rtl::{verilog_name, PipelinedModule};
use super::Word;
use crate::cost::inventory::addr_bits;

/// Where the PE takes its datapath's unit ports from.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct UnitWiring {
    /// Per-sample words of the controller's broadcast (`bc_<port>`),
    /// taken at issue: the datapath's port name and word.
    pub row: Vec<(String, Word)>,
    /// Frame registers (`frm_<port>`), in `frm_sel` order: the datapath's
    /// port name and word.
    pub frame: Vec<(String, Word)>,
}

impl UnitWiring {
    /// The wiring of `dp`'s unit ports; the plain sample has none.
    pub fn of(dp: &PipelinedModule) -> UnitWiring {
        let row_ports = super::compose::VOI_ROW_PORTS.map(verilog_name);
        let mut u = UnitWiring::default();
        for p in dp.ports.iter().filter(|p| p.input) {
            if !p.name.starts_with("voi_") {
                continue;
            }
            let entry = (p.name.clone(), p.word);
            if row_ports.contains(&p.name) {
                u.row.push(entry);
            } else {
                u.frame.push(entry);
            }
        }
        u
    }

    /// The broadcast words the PE takes at issue for its units.
    pub fn row_names(&self) -> impl Iterator<Item = &str> {
        self.row.iter().map(|(n, _)| n.as_str())
    }

    /// Whether `port` is a frame register.
    pub fn is_frame(&self, port: &str) -> bool {
        self.frame.iter().any(|(n, _)| n == port)
    }

    /// Bits of `frm_sel`.
    pub fn sel_bits(&self) -> u32 {
        addr_bits(self.frame.len() as u64).max(1)
    }

    /// Bits of `frm_data`: the widest frame register.
    pub fn data_bits(&self) -> u32 {
        self.frame.iter().map(|(_, w)| w.bits).max().unwrap_or(1)
    }

    /// Bits of the frame registers.
    pub fn register_bits(&self) -> u64 {
        self.frame.iter().map(|(_, w)| u64::from(w.bits)).sum()
    }

    /// `frm_sel`'s code of frame register `port`.
    pub fn sel(&self, port: &str) -> Option<usize> {
        self.frame.iter().position(|(n, _)| n == port)
    }

    /// The module's register port, or nothing without frame registers.
    pub fn ports(&self) -> String {
        if self.frame.is_empty() {
            return String::new();
        }
        format!(
            "  // The host's frame registers (the units' per-frame constants): register frm_sel takes frm_data.
  input wire frm_we,
  input wire [{}:0] frm_sel,
  input wire [{}:0] frm_data,\n",
            self.sel_bits() - 1,
            self.data_bits() - 1
        )
    }

    /// The frame registers and their write (nothing without them).
    pub fn registers(&self) -> String {
        let mut t = String::new();
        if self.frame.is_empty() {
            return t;
        }
        let w = &mut t;
        let _ = writeln!(
            w,
            "  // The frame registers, written by the host before the frame."
        );
        for (n, word) in &self.frame {
            let _ = writeln!(w, "  reg [{}:0] frm_{n};", word.bits - 1);
        }
        let _ = writeln!(w, "  always @(posedge clk) begin\n    if (rst) begin");
        for (n, _) in &self.frame {
            let _ = writeln!(w, "      frm_{n} <= 0;");
        }
        let _ = writeln!(w, "    end else if (frm_we) begin\n      case (frm_sel)");
        let sb = self.sel_bits();
        for (i, (n, word)) in self.frame.iter().enumerate() {
            let _ = writeln!(
                w,
                "        {sb}'d{i}: frm_{n} <= frm_data[{}:0];",
                word.bits - 1
            );
        }
        let _ = writeln!(w, "        default: ;\n      endcase\n    end\n  end");
        t
    }

    /// The lines of the emitted file's header that say where the units'
    /// ports come from.
    pub fn header(&self) -> String {
        let mut h = String::new();
        if !self.row.is_empty() {
            let names: Vec<String> = self.row_names().map(|n| format!("bc_{n}")).collect();
            let _ = writeln!(
                h,
                "// Units: {} are the broadcast's (the row's y position, the slice), taken at issue;",
                names.join(", ")
            );
        }
        if !self.frame.is_empty() {
            let names: Vec<String> = self
                .frame
                .iter()
                .enumerate()
                .map(|(i, (n, _))| format!("{i} {n}"))
                .collect();
            let _ = writeln!(
                h,
                "// frame registers by frm_sel code (written while frm_we is high, before the frame):\n//   {}.",
                names.join(", ")
            );
        }
        h
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::PipelineConfig;
    use crate::hw::compose::{sample, Units};

    /// The VOI's row and slice come from the broadcast, and every one of
    /// its per-frame words ([`crate::voi::VoiUnit::port_words`]) is a
    /// frame register with its own `frm_sel` code, written in the
    /// module's text; the plain sample has none.
    #[test]
    fn the_voi_ports_are_the_broadcast_s_and_frame_registers() {
        let cfg = PipelineConfig::default();
        let plain = crate::hw::pipeline_rtl::emit(&sample(&cfg, Units::default()), "p").unwrap();
        assert_eq!(UnitWiring::of(&plain), UnitWiring::default());
        let units = Units {
            voi: true,
            ..Units::default()
        };
        let dp = crate::hw::pipeline_rtl::emit(&sample(&cfg, units), "v").unwrap();
        let u = UnitWiring::of(&dp);
        let rows: Vec<&str> = u.row_names().collect();
        assert_eq!(rows, ["voi_y", "voi_z"]);
        let z = crate::fixed::Fx::from_raw_unchecked(0, cfg.position);
        let unit =
            crate::voi::VoiUnit::from_words([z; 3], [z; 3], [z; 3], z, z, (true, false, false));
        let words = unit.port_words();
        assert_eq!(u.frame.len(), words.len());
        let regs = u.registers();
        for (n, _) in &words {
            let port = format!("voi_{}", n.replace('.', "_"));
            let sel = u
                .sel(&port)
                .unwrap_or_else(|| panic!("{port} is a register"));
            assert!(regs.contains(&format!("{}'d{sel}: frm_{port} <=", u.sel_bits())));
        }
        assert!(u.ports().contains("input wire frm_we"));
    }
}
