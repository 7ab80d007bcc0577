#!/usr/bin/env python3
"""What each statement of the PE sample stage's control costs in LUT4.

Emits the 16^3, 2-PE sample stage (`ercube rtl --dims 16,16,16 --pes 2`),
synthesizes `ercube_pe_sample` alone with yosys `synth_ice40 -dsp` (the
datapath `ercube_sample` a black box), then again with one statement taken
out at a time: replaced by the simplest stand-in that keeps its outputs
driven from its inputs (a select by one input, a sum by its first operand,
a one-hot pick by the bits themselves), so that the logic around it stays.
Prints the control's totals and a markdown table of the LUT4 each
statement takes (the whole control's less the control's without it).

    python3 bench/control_statements.py target/release/ercube [--jobs 2]
"""

import argparse
import concurrent.futures
import pathlib
import re
import shutil
import subprocess
import sys
import tempfile

# (statement, [(pattern, replacement)]): each pattern must match once.
STATEMENTS = [
    (
        "the plan port: the run moved to the held range, its ends and the count as thermometer codes",
        [(r"assign pl_bits = pl_ge & pl_le & pl_in;", "assign pl_bits = {{n}{pl_lo[0]}};")],
    ),
    (
        "the taps' selects: row bank, or the right neighbour's edge word",
        [
            (r"assign tap_v00 = [^;]*;", "assign tap_v00 = q00;"),
            (r"assign tap_v10 = [^;]*;", "assign tap_v10 = q10;"),
            (r"assign tap_v01 = [^;]*;", "assign tap_v01 = q01;"),
            (r"assign tap_v11 = [^;]*;", "assign tap_v11 = q11;"),
        ],
    ),
    (
        "the issue's one-hot pick (`bits & -bits`) and the bits left",
        [
            (r"wire \[(\d+):0\] one = row_bits & \(~row_bits \+ \d+'d1\);", r"wire [\1:0] one = row_bits;"),
            (r"rem <= row_bits & ~one;", "rem <= row_bits >> 1;"),
        ],
    ),
    (
        "the plan FIFO's head: its register, the memory's read ahead, the write bypasses",
        [(r"wire \[(\d+):0\] hq = p_byp \? p_bw : p_h;", r"wire [\1:0] hq = p_q;")],
    ),
    (
        "the accumulators' forwarding of a write-back",
        [(r"acc_word = \(fw_v && fw_a == s_addr\) \? fw_d : ", "acc_word = ")],
    ),
    (
        "the taps' clamps of `x0` and `x0 + 1` into the volume (compares, selects, the clamped forms' registers)",
        [
            (r"a00 = lo0 \? rl0 : hi0 \? rh0 : rl0 \+ x0_a;", "a00 = rl0 + x0_a;"),
            (r"a01 = lo1 \? rl0 : hi1 \? rh0 : rp0 \+ x0_a;", "a01 = rp0 + x0_a;"),
            (r"a10 = lo0 \? rl1 : hi0 \? rh1 : rl1 \+ x0_a;", "a10 = rl1 + x0_a;"),
            (r"a11 = lo1 \? rl1 : hi1 \? rh1 : rp1 \+ x0_a;", "a11 = rp1 + x0_a;"),
            (r"held1 = lo1 \? end_i > 0 : hi1 \? last_i < end_i : x0_i < end_i - 1;", "held1 = x0_i < end_i - 1;"),
        ],
    ),
    (
        "the address `row * slots + slot`",
        [(r"wire \[(\d+):0\] addr = [^;]*;", r"wire [\1:0] addr = {row_w, slot};")],
    ),
    (
        "the slot `map_sl + idx` wrapped",
        [(r"wire \[(\d+):0\] slot = sl_sum >= \d+ \? sl_sum - \d+ : sl_sum;", r"wire [\1:0] slot = sl_sum;")],
    ),
]

SCRIPT = """read_verilog -sv ercube_sample.v ercube_pe_sample.v
blackbox ercube_sample
synth_ice40 -dsp -top ercube_pe_sample
tee -o stat.txt stat
"""


def synth(base: pathlib.Path, name: str, text: str) -> dict:
    d = base / name
    d.mkdir()
    shutil.copy(base / "rtl" / "ercube_sample.v", d)
    (d / "ercube_pe_sample.v").write_text(text)
    (d / "s.ys").write_text(SCRIPT)
    subprocess.run(["yosys", "-q", "-s", "s.ys"], cwd=d, check=True, stdout=subprocess.DEVNULL)
    cells = {}
    for line in (d / "stat.txt").read_text().splitlines():
        m = re.match(r"\s+(SB_\w+)\s+(\d+)", line)
        if m:
            cells[m.group(1)] = cells.get(m.group(1), 0) + int(m.group(2))
    return cells


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("ercube")
    ap.add_argument("--jobs", type=int, default=2)
    a = ap.parse_args()
    if shutil.which("yosys") is None:
        print("control_statements: yosys is not on PATH", file=sys.stderr)
        return 2
    with tempfile.TemporaryDirectory() as tmp:
        base = pathlib.Path(tmp)
        subprocess.run(
            [a.ercube, "rtl", "--out-dir", str(base / "rtl"), "--dims", "16,16,16", "--pes", "2"],
            check=True,
            stdout=subprocess.DEVNULL,
        )
        text = (base / "rtl" / "ercube_pe_sample.v").read_text()
        n = re.search(r"wire \[(\d+):0\] pl_bits;", text)
        width = int(n.group(1)) + 1 if n else 1
        variants = {"whole": text}
        for i, (what, subs) in enumerate(STATEMENTS):
            t = text
            for pat, rep in subs:
                t, k = re.subn(pat, rep.replace("{n}", str(width)), t)
                if k != 1:
                    print(f"control_statements: `{pat}` matched {k} times ({what})", file=sys.stderr)
                    return 1
            variants[f"s{i}"] = t
        with concurrent.futures.ThreadPoolExecutor(a.jobs) as ex:
            res = dict(zip(variants, ex.map(lambda kv: synth(base, *kv), variants.items())))
    whole = res["whole"]
    ff = sum(v for k, v in whole.items() if k.startswith("SB_DFF"))
    print(
        f"control alone: {whole.get('SB_LUT4', 0)} LUT4, {whole.get('SB_CARRY', 0)} SB_CARRY, {ff} flip-flops\n"
    )
    print("| statement of the control | LUT4 it takes |\n| --- | ---: |")
    rows = [
        (what, whole.get("SB_LUT4", 0) - res[f"s{i}"].get("SB_LUT4", 0))
        for i, (what, _) in enumerate(STATEMENTS)
    ]
    for what, lut in sorted(rows, key=lambda r: -r[1]):
        print(f"| {what} | {lut} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
