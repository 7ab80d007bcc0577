"""The Python module's overhead on a frame, measured against the command line.

usage: python overhead.py ERCUBE_BINARY VOLUME [--rounds R] [--frames F]
                          [--methods er,er-ftb,pipeline] [--threads 1,2]
                          [-- RENDER FLAGS...]

For every method and thread count, R rounds (default 5) interleave
`ercube render --volume VOLUME --method M --threads T --repeat F --stats`
(F frames in one process, each frame's time_s) with F calls of
ercube.render of the same voxels, method and threads in this process (each
call's wall-clock time, converting the arrays in and out, and the frame
time it reports), the two taking turns at going first; the pairs run in a
rotated order each round, so a change of the machine's load falls on every
pair alike. The pipeline runs with --no-golden-twin (no_golden_twin=True):
its golden twin is rendered outside the command line's time_s but inside a
call.

Prints one Markdown row a pair: the median command-line frame, the median
call, their ratio (the overhead: the figure to keep within 1.05), the
median over the rounds of each round's ratio (the calls and frames of one
round ran side by side, under the same load), the median frame a call
reports, and the median time a call spends outside its own frame (its wall-clock time minus the time_s it reports: converting the
arrays, parsing the options, comparing the voxels with the kept ones; the
steadier figure on a loaded machine).
"""

import json
import os
import statistics
import subprocess
import sys
import tempfile
import time

import ercube


def options(flags):
    """Command-line flags as ercube.render's keyword arguments."""
    kw, k = {}, 0
    while k < len(flags):
        key = flags[k].lstrip("-").replace("-", "_")
        # A flag without a value (--no-golden-twin) is a boolean option.
        if k + 1 < len(flags) and not flags[k + 1].startswith("--"):
            kw[key], k = flags[k + 1], k + 2
        else:
            kw[key], k = True, k + 1
    return kw


def main() -> None:
    args = sys.argv[1:]
    flags = []
    if "--" in args:
        i = args.index("--")
        args, flags = args[:i], args[i + 1:]
    binary, volume = args[0], args[1]
    named = dict(zip(args[2::2], args[3::2]))
    rounds = int(named.get("--rounds", 5))
    frames = int(named.get("--frames", 5))
    methods = named.get("--methods", "er,er-ftb,pipeline").split(",")
    threads = [int(t) for t in named.get("--threads", "1,2").split(",")]
    voxels, spacing = ercube.load(volume)
    pairs = [(m, t) for m in methods for t in threads]

    def flags_of(method, t):
        f = ["--method", method, "--threads", str(t), *flags]
        return f + ["--no-golden-twin"] if method == "pipeline" else f

    for m, t in pairs:  # warm up: the kept volume, every pool
        ercube.render(voxels, spacing=spacing, **options(flags_of(m, t)))
    cli = {p: [] for p in pairs}
    call = {p: [] for p in pairs}
    inner = {p: [] for p in pairs}
    ratio = {p: [] for p in pairs}
    with tempfile.TemporaryDirectory() as d:
        stats, png = os.path.join(d, "s.json"), os.path.join(d, "r.png")
        for r in range(rounds):
            for p in pairs[r % len(pairs):] + pairs[:r % len(pairs)]:
                f = flags_of(*p)
                kw = options(f)
                for side in ("cli", "python") if r % 2 == 0 else ("python", "cli"):
                    if side == "cli":
                        subprocess.run([binary, "render", "--volume", volume, "--repeat", str(frames),
                                        "--stats", stats, "--out", png, *f],
                                       check=True, stdout=subprocess.DEVNULL)
                        with open(stats) as s:
                            cli[p] += json.load(s)["times_s"]
                        continue
                    for _ in range(frames):
                        start = time.perf_counter()
                        _, st = ercube.render(voxels, spacing=spacing, **kw)
                        call[p].append(time.perf_counter() - start)
                        inner[p].append(st["time_s"])
                # The round's pair: its calls' median over its frames'.
                ratio[p].append(statistics.median(call[p][-frames:]) / statistics.median(cli[p][-frames:]))
    m = statistics.median
    print(f"{os.path.basename(volume)}: {rounds} rounds of {frames} frames each side, medians")
    print("| method | threads | command line frame | Python call | call / frame | same round | frame in Python | call outside its frame |")
    print("| --- | --- | --- | --- | --- | --- | --- | --- |")
    for p in pairs:
        c, k, i = m(cli[p]), m(call[p]), m(inner[p])
        out = m([a - b for a, b in zip(call[p], inner[p])])
        print(f"| {p[0]} | {p[1]} | {c * 1e3:.1f} ms | {k * 1e3:.1f} ms | {k / c:.3f} | {m(ratio[p]):.3f} | "
              f"{i * 1e3:.1f} ms | {out * 1e3:.2f} ms |")


if __name__ == "__main__":
    main()
