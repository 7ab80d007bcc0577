"""cocotb testbench: an emitted datapath unit against the model.

Every clock, random raw words go to every input port of the unit; each
output is checked, `latency` clocks later, against `ercube.Datapath.eval`
on the same words (the model, bit for bit). The unit's ports are the
Datapath's inputs and outputs by name, plus `clk`; a unit that also has
`rst`, `in_valid` and `out_valid` is reset first, and its outputs are
checked when `out_valid` is high (and `out_valid` must rise exactly
`latency` clocks after `in_valid`). The first differing cycle and signal
fails the test.

Configured by the environment (run.py sets it): ERCUBE_UNIT (sample,
bilinear, composite), ERCUBE_ORDER (btf, ftb), ERCUBE_CONFIG (a pipeline
TOML file, optional), ERCUBE_TF (the tables' transfer function),
ERCUBE_SAMPLES, ERCUBE_SEED.
"""

import os
import random
import time
from collections import deque

import cocotb
from cocotb.clock import Clock
from cocotb.triggers import FallingEdge

import ercube


def model():
    config = os.environ.get("ERCUBE_CONFIG")
    text = open(config).read() if config else None
    dp = ercube.Datapath(
        config=text,
        order=os.environ.get("ERCUBE_ORDER", "btf"),
        unit=os.environ.get("ERCUBE_UNIT", "composite"),
    )
    if dp.tables:
        dp.fill_tables(os.environ.get("ERCUBE_TF", "grey-ramp"))
    return dp


def random_word(rng, port):
    bits = port["bits"]
    if port["signed"]:
        return rng.randrange(-(1 << (bits - 1)), 1 << (bits - 1))
    return rng.randrange(0, 1 << bits)


@cocotb.test()
async def unit_matches_the_model(dut):
    dp = model()
    samples = int(os.environ.get("ERCUBE_SAMPLES", "2000"))
    rng = random.Random(int(os.environ.get("ERCUBE_SEED", "1")))
    latency = dp.latency
    handshake = all(hasattr(dut, n) for n in ("rst", "in_valid", "out_valid"))
    ins = [(p, getattr(dut, p["name"])) for p in dp.inputs]
    outs = [(p, getattr(dut, p["name"])) for p in dp.outputs]

    cocotb.start_soon(Clock(dut.clk, 10, unit="step").start())
    if handshake:
        dut.rst.value = 1
        dut.in_valid.value = 0
        for _ in range(2):
            await FallingEdge(dut.clk)
        dut.rst.value = 0

    # (cycle driven, expected words) of samples in flight.
    pending = deque()
    start = time.perf_counter()
    checked = 0
    cycle = 0
    while checked < samples:
        await FallingEdge(dut.clk)
        # Outputs after the rising edge that ended cycle - 1.
        due = pending and (
            int(dut.out_valid.value) == 1 if handshake else cycle - pending[0][0] == latency
        )
        if handshake and pending and not due:
            assert cycle - pending[0][0] < latency, (
                f"cycle {cycle}: out_valid still low {latency} clocks after in_valid"
            )
        if due:
            driven, want = pending.popleft()
            assert cycle - driven == latency, (
                f"cycle {cycle}: out_valid after {cycle - driven} clocks, latency {latency}"
            )
            for p, h in outs:
                got = h.value.to_unsigned()
                exp = want[p["name"]] & ((1 << p["bits"]) - 1)
                assert got == exp, (
                    f"first mismatch at cycle {cycle} (sample driven at cycle {driven}): "
                    f"{p['name']}: model {exp:#x}, rtl {got:#x}"
                )
            checked += 1
        if cycle < samples:
            words = {p["name"]: random_word(rng, p) for p, _ in ins}
            for p, h in ins:
                h.value = words[p["name"]] & ((1 << p["bits"]) - 1)
            if handshake:
                dut.in_valid.value = 1
            pending.append((cycle, dp.eval(**words)))
        elif handshake:
            dut.in_valid.value = 0
        cycle += 1
    rate = checked / (time.perf_counter() - start)
    dut._log.info(f"ercube: {checked} samples match the model ({rate:.0f} samples/s)")
