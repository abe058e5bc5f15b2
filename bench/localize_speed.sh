#!/usr/bin/env bash
# The localizer's time a scan by stage, this build beside an earlier one, in one run: drive 0005's
# paper protocol (77 odd scans, 16 of 64 beams, LiDAR only, on the even scans' map), `pl-localize`
# on one thread (taskset to one core when there is taskset), the two builds alternating RUNS times
# (5). Per build: the median over the runs of each stage's median a scan (preparation, prediction:
# LiDAR odometry, map update, registration, integrity checks, and the whole scan), beside its APE,
# status counts, scans reported ok while more than 0.5 m off, and median protection level. Then
# bench_localize (when built, with PCL) sets this build beside PCL's ICP and NDT on the same scans.
#   bench/localize_speed.sh BEFORE_BIN_DIR BIN_DIR WORK_DIR [RUNS]
set -euo pipefail
usage="usage: bench/localize_speed.sh BEFORE_BIN_DIR BIN_DIR WORK_DIR [RUNS]"
before=${1:?$usage}
bin=${2:?$usage}
work=${3:?$usage}
runs=${4:-5}
before=$(cd "$before" && pwd)
bin=$(cd "$bin" && pwd)
# shellcheck source=bench/k05_map.sh
source "$(dirname "$0")/k05_map.sh"
k05_map localize_speed "$bin" "$work" || exit 0
export PL_NO_PROGRESS=1
one_core=()
command -v taskset >/dev/null && one_core=(taskset -c 0)
out="$work/localize_speed"
mkdir -p "$out"
for r in $(seq 1 "$runs"); do
  for b in before after; do
    [[ $b == before ]] && dir=$before || dir=$bin
    "${one_core[@]}" "$dir/pl-localize" --dataset "$drive" --db "$k05/maps.sqlite" --map k05 --beams 16 --scans odd \
      --odometry lidar --init gt --out "$out/$b-$r.tum" --kitti-out "$out/$b-$r.txt" --timing "$out/$b-$r.csv" >"$out/$b-$r.log"
    "$bin/pl-eval" ape --json --est "$out/$b-$r.txt" --gt "$k05/gt_odd.txt" >"$out/$b-$r-ape.json"
  done
done

python3 - "$out" "$runs" "$k05/gt_odd.txt" <<'PY'
import csv, json, math, statistics as st, sys
out, runs, gt_path = sys.argv[1], int(sys.argv[2]), sys.argv[3]
gt = [list(map(float, l.split())) for l in open(gt_path) if l.strip() and not l.startswith("#")]
stages = [("prepare_ms", "prepare"), ("odometry_ms", "predict"), ("map_ms", "map"), ("registration_ms", "register"),
          ("integrity_ms", "integrity"), ("total_ms", "whole")]
def build(name):
    per_run, last = [], None
    for r in range(1, runs + 1):
        rows = list(csv.DictReader(open(f"{out}/{name}-{r}.csv")))
        per_run.append({k: st.median(float(x[k]) for x in rows) for k, _ in stages})
        last = rows
    times = {k: st.median(p[k] for p in per_run) for k, _ in stages}
    ape = json.load(open(f"{out}/{name}-{runs}-ape.json"))
    est = [list(map(float, l.split())) for l in open(f"{out}/{name}-{runs}.txt") if l.strip() and not l.startswith("#")]
    off_ok = sum(1 for x, e, g in zip(last, est, gt)
                 if x["status"] == "ok" and math.dist((e[3], e[7], e[11]), (g[3], g[7], g[11])) > 0.5)
    counts = {h: sum(1 for x in last if x["status"] == h) for h in ("ok", "degraded", "lost")}
    prot = st.median(float(x["protection_m"]) for x in last)
    return times, ape, counts, off_ok, prot
print(f"drive 0005, paper protocol, pl-localize on one core, median of {runs} alternating runs of each stage's median a scan (ms)")
print("  build   " + "".join(f"{label:>10}" for _, label in stages) + "  APE mean    max   ok/degr/lost  ok>0.5m  protection")
res = {}
for name in ("before", "after"):
    t, ape, c, off, prot = res[name] = build(name)
    print(f"  {name:7} " + "".join(f"{t[k]:10.2f}" for k, _ in stages) +
          f"  {ape['mean']:8.4f} {ape['max']:6.4f}  {c['ok']:2d}/{c['degraded']}/{c['lost']}        {off}      {prot:.3f} m")
b, a = res["before"][0], res["after"][0]
print(f"  registration {b['registration_ms'] / a['registration_ms']:.2f} times as fast, the whole scan {b['total_ms'] / a['total_ms']:.2f} times")
PY

if [[ -x "$bin/bench_localize" ]]; then
  echo
  echo "the same scans, this build beside PCL's ICP and NDT (bench_localize, one thread):"
  "${one_core[@]}" "$bin/bench_localize" "$drive" "$k05/maps.sqlite" --map k05
fi
