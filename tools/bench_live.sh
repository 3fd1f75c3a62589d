#!/usr/bin/env bash
# Live-trainer benchmarks (docs/BENCHMARKS.md, "live"): runs `dentar live` on
# generated footage paced as a 30 fps camera, under Xvfb, and prints one
# table row per configuration from each run's summary JSON.
#
#   tools/bench_live.sh table [SECONDS]        latency / fps vs resolution, occlusion, mirror
#   tools/bench_live.sh engine [SECONDS]       engine timing with/without isolation, with/without stress
#   tools/bench_live.sh memory [SECONDS]       RSS growth over a long run
#   tools/bench_live.sh rehearsal [SECONDS]    issue 26: each footage suggested for a camera-free try
#   tools/bench_live.sh discovery [SECONDS]    720p: tag discovery inline vs async; background threads' CPU
#   tools/bench_live.sh display [SECONDS]      720p: CPU display path vs GPU (GL-resident) path, alternating
#                                              runs of the same binary (PAIRS pairs, default 2)
#
# Environment: BUILD_DIR (default build), OUT (default out/bench_live).
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
bin="${BUILD_DIR:-$root/build}/dentar"
out="${OUT:-$root/out/bench_live}"
mode="${1:-table}"
secs="${2:-30}"
mkdir -p "$out"

# The stand-in camera plays Motion JPEG, as UVC webcams deliver 720p: the
# generator's lossless FFV1 takes ~47 ms a 720p frame to decode, more than a
# 30 fps camera's whole frame period on one core (Debian's ffmpeg transcodes).
clip() {  # clip W H -> folder with camera.avi (MJPG), station.json, session.dlog
  local d="$out/clip_${1}x${2}"
  if [[ ! -f "$d/session.dlog" ]]; then
    "$bin" synth --preset standard --frames 150 --resolution "${1}x${2}" --seed 5 --out "$d" >/dev/null
  fi
  if [[ ! -f "$d/camera.avi" ]]; then
    ffmpeg -loglevel error -y -i "$d/video.mkv" -c:v mjpeg -q:v 3 "$d/camera.avi"
  fi
  echo "$d"
}

run() {  # run NAME CLIP [live options...] -> prints a table row
  local name="$1" c="$2"; shift 2
  xvfb-run -a -s '-screen 0 1920x1200x24' "$bin" live --camera "live:$c/camera.avi" --station "$c/station.json" \
    --loop --seconds "$secs" --quiet --summary "$out/$name.json" "$@" >/dev/null
  python3 - "$out/$name.json" "$name" <<'PY'
import json, sys
s = json.load(open(sys.argv[1])); e = s["engine"]; f = s["frames"]
mins = s["wall_s"] / 60
print(f"| {sys.argv[2]} | {s['latency_ms']['p50']:.1f} | {s['latency_ms']['p99']:.1f} | {s['displayed_fps']:.1f} | "
      f"{f['dropped_source']} / {f['dropped_consumer']} | {s['process_ms']['p50']:.1f} / {s['process_ms']['p99']:.1f} | "
      f"{e['step_us']['p999']:.0f} / {e['step_us']['max']:.0f} | {e['missed_deadlines']/mins:.2f} | {e['watchdog_trips']} | "
      f"{s['rss_mb']['growth_after_10s']:.1f} |")
PY
}

run_cam() {  # run_cam NAME CAMERA_FILE STATION [live options...]: any footage, any station
  local name="$1" cam="$2" st="$3"; shift 3
  xvfb-run -a -s '-screen 0 1920x1200x24' "$bin" live --camera "live:$cam" --station "$st" \
    --loop --seconds "$secs" --quiet --summary "$out/$name.json" "$@" >/dev/null
  python3 - "$out/$name.json" "$name" <<'PY'
import json, sys
s = json.load(open(sys.argv[1])); e = s["engine"]; f = s["frames"]
mins = s["wall_s"] / 60
print(f"| {sys.argv[2]} | {s['latency_ms']['p50']:.1f} | {s['latency_ms']['p99']:.1f} | {s['displayed_fps']:.1f} | "
      f"{f['dropped_source']} / {f['dropped_consumer']} | {s['process_ms']['p50']:.1f} / {s['process_ms']['p99']:.1f} | "
      f"{e['step_us']['p999']:.0f} / {e['step_us']['max']:.0f} | {e['missed_deadlines']/mins:.2f} | {e['watchdog_trips']} | "
      f"{s['rss_mb']['growth_after_10s']:.1f} |")
PY
}

header() {
  echo "| run | latency p50 ms | p99 ms | displayed fps | dropped source / consumer | frame p50 / p99 ms | engine step p99.9 / max us | missed deadlines /min | watchdog trips | RSS growth after 10 s, MB |"
  echo "|---|---|---|---|---|---|---|---|---|---|"
}

case "$mode" in
  table)
    c480=$(clip 640 480); c720=$(clip 1280 720)
    header
    run "640x480 full" "$c480" --stylus replay:"$c480/session.dlog"
    run "1280x720 full" "$c720" --stylus replay:"$c720/session.dlog"
    run "1280x720 no mirror" "$c720" --stylus replay:"$c720/session.dlog" --no-mirror
    run "1280x720 no occlusion" "$c720" --stylus replay:"$c720/session.dlog" --no-occlusion --no-segmentation
    run "1280x720 no hud" "$c720" --stylus replay:"$c720/session.dlog" --no-hud
    ;;
  engine)
    c720=$(clip 1280 720)
    header
    run "isolated" "$c720" --stylus sim
    run "not isolated" "$c720" --stylus sim --engine-cpu -1 --no-realtime
    command -v stress >/dev/null || { echo "stress not installed (apt install stress)"; exit 1; }
    stress --cpu 2 --timeout "$((secs + 20))" >/dev/null 2>&1 & sp=$!
    sleep 1
    run "isolated + stress" "$c720" --stylus sim
    run "not isolated + stress" "$c720" --stylus sim --engine-cpu -1 --no-realtime
    kill "$sp" 2>/dev/null || true; wait "$sp" 2>/dev/null || true
    ;;
  discovery)
    c720=$(clip 1280 720)
    header
    run "720p inline, background with frame thread" "$c720" --stylus replay:"$c720/session.dlog" --discovery inline --background-cpu others
    run "720p async, background with frame thread" "$c720" --stylus replay:"$c720/session.dlog" --background-cpu others
    run "720p async, background on engine CPU (default)" "$c720" --stylus replay:"$c720/session.dlog"
    run "720p default, sim hand cutting" "$c720" --stylus sim
    ;;
  display)
    c720=$(clip 1280 720)
    header
    for i in $(seq 1 "${PAIRS:-2}"); do
      for p in cpu gl; do
        run "720p $p path, run $i" "$c720" --stylus replay:"$c720/session.dlog" --display-path "$p"
        # The path that really ran (gl falls back to cpu when it must), and its CPU traffic.
        python3 -c 'import json,sys; d=json.load(open(sys.argv[1]))["display"]; print("   display:", d["path"], "readback_px", d["readback_px"], "cpu_blend_px", d["cpu_blend_px"], "replaced", d["gl_frames_replaced"], d["note"])' "$out/720p $p path, run $i.json" >&2
      done
    done
    ;;
  rehearsal)
    # Issue 26: every footage the program suggests for trying `dentar live` without a camera
    # (the no-camera message, `dentar live --help`, the README), made as suggested, and the
    # old suggestion (the lossless video.mkv) for comparison.
    r="$out/rehearsal"; mkdir -p "$r"; n="${REHEARSAL_FRAMES:-300}"  # played with --loop
    [[ -f "$r/clip/camera.avi" ]] || "$bin" synth --frames "$n" --resolution 1280x720 --webcam --out "$r/clip" >/dev/null
    [[ -f "$r/box/camera.avi" ]] || "$bin" synth --station box --frames "$n" --resolution 1280x720 --webcam --out "$r/box" >/dev/null
    [[ -f "$r/clip480/video.mkv" ]] || "$bin" synth --frames "$n" --out "$r/clip480" >/dev/null
    header
    run_cam "720p camera.avi (MJPG), as README, --help and the no-camera message suggest" "$r/clip/camera.avi" "$r/clip/station.json" \
      --stylus replay:"$r/clip/session.dlog"
    run_cam "box: 720p camera.avi, --station box (built-in, cropped intrinsics), replay" "$r/box/camera.avi" box \
      --stylus replay:"$r/box/session.dlog" --no-occlusion
    run_cam "box: 720p camera.avi, --station box, --stylus sim" "$r/box/camera.avi" box --stylus sim --no-occlusion
    run_cam "before: 720p video.mkv (FFV1)" "$r/clip/video.mkv" "$r/clip/station.json" --stylus replay:"$r/clip/session.dlog"
    run_cam "before: 640x480 video.mkv (FFV1, synth's default size)" "$r/clip480/video.mkv" "$r/clip480/station.json" \
      --stylus replay:"$r/clip480/session.dlog"
    ;;
  memory)
    c720=$(clip 1280 720)
    header
    run "memory ${secs}s" "$c720" --stylus sim
    ;;
  *) echo "usage: tools/bench_live.sh table|engine|memory|discovery|display|rehearsal [SECONDS]" >&2; exit 2 ;;
esac
