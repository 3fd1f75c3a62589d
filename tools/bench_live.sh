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
# Issue 28 (docs/BENCHMARKS.md "Issue 28 session 16"); add --stress to run `stress --cpu 2` beside:
#   tools/bench_live.sh latency [SECONDS] [--stress]  stereo 2x1280x720 and 2x640x480 (two paced cameras;
#                                              2x640x480 also as one side-by-side camera), mono 1920x1080:
#                                              DentAR (occlusion and mirror on) against the bare passthrough
#                                              viewer (dentar live --passthrough) on the same footage
#   tools/bench_live.sh engine5 [SECONDS] [--stress]  the engine during the stereo live path (2x1280x720,
#                                              simulated hand cutting), default 300 s
#   tools/bench_live.sh memory5 [SECONDS]      RSS over a stereo live run (default 600 s): growth after 60 s
#   tools/bench_live.sh eyes [SECONDS]         issue 28 session 17: stereo 2x640x480 into the headset (HEADSET=),
#                                              the right eye on its own thread against the frame thread, alternating
#                                              and the window's rasteriser allowed on any CPU (PAIRS, default 3;
#                                              OLD_BIN=another build as a fourth arm)
#   tools/bench_live.sh warp [SECONDS]         issue 28 session 18: stereo 2x640x480 (two cameras) into the headset
#                                              (HEADSET=), the pre-warp pass full (sessions 15-17) / exact (default) /
#                                              mesh, DentAR and the bare passthrough viewer, alternating (PAIRS, default 2)
#   tools/bench_live.sh idle [SECONDS]         issue 28 session 19: stereo into the headset (HEADSET=), the window
#                                              redrawn at every wake without a new frame (--idle-redraw-ms 0) against
#                                              the default (HUD at 10 Hz), alternating (PAIRS, default 2); CPU per frame
#   tools/bench_live.sh decode [SECONDS]       issue 28 session 20: stereo 2x1280x720 into the headset (HEADSET=),
#                                              Motion JPEG decoded for every frame against on demand, alternating
#                                              (PAIRS, default 2); CPU and decodes per frame shown
#   tools/bench_live.sh yuyv [SECONDS]         session 21 (session 20's A/B, then DENTAR_KEEP_YUYV=0|1): stereo
#                                              2x1280x720 side by side into the headset (HEADSET=), CPU display path,
#                                              --cpu-display-yuyv keep (default) against convert, alternating
#                                              (PAIRS, default 2); CPU per frame shown and capture to swap
#   tools/bench_live.sh wake [SECONDS]         the engine with the CPUs' wake-up latency held (default) and
#                                              not (--cpu-wake-latency-us -1), GL and CPU display paths,
#                                              alternating (PAIRS pairs, default 2)
#   tools/bench_live.sh machine [SECONDS] [--stress]  session 18: the machine's own wake-up misses, the
#                                              engine's rival: cyclictest (Debian package rt-tests) on the
#                                              engine's CPU at its priority and period (SCHED_FIFO 80, 1 ms),
#                                              nothing else of ours running; a wake-up > 1 ms late is what the
#                                              engine counts as a missed deadline
#
# Environment: BUILD_DIR (default build), OUT (default out/bench_live), HEADSET (a headset profile:
# latency's stereo rows drive --output sbs with it). Nothing is installed: without
# `stress` (Debian package stress) the --stress rows are left out and the script says so.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
bin="${BUILD_DIR:-$root/build}/dentar"
out="${OUT:-$root/out/bench_live}"
mode="${1:-table}"
stress_on=0
args=()
for a in "${@:2}"; do
  if [[ "$a" == "--stress" ]]; then stress_on=1; else args+=("$a"); fi
done
case "$mode" in engine5) dflt=300 ;; memory5) dflt=600 ;; *) dflt=30 ;; esac
secs="${args[0]:-$dflt}"
mkdir -p "$out"

# The stand-in camera plays Motion JPEG, as UVC webcams deliver 720p: the
# generator's lossless FFV1 takes ~47 ms a 720p frame to decode, more than a
# 30 fps camera's whole frame period on one core (synth --webcam writes it).
clip() {  # clip W H -> folder with camera.avi (MJPG), station.json, session.dlog
  local d="$out/clip_${1}x${2}"
  if [[ ! -f "$d/session.dlog" || ! -f "$d/camera.avi" ]]; then
    "$bin" synth --preset standard --frames 150 --resolution "${1}x${2}" --seed 5 --webcam --out "$d" >/dev/null
  fi
  echo "$d"
}

# Stereo footage, each eye W x H: camera.avi side by side (one device, --stereo),
# camera_left.avi and camera_right.avi (two cameras, --camera-right), the rig in station.json.
clip_stereo() {
  local d="$out/clip_stereo_${1}x${2}"
  if [[ ! -f "$d/session.dlog" || ! -f "$d/camera_right.avi" ]]; then
    "$bin" synth --preset standard --stereo --frames 150 --resolution "${1}x${2}" --seed 5 --webcam --out "$d" >/dev/null
  fi
  echo "$d"
}

stress_pid=""
start_stress() {  # start_stress SECONDS: `stress --cpu 2` for that long (0 when missing)
  if ! command -v stress >/dev/null; then
    echo "stress is not installed (Debian package stress: apt install stress): the --stress rows are left out" >&2
    return 1
  fi
  stress --cpu 2 --timeout "$1" >/dev/null 2>&1 & stress_pid=$!
  sleep 1
}
stop_stress() { [[ -n "$stress_pid" ]] && { kill "$stress_pid" 2>/dev/null || true; wait "$stress_pid" 2>/dev/null || true; }; stress_pid=""; }
trap stop_stress EXIT

# One run's summary as JSON lines for the tables below: live NAME [live options...]
live_json() {
  local name="$1"; shift
  xvfb-run -a -s '-screen 0 1920x1200x24' "$bin" live --loop --seconds "$secs" --quiet --summary "$out/$name.json" "$@" >/dev/null
}

# Issue 28 latency: DentAR against the bare passthrough viewer on the same footage.
latency_pair() {  # latency_pair NAME CLIP_DIR [camera options...]
  local name="$1" c="$2"; shift 2
  live_json "$name, dentar" --station "$c/station.json" --stylus replay:"$c/session.dlog" "$@"
  live_json "$name, passthrough" --station "$c/station.json" --stylus none --no-hud --passthrough "$@"
  python3 - "$out/$name, dentar.json" "$out/$name, passthrough.json" "$name" <<'PY'
import json, sys
a = json.load(open(sys.argv[1])); p = json.load(open(sys.argv[2])); e = a["engine"]
def drops(s):
    f = s["frames"]; r = s.get("stereo", {}).get("right_eye_dropped")
    return f"{f['dropped_source']} / {f['dropped_consumer']}" + (f" / {r}" if r is not None else "")
mins = a["wall_s"] / 60
la, lp = a["latency_ms"], p["latency_ms"]
def stale(s):  # issue 28 session 17: two cameras' pairs skipped for a newer one, and the eye threads
    st = s.get("stereo")
    return "-" if st is None or "stale_pairs_skipped" not in st else f"{st['stale_pairs_skipped']} ({st['eye_threads']})"
def stages(s):  # where the latency goes (summary stages_ms), p50 ms
    g = s.get("stages_ms", {})
    names = ["pickup", "pair_wait", "track", "compose_left", "compose_right", "process_cpu", "to_display", "display"]
    return " / ".join(f"{g[n]['p50']:.1f}" if n in g else "-" for n in names)
print(f"| {sys.argv[3]} | {la['p50']:.1f} / {la['p99']:.1f} | {lp['p50']:.1f} / {lp['p99']:.1f} | "
      f"{la['p50'] - lp['p50']:+.1f} / {la['p99'] - lp['p99']:+.1f} | {a['displayed_fps']:.1f} / {p['displayed_fps']:.1f} | "
      f"{drops(a)} | {drops(p)} | {a['process_ms']['p50']:.1f} / {a['process_ms']['p99']:.1f} | "
      f"{e['step_us']['p999']:.0f} | {e['missed_deadlines'] / mins:.1f} | {e['watchdog_trips']} | {stale(a)} | {stages(a)} |")
PY
}
latency_header() {
  echo "| run | DentAR capture to swap p50 / p99 ms | passthrough p50 / p99 ms | DentAR adds p50 / p99 ms | fps DentAR / passthrough | dropped source / consumer (/ right eye), DentAR | same, passthrough | frame p50 / p99 ms | engine step p99.9 us | missed deadlines /min | watchdog trips | stale pairs skipped (eye threads) | p50 ms: pickup / pair wait / track / compose L / compose R / frame CPU / to display / display |"
  echo "|---|---|---|---|---|---|---|---|---|---|---|---|---|"
}
latency_rows() {  # latency_rows SUFFIX
  local s2_720 s2_480 m1080
  s2_720=$(clip_stereo 1280 720); s2_480=$(clip_stereo 640 480); m1080=$(clip 1920 1080)
  # HEADSET=profile.json: the stereo rows drive the side-by-side headset view (each eye its own
  # composite), as a student wearing the headset sees it; without it the mono window.
  local -a hs=()
  [[ -n "${HEADSET:-}" ]] && hs=(--output sbs --headset "$HEADSET")
  latency_pair "stereo 2x1280x720, two cameras$1" "$s2_720" --camera live:"$s2_720/camera_left.avi" --camera-right live:"$s2_720/camera_right.avi" "${hs[@]}"
  latency_pair "stereo 2x640x480, two cameras$1" "$s2_480" --camera live:"$s2_480/camera_left.avi" --camera-right live:"$s2_480/camera_right.avi" "${hs[@]}"
  latency_pair "stereo 2x640x480, side by side$1" "$s2_480" --camera live:"$s2_480/camera.avi" --stereo "${hs[@]}"
  latency_pair "mono 1920x1080$1" "$m1080" --camera live:"$m1080/camera.avi"
}

# Issue 28 engine goals: p99.9 step <= 200 us, <= 1 missed deadline a minute, 0 watchdog trips.
engine_row() {  # engine_row NAME [live options...]
  local name="$1"; shift
  local c; c=$(clip_stereo 1280 720)
  live_json "$name" --station "$c/station.json" --camera live:"$c/camera_left.avi" --camera-right live:"$c/camera_right.avi" --stylus sim "$@"
  python3 - "$out/$name.json" "$name" <<'PY'
import json, sys
s = json.load(open(sys.argv[1])); e = s["engine"]; u = e["step_us"]; w = e.get("wake_latency", {})
mins = s["wall_s"] / 60
print(f"| {sys.argv[2]} | {s['wall_s']:.0f} | {u['p50']:.0f} / {u['p99']:.0f} / {u['p999']:.0f} / {u['max']:.0f} | {e['missed_deadlines']} | "
      f"{e['missed_deadlines'] / mins:.2f} | {e['watchdog_trips']} | {e['jitter_us']['p99']:.0f} / {e['jitter_us']['max']:.0f} | "
      f"{w.get('held', '-')} | {w.get('cpu_halts_per_s', -1):.0f} | {s['latency_ms']['p50']:.1f} / {s['latency_ms']['p99']:.1f} | "
      f"{s['displayed_fps']:.1f} | {s['removed_mm3']['total']:.2f} | skipped periods {e.get('periods_skipped', '-')} |")
# Session 17: the late wake-ups attributed (engine.wake, docs/formats.md), one row per run.
a = e.get("wake", {})
if a.get("available"):
    causes = ["step", "host", "our_thread", "other_task", "irq", "unexplained"]
    fmt = lambda k: " / ".join(str(a[k].get(c, 0)) for c in causes)
    print(f"| {sys.argv[2]}: attributed | late {a['late']} (dropped {a['dropped']}) | missed {fmt('missed_by')} | "
          f"trips {fmt('trips_by')} | steal {a['cpu_steal_ms']:.0f} ms on CPU {a['engine_cpu']} | irq {a['cpu_irq_ms']:.0f} ms | "
          f"engine run-queue wait {a['engine_wait_ms']:.1f} ms | others on CPU {a['cpu_others_run_ms']:.0f} ms | "
          f"worst {', '.join('%.1f ms %s' % (x['late_ms'], x['cause']) for x in a['worst'][:3])} | | | |")
elif a:
    print(f"| {sys.argv[2]}: not attributed: {a.get('note', '')} |||||||||||")
PY
}
engine_header() {
  echo "Each run's second row: late wake-ups, missed deadlines and trips by cause, step / host / our_thread / other_task / irq / unexplained (docs/formats.md engine.wake)."
  echo
  echo "| run | s | step p50 / p99 / p99.9 / max us | missed deadlines | per minute | watchdog trips | wake-up lateness p99 / max us | wake latency held | engine CPU halts /s | latency p50 / p99 ms | fps | removed mm3 |"
  echo "|---|---|---|---|---|---|---|---|---|---|---|---|"
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
  latency)
    latency_header
    latency_rows ""
    if [[ $stress_on == 1 ]] && start_stress "$((8 * (secs + 40)))"; then
      latency_rows " + stress"
      stop_stress
    fi
    ;;
  engine5)
    engine_header
    engine_row "stereo 2x1280x720, sim hand"
    if [[ $stress_on == 1 ]] && start_stress "$((secs + 60))"; then
      engine_row "stereo 2x1280x720, sim hand + stress"
      stop_stress
    fi
    ;;
  warp)
    # Issue 28 session 18: the headset's pre-warp pass (--warp-pass), the same footage and
    # binary, the arms one after another in each round; the display stage (take to swap) is
    # where the pass's cost shows.
    [[ -n "${HEADSET:-}" ]] || { echo "warp needs HEADSET=a headset profile (assets/headsets/...)" >&2; exit 2; }
    c=$(clip_stereo 640 480)
    latency_header
    for i in $(seq 1 "${PAIRS:-2}"); do
      for w in full exact mesh; do
        latency_pair "stereo 2x640x480, two cameras, warp $w, run $i" "$c" --camera live:"$c/camera_left.avi" \
          --camera-right live:"$c/camera_right.avi" --output sbs --headset "$HEADSET" --warp-pass "$w"
      done
    done
    ;;
  idle)
    # Issue 28 session 19: the window's redraw without a new frame, every wake (--idle-redraw-ms 0,
    # sessions 13-18) against the HUD's 10 Hz (default), the same binary and footage, alternating:
    # stereo 2x1280x720 (two cameras and one side-by-side camera) and 2x640x480 (two cameras),
    # into the headset view (HEADSET=). Latency, and the summary's CPU per frame shown (cpu, ms).
    [[ -n "${HEADSET:-}" ]] || { echo "idle needs HEADSET=a headset profile (assets/headsets/...)" >&2; exit 2; }
    s720=$(clip_stereo 1280 720); s480=$(clip_stereo 640 480)
    echo "| run | capture to swap p50 / p99 ms | fps | dropped source / consumer | CPU ms a frame shown: process / main (display) / window+headless rasterisers / frame / right eye / capture L+R | idle draws / skipped | display stage p50 ms |"
    echo "|---|---|---|---|---|---|---|"
    for i in $(seq 1 "${PAIRS:-2}"); do
      for w in 0 100; do
        for row in "2x1280x720 two cameras|$s720|--camera live:$s720/camera_left.avi --camera-right live:$s720/camera_right.avi" \
                   "2x1280x720 side by side|$s720|--camera live:$s720/camera.avi --stereo" \
                   "2x640x480 two cameras|$s480|--camera live:$s480/camera_left.avi --camera-right live:$s480/camera_right.avi"; do
          IFS='|' read -r rn c cam <<<"$row"
          n="$rn, idle redraw $w ms, run $i"
          # shellcheck disable=SC2086
          live_json "$n" --station "$c/station.json" --stylus replay:"$c/session.dlog" $cam --output sbs \
            --headset "$HEADSET" --idle-redraw-ms "$w"
          python3 - "$out/$n.json" "$n" <<'PY'
import json, sys
s = json.load(open(sys.argv[1])); f = s["frames"]; d = s["display"]; c = s.get("cpu", {}); t = c.get("threads_ms_per_frame", {})
main = sum(v for k, v in t.items() if k == "dentar" or (k.startswith("dentar_") and "disk" not in k))
g = lambda k: t.get(k, 0.0)
print(f"| {sys.argv[2]} | {s['latency_ms']['p50']:.1f} / {s['latency_ms']['p99']:.1f} | {s['displayed_fps']:.1f} | "
      f"{f['dropped_source']} / {f['dropped_consumer']} | {c.get('process_ms_per_frame', 0):.1f} / {main:.1f} / {g('llvmpipe-0'):.1f} / "
      f"{g('dentar-frame'):.1f} / {g('dentar-eye-r'):.1f} / {g('dentar-cap-l') + g('dentar-cap-r'):.1f} | "
      f"{d.get('idle_draws', '-')} / {d.get('idle_skipped', '-')} | {s['stages_ms'].get('display', {}).get('p50', 0):.1f} |")
PY
        done
      done
    done
    ;;
  decode)
    # Issue 28 session 20: Motion JPEG decoded for every captured frame (--jpeg-decode every-frame,
    # sessions 18-19) against only the frames the frame thread takes (on-demand); session 21: eager
    # (the newest packet decoded on the capture side once the previous one was taken). The same
    # binary and footage, alternating (MODES=, default all three): stereo 2x1280x720 two cameras and
    # side by side into the headset view (HEADSET=), and mono 1920x1080 (ROWS=: two, sbs, mono).
    # CPU per frame shown (summary cpu), decodes per frame shown, the frame thread's pickup.
    [[ -n "${HEADSET:-}" ]] || { echo "decode needs HEADSET=a headset profile (assets/headsets/...)" >&2; exit 2; }
    s720=$(clip_stereo 1280 720); m1080=$(clip 1920 1080)
    echo "| run | fps shown | CPU ms a frame shown: process / capture L+R / frame / right eye | decodes a frame shown L + R | skipped undecoded L / R | dropped source / consumer / right eye | stale pairs skipped / untaken | frames left eye only / both | corrupt JPEG | pickup p50 / p99 ms | capture to swap p50 / p99 ms |"
    echo "|---|---|---|---|---|---|---|---|---|---|---|"
    for i in $(seq 1 "${PAIRS:-2}"); do
      for m in ${MODES:-every-frame on-demand eager}; do
        for row in "2x1280x720 two cameras|$s720|two|--camera live:$s720/camera_left.avi --camera-right live:$s720/camera_right.avi --output sbs --headset $HEADSET" \
                   "2x1280x720 side by side|$s720|sbs|--camera live:$s720/camera.avi --stereo --output sbs --headset $HEADSET" \
                   "mono 1920x1080|$m1080|mono|--camera live:$m1080/camera.avi"; do
          IFS='|' read -r rn c key cam <<<"$row"
          [[ " ${ROWS:-two sbs mono} " == *" $key "* ]] || continue
          n="$rn, decode $m, run $i"
          # shellcheck disable=SC2086
          live_json "$n" --station "$c/station.json" --stylus replay:"$c/session.dlog" $cam --jpeg-decode "$m"
          python3 - "$out/$n.json" "$n" <<'PY'
import json, sys
s = json.load(open(sys.argv[1])); f = s["frames"]; st = s.get("stereo", {}); c = s.get("cpu", {}); t = c.get("threads_ms_per_frame", {})
g = lambda k: t.get(k, 0.0)
dl, dr = f.get("jpeg_decodes", 0), st.get("right_eye_jpeg_decodes", 0)
shown = max(1, f["displayed"])
pk = s["stages_ms"].get("pickup", {})
print(f"| {sys.argv[2]} | {s['displayed_fps']:.1f} | {c.get('process_ms_per_frame', 0):.1f} / "
      f"{g('dentar-cap-l') + g('dentar-cap-r'):.1f} / {g('dentar-frame'):.1f} / {g('dentar-eye-r'):.1f} | "
      f"{(dl + dr) / shown:.2f} = {dl / shown:.2f} + {dr / shown:.2f} ({dl} + {dr} / {f['displayed']}) | "
      f"{f.get('jpeg_skipped_undecoded', '-')} / {st.get('right_eye_jpeg_skipped_undecoded', '-')} | "
      f"{f['dropped_source']} / {f['dropped_consumer']} / {st.get('right_eye_dropped', '-')} | "
      f"{st.get('stale_pairs_skipped', '-')} / {st.get('stale_pairs_untaken', '-')} | "
      f"{st.get('frames_left_eye_only', '-')} / {st.get('frames_both_eyes', '-')} | {f.get('corrupt_jpeg', 0)} | "
      f"{pk.get('p50', 0):.1f} / {pk.get('p99', 0):.1f} | {s['latency_ms']['p50']:.1f} / {s['latency_ms']['p99']:.1f} |")
PY
        done
      done
    done
    ;;
  yuyv)
    # Session 20 measured this A/B with the environment switch DENTAR_KEEP_YUYV=0|1; since session 21
    # it is the option --cpu-display-yuyv keep|convert (the variable is gone).
    [[ -n "${HEADSET:-}" ]] || { echo "yuyv needs HEADSET=a headset profile (assets/headsets/...)" >&2; exit 2; }
    s720=$(clip_stereo 1280 720)
    echo "| run | fps shown | CPU ms a frame shown: process / frame | capture to swap p50 / p99 ms | dropped source / consumer |"
    echo "|---|---|---|---|---|"
    for i in $(seq 1 "${PAIRS:-2}"); do
      for m in keep convert; do
        n="2x1280x720 side by side, cpu-display-yuyv $m, run $i"
        live_json "$n" --station "$s720/station.json" --stylus replay:"$s720/session.dlog" --camera live:"$s720/camera.avi" \
          --stereo --output sbs --headset "$HEADSET" --display-path cpu --cpu-display-yuyv "$m"
        python3 - "$out/$n.json" "$n" <<'PY'
import json, sys
s = json.load(open(sys.argv[1])); f = s["frames"]; c = s.get("cpu", {}); t = c.get("threads_ms_per_frame", {})
print(f"| {sys.argv[2]} | {s['displayed_fps']:.1f} | {c.get('process_ms_per_frame', 0):.1f} / {t.get('dentar-frame', 0):.1f} | "
      f"{s['latency_ms']['p50']:.1f} / {s['latency_ms']['p99']:.1f} | {f['dropped_source']} / {f['dropped_consumer']} |")
PY
      done
    done
    ;;
  wake)
    c720=$(clip 1280 720)
    engine_header
    for i in $(seq 1 "${PAIRS:-2}"); do
      for p in gl cpu; do
        for w in 0 -1; do
          n="720p $p path, wake latency $( [[ $w == 0 ]] && echo held || echo "not held"), run $i"
          live_json "$n" --station "$c720/station.json" --camera live:"$c720/camera.avi" --stylus replay:"$c720/session.dlog" \
            --display-path "$p" --cpu-wake-latency-us "$w"
          python3 - "$out/$n.json" "$n" <<'PY'
import json, sys
s = json.load(open(sys.argv[1])); e = s["engine"]; u = e["step_us"]; w = e["wake_latency"]
mins = s["wall_s"] / 60
print(f"| {sys.argv[2]} | {s['wall_s']:.0f} | {u['p50']:.0f} / {u['p99']:.0f} / {u['p999']:.0f} / {u['max']:.0f} | {e['missed_deadlines']} | "
      f"{e['missed_deadlines'] / mins:.2f} | {e['watchdog_trips']} | {e['jitter_us']['p99']:.0f} / {e['jitter_us']['max']:.0f} | "
      f"{w['held']} | {w['cpu_halts_per_s']:.0f} | {s['latency_ms']['p50']:.1f} / {s['latency_ms']['p99']:.1f} | "
      f"{s['displayed_fps']:.1f} | {s['removed_mm3']['total']:.2f} |")
PY
        done
      done
    done
    ;;
  memory5)
    c=$(clip_stereo 1280 720)
    echo "| run | s | RSS at 60 s MB | largest RSS after 60 s MB | growth MB | at the end (threads joined) MB | frames processed | fps |"
    echo "|---|---|---|---|---|---|---|---|"
    live_json "memory stereo" --station "$c/station.json" --camera live:"$c/camera_left.avi" --camera-right live:"$c/camera_right.avi" --stylus sim
    python3 - "$out/memory stereo.json" <<'PY'
import json, sys
s = json.load(open(sys.argv[1])); r = s["rss_mb"]
g = r["max_after_60s"] - r["after_60s"] if r["after_60s"] > 0 else float("nan")
print(f"| stereo 2x1280x720, sim hand | {s['wall_s']:.0f} | {r['after_60s']:.1f} | {r['max_after_60s']:.1f} | **{g:+.1f}** | "
      f"{r['end']:.1f} | {s['frames']['processed']} | {s['displayed_fps']:.1f} |")
PY
    ;;
  eyes)
    # Issue 28 session 17: stereo 2x640x480 (two cameras) into the headset (HEADSET=profile), the
    # right eye on its own thread (--eye-threads 2, the default) against both eyes on the frame
    # thread (--eye-threads 1), and with the window's rasteriser (the pre-warp) allowed beside the
    # engine (--window-raster-cpu any), alternating PAIRS times (default 3); OLD_BIN=another dentar adds
    # a fourth arm (e.g. a build before the change, run with its defaults).
    [[ -n "${HEADSET:-}" ]] || { echo "eyes needs HEADSET=a headset profile (assets/headsets/...)" >&2; exit 2; }
    c=$(clip_stereo 640 480)
    echo "| run | capture to swap p50 / p99 ms | fps | dropped source / consumer / right eye | frame p50 / p99 ms | stale pairs skipped (eye threads) | p50 ms: pickup / pair wait / track / compose L / compose R / frame CPU / to display / display | engine step p99.9 us | missed deadlines /min | watchdog trips |"
    echo "|---|---|---|---|---|---|---|---|---|---|"
    eyes_row() {  # eyes_row NAME BIN [live options...]
      local name="$1" b="$2"; shift 2
      xvfb-run -a -s '-screen 0 1920x1200x24' "$b" live --loop --seconds "$secs" --quiet --summary "$out/$name.json" \
        --station "$c/station.json" --stylus replay:"$c/session.dlog" --camera live:"$c/camera_left.avi" \
        --camera-right live:"$c/camera_right.avi" --output sbs --headset "$HEADSET" "$@" >/dev/null
      python3 - "$out/$name.json" "$name" <<'PY'
import json, sys
s = json.load(open(sys.argv[1])); e = s["engine"]; f = s["frames"]; st = s.get("stereo", {}); g = s.get("stages_ms", {})
mins = s["wall_s"] / 60
names = ["pickup", "pair_wait", "track", "compose_left", "compose_right", "process_cpu", "to_display", "display"]
stg = " / ".join(f"{g[n]['p50']:.1f}" if n in g else "-" for n in names)
stale = f"{st['stale_pairs_skipped']} ({st['eye_threads']})" if "stale_pairs_skipped" in st else "-"
print(f"| {sys.argv[2]} | {s['latency_ms']['p50']:.1f} / {s['latency_ms']['p99']:.1f} | {s['displayed_fps']:.1f} | "
      f"{f['dropped_source']} / {f['dropped_consumer']} / {st.get('right_eye_dropped', '-')} | "
      f"{s['process_ms']['p50']:.1f} / {s['process_ms']['p99']:.1f} | {stale} | {stg} | {e['step_us']['p999']:.0f} | "
      f"{e['missed_deadlines'] / mins:.1f} | {e['watchdog_trips']} |")
PY
    }
    for i in $(seq 1 "${PAIRS:-3}"); do
      eyes_row "eyes 1, run $i" "$bin" --eye-threads 1
      eyes_row "eyes 2 (default), run $i" "$bin"
      eyes_row "eyes 2, window raster any, run $i" "$bin" --window-raster-cpu any
      [[ -n "${OLD_BIN:-}" ]] && eyes_row "old build, run $i" "$OLD_BIN"
    done
    ;;
  machine)
    command -v cyclictest >/dev/null || { echo "cyclictest is not installed (Debian package rt-tests: apt install rt-tests)" >&2; exit 1; }
    cpu=$(($(nproc) - 1))  # the engine's default CPU: the last one
    machine_row() {  # machine_row NAME: cyclictest for secs on the engine's CPU, histogram in us
      mkdir -p "$out"
      cyclictest -m -q -p 80 -a "$cpu" -t 1 -i 1000 -D "${secs}s" -h 20000 > "$out/$1.cyclictest" 2>&1 || true
      python3 - "$out/$1.cyclictest" "$1" "$secs" <<'PY'
import sys
hist, over, mx, n = {}, 0, 0, 0
for line in open(sys.argv[1]):
    p = line.split()
    if len(p) == 2 and p[0].isdigit():
        hist[int(p[0])] = int(p[1]); n += int(p[1])
    elif line.startswith("# Histogram Overflows:"):
        over = int(p[3])
    elif line.startswith("# Max Latencies:"):
        mx = int(p[3])
if n == 0:
    print(f"| {sys.argv[2]} | cyclictest gave no histogram: see {sys.argv[1]} |"); sys.exit(0)
late = lambda us: sum(c for k, c in hist.items() if k > us) + over
def pct(q):
    acc = 0
    for k in sorted(hist):
        acc += hist[k]
        if acc >= q * (n + over): return k
    return mx
mins = float(sys.argv[3]) / 60
print(f"| {sys.argv[2]} | {sys.argv[3]} | {n + over} | {pct(0.5)} / {pct(0.99)} / {pct(0.999)} / {mx} | "
      f"{late(200)} | {late(1000)} | {late(1000) / mins:.2f} | {late(3000)} |")
PY
    }
    echo "| run | s | wake-ups | latency p50 / p99 / p99.9 / max us | > 200 us | > 1 ms (a missed deadline) | per minute | > 3 ms |"
    echo "|---|---|---|---|---|---|---|---|"
    machine_row "cyclictest FIFO 80 on CPU $cpu, 1 ms"
    if [[ $stress_on == 1 ]] && start_stress "$((secs + 20))"; then
      machine_row "cyclictest FIFO 80 on CPU $cpu, 1 ms + stress"
      stop_stress
    fi
    ;;
  *) echo "usage: tools/bench_live.sh table|engine|memory|discovery|display|rehearsal|latency|engine5|memory5|warp|idle|decode|yuyv|wake|eyes|machine [SECONDS] [--stress]" >&2; exit 2 ;;
esac
