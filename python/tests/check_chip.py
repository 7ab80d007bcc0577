"""Checks ercube.Chip stepped one clock at a time against the command line.

usage: python check_chip.py CASE.json

CASE.json holds the frame ("scene", "kwargs" for Chip.begin), the values
`ercube render --vcd` traced at a few cycles ("cycles": [{"cycle": C,
"ctrl": {name: value}, "pes": [{name: value}, ...]}], names below top.ctrl
and top.pe_K), and the command line's "raw" (--raw-npy) and "stats"
(--stats) files. Steps the frame to each cycle and requires Chip.ports()
(a structured array, one record per PE) and Chip.broadcast() (a record) to
hold the traced values, bit pattern for bit pattern, in fields wide enough;
requires Chip.run's trace of the same frame to hold ports()'s values at
those cycles; steps to the end and
requires the cycle count to be the statistics' and finish()'s raw words to
be --raw-npy's and run_frame's. Prints one line per check; exits 1 on a
mismatch.
"""

import json
import sys

import numpy as np

import ercube


def pattern(value, bits: int) -> int:
    """A field's value as the waveform's bit pattern (two's complement
    over the signal's width)."""
    return int(value) & ((1 << bits) - 1)


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
    checked = []
    for want in case["cycles"]:
        c = want["cycle"]
        got = chip.step(c - chip.cycle)
        if got != c or chip.cycle != c:
            print(f"FAIL: stepped to {got}, not {c}")
            return 1
        ports = chip.ports()
        bc = chip.broadcast()
        bits = ports.dtype.metadata["bits"]
        if ports.shape != (len(want["pes"]),):
            print(f"FAIL cycle {c}: ports() has shape {ports.shape}")
            return 1
        bad = [n for n, v in want["ctrl"].items() if pattern(bc[n], bc.dtype.metadata["bits"][n]) != v]
        for k, pe in enumerate(want["pes"]):
            bad += [
                f"pe_{k}.{n}: {ports[n][k]} != {v}"
                for n, v in pe.items()
                if pattern(ports[n][k], bits[n]) != v
            ]
        # Every signal the VCD has for a PE, and no other; each field wide
        # enough for its signal, signed where it is two's complement.
        names = [n for n in ports.dtype.names if not n.startswith("report.")]
        extra = [n for n in names if n not in want["pes"][0]]
        missing = [n for n in want["pes"][0] if n not in names]
        narrow = [n for n in names if ports.dtype[n].itemsize * 8 < bits[n] or ports.dtype[n].kind not in "ui"]
        # Ray indices are two's complement; valids and accumulators not.
        kinds = {"ray_mx": "i", "left.ray_mx": "i", "right.parent_mx": "i", "host.mx": "i",
                 "busy": "u", "acc_r": "u", "host.valid": "u"}
        narrow += [f"{n} kind {ports.dtype[n].kind}" for n, k in kinds.items() if ports.dtype[n].kind != k]
        if bad or extra or missing or narrow or bc["cycle"] != c:
            print(f"FAIL cycle {c}: {bad[:5]} extra {extra[:5]} missing {missing[:5]} narrow {narrow[:5]}")
            return 1
        n = sum(len(pe) for pe in want["pes"]) + len(want["ctrl"])
        print(
            f"cycle {c} ({ercube.STAGES[bc['stage']]}): {n} values equal to the VCD; "
            f"commands {chip.commands()[:3]}"
        )
        checked.append(c)

    # The same cycles traced by Chip.run: every column equals ports() and
    # broadcast() at those cycles.
    chip.begin(voxels, **kw)
    names = [n for n in ports.dtype.names]
    trace = chip.run(max(checked), signals=names + ["ctrl.stage", "ctrl.row"])
    if list(trace["cycle"]) != list(range(1, max(checked) + 1)):
        print("FAIL: Chip.run's cycles are not 1..N")
        return 1
    chip2 = ercube.Chip()
    chip2.begin(voxels, **kw)
    for c in checked:
        chip2.step(c - chip2.cycle)
        p = chip2.ports()
        b = chip2.broadcast()
        diff = [n for n in names if not np.array_equal(trace[n][c - 1], p[n])]
        if diff or trace["ctrl.stage"][c - 1] != b["stage"] or trace["ctrl.row"][c - 1] != b["row"]:
            print(f"FAIL: Chip.run's trace differs from ports() at cycle {c}: {diff[:5]}")
            return 1
        if trace[names[0]].dtype != p.dtype[names[0]]:
            print("FAIL: Chip.run's arrays have other dtypes than ports()'s fields")
            return 1
    print(f"Chip.run traced {len(trace['cycle'])} cycles of {len(names)} PE signals: equal to ports() at {checked}")
    try:
        chip2.run(1, signals=["no_such_signal"])
        print("FAIL: an unknown signal was traced")
        return 1
    except ercube.Error as e:
        print(f"unknown signal: {str(e)[:60]}...")
    chip2.finish()
    # A whole frame's trace: the PEs' busy cycles are the stats' samples.
    chip2.begin(voxels, **kw)
    whole = chip2.run(10**9, signals=["busy"])
    busy = int(whole["busy"].sum())
    if len(whole["cycle"]) != stats["cycles"] or busy != stats["samples_total"] or not chip2.done:
        print(f"FAIL: Chip.run of the whole frame: {len(whole['cycle'])} cycles, {busy} busy")
        return 1
    print(f"Chip.run of the whole frame: {busy} busy PE cycles, the stats' samples_total")

    chip.begin(voxels, **kw)
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
