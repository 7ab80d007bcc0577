"""cocotb testbench: one PE's sample stage (ercube_pe_sample) over a frame,
driven with the model's stimulus and checked against the model.

Replays the files `ercube vectors --stage pe` writes: after reset the
tables go in through the host port (`tables.hex`, also loaded into
`ercube.Datapath`), then each clock the memory writes of the clock before
(`pe<K>_writes.hex`: slice loads, buffer words and termination bits the
model changed without a clock, and under the interleave and cyclic
mappings the column map and column decoder, written into the module's
memories by their hierarchical names) and each input's row (`pe<K>_<port>.hex`: the
broadcast, the held range, the plan port, the right neighbour's edge
words); in the middle of each clock every output is compared with its row
(the valids every clock, the words where their valid is 1). Each issued
sample is also evaluated by `ercube.Datapath.eval` from the files' words
(the ray, the broadcast's row words at issue, the taps, the accumulators
read), which must give the write-back the files expect `depth` clocks
later: the Python model and the captured frame agree. The first differing
cycle and signal fail the test.

Configured by the environment (run.py sets it): ERCUBE_VECTORS (the
directory), ERCUBE_ORDER, ERCUBE_CONFIG (the frame's `--order` and
`--config`).
"""

import json
import os
import time
from pathlib import Path

import cocotb
from cocotb.clock import Clock
from cocotb.triggers import FallingEdge
from cocotb.types import LogicArray

import ercube

# The row words of the broadcast, by the datapath input each feeds.
ROW_WORDS = ["a", "t", "b", "k", "row_wy", "sy", "sz"]


def words(path):
    return [int(w, 16) for w in Path(path).read_text().split()]


def signed(word, bits):
    top = 1 << (bits - 1)
    return word - (top << 1) if word & top else word


def mask(word, bits):
    return word & ((1 << bits) - 1)


@cocotb.test()
async def pe_sample_stage_matches_the_model(dut):
    vec = Path(os.environ["ERCUBE_VECTORS"])
    man = json.loads((vec / "manifest.json").read_text())
    assert man.get("stage") == "pe", "give the files of `ercube vectors --stage pe`"
    k, rows, depth = man["pe"], man["rows"], man["depth"]
    config = os.environ.get("ERCUBE_CONFIG")
    dp = ercube.Datapath(
        config=Path(config).read_text() if config else None,
        order=os.environ.get("ERCUBE_ORDER", "btf"),
        unit="sample",
    )
    m = dp.pipelined()
    assert m["depth"] == depth, (
        f"the model's depth {m['depth']} is not the vectors' {depth}: "
        "open it with the frame's --config and --order"
    )
    ports = {p["name"]: p for p in m["ports"]}
    meta = {f["signal"]: f for f in man["files"]}
    col = {n: words(vec / f["path"]) for n, f in meta.items()}
    drive = [n for n, f in meta.items() if f["direction"] == "in"]
    outs = [n for n, f in meta.items() if f["direction"] == "out"]
    h = {n: getattr(dut, n) for n in drive + outs}
    for c in man["constants"]:
        getattr(dut, c["signal"]).value = int(c["value"], 16)
    for n in ["vld_we", "vld_z", "vld_bank", "vld_row", "vld_col", "vld_data"]:
        getattr(dut, n).value = 0
    for n in drive:
        h[n].value = 0

    cocotb.start_soon(Clock(dut.clk, 10, unit="step").start())
    dut.rst.value = 1
    dut.tbl_we.value = 0
    for _ in range(4):
        await FallingEdge(dut.clk)
    dut.rst.value = 0
    # The tables: through the host port, and into the model by tbl_sel.
    start = time.perf_counter()
    sb, ab, db = (ports[n]["bits"] for n in ["tbl_sel", "tbl_addr", "tbl_data"])
    names = {t["sel"]: t for t in m["tables"]}
    tables = {}
    for row in words(vec / "tables.hex") if man["tables"]["rows"] else []:
        sel, addr, data = (row >> (ab + db)) & ((1 << sb) - 1), (row >> db) & ((1 << ab) - 1), row & ((1 << db) - 1)
        tables.setdefault(sel, {})[addr] = data
        dut.tbl_we.value = 1
        dut.tbl_sel.value = sel
        dut.tbl_addr.value = addr
        dut.tbl_data.value = data
        await FallingEdge(dut.clk)
    dut.tbl_we.value = 0
    for sel, ws in tables.items():
        t = names[sel]
        dp.load_table(t["name"], [mask(ws.get(a, 0), t["bits"]) for a in range(t["depth"])])
    tables_s = time.perf_counter() - start

    wf = {f["name"]: f["bits"] for f in man["writes"]["fields"]}
    mems = man["writes"]["mem"]
    writes = []
    if man["writes"]["count"]:
        for w in words(vec / man["writes"]["path"]):
            data = w & ((1 << wf["data"]) - 1)
            addr = (w >> wf["data"]) & ((1 << wf["addr"]) - 1)
            mem = (w >> (wf["data"] + wf["addr"])) & ((1 << wf["mem"]) - 1)
            writes.append((w >> (wf["data"] + wf["addr"] + wf["mem"]), mems[mem], addr, data))
    handles = {n: getattr(dut, n) for n in set(x[1] for x in writes)}
    inputs = {p["name"]: p for p in dp.inputs}
    tap_stage = man["tap_stage"]
    cw = next(p["bits"] for p in dp.outputs if p["name"] == "acc_out_r")
    wi = checks = issued = 0
    start = time.perf_counter()
    for r in range(rows):
        # The memory writes of the clock before, then this clock's inputs.
        # A write lands at the end of the time step, so a clock's bits of
        # one termination word gather first.
        term = {}
        while wi < len(writes) and writes[wi][0] + 1 <= r:
            _, mem, addr, data = writes[wi]
            if mem == "term":
                # One bit of the row's word; the others as they are (X too).
                if addr not in term:
                    term[addr] = list(str(handles[mem][addr].value))
                bits = term[addr]
                bits[len(bits) - 1 - (data >> 1)] = "1" if data & 1 else "0"
            else:
                handles[mem][addr].value = data
            wi += 1
        for addr, bits in term.items():
            handles["term"][addr].value = LogicArray("".join(bits))
        for n in drive:
            h[n].value = col[n][r]
        await FallingEdge(dut.clk)
        for n in outs:
            when = meta[n]["checked"]
            if when != "every cycle" and not col[when.split()[1]][r]:
                continue
            checks += 1
            got, exp = h[n].value, col[n][r]
            if not got.is_resolvable or int(got) != exp:
                shown = f"{int(got):#x}" if got.is_resolvable else str(got)
                raise AssertionError(
                    f"first mismatch at cycle {r} (PE {k}): {n}: model {exp:#x}, rtl {shown}"
                )
        if col["iss_valid"][r]:
            # The sample through the Python model, from the files' words.
            def at(n, row):
                return signed(col[n][row], meta[n]["width"]) if meta[n]["signed"] else col[n][row]

            bundle = {w: at(f"bc_{w}", r) for w in ROW_WORDS}
            bundle["slot_m"] = at("iss_m", r)
            # The ray's accumulators reach the datapath a clock after its issue.
            for c in "rgba":
                bundle[f"acc_{c}"] = col[f"iss_acc_{c}"][r + 1]
            for t in ["v00", "v01", "v10", "v11"]:
                bundle[t] = col[f"tap_{t}"][r + tap_stage]
            bundle = {n: v for n, v in bundle.items() if n in inputs}
            out = dp.eval(**bundle)
            wb = col["wb_data"][r + depth]
            for i, c in enumerate("rgba"):
                bits = inputs[f"acc_{c}"]["bits"]
                got = (wb >> (i * cw)) & ((1 << bits) - 1)
                assert mask(out[f"acc_out_{c}"], bits) == got, (
                    f"ercube.Datapath and the vectors differ for PE {k}'s sample issued at cycle {r}: "
                    f"acc_out_{c}: Datapath {mask(out[f'acc_out_{c}'], bits):#x}, vectors {got:#x}"
                )
            issued += 1
    assert issued == man["samples"], f"{issued} issued, manifest {man['samples']}"
    rate = rows / (time.perf_counter() - start)
    dut._log.info(
        f"ercube: PE {k}: {issued} samples and {checks} checks match the model over {rows} cycles "
        f"(ercube_pe_sample, {len(writes)} memory writes; {rate:.0f} cycles/s; tables in {tables_s:.1f} s)"
    )
