"""Checks ercube.pe_vectors against the files of `ercube vectors --stage pe`
(written by tests/wheel/pe_vectors.rs for the same frame: PE 1 of 3,
ml:16, 12x12, front to back, tf ml; or the frame FRAME names): every
port's words each clock, the memory writes, the tables, the constants and
the counts equal the files'; each issued sample's write-back equals
ercube.Datapath.eval on the bundle the arrays give; the errors raise
ercube.Error. Prints what it checked; exits non-zero on the first
difference.

usage: python check_pe_vectors.py DIR [FRAME]

FRAME is JSON: {"scene": ..., "config": TOML text, "kwargs": {...}} (the
keyword arguments of ercube.pe_vectors besides config), for a frame of
another mapping.
"""

import json
import sys
import time
from pathlib import Path

import numpy as np

import ercube

vec = Path(sys.argv[1])
man = json.loads((vec / "manifest.json").read_text())


def words(path):
    return [int(w, 16) for w in (vec / path).read_text().split()]


frame = json.loads(sys.argv[2]) if len(sys.argv) > 2 else {
    "scene": "ml:16",
    "config": None,
    "kwargs": {"pe": 1, "pes": 3, "size": [12, 12], "order": "ftb", "tf": "ml"},
}
start = time.perf_counter()
v = ercube.pe_vectors(ercube.scene(frame["scene"]), config=frame["config"], **frame["kwargs"])
took = time.perf_counter() - start

for key in ["pe", "pes", "rows", "depth", "tap_stage", "samples", "frame_cycles", "mapping"]:
    assert v[key] == man[key], (key, v[key], man[key])
assert v["samples_all_pes"] == man["samples_all_pes"]
rows = v["rows"]

# Every port's words, each clock.
files = {f["signal"]: f for f in man["files"]}
assert set(files) == set(v["inputs"]) | set(v["outputs"]), sorted(files)
for name, f in files.items():
    side = v["inputs"] if f["direction"] == "in" else v["outputs"]
    got = side[name]
    assert got.dtype == np.uint64 and got.shape == (rows,), (name, got.dtype, got.shape)
    assert np.array_equal(got, np.array(words(f["path"]), dtype=np.uint64)), name
    p = v["ports"][name]
    assert (p["bits"], p["signed"], p["direction"], p["checked"]) == (
        f["width"], f["signed"], f["direction"], f["checked"]), (name, p, f)
for c in man["constants"]:
    assert v["constants"][c["signal"]] == int(c["value"], 16), c

# The memory writes: {cycle, mem, addr, data} as the file packs them.
wf = {f["name"]: f["bits"] for f in man["writes"]["fields"]}
assert v["memories"] == man["writes"]["mem"]
w = v["writes"]
assert len(w["cycle"]) == man["writes"]["count"]
for i, line in enumerate(words(man["writes"]["path"])):
    data = line & ((1 << wf["data"]) - 1)
    addr = (line >> wf["data"]) & ((1 << wf["addr"]) - 1)
    mem = (line >> (wf["data"] + wf["addr"])) & ((1 << wf["mem"]) - 1)
    cycle = line >> (wf["data"] + wf["addr"] + wf["mem"])
    got = (int(w["cycle"][i]), int(w["mem"][i]), int(w["addr"][i]), int(w["data"][i]))
    assert got == (cycle, mem, addr, data), (i, got, (cycle, mem, addr, data))

# The tables, as the host port's rows write them.
dp = ercube.Datapath(config=frame["config"], order=frame["kwargs"].get("order"))
m = dp.pipelined()
ports = {p["name"]: p for p in m["ports"]}
sb, ab, db = (ports[n]["bits"] for n in ["tbl_sel", "tbl_addr", "tbl_data"])
by_sel = {t["sel"]: t for t in m["tables"]}
host = {}
for row in words(man["tables"]["path"]):
    sel, addr, data = (row >> (ab + db)) & ((1 << sb) - 1), (row >> db) & ((1 << ab) - 1), row & ((1 << db) - 1)
    host.setdefault(by_sel[sel]["name"], {})[addr] = data
assert set(host) == set(v["tables"]), (sorted(host), sorted(v["tables"]))
for name, table in v["tables"].items():
    bits = next(t["bits"] for t in m["tables"] if t["name"] == name)
    masked = [int(x) & ((1 << bits) - 1) for x in table]
    assert masked == [host[name].get(a, 0) for a in range(len(table))], name
    dp.load_table(name, [int(x) for x in table])
for name, text in v["verilog"].items():
    assert text == (vec / f"{name}.v").read_text(), name

# Each issued sample through the model: its write-back `depth` clocks on.
ins, outs = v["inputs"], v["outputs"]
inputs = {p["name"]: p for p in dp.inputs}


def value(name, row):
    word, p = int((ins | outs)[name][row]), v["ports"][name]
    return word - (1 << p["bits"]) if p["signed"] and word >> (p["bits"] - 1) else word


cw = next(p["bits"] for p in dp.outputs if p["name"] == "acc_out_r")
issues = np.flatnonzero(outs["iss_valid"])
for r in issues:
    bundle = {n: value(f"bc_{n}", r) for n in ["a", "t", "b", "k", "row_wy", "sy", "sz"]}
    bundle["slot_m"] = value("iss_m", r)
    # The ray's accumulators reach the datapath a clock after its issue.
    bundle.update({f"acc_{c}": value(f"iss_acc_{c}", r + 1) for c in "rgba"})
    bundle.update({t: value(f"tap_{t}", r + v["tap_stage"]) for t in ["v00", "v01", "v10", "v11"]})
    out = dp.eval(**{n: x for n, x in bundle.items() if n in inputs})
    assert outs["wb_valid"][r + v["depth"]] == 1, r
    wb = int(outs["wb_data"][r + v["depth"]])
    for i, c in enumerate("rgba"):
        assert (wb >> (i * cw)) & ((1 << cw) - 1) == out[f"acc_out_{c}"] & ((1 << cw) - 1), (r, c)
assert len(issues) == v["samples"]
print(
    f"pe_vectors: PE 1 ({v['mapping']}): {len(issues)} samples, {rows} clocks, {len(w['cycle'])} memory writes "
    f"equal to the files and the model ({took:.2f} s)"
)
if len(sys.argv) > 2:
    sys.exit(0)

for call, says in [
    (lambda: ercube.pe_vectors(ercube.scene("ml:16"), pe=3, pes=3, size=(12, 12)), "--pe 3: the frame has 3 PEs"),
    # 4 PEs: the shading unit loads (4 voxel columns a PE), so what refuses is the vectors' plain sample.
    (lambda: ercube.pe_vectors(ercube.scene("ml:16"), pes=4, size=(12, 12), shade=True), "plain sample only"),
    (lambda: ercube.pe_vectors(ercube.scene("ml:16"), size=(12, 12), shade=True), "at least 2 voxel columns per PE"),
    (lambda: ercube.pe_vectors(ercube.scene("ml:16"), order="up"), "order"),
    (lambda: ercube.pe_vectors(ercube.scene("ml:16"), config="pes = 0"), "pes"),
]:
    try:
        call()
    except ercube.Error as e:
        assert says in str(e) and "\n" not in str(e), (says, str(e))
    else:
        raise AssertionError(f"no error for {says}")
print("pe_vectors: errors raise ercube.Error")
