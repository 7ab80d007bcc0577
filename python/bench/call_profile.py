"""Where an ercube.render call spends its time outside its frame, by perf.

usage: python call_profile.py VOLUME [--method M] [--threads T] [--calls N]

Runs `perf record` (cpu-clock samples at 5 kHz with DWARF call stacks) over
this script rendering VOLUME N times (default 200) with method M (default
er-ftb) on T threads (default 1), after 3 warm-up calls, then attributes
each sample taken between the first and the last call to the first part in
PARTS a frame of its stack names (the frame's own time, `time_s`, first).
Prints each part's CPU time a call, in ms: the samples over the sampling
rate and the calls; their sum outside the frame leaves out the pool's
other workers, which spin beside the call rather than in its way. At one
thread that is all they do; with more, the work they take from the frame
or the comparison is counted with them (their stacks start in the pool),
so the figures are for one thread. Needs perf; the wheel's debug line tables name the
Rust functions.
"""

import collections
import os
import subprocess
import sys
import tempfile

HZ = 5000
WARM = 3

# (part, names a stack frame contains), in the order they are tried.
PARTS = [
    ("the frame (time_s)", ["timed_frames", "timed_with<"]),
    ("voxel comparison", ["lend_if", "VoxelsRef>::equals", "ercube::frame::same"]),
    ("memory limits", ["Limits::read", "Limits::recent", "Budget::"]),
    ("preparing the kept stack for the camera", ["Reuse::prepared", "Prepared::moved", "Prepared::place"]),
    ("transfer function and camera", ["load_given"]),
    ("flags", ["ercube::frame::parse", "clap"]),
    ("statistics dict", ["json_value", "pythonize"]),
    ("statistics (JSON values)", ["frame_json", "serde_json"]),
    ("image to numpy", ["image_array", "Pixels"]),
    ("array from numpy", ["Input::of", "Input::ready", "Input>::of", "Input>::ready"]),
    ("progress display", ["indicatif", "progress::Stage"]),
    ("rest of the golden frame", ["frame_golden"]),
    ("hand-off to the pool", ["with_threads", "frame_reusing", "render_borrowed", "detach", "LockLatch"]),
    ("rest of the call", ["ercube_python"]),
    ("other workers", ["wait_until_cold", "Sleep::", "ThreadBuilder::run"]),
]


def loop(volume, method, threads, calls):
    import ercube

    voxels, spacing = ercube.load(volume)
    for _ in range(WARM + calls):
        ercube.render(voxels, spacing=spacing, method=method, threads=threads)


def stacks(text):
    """(time, [frame names]) of each sample of `perf script -F time,ip,sym`."""
    now, frames = 0.0, []
    for line in text.splitlines():
        if not line.strip():
            if frames:
                yield now, frames
            frames = []
        elif line[0] not in " \t":
            now = float(line.split()[-1].rstrip(":"))
        else:
            parts = line.split(None, 1)
            frames.append(parts[1] if len(parts) > 1 else "?")
    if frames:
        yield now, frames


def main():
    args = sys.argv[1:]
    if args and args[0] == "--loop":
        loop(args[1], args[2], int(args[3]), int(args[4]))
        return
    volume = args[0]
    named = dict(zip(args[1::2], args[2::2]))
    method = named.get("--method", "er-ftb")
    threads = int(named.get("--threads", 1))
    calls = int(named.get("--calls", 200))
    with tempfile.TemporaryDirectory() as d:
        data = os.path.join(d, "perf.data")
        subprocess.run(["perf", "record", "-q", "-F", str(HZ), "--call-graph", "dwarf,16384", "-o", data,
                        sys.executable, __file__, "--loop", volume, method, str(threads), str(calls)],
                       check=True)
        text = subprocess.run(["perf", "script", "-i", data, "-F", "time,ip,sym", "--inline"],
                              check=True, capture_output=True, text=True).stdout
    samples = list(stacks(text))
    # The calls' window: from the first call after the volume loaded to the last.
    loads = [t for t, s in samples if any("__pyfunction_load" in f for f in s)]
    calls_at = [t for t, s in samples if any("__pyfunction_render" in f or "timed_frames" in f for f in s)]
    start = min(t for t in calls_at if not loads or t > max(loads))
    end = max(calls_at)
    counts = collections.Counter()
    for t, s in samples:
        if start <= t <= end:
            part = next((p for p, names in PARTS if any(n in f for f in s for n in names)), "other (Python)")
            counts[part] += 1
    n = WARM + calls
    print(f"{os.path.basename(volume)}, {method}, {threads} thread(s): CPU time a call, ms ({n} calls)")
    print("| part | ms |")
    print("| --- | --- |")
    outside = 0.0
    for p in [p for p, _ in PARTS] + ["other (Python)"]:
        ms = counts[p] / HZ / n * 1e3
        # The other workers spin beside the call, not in its way.
        if p not in ("the frame (time_s)", "other workers"):
            outside += ms
        print(f"| {p} | {ms:.3f} |")
    print(f"| outside the frame (the other workers apart) | {outside:.3f} |")


if __name__ == "__main__":
    main()
