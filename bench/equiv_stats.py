#!/usr/bin/env python3
"""After bench/equiv.sh: which cases' bits match and which stats differ.

    python3 bench/equiv_stats.py [WORKDIR]

For each case under WORKDIR (default /tmp/ercube-equiv) prints whether the
raw words, the float image and the PNG are byte-identical, then every stats
key (timing keys dropped, as equiv.sh drops them) whose value differs, as
`key: base -> new (delta)`. Exits 1 when any case's bits differ.
"""
import json
import os
import sys


def flat(d, prefix=""):
    """Leaves of a JSON value as dotted keys."""
    if isinstance(d, dict):
        for k, v in d.items():
            yield from flat(v, f"{prefix}{k}.")
    elif isinstance(d, list):
        for i, v in enumerate(d):
            yield from flat(v, f"{prefix}{i}.")
    else:
        yield prefix[:-1], d


def same(a, b):
    if not (os.path.exists(a) or os.path.exists(b)):
        return True
    try:
        return open(a, "rb").read() == open(b, "rb").read()
    except OSError:
        return False


def main():
    work = sys.argv[1] if len(sys.argv) > 1 else "/tmp/ercube-equiv"
    status = 0
    for name in sorted(os.listdir(os.path.join(work, "new"))):
        b = os.path.join(work, "base", name)
        n = os.path.join(work, "new", name)
        bits = all(same(os.path.join(b, f), os.path.join(n, f)) for f in ("r.npy", "i.npy", "i.png"))
        status |= not bits
        sb = dict(flat(json.load(open(os.path.join(b, "s.cmp.json")))))
        sn = dict(flat(json.load(open(os.path.join(n, "s.cmp.json")))))
        diffs = []
        for k in sorted(set(sb) | set(sn)):
            x, y = sb.get(k), sn.get(k)
            if x != y:
                d = ""
                if isinstance(x, (int, float)) and isinstance(y, (int, float)):
                    d = f" ({y - x:+g})"
                diffs.append(f"  {k}: {x} -> {y}{d}")
        print(f"{name}: bits {'same' if bits else 'DIFFER'}, {len(diffs)} stats keys differ")
        for line in diffs:
            print(line)
    return status


if __name__ == "__main__":
    sys.exit(main())
