"""Checks ercube.Chip stepped one clock at a time against the command line.

usage: python check_chip.py CASE.json

CASE.json holds the frame ("scene", "kwargs" for Chip.begin), the values
`ercube render --vcd` traced at a few cycles ("cycles": [{"cycle": C,
"ctrl": {name: value}, "pes": [{name: value}, ...]}], names below top.ctrl
and top.pe_K), and the command line's "raw" (--raw-npy) and "stats"
(--stats) files. Steps the frame to each cycle and requires Chip.ports()
and Chip.broadcast() to hold the traced values; steps to the end and
requires the cycle count to be the statistics' and finish()'s raw words to
be --raw-npy's and run_frame's. Prints one line per check; exits 1 on a
mismatch.
"""

import json
import sys

import numpy as np

import ercube


def main() -> int:
    case = json.load(open(sys.argv[1]))
    voxels = ercube.scene(case["scene"])
    kw = case["kwargs"]
    want_raw = np.load(case["raw"])
    stats = json.load(open(case["stats"]))
    chip = ercube.Chip()
    try:
        chip.step()
        print("FAIL: step before begin did not raise")
        return 1
    except ercube.Error as e:
        print(f"step before begin: {e}")
    try:
        chip.begin(voxels, method="er")
        print("FAIL: a golden method began")
        return 1
    except ercube.Error as e:
        print(f"golden begin: {e}")

    chip.begin(voxels, **kw)
    assert chip.cycle == 0 and not chip.done
    for want in case["cycles"]:
        c = want["cycle"]
        got = chip.step(c - chip.cycle)
        if got != c or chip.cycle != c:
            print(f"FAIL: stepped to {got}, not {c}")
            return 1
        ports = chip.ports()
        bc = chip.broadcast()
        bad = [n for n, v in want["ctrl"].items() if bc[n] != v]
        for k, pe in enumerate(want["pes"]):
            bad += [f"pe_{k}.{n}: {ports[k][n]} != {v}" for n, v in pe.items() if ports[k][n] != v]
        # Every signal the VCD has for a PE, and no other.
        extra = [n for n in ports[0] if n != "report" and n not in want["pes"][0]]
        if bad or extra or bc["cycle"] != c:
            print(f"FAIL cycle {c}: {bad[:5]} extra {extra[:5]}")
            return 1
        n = sum(len(pe) for pe in want["pes"]) + len(want["ctrl"])
        print(f"cycle {c} ({bc['stage_name']}): {n} values equal to the VCD; commands {bc['commands'][:3]}")
    while not chip.done:
        chip.step(100000)
    if chip.cycle != stats["cycles"]:
        print(f"FAIL: {chip.cycle} cycles stepped, stats say {stats['cycles']}")
        return 1
    image, raw, st = chip.finish()
    if not np.array_equal(raw, want_raw) or st["cycles"] != stats["cycles"]:
        print("FAIL: the stepped frame's raw words differ from --raw-npy's")
        return 1
    print(f"stepped {chip.cycle} cycles: raw words equal --raw-npy's")

    # Finished early, and begun again over a frame in progress.
    chip.load(voxels)
    chip.begin(**kw)
    chip.step(10)
    chip.begin(**kw)
    chip.step(500)
    _, raw2, _ = chip.finish()
    chip2 = ercube.Chip()
    chip2.load(voxels)
    _, raw3, _ = chip2.run_frame(**kw)
    if not (np.array_equal(raw2, want_raw) and np.array_equal(raw3, want_raw)):
        print("FAIL: finish() after 500 cycles or run_frame differ")
        return 1
    print("finished after 500 cycles and run_frame: raw words equal")
    chip.begin(**kw)
    chip.step(20)
    del chip
    print("dropped mid-frame")
    return 0


if __name__ == "__main__":
    sys.exit(main())
