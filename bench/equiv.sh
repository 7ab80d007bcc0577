#!/usr/bin/env bash
# Refactor check: renders a fixed set of pipeline frames with two ercube
# binaries and compares the PNG, the float image, the raw accumulator words,
# the stats JSON (without its timing keys) and, for traced runs, the VCD,
# byte for byte.
#
#   bench/equiv.sh BASE_BIN NEW_BIN [WORKDIR]
#
# Prints one line per case (`same` or `DIFF: files`) and exits 1 on any
# difference or failed render. The brain volume is ../shared/data/brainsmall.den
# beside the repository, as the tests find it, or $ERCUBE_BRAIN.
set -u
base=${1:?base binary}
new=${2:?new binary}
work=${3:-/tmp/ercube-equiv}
root=$(cd "$(dirname "$0")/.." && pwd)
brain=${ERCUBE_BRAIN:-$root/../shared/data/brainsmall.den}
[ -r "$brain" ] || { echo "equiv.sh: no brain volume at $brain (set ERCUBE_BRAIN)"; exit 2; }
rm -rf "$work"
mkdir -p "$work/cfg"

cat >"$work/cfg/overlap.toml" <<'T'
mapping = "interleave"
migration = "overlapped"
link_skip_empty = true
pass_skip_empty = true
link_lanes = 3
occupancy_block = 8
pes = 8
T
cat >"$work/cfg/cyclic.toml" <<'T'
mapping = "cyclic"
cyclic_width = 4
pass_skip_empty = true
T
cat >"$work/cfg/external.toml" <<'T'
ray_buffer = "external"
link_skip_empty = true
T
cat >"$work/cfg/overlap2.toml" <<'T'
mapping = "interleave"
migration = "overlapped"
link_lanes = 2
T

# name|threads|arguments (the method last but one group)
cases=(
  "brain-btf|2|--volume $brain --tf brain --method pipeline"
  "brain-ftb|2|--volume $brain --tf brain --method pipeline-ftb"
  "brain-btf-t1|1|--volume $brain --tf brain --method pipeline"
  "brain-ftb-t1|1|--volume $brain --tf brain --method pipeline-ftb"
  "brain-shade|2|--volume $brain --tf brain --method pipeline --shade"
  "brain-shade-ftb-t1|1|--volume $brain --tf brain --method pipeline-ftb --shade"
  "brain-preint|2|--volume $brain --tf brain --method pipeline --preintegrate"
  "brain-preint-ftb|1|--volume $brain --tf brain --method pipeline-ftb --preintegrate"
  "brain-voi|2|--volume $brain --tf brain --method pipeline --voi sphere:40,60,50,25 --voi-scale 3"
  "brain-voi-ftb|1|--volume $brain --tf brain --method pipeline-ftb --voi box:10,10,10,60,70,60 --voi-outside --voi-ramp 4"
  "brain-overlap|2|--volume $brain --tf brain --method pipeline --config CFG/overlap.toml"
  "brain-overlap-ftb-t1|1|--volume $brain --tf brain --method pipeline-ftb --config CFG/overlap.toml --shade"
  "brain-cyclic|2|--volume $brain --tf brain --method pipeline --config CFG/cyclic.toml --shade"
  "brain-external|1|--volume $brain --tf brain --method pipeline --config CFG/external.toml"
  "brain-external-ftb|2|--volume $brain --tf brain --method pipeline-ftb --config CFG/external.toml"
  "brain-overlap2-preint|2|--volume $brain --tf brain --method pipeline --config CFG/overlap2.toml --preintegrate"
  "brain-noskip|2|--volume $brain --tf brain --method pipeline --no-skip-empty --no-cull"
  "brain-noskip-ftb-overlap|1|--volume $brain --tf brain --method pipeline-ftb --no-skip-empty --config CFG/overlap2.toml"
  "brain-clip|2|--volume $brain --tf brain --method pipeline --clip 0,0,1,-30 --shade"
  "checker64|2|--scene checker:64 --method pipeline"
  "checker64-ftb-t1|1|--scene checker:64 --method pipeline-ftb"
  "checker64-overlap|2|--scene checker:64 --method pipeline --config CFG/overlap.toml"
  "ml40-pes5|2|--scene ml:40 --method pipeline --pes 5"
  "ml40-pes5-ftb|1|--scene ml:40 --method pipeline-ftb --pes 5 --shade"
  "ml40-pes5-cyclic|2|--scene ml:40 --method pipeline --pes 5 --config CFG/cyclic.toml"
  "brain-vcd|2|--volume $brain --tf brain --method pipeline --size 64x64 --vcd VCD"
  "brain-vcd-ftb-t1|1|--volume $brain --tf brain --method pipeline-ftb --size 64x64 --shade --vcd VCD"
  "ml40-vcd-overlap|2|--scene ml:40 --method pipeline --pes 5 --config CFG/overlap.toml --vcd VCD --trace-signals all"
  "checker64-vcd-external|1|--scene checker:64 --method pipeline --config CFG/external.toml --vcd VCD --size 64x64"
)

status=0
for c in "${cases[@]}"; do
  IFS='|' read -r name threads args <<<"$c"
  failed=""
  for side in base new; do
    bin=$base
    [ "$side" = new ] && bin=$new
    d="$work/$side/$name"
    mkdir -p "$d"
    a=${args//CFG/$work/cfg}
    a=${a//VCD/$d/w.vcd}
    # shellcheck disable=SC2086
    if ! RAYON_NUM_THREADS=$threads "$bin" render $a \
      --raw-npy "$d/r.npy" --npy "$d/i.npy" --stats "$d/s.json" --out "$d/i.png" \
      >"$d/out.txt" 2>"$d/err.txt"; then
      echo "$name: $side failed: $(head -c 300 "$d/err.txt")"
      failed=1
      status=1
    fi
    python3 - "$d/s.json" >"$d/s.cmp.json" <<'P'
import json, sys
d = json.load(open(sys.argv[1]))
for k in ("time_s", "times_s", "pe_cycles_per_second"):
    d.pop(k, None)
print(json.dumps(d, sort_keys=True, indent=1))
P
  done
  diffs=""
  for f in r.npy i.npy i.png s.cmp.json w.vcd w.gtkw w.stage.txt; do
    b="$work/base/$name/$f"
    n="$work/new/$name/$f"
    [ -e "$b" ] || [ -e "$n" ] || continue
    cmp -s "$b" "$n" || diffs="$diffs $f"
  done
  # The waveforms are large: keep them only when they differ.
  [ -z "$diffs" ] && rm -f "$work"/{base,new}/"$name"/w.vcd
  if [ -n "$failed" ]; then
    echo "$name: FAILED"
  elif [ -z "$diffs" ]; then
    echo "$name: same ($(grep -o '[0-9]* cycles' "$work/new/$name/out.txt" | head -1))"
  else
    echo "$name: DIFF:$diffs"
    status=1
  fi
done
exit $status
