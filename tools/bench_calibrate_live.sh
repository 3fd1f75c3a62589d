#!/usr/bin/env bash
# The whole station through `dentar calibrate live` at human pace, driven by the simulated
# instructor, for a few seeds: per-step instructor time, the camera against the clip's truth,
# the static co-location (bur tip vs tooth, 500 working poses) and the end-to-end co-location
# with camera tracking (`dentar calibrate check --simulate` on a copy of the live station file:
# the generator's footage rendered with the same hidden truth, tracked with the live-calibrated
# camera). docs/BENCHMARKS.md, "the whole station live".
# Usage: tools/bench_calibrate_live.sh [BUILD_DIR] [OUT_DIR] [SEEDS...]   (default build, out/bench_cal_live, 3 4 5)
set -euo pipefail
BUILD=${1:-build}
OUT=${2:-out/bench_cal_live}
shift 2 2>/dev/null || true
SEEDS=("$@")
[ ${#SEEDS[@]} -eq 0 ] && SEEDS=(3 4 5)
DENTAR="$BUILD/dentar"
mkdir -p "$OUT"
run_seed() {
  local s=$1 d="$OUT/seed$1"
  mkdir -p "$d"
  rm -f "$d/station.json" "$d/station.camera.yaml" "$d/summary.json" "$d/check_station.json"
  # The clip is deterministic per seed: kept between runs.
  [ -f "$d/clip/clip.json" ] || "$DENTAR" synth --board aprilgrid:6x5:24:8 --holds 16 --seed "$s" --out "$d/clip" > "$d/synth.log" 2>&1
  xvfb-run -a -s '-screen 0 1280x1024x24' "$DENTAR" calibrate live --haptic sim --pace 1 --seed "$s" \
    --camera "live:$d/clip/video.mkv" --station "$d/station.json" --summary "$d/summary.json" --seconds 900 \
    > "$d/live.log" 2>&1
  cp "$d/station.json" "$d/check_station.json"
  "$DENTAR" calibrate check --simulate --seed "$s" --frames 30 --station "$d/check_station.json" > "$d/check.log" 2>&1 || true
}
# One seed at a time: the step times are the instructor's, and a starved window misses holds.
for s in "${SEEDS[@]}"; do run_seed "$s"; done
python3 - "$OUT" "${SEEDS[@]}" <<'PY'
import json, re, sys, statistics as st
out, seeds = sys.argv[1], sys.argv[2:]
steps = ["camera", "pivot", "register", "tooth", "mirror", "check"]
print("seed  " + "  ".join(f"{x:>8}" for x in steps) + "     total  camMax_px  static_mean/p99_mm  tracked_mean/max_mm")
allf, allstatic = [], []
for s in seeds:
    d = f"{out}/seed{s}"
    j = json.load(open(f"{d}/summary.json"))
    t = {x["step"]: x["seconds"] for x in j["steps"]}
    txt = open(f"{d}/check.log").read()
    fr = [float(m) for m in re.findall(r"bur tip error ([0-9.]+) mm", txt)]
    img = re.findall(r"in the image .*?: mean ([0-9.]+) px = ([0-9.]+) mm", txt)
    allf += fr
    tr = j["truth"]
    print(f"{s:>4}  " + "  ".join(f"{t.get(x, float('nan')):8.1f}" for x in steps) +
          f"  {j['total_s']:8.1f}  {tr['camera_max_error_px']:9.2f}  {tr['static_colocation_mean_mm']:.3f}/{tr['static_colocation_p99_mm']:.3f}" +
          (f"         {st.mean(fr):.3f}/{max(fr):.3f} ({len(fr)} frames)" if fr else "  (no tracked frames)") +
          (f"  image {img[0][0]} px = {img[0][1]} mm" if img else ""))
if allf:
    allf.sort()
    p99 = allf[min(len(allf) - 1, int(0.99 * (len(allf) - 1) + 0.999))]
    print(f"tracked co-location over {len(allf)} frames: mean {st.mean(allf):.3f} mm, median {st.median(allf):.3f}, p99 {p99:.3f} mm")
PY
