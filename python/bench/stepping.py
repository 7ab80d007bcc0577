"""Cycles per second of a stepped frame through ercube.Chip, four ways.

usage: python stepping.py [ROUNDS] [CYCLES]

On the merging 4-PE ml:24 frame of docs/verify.md (7,159 cycles), each
round begins the frame and clocks CYCLES cycles (default 5000):
  step(n)        one call: the stepper's loop in Rust (the GIL released),
                 nothing read; the floor every other way pays;
  run(signals)   Chip.run(CYCLES, signals=[busy, acc_r, ..., ctrl.stage]):
                 the same loop keeping 8 signals per cycle as arrays;
  run(all)       Chip.run(CYCLES): every signal of every PE and the
                 controller (79 columns on this frame);
  step+ports     a Python loop of step(), ports() and broadcast().
Prints the median cycles per second of each over ROUNDS rounds
(default 5), interleaved.
"""

import statistics
import sys
import time

import ercube

SIGNALS = ["busy", "ray_mx", "sample", "acc_r", "acc_a", "right.ray_valid", "host.valid", "ctrl.stage"]


def main() -> None:
    rounds = int(sys.argv[1]) if len(sys.argv) > 1 else 5
    cycles = int(sys.argv[2]) if len(sys.argv) > 2 else 5000
    voxels = ercube.scene("ml:24")
    kw = dict(pes=4, tf="ml", size=(32, 32), eye=(13.1, 10.7, -6.0))
    chip = ercube.Chip()

    def step_n():
        chip.step(cycles)

    def run_some():
        chip.run(cycles, signals=SIGNALS)

    def run_all():
        chip.run(cycles)

    def python_loop():
        for _ in range(cycles):
            chip.step()
            chip.ports()
            chip.broadcast()

    ways = {"step(n)": step_n, "run(signals)": run_some, "run(all)": run_all, "step+ports": python_loop}
    times = {k: [] for k in ways}
    for _ in range(rounds):
        for name, f in ways.items():
            chip.begin(voxels, **kw)
            t = time.perf_counter()
            f()
            times[name].append(time.perf_counter() - t)
            assert chip.cycle == cycles, (name, chip.cycle)
    for name, ts in times.items():
        print(f"{name:>13}: {cycles / statistics.median(ts):9.0f} cycles/s (median of {rounds})")


if __name__ == "__main__":
    main()
