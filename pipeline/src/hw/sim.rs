//! Building and running a Verilog testbench in Verilator (`--binary`) or
//! Icarus Verilog (`iverilog -g2005`, `vvp`).

use std::path::{Path, PathBuf};
use std::process::Command;

/// A Verilog simulator.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Simulator {
    /// Verilator 5, compiled to an executable.
    Verilator,
    /// Icarus Verilog, compiled to `vvp` code.
    Icarus,
}

impl Simulator {
    /// Both, Verilator first.
    pub const ALL: [Simulator; 2] = [Simulator::Verilator, Simulator::Icarus];

    /// The program that must be on `PATH`.
    pub fn tool(self) -> &'static str {
        match self {
            Simulator::Verilator => "verilator",
            Simulator::Icarus => "iverilog",
        }
    }
}

/// Why a build or a run failed: the command and what it said.
#[derive(Debug, thiserror::Error)]
#[error("{0}")]
pub struct SimError(pub String);

fn run(cmd: &mut Command) -> Result<String, SimError> {
    let out = cmd
        .output()
        .map_err(|e| SimError(format!("cannot run {:?}: {e}", cmd.get_program())))?;
    let text = format!(
        "{}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    if out.status.success() {
        Ok(text)
    } else {
        Err(SimError(format!("{:?} failed: {text}", cmd.get_program())))
    }
}

/// Builds `sources` (top module `top`) with `sim` in `dir`; returns what
/// [`simulate`] runs.
pub fn build(
    sim: Simulator,
    dir: &Path,
    sources: &[PathBuf],
    top: &str,
) -> Result<PathBuf, SimError> {
    match sim {
        Simulator::Verilator => {
            let obj = dir.join("obj_dir");
            run(Command::new("verilator")
                .args([
                    "--binary",
                    "-Wno-fatal",
                    "-Wno-lint",
                    "-Wno-style",
                    "--top-module",
                    top,
                ])
                .args(["-j", "2", "-Mdir"])
                .arg(&obj)
                .args(["-o", "sim"])
                .args(sources))?;
            Ok(obj.join("sim"))
        }
        Simulator::Icarus => {
            let out = dir.join("sim.vvp");
            run(Command::new("iverilog")
                .args(["-g2005", "-s", top, "-o"])
                .arg(&out)
                .args(sources))?;
            Ok(out)
        }
    }
}

/// Runs what [`build`] made, in `dir`.
pub fn simulate(sim: Simulator, exe: &Path, dir: &Path) -> Result<String, SimError> {
    match sim {
        Simulator::Verilator => run(Command::new(exe).current_dir(dir)),
        Simulator::Icarus => run(Command::new("vvp").arg("-n").arg(exe).current_dir(dir)),
    }
}
