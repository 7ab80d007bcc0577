"""Checks ercube.render against the command line's outputs.

usage: python check_render.py CASES.json

CASES.json is a list of {"source": "brain" | "scene", "kwargs": {...},
"npy": PATH, "stats": PATH}: each case renders the source through
ercube.render(**kwargs) and requires the image to equal the command line's
--npy bit for bit, and the stats dict to equal its --stats (apart from the
wall-clock fields). Prints one line per case; exits 1 on any mismatch.
"""

import json
import sys

import numpy as np

import ercube

TIMES = ("time_s", "times_s", "pe_cycles_per_second")


def main() -> int:
    cases = json.load(open(sys.argv[1]))
    brain, spacing = ercube.load(cases[0]["brain"])
    assert brain.dtype == np.uint8 and brain.ndim == 3, (brain.dtype, brain.shape)
    scene = ercube.scene(cases[0]["scene"])
    bad = 0
    for c in cases:
        voxels = brain if c["source"] == "brain" else scene
        kw = dict(c["kwargs"])
        if c["source"] == "brain":
            kw["spacing"] = spacing
        image, stats = ercube.render(voxels, **kw)
        want = np.load(c["npy"])
        same = (
            image.dtype == np.float32
            and image.shape == want.shape
            and np.array_equal(image.view(np.uint32), want.view(np.uint32))
        )
        cli = json.load(open(c["stats"]))
        for d in (stats, cli):
            for k in TIMES:
                d.pop(k, None)
            d.get("gaze_vs_full", {}).pop("full_time_s", None)
        same_stats = stats == cli
        print(f"{c['source']} {kw.get('method', 'er')}: image {'same' if same else 'DIFFERENT'}, "
              f"stats {'same' if same_stats else 'DIFFERENT'}")
        if not same_stats:
            for k in sorted(set(stats) | set(cli)):
                if stats.get(k) != cli.get(k):
                    print(f"  {k}: python {stats.get(k)!r} cli {cli.get(k)!r}")
        bad += (not same) + (not same_stats)
    bad += check_kept(brain, spacing)
    bad += check_frozen(brain, spacing, cases[0]["scene"])
    # An error is an ercube.Error carrying the command line's message.
    try:
        ercube.render(scene, size=(0, 0))
        print("size (0, 0) was accepted")
        bad += 1
    except ercube.Error as e:
        print(f"error: {e}")
        bad += "each side must be 1 to 16384" not in str(e)
    return 1 if bad else 0


def check_kept(brain, spacing) -> int:
    """The kept volume never gives a stale frame: an array changed in place
    renders as a fresh copy of it does; a strided view as its contiguous
    copy; a windowed render (which renders a new volume) twice the same."""
    bad = 0

    def same(a, b):
        return np.array_equal(a.view(np.uint32), b.view(np.uint32))

    def fresh(voxels, **kw):
        ercube.clear_cache()
        return ercube.render(voxels.copy(), spacing=spacing, **kw)[0]

    v = brain.copy()
    before = ercube.render(v, spacing=spacing, size=(64, 64))[0]
    v[30:50] = 255 - v[30:50]
    after = ercube.render(v, spacing=spacing, size=(64, 64))[0]
    ok = same(after, fresh(v, size=(64, 64))) and not same(after, before)
    print(f"changed in place: {'fresh' if ok else 'STALE'}")
    bad += not ok
    flipped = brain[:, ::-1, :]
    got = ercube.render(flipped, spacing=spacing, size=(64, 64))[0]
    ok = same(got, fresh(np.ascontiguousarray(flipped), size=(64, 64)))
    print(f"strided view: {'same' if ok else 'DIFFERENT'}")
    bad += not ok
    w = ercube.render(brain, spacing=spacing, size=(64, 64), window=(20, 200))[0]
    w2 = ercube.render(brain, spacing=spacing, size=(64, 64), window=(20, 200))[0]
    ok = same(w, w2) and same(w, fresh(brain, size=(64, 64), window=(20, 200)))
    print(f"windowed twice: {'same' if ok else 'DIFFERENT'}")
    bad += not ok
    return bad


def check_frozen(brain, spacing, scene) -> int:
    """Arrays of ercube.load and ercube.scene are read-only over a buffer
    that cannot change, so a call with one is not compared with the kept
    volume: every such frame (a sub-block, another buffer of the same
    shape, the same view again after another) equals the frame of a fresh
    copy; an image handed out stays as it was while later frames run."""
    bad = 0

    def same(a, b):
        return np.array_equal(a.view(np.uint32), b.view(np.uint32))

    def fresh(voxels, **kw):
        ercube.clear_cache()
        return ercube.render(np.array(voxels), **kw)[0]

    try:
        brain.flags.writeable = True
        print("frozen: the loaded array was made writable")
        bad += 1
    except ValueError:
        print("frozen: the loaded array stays read-only")
    kw = dict(spacing=spacing, size=(48, 40))
    low, high = brain[10:60], brain[30:80]
    images = [ercube.render(v, **kw)[0] for v in (brain, low, high, brain, low)]
    want = [fresh(v, **kw) for v in (brain, low, high)]
    ok = all(same(a, b) for a, b in zip(images, want + want[:2])) and not same(want[1], want[2])
    print(f"frozen sub-blocks: {'fresh' if ok else 'STALE'}")
    bad += not ok
    kind, side = scene.split(":")
    a, b = ercube.scene(scene), ercube.scene(("checker:" if kind == "sphere" else "sphere:") + side)
    ok = a.shape == b.shape
    if ok:
        got = [ercube.render(v, size=(48, 40))[0] for v in (a, b, a)]
        want = [fresh(v, size=(48, 40)) for v in (a, b)]
        ok = same(got[0], want[0]) and same(got[1], want[1]) and same(got[2], want[0]) and not same(want[0], want[1])
    print(f"frozen buffers of one shape: {'fresh' if ok else 'STALE'}")
    bad += not ok
    first = ercube.render(brain, **kw)[0]
    keep = first.copy()
    moved = [ercube.render(brain, eye=(64, 64 + 10 * k, -150), **kw)[0] for k in range(6)]
    back = ercube.render(brain, **kw)[0]
    ok = same(first, keep) and same(back, keep) and not same(moved[3], keep)
    print(f"images held across frames: {'unchanged' if ok else 'OVERWRITTEN'}")
    bad += not ok
    return bad


if __name__ == "__main__":
    sys.exit(main())
