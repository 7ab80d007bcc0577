"""Checks ercube.Datapath against words the model computed (cases.json
written by tests/wheel.rs): ports, latency, each sample's outputs, and the
errors. Prints one line per unit; exits non-zero on the first difference."""

import json
import sys

import ercube

cases = json.load(open(sys.argv[1]))
for c in cases:
    dp = ercube.Datapath(order=c["order"], unit=c["unit"])
    if c["tf"]:
        dp.fill_tables(c["tf"])
    assert dp.latency == c["latency"], (dp.latency, c["latency"])
    assert dp.inputs == c["inputs"], dp.inputs
    assert dp.outputs == c["outputs"], dp.outputs
    for words, want in c["samples"]:
        got = dp.eval(**words)
        assert got == want, (c["unit"], words, got, want)
    print(f"{c['unit']} {c['order']}: {len(c['samples'])} samples same")

dp = ercube.Datapath(unit="composite")
for call, says in [
    (lambda: dp.eval(acc_r=1), "input acc_g is missing"),
    (lambda: dp.eval(nope=1), "has no input 'nope'"),
    (lambda: dp.eval(**{p["name"]: 1 << 40 for p in dp.inputs}), "outside"),
    (lambda: ercube.Datapath(unit="nope"), "sample, bilinear, composite"),
    (lambda: ercube.Datapath(order="up"), "btf"),
    (lambda: ercube.Datapath(config="pes = 0"), "pes"),
    (lambda: ercube.Datapath().load_table("class_r", [0]), "holds"),
    (lambda: ercube.Datapath().verilog(), "memory read"),
]:
    try:
        call()
    except ercube.Error as e:
        assert says in str(e), (says, str(e))
    else:
        raise AssertionError(f"no error for {says}")
print("errors raise ercube.Error")
