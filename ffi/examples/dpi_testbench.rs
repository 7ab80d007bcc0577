//! Writes the DPI-C scoreboard testbench of a datapath unit into a folder,
//! ready for Verilator:
//!
//! ```text
//! cargo run --release -p ercube-ffi --example dpi_testbench -- \
//!     [--unit composite] [--order btf] [--config FILE] [--tf grey-ramp] \
//!     [--samples 100000] [--verilog FILE --top MODULE] --out-dir DIR
//! ```
//!
//! `DIR` gets `ercube_pkg.sv`, `tb.sv`, `unit.v` (the unit's emitted
//! Verilog, or a copy of `--verilog`), `unit.vlt` and `sim_main.cpp`; the
//! Verilator command that builds and runs it is printed.
//!
//! `--unit sample` is the whole pipelined datapath, `ercube_sample` as
//! `ercube rtl` emits it (`--verilog FILE --top MODULE`: a module with its
//! ports), checked by [`ercube_ffi::sample_testbench`]: random bundles
//! with bubbles by default, or a frame's captured issue stream written by
//! `ercube vectors` (run with `+vectors=DIR +pe=K +first=N`).
//!
//! `--pe-vectors DIR` is one PE's sample stage, `ercube_pe_sample`, driven
//! with the files `ercube vectors --stage pe --out-dir DIR` writes and
//! checked by [`ercube_ffi::pe_testbench`] (give the frame's `--order` and
//! `--config`; `--verilog FILE` replaces the vectors' `ercube_pe_sample.v`
//! with a module of the same name, ports and memories). `DIR` gets the
//! two modules besides, and the run is `obj/Vtb +vectors=DIR`.

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use ercube_ffi::pe_testbench::pe_testbench;
use ercube_ffi::sample_testbench::sample_testbench;
use ercube_ffi::testbench::{testbench, MAIN, PACKAGE, WAIVER};
use pipeline::hw::unit::Unit;

fn run() -> Result<String, String> {
    let mut args = std::env::args().skip(1);
    let (mut unit, mut order, mut tf) = (
        "composite".to_owned(),
        "btf".to_owned(),
        "grey-ramp".to_owned(),
    );
    let (mut config, mut verilog, mut top, mut out) = (None, None, None, None);
    let mut pe_vectors: Option<PathBuf> = None;
    let mut samples = 100_000u32;
    while let Some(a) = args.next() {
        let mut val = || args.next().ok_or_else(|| format!("{a} needs a value"));
        match a.as_str() {
            "--unit" => unit = val()?,
            "--order" => order = val()?,
            "--tf" => tf = val()?,
            "--config" => config = Some(val()?),
            "--verilog" => verilog = Some(val()?),
            "--top" => top = Some(val()?),
            "--out-dir" => out = Some(PathBuf::from(val()?)),
            "--pe-vectors" => pe_vectors = Some(PathBuf::from(val()?)),
            "--samples" => samples = val()?.parse().map_err(|e| format!("--samples: {e}"))?,
            _ => return Err(format!("unknown argument {a}")),
        }
    }
    let out = out.ok_or("--out-dir DIR is required")?;
    if pe_vectors.is_some() {
        unit = "sample".to_owned();
    }
    let toml = match &config {
        Some(p) => std::fs::read_to_string(p).map_err(|e| format!("{p}: {e}"))?,
        None => String::new(),
    };
    let mut u = Unit::from_toml(
        (!toml.is_empty()).then_some(toml.as_str()),
        Some(&order),
        &unit,
    )
    .map_err(|e| e.to_string())?;
    u.fill_tables(&tf).map_err(|e| e.to_string())?;
    if let Some(dir) = pe_vectors {
        return pe(&u, &dir, verilog, &out, (&toml, &order));
    }
    let whole = u.name() == "sample";
    let (text, module) = match (verilog, top) {
        (Some(v), Some(t)) => (
            std::fs::read_to_string(&v).map_err(|e| format!("{v}: {e}"))?,
            t,
        ),
        (None, None) if whole => {
            let m = u.pipelined("ercube_sample").map_err(|e| e.to_string())?;
            (m.verilog, m.name)
        }
        (None, None) => {
            let m = format!("ercube_{unit}");
            (u.verilog(&m).map_err(|e| e.to_string())?, m)
        }
        _ => return Err("--verilog and --top go together".into()),
    };
    let (tb, run) = if whole {
        let reference = u.pipelined("ercube_sample").map_err(|e| e.to_string())?;
        let tb = sample_testbench(&u, &reference, (&text, &module), (&toml, &order, &tf))?;
        (tb, format!(" +samples={samples}"))
    } else {
        let tb = testbench(&u, &text, &module, (&toml, &order, &tf), samples)?;
        (tb, String::new())
    };
    std::fs::create_dir_all(&out).map_err(|e| format!("{}: {e}", out.display()))?;
    for (name, t) in [
        ("ercube_pkg.sv", PACKAGE),
        ("tb.sv", tb.as_str()),
        ("unit.v", text.as_str()),
        ("unit.vlt", WAIVER),
        ("sim_main.cpp", MAIN),
    ] {
        std::fs::write(out.join(name), t).map_err(|e| format!("{name}: {e}"))?;
    }
    let lib = lib()?;
    Ok(format!(
        "cd {} && verilator --cc --exe --build -j 2 --top-module tb -Mdir obj -o Vtb \\\n  unit.vlt ercube_pkg.sv unit.v tb.sv sim_main.cpp \\\n  -LDFLAGS \"{} -lpthread -ldl -lm\" && obj/Vtb{run}",
        out.display(),
        lib.display()
    ))
}

/// Writes the PE's sample stage testbench of the vectors in `dir` into
/// `out`; the command that builds and runs it.
fn pe(
    u: &Unit,
    dir: &Path,
    verilog: Option<String>,
    out: &Path,
    model: (&str, &str),
) -> Result<String, String> {
    let read = |p: &Path| std::fs::read_to_string(p).map_err(|e| format!("{}: {e}", p.display()));
    let manifest = read(&dir.join("manifest.json"))?;
    let pe_file = match &verilog {
        Some(v) => PathBuf::from(v),
        None => dir.join("ercube_pe_sample.v"),
    };
    let pe_text = read(&pe_file)?;
    let tb = pe_testbench(u, &manifest, &pe_text, model)?;
    let datapath = read(&dir.join("ercube_sample.v"))?;
    std::fs::create_dir_all(out).map_err(|e| format!("{}: {e}", out.display()))?;
    for (name, t) in [
        ("ercube_pkg.sv", PACKAGE),
        ("tb.sv", tb.as_str()),
        ("ercube_sample.v", datapath.as_str()),
        ("ercube_pe_sample.v", pe_text.as_str()),
        ("sim_main.cpp", MAIN),
    ] {
        std::fs::write(out.join(name), t).map_err(|e| format!("{name}: {e}"))?;
    }
    let vectors = dir
        .canonicalize()
        .map_err(|e| format!("{}: {e}", dir.display()))?;
    Ok(format!(
        "cd {} && verilator --cc --exe --build -j 2 --top-module tb -Mdir obj -o Vtb \\\n  ercube_pkg.sv ercube_sample.v ercube_pe_sample.v tb.sv sim_main.cpp \\\n  -LDFLAGS \"{} -lpthread -ldl -lm\" && obj/Vtb +vectors={}",
        out.display(),
        lib()?.display(),
        vectors.display()
    ))
}

/// The static library: this example is built into target/release/examples,
/// beside the library's folder.
fn lib() -> Result<PathBuf, String> {
    let exe = std::env::current_exe().map_err(|e| e.to_string())?;
    exe.parent()
        .and_then(|p| p.parent())
        .map(|p| p.join("libercube_ffi.a"))
        .ok_or_else(|| "cannot find target/release".to_owned())
}

fn main() -> ExitCode {
    match run() {
        Ok(cmd) => {
            println!("{cmd}");
            ExitCode::SUCCESS
        }
        Err(e) => {
            eprintln!("dpi_testbench: error: {e}");
            ExitCode::from(2)
        }
    }
}
