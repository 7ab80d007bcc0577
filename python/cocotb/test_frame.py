"""cocotb testbench: a real frame's captured issue stream through the whole
pipelined sample datapath, checked against the model.

Replays the files `ercube vectors` writes (a window of a frame: per PE and
per cycle, every sample its datapath issued, with the bubbles between
them) into `ercube_sample` (the emitted module, or one with its ports),
one PE's stream after another: after reset the frame's tables go in
through the host port, then each row of `pe<K>_<port>.hex` is one clock,
the sample's ports on its issue cycle and its voxel taps on the row the
capture placed them (`stage(v00)` clocks later, as a block RAM addressed by
`x0` returns them). Every cycle: `out_valid` and `x0` as the files say;
where `out_valid` is 1, the accumulators `acc_out_*` as the model wrote
them back. Each issued sample is also evaluated by `ercube.Datapath`
(opened with the frame's configuration and order, its tables loaded from
the files), which must give the files' words: the Python model and the
captured frame agree. The first differing cycle (the frame's cycle
number) and signal fail the test.

Configured by the environment (run.py sets it): ERCUBE_VECTORS (the
directory), ERCUBE_PES (comma-separated PEs, default 0), ERCUBE_ORDER,
ERCUBE_CONFIG (the frame's `--order` and `--config`).
"""

import json
import os
import time
from pathlib import Path

import cocotb
from cocotb.clock import Clock
from cocotb.triggers import FallingEdge

import ercube


def model():
    config = os.environ.get("ERCUBE_CONFIG")
    text = Path(config).read_text() if config else None
    return ercube.Datapath(config=text, order=os.environ.get("ERCUBE_ORDER", "btf"), unit="sample")


def words(path, bits, signed):
    """A `$readmemh` file's words, sign-extended where the port is signed."""
    out = []
    top = 1 << (bits - 1)
    for line in Path(path).read_text().split():
        w = int(line, 16)
        out.append(w - (top << 1) if signed and w & top else w)
    return out


def mask(word, bits):
    return word & ((1 << bits) - 1)


@cocotb.test()
async def frame_stream_matches_the_model(dut):
    vec = Path(os.environ["ERCUBE_VECTORS"])
    man = json.loads((vec / "manifest.json").read_text())
    pes = [int(p) for p in os.environ.get("ERCUBE_PES", "0").split(",")]
    dp = model()
    m = dp.pipelined()
    depth = m["depth"]
    assert depth == man["depth"], (
        f"the module's depth {depth} is not the vectors' {man['depth']}: "
        "open the model with the frame's --config and --order"
    )
    first, rows = man["first_cycle"], man["rows"]
    ports = {p["name"]: p for p in m["ports"]}
    h = {n: getattr(dut, n) for n in ports if n != "clk"}

    cocotb.start_soon(Clock(dut.clk, 10, unit="step").start())
    dut.rst.value = 1
    dut.in_valid.value = 0
    dut.tbl_we.value = 0
    for _ in range(2):
        await FallingEdge(dut.clk)
    dut.rst.value = 0
    # The frame's tables, into the model and through the host port.
    start = time.perf_counter()
    tbits = ports["tbl_data"]["bits"]
    for t in man["tables"]:
        ws = words(vec / t["path"], t["width"], False)
        dp.load_table(t["table"], ws)
        for addr, w in enumerate(dp.table(t["table"])):
            dut.tbl_we.value = 1
            dut.tbl_sel.value = t["tbl_sel"]
            dut.tbl_addr.value = addr
            dut.tbl_data.value = mask(w, tbits)
            await FallingEdge(dut.clk)
    dut.tbl_we.value = 0
    tables_s = time.perf_counter() - start

    inputs = [p["name"] for p in dp.inputs]
    total = checked_rows = 0
    start = time.perf_counter()
    for pe in pes:
        files = [f for f in man["files"] if f["pe"] == pe]
        assert files, f"the vectors have no PE {pe} (PEs 0..{man['pes'] - 1})"
        col = {f["signal"]: words(vec / f["path"], f["width"], f["signed"]) for f in files}
        meta = {f["signal"]: f for f in files}
        drive = [f["signal"] for f in files if f["direction"] == "in"]
        every = [f["signal"] for f in files if f["direction"] == "out" and f["checked"] == "every cycle"]
        written = [f["signal"] for f in files if f["direction"] == "out" and f["checked"] != "every cycle"]
        issued = 0
        for r in range(rows):
            cycle = first + r
            # The outputs of this cycle (after the rising edge that ended the last).
            for n in every + (written if col["out_valid"][r] else []):
                got = int(h[n].value)
                exp = mask(col[n][r], meta[n]["width"])
                if got != exp:
                    frm = cycle - meta[n]["clocks_after_issue"]
                    raise AssertionError(
                        f"first mismatch at cycle {cycle} (PE {pe}, sample issued at cycle {frm}): "
                        f"{n}: model {exp:#x}, rtl {got:#x}"
                    )
            # This cycle's row; an issued sample evaluated by the model too.
            for n in drive:
                h[n].value = mask(col[n][r], meta[n]["width"])
            if col["in_valid"][r]:
                bundle = {n: col[n][r + ports[n]["stage"]] for n in inputs}
                out = dp.eval(**bundle)
                for n, w in out.items():
                    at = r + (depth if n in written else ports[n]["stage"])
                    assert mask(w, ports[n]["bits"]) == mask(col[n][at], ports[n]["bits"]), (
                        f"ercube.Datapath and the vectors differ for PE {pe}'s sample issued at "
                        f"cycle {cycle}: {n}: Datapath {w:#x}, vectors {col[n][at]:#x}"
                    )
                issued += 1
            await FallingEdge(dut.clk)
        assert issued == man["samples"][pe], f"PE {pe}: {issued} issued, manifest {man['samples'][pe]}"
        dut._log.info(f"ercube: PE {pe}: {issued} samples match the model over cycles {first}..{first + rows - 1}")
        total += issued
        checked_rows += rows
    rate = checked_rows / (time.perf_counter() - start)
    dut._log.info(
        f"ercube: {total} samples of PEs {','.join(map(str, pes))} match the model over "
        f"{checked_rows} cycles ({m['name']}, depth {depth}, a frame's stream; "
        f"{rate:.0f} cycles/s; tables in {tables_s:.1f} s)"
    )
