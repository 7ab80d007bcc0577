#!/usr/bin/env python3
"""CPU time per frame of the pipeline model against golden `er`.

    python3 bench/pipeline_speed.py [--rounds R] [--frames N] BIN [BIN2]

For each view (checker:256 with and without skipping, brainsmall), each
thread count (1, 2) and each method (`er`, then `pipeline` with BIN and,
if given, BIN2), runs `BIN render VIEW --method M --threads T` under
`perf stat -e task-clock` once with `--repeat N` and once with
`--repeat 1`; the difference divided by N - 1 is the CPU time of one
frame without the process's set-up (loading or building the volume,
preparing the view, writing the image); the `--repeat N` run's stats
give the median wall time of a frame (`time_s`) beside it. The
pipeline runs with `--pes 16 --no-golden-twin`. At two threads the CPU
time counts both threads, waiting ones included. Runs are interleaved round by round, so that a
busy machine slows every method alike; CPU time (task-clock), not wall
time, is what is compared, since the machine may be shared. Prints
each round's per-frame milliseconds and, per view and thread count,
the median over the rounds and the ratio pipeline / golden.
"""
import argparse
import json
import statistics
import subprocess
import sys
import tempfile

BRAIN = "../shared/data/brainsmall.den"
VIEWS = {
    "checker:256 skip": ["--scene", "checker:256", "--eye", "128,128,-128", "--fov", "90", "--size", "256x256"],
    "checker:256 no skip": ["--scene", "checker:256", "--eye", "128,128,-128", "--fov", "90",
                            "--size", "256x256", "--no-skip-empty", "--no-cull"],
    "brainsmall": ["--volume", BRAIN, "--eye", "64,64,-64", "--fov", "90", "--size", "256x256"],
}


def task_clock_ms(cmd):
    """CPU milliseconds `perf stat -e task-clock` reports for `cmd`."""
    out = subprocess.run(["perf", "stat", "-x,", "-e", "task-clock"] + cmd,
                         capture_output=True, text=True)
    if out.returncode != 0:
        sys.exit(f"failed: {' '.join(cmd)}\n{out.stderr[-500:]}")
    for line in out.stderr.splitlines():
        f = line.split(",")
        if len(f) > 2 and f[2].startswith("task-clock"):
            return float(f[0])
    sys.exit(f"no task-clock in perf's output for {' '.join(cmd)}")


def frame_ms(binary, view, method, threads, frames, png):
    cmd = [binary, "render"] + VIEWS[view] + ["--method", method, "--threads", str(threads), "--out", png]
    if method.startswith("pipeline"):
        cmd += ["--pes", "16", "--no-golden-twin"]
    stats = png + ".json"
    many = task_clock_ms(cmd + ["--repeat", str(frames), "--stats", stats])
    wall = json.load(open(stats))["time_s"] * 1e3
    one = task_clock_ms(cmd + ["--repeat", "1"])
    return (many - one) / (frames - 1), wall


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("bins", nargs="+", help="ercube binaries (pipeline runs each; er the first)")
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--frames", type=int, default=6)
    ap.add_argument("--views", default=",".join(VIEWS), help="comma-separated subset of the views")
    a = ap.parse_args()
    views = a.views.split(",")
    times, walls = {}, {}
    with tempfile.TemporaryDirectory() as d:
        png = f"{d}/f.png"
        for r in range(a.rounds):
            for view in views:
                for t in (1, 2):
                    runs = [("er", a.bins[0])] + [(f"pipeline[{i}]", b) for i, b in enumerate(a.bins)]
                    for name, b in runs:
                        m = "er" if name == "er" else "pipeline"
                        ms, wall = frame_ms(b, view, m, t, a.frames, png)
                        times.setdefault((view, t, name), []).append(ms)
                        walls.setdefault((view, t, name), []).append(wall)
                        print(f"round {r} {view} T={t} {name}: {ms:.1f} ms CPU, {wall:.1f} ms wall", flush=True)
    print()
    for label, table in (("CPU ms per frame (task-clock)", times), ("wall ms per frame (stats time_s)", walls)):
        print(f"{label}, medians over the rounds:")
        print("| view | threads | golden er | " + " | ".join(
            f"pipeline[{i}] | ratio[{i}]" for i in range(len(a.bins))) + " |")
        print("| --- " * (3 + 2 * len(a.bins)) + "|")
        for view in views:
            for t in (1, 2):
                g = statistics.median(table[(view, t, "er")])
                cells = [view, str(t), f"{g:.1f}"]
                for i in range(len(a.bins)):
                    p = statistics.median(table[(view, t, f"pipeline[{i}]")])
                    cells += [f"{p:.1f}", f"{p / g:.2f}x"]
                print("| " + " | ".join(cells) + " |")
        print()


if __name__ == "__main__":
    main()
