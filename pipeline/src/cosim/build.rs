//! Building a generated testbench with Verilator or Icarus once per text:
//! the build lives in a cache directory named by a hash of the sources,
//! the simulator's version and the build's options, beside a copy of the
//! sources that a later build compares before reusing it. A build is made
//! in a private directory and renamed into place, so runs in parallel never
//! see half a build.

use std::hash::{Hash, Hasher};
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Instant;

pub use crate::hw::sim::{SimError, Simulator};

/// A built simulation.
#[derive(Debug, Clone)]
pub struct Built {
    /// What [`run`] runs: Verilator's executable or Icarus's `vvp` file.
    pub exe: PathBuf,
    /// The simulator.
    pub sim: Simulator,
    /// Seconds the build took (zero when found in the cache).
    pub seconds: f64,
    /// Whether it was found in the cache.
    pub cached: bool,
}

fn output(cmd: &mut Command) -> Result<String, SimError> {
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
        let first = text
            .lines()
            .find(|l| l.contains("rror"))
            .unwrap_or_else(|| text.lines().next().unwrap_or(""));
        Err(SimError(format!(
            "{:?} failed: {}",
            cmd.get_program(),
            first.trim()
        )))
    }
}

/// The simulator's version line (part of the cache key).
fn version(sim: Simulator) -> Result<String, SimError> {
    let v = match sim {
        Simulator::Verilator => output(Command::new("verilator").arg("--version"))?,
        Simulator::Icarus => output(Command::new("iverilog").arg("-V")).unwrap_or_default(),
    };
    Ok(v.lines().next().unwrap_or("").trim().to_owned())
}

/// The sources as the cache stores them: each file's name and text.
fn manifest(sources: &[(&str, &str)], key: &str) -> String {
    let mut s = format!("{key}\n");
    for (name, text) in sources {
        s.push_str(&format!("== {name} {}\n{text}", text.len()));
    }
    s
}

/// Builds `sources` (file name and text; top module `top`) with `sim`
/// under `cache`, or finds the same build there. `vcd` builds with
/// waveform dumping (`ERCUBE_VCD` defined).
pub fn build(
    sim: Simulator,
    cache: &Path,
    sources: &[(&str, &str)],
    top: &str,
    vcd: bool,
) -> Result<Built, SimError> {
    let key = format!("{} | {} | top {top} | vcd {vcd}", sim.tool(), version(sim)?);
    let text = manifest(sources, &key);
    let mut h = std::collections::hash_map::DefaultHasher::new();
    text.hash(&mut h);
    let name = format!("{}-{:016x}", sim.tool(), h.finish());
    let dir = cache.join(&name);
    let exe_in = |d: &Path| match sim {
        Simulator::Verilator => d.join("obj").join("sim"),
        Simulator::Icarus => d.join("sim.vvp"),
    };
    let same = |d: &Path| {
        exe_in(d).is_file()
            && std::fs::read_to_string(d.join("sources.txt")).is_ok_and(|s| s == text)
    };
    if same(&dir) {
        return Ok(Built {
            exe: exe_in(&dir),
            sim,
            seconds: 0.0,
            cached: true,
        });
    }
    let err = |e: std::io::Error| SimError(format!("cosim cache {}: {e}", cache.display()));
    std::fs::create_dir_all(cache).map_err(err)?;
    let tmp = tempfile::Builder::new()
        .prefix(&format!(".{name}-"))
        .tempdir_in(cache)
        .map_err(err)?;
    let t = Instant::now();
    let mut files = Vec::new();
    for (n, body) in sources {
        let p = tmp.path().join(n);
        std::fs::write(&p, body).map_err(err)?;
        files.push(p);
    }
    match sim {
        Simulator::Verilator => {
            let mut cmd = Command::new("verilator");
            cmd.current_dir(tmp.path())
                .args(["--binary", "-Wno-fatal", "-Wno-lint", "-Wno-style"])
                .args(["--top-module", top, "-j", "2", "-Mdir", "obj", "-o", "sim"]);
            if vcd {
                cmd.args(["--trace", "-DERCUBE_VCD"]);
            }
            output(cmd.args(&files))?;
        }
        Simulator::Icarus => {
            let mut cmd = Command::new("iverilog");
            cmd.args(["-g2005", "-s", top, "-o"])
                .arg(tmp.path().join("sim.vvp"));
            if vcd {
                cmd.arg("-DERCUBE_VCD");
            }
            output(cmd.args(&files))?;
        }
    }
    std::fs::write(tmp.path().join("sources.txt"), &text).map_err(err)?;
    let seconds = t.elapsed().as_secs_f64();
    let built = tmp.keep();
    // Another run may have finished the same build first: then its copy
    // stays and this one goes.
    if std::fs::rename(&built, &dir).is_err() {
        let _ = std::fs::remove_dir_all(&built);
        if !same(&dir) {
            return Err(SimError(format!(
                "cosim cache: cannot place the build at {}",
                dir.display()
            )));
        }
    }
    Ok(Built {
        exe: exe_in(&dir),
        sim,
        seconds,
        cached: false,
    })
}

/// Runs `built` in `dir` with `args` (plusargs): what it printed and the
/// seconds it took.
pub fn run(built: &Built, dir: &Path, args: &[String]) -> Result<(String, f64), SimError> {
    let t = Instant::now();
    let text = match built.sim {
        Simulator::Verilator => output(Command::new(&built.exe).args(args).current_dir(dir))?,
        Simulator::Icarus => output(
            Command::new("vvp")
                .arg("-n")
                .arg(&built.exe)
                .args(args)
                .current_dir(dir),
        )?,
    };
    Ok((text, t.elapsed().as_secs_f64()))
}
