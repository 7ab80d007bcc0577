"""cocotb testbench: the whole pipelined sample datapath against the model.

Drives `ercube_sample` (as `ercube rtl` emits it, `Datapath.pipelined`, or
a module with its ports) with bundles of random words over every port's
full range from `ercube.Datapath(unit="sample")`, a share of the cycles
bubbles (`in_valid` low, the ports and taps random and to be ignored).
After reset the model's tables go in through the host port (`tbl_we`,
`tbl_sel`, `tbl_addr`, `tbl_data`). A sample's voxel taps are driven
`stage(v00)` clocks after its issue, as a block RAM addressed by `x0`
returns them. Every cycle: `out_valid` exactly when a sample issued
`depth` clocks before, then its accumulators (`Datapath.eval`), otherwise
the last sample's held; `x0` of the sample issued `stage(x0)` clocks before
(zero in a bubble). The first differing cycle and signal fails the test.

Configured by the environment (run.py sets it): ERCUBE_ORDER (btf, ftb),
ERCUBE_CONFIG (a pipeline TOML file, optional), ERCUBE_TF (the tables'
transfer function), ERCUBE_SAMPLES, ERCUBE_BUBBLES (percent), ERCUBE_SEED.
"""

import os
import random
import time

import cocotb
from cocotb.clock import Clock
from cocotb.triggers import FallingEdge

import ercube

CONTROL = {"clk", "rst", "in_valid", "out_valid", "tbl_we", "tbl_sel", "tbl_addr", "tbl_data"}


def model():
    config = os.environ.get("ERCUBE_CONFIG")
    text = open(config).read() if config else None
    dp = ercube.Datapath(config=text, order=os.environ.get("ERCUBE_ORDER", "btf"), unit="sample")
    dp.fill_tables(os.environ.get("ERCUBE_TF", "grey-ramp"))
    return dp


def random_word(rng, port):
    bits = port["bits"]
    if port["signed"]:
        return rng.randrange(-(1 << (bits - 1)), 1 << (bits - 1))
    return rng.randrange(0, 1 << bits)


def mask(word, bits):
    return word & ((1 << bits) - 1)


@cocotb.test()
async def sample_datapath_matches_the_model(dut):
    dp = model()
    m = dp.pipelined()
    depth = m["depth"]
    samples = int(os.environ.get("ERCUBE_SAMPLES", "1000"))
    bubbles = int(os.environ.get("ERCUBE_BUBBLES", "25"))
    rng = random.Random(int(os.environ.get("ERCUBE_SEED", "1")))
    data = [p for p in m["ports"] if p["name"] not in CONTROL]
    issue = [p for p in data if p["input"] and p["stage"] == 0]
    late = [p for p in data if p["input"] and p["stage"] > 0]
    probes = [p for p in data if not p["input"] and p["stage"] != depth]
    results = [p for p in data if not p["input"] and p["stage"] == depth]
    h = {p["name"]: getattr(dut, p["name"]) for p in data}

    cocotb.start_soon(Clock(dut.clk, 10, unit="step").start())
    dut.rst.value = 1
    dut.in_valid.value = 0
    dut.tbl_we.value = 0
    for p in issue + late:
        h[p["name"]].value = 0
    for _ in range(2):
        await FallingEdge(dut.clk)
    dut.rst.value = 0
    # The model's tables through the host port, one word a clock.
    start = time.perf_counter()
    tbits = {p["name"]: p["bits"] for p in m["ports"] if p["name"].startswith("tbl_")}
    for t in m["tables"]:
        for addr, word in enumerate(dp.table(t["name"])):
            dut.tbl_we.value = 1
            dut.tbl_sel.value = t["sel"]
            dut.tbl_addr.value = addr
            dut.tbl_data.value = mask(word, tbits["tbl_data"])
            await FallingEdge(dut.clk)
    dut.tbl_we.value = 0
    tables_s = time.perf_counter() - start

    # Per cycle: the taps to drive, the expected outputs and the issue
    # cycle they belong to.
    taps, expect_probe, expect_result = {}, {}, {}
    held = {p["name"]: 0 for p in results}
    held_from = 0
    issued = checked = 0
    last = None
    cycle = 0
    start = time.perf_counter()
    while last is None or cycle <= last + depth:
        # The outputs of this cycle (after the rising edge that ended the last).
        want = expect_result.pop(cycle, None)
        got_valid = int(dut.out_valid.value)
        assert got_valid == (want is not None), (
            f"first mismatch at cycle {cycle}: out_valid: model {int(want is not None)}, rtl {got_valid}"
        )
        if want is not None:
            held_from, words = want
            held.update(words)
            checked += 1
        for p in results:
            got = h[p["name"]].value.to_unsigned()
            exp = mask(held[p["name"]], p["bits"])
            assert got == exp, (
                f"first mismatch at cycle {cycle} (sample issued at cycle {held_from}): "
                f"{p['name']}: model {exp:#x}, rtl {got:#x}"
            )
        frm, words = expect_probe.pop(cycle, (None, {}))
        for p in probes:
            got = h[p["name"]].value.to_unsigned()
            exp = mask(words.get(p["name"], 0), p["bits"])
            assert got == exp, (
                f"first mismatch at cycle {cycle} (sample issued at cycle {frm}): "
                f"{p['name']}: model {exp:#x}, rtl {got:#x}"
            )
        # This cycle's inputs: the taps issued stage clocks ago, the next bundle.
        for p in late:
            h[p["name"]].value = taps.pop((cycle, p["name"]), 0)
        valid = issued < samples and rng.randrange(100) >= bubbles
        words = {p["name"]: random_word(rng, p) for p in issue + late}
        dut.in_valid.value = int(valid)
        for p in issue:
            h[p["name"]].value = mask(words[p["name"]], p["bits"])
        for p in late:
            taps[(cycle + p["stage"], p["name"])] = mask(words[p["name"]], p["bits"])
        if valid:
            out = dp.eval(**words)
            for p in probes:
                expect_probe.setdefault(cycle + p["stage"], (cycle, {}))[1][p["name"]] = out[p["name"]]
            expect_result[cycle + depth] = (cycle, {p["name"]: out[p["name"]] for p in results})
            issued += 1
            if issued == samples:
                last = cycle
        await FallingEdge(dut.clk)
        cycle += 1
    assert checked == issued == samples, f"{issued} issued, {checked} checked"
    rate = checked / (time.perf_counter() - start)
    dut._log.info(
        f"ercube: {checked} samples match the model over {cycle} cycles "
        f"({m['name']}, depth {depth}; {rate:.0f} samples/s; tables in {tables_s:.1f} s)"
    )
