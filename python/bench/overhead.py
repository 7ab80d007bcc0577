"""The Python module's overhead on one frame, measured against the command line.

usage: python overhead.py ERCUBE_BINARY VOLUME [ROUNDS] [-- RENDER FLAGS...]

Interleaves, ROUNDS times (default 15): `ercube render --volume VOLUME
--stats` (its frame time, stats time_s, and the process's wall-clock
time), ercube.render of the same voxels (the wall-clock time of the call,
converting the arrays in and out, and the frame time it reports), and the
same call after ercube.clear_cache() (the volume prepared again, as a first
call does), the two calls taking turns at following the command line.
Prints the medians, the ratios of the Python calls to the command
line's frame time, and the median time a kept call spends outside its own
frame (the call's wall-clock time minus the time_s it reports: converting
the arrays in and out, parsing the options, resolving the transfer
function; the steadier figure on a loaded machine).
"""

import json
import os
import statistics
import subprocess
import sys
import tempfile
import time

import ercube


def main() -> None:
    args = sys.argv[1:]
    flags = []
    if "--" in args:
        i = args.index("--")
        args, flags = args[:i], args[i + 1:]
    binary, volume = args[0], args[1]
    rounds = int(args[2]) if len(args) > 2 else 15
    voxels, spacing = ercube.load(volume)
    kw = {}
    k = 0
    while k < len(flags):
        key = flags[k].lstrip("-").replace("-", "_")
        # A flag without a value (--no-golden-twin) is a boolean option.
        if k + 1 < len(flags) and not flags[k + 1].startswith("--"):
            kw[key], k = flags[k + 1], k + 2
        else:
            kw[key], k = True, k + 1
    ercube.render(voxels, spacing=spacing, **kw)  # warm up
    cli, wall, call, inner, cold, outside = [], [], [], [], [], []
    with tempfile.TemporaryDirectory() as d:
        stats, png = os.path.join(d, "s.json"), os.path.join(d, "r.png")
        for r in range(rounds):
            t = time.perf_counter()
            subprocess.run([binary, "render", "--volume", volume, "--stats", stats,
                            "--out", png, *flags], check=True, stdout=subprocess.DEVNULL)
            wall.append(time.perf_counter() - t)
            cli.append(json.load(open(stats))["time_s"])
            # A call made right after the command line's process measures
            # slower than one after another call, so the two calls take
            # turns at that place.
            for kept in (True, False) if r % 2 == 0 else (False, True):
                if not kept:
                    ercube.clear_cache()
                t = time.perf_counter()
                _, st = ercube.render(voxels, spacing=spacing, **kw)
                (call if kept else cold).append(time.perf_counter() - t)
                if kept:
                    inner.append(st["time_s"])
                    outside.append(call[-1] - st["time_s"])
    m = statistics.median
    print(f"rounds {rounds}: cli frame {m(cli) * 1e3:.1f} ms (process {m(wall) * 1e3:.1f} ms), python call {m(call) * 1e3:.1f} ms "
          f"(its frame {m(inner) * 1e3:.1f} ms); python call / cli frame = {m(call) / m(cli):.3f}, "
          f"python frame / cli frame = {m(inner) / m(cli):.3f}; after clear_cache {m(cold) * 1e3:.1f} ms, "
          f"{m(cold) / m(cli):.3f} of the cli frame; a kept call outside its frame {m(outside) * 1e3:.2f} ms")


if __name__ == "__main__":
    main()
