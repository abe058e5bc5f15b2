# Sourced by the rate benchmarks: median, rate_phases (below), and run NAME GT [pl-localize flags...], which localizes
# $rates_drive's odd scans on map $rates_map of $rates_db (or $db when set) with 16 of 64 beams, LiDAR
# only, from the first scan's ground-truth pose, writes $rates_out/NAME.{tum,txt,csv,log,scans}
# (per scan: 3-D error, protection level, milliseconds, status, horizontal error) and prints one
# table row: scans, APE mean, median, max, scans > 0.5 m off and of them ok, status counts, the share
# of scans whose horizontal error exceeds their protection level, the median protection level and ms.
median() { sort -g | awk '{ a[NR] = $1 } END { if (NR % 2) print a[(NR + 1) / 2]; else print (a[NR / 2] + a[NR / 2 + 1]) / 2 }'; }

# One run: pl-localize with the given arguments, then the per-scan errors joined with the status and
# protection columns of its CSV (the KITTI output has one line per scan, as the ground truth given)
# in $rates_out/NAME.scans; no output.
localize() {
  local name=$1 gt=$2
  shift 2
  local out
  out=$(scans_stem "$name")
  "$bin/pl-localize" --dataset "$rates_drive" --db "${db:-$rates_db}" --map "$rates_map" --beams 16 --scans odd --odometry lidar \
    --init gt --out "$out.tum" --kitti-out "$out.txt" --timing "$out.csv" "$@" >"$out.log"
  scan_rows "$out.txt" "$gt" "$out.csv" >"$out.scans"
}

# Per scan of a KITTI pose file EST against GT, joined with pl-localize's timing CSV: 3-D error,
# protection level, milliseconds (odometry + registration + checks), status, horizontal error.
# (Lines of a pose file's header, "# ...", are not poses: r counts a file's other lines.)
scan_rows() {
  awk '
    FNR == 1 { file++; r = 0 }
    /^#/ { next }
    { r++ }
    file == 1 { ex[r] = $4; ey[r] = $8; ez[r] = $12; n = r; next }
    file == 2 { gx[r] = $4; gy[r] = $8; gz[r] = $12; next }
    { split($0, f, ",") }
    r == 1 { for (i = 1; i in f; i++) col[f[i]] = i; next }
    { k = r - 1; h = (ex[k] - gx[k]) ^ 2 + (ey[k] - gy[k]) ^ 2
      printf "%.4f %s %s %s %.4f\n", sqrt(h + (ez[k] - gz[k]) ^ 2), f[col["protection_m"]], f[col["registration_ms"]] + f[col["odometry_ms"]] + f[col["integrity_ms"]], f[col["status"]],
        sqrt(h) }' "$1" "$2" "$3"
}

# Where run NAME's files go (spaces and commas out of the name).
scans_stem() {
  local out="$rates_out/$1"
  out=${out// /_}
  echo "${out//,/}"
}

# The table row of the named runs' scans taken together: summarize LABEL NAME...
summarize() {
  local label=$1 all
  shift
  all=$(for name in "$@"; do cat "$(scans_stem "$name").scans"; done)
  local summary
  summary=$(awk '{ n++; s += $1; if ($1 > m) m = $1; if ($1 > 0.5) { far++; if ($4 == "ok") lie++ }
                   if ($5 > $2) v++; ok += $4 == "ok"; dg += $4 == "degraded"; ls += $4 == "lost" }
                 END { printf "%d | %.3f | %%s | %.2f | %d | %d | %d / %d / %d | %.1f %%%%", n, s / n, m, far, lie, ok, dg, ls, 100 * v / n }' <<<"$all")
  printf "| %s | $summary | %.2f | %.1f |\n" "$label" "$(cut -d' ' -f1 <<<"$all" | median)" "$(cut -d' ' -f2 <<<"$all" | median)" \
    "$(cut -d' ' -f3 <<<"$all" | median)"
}

# localize, then its row.
run() {
  localize "$@"
  summarize "$1" "$1"
}

# Every k-th scan is k drives interleaved in the recording: each phase from its own first scan's
# pose, their scans summed into one row. rate_phases LABEL K GT_ALL [pl-localize flags...]
rate_phases() {
  local label=$1 k=$2 gt_all=$3 names=() p
  shift 3
  for ((p = 0; p < k; p++)); do
    awk -v k="$k" -v p="$p" '(NR - 1) % k == p' "$gt_all" >"$rates_out/gt_${k}_$p.txt"
    localize "$label, phase $p" "$rates_out/gt_${k}_$p.txt" --every "$k" --phase "$p" "$@"
    names+=("$label, phase $p")
  done
  if ((k > 1)); then label="$label, phases 0-$((k - 1))"; fi
  summarize "$label" "${names[@]}"
}

