#!/usr/bin/env python3
"""The overlay's error against generated truth, at the frame's own capture time and at display time.

Reads a `dentar live --record DIR` recording of generated footage (`dentar synth`, truth.jsonl), or a
`dentar offline --out DIR` folder (every frame, not paced; its frames.csv man_tx_mm.. columns):
per frame, the tooth as drawn (the drawn mannequin pose with the truth's T_man_tooth) against
  - the truth of the image it was drawn on (the footage frame: what the video shows), and
  - the truth at display time: the footage's poses interpolated at the frame's time + LATENCY_MS
    (the run's capture-to-swap latency, e.g. its summary's p50).
The error is the mean image distance (px, pinhole) of eight points on a 10 mm box around the tooth
(its outline's extent), p50 / p95 / max over the frames with a drawn tooth.

usage: tools/predict_error.py RUN_DIR TRUTH_JSONL LATENCY_MS [--name NAME] [--predict-ms MS]
(--predict-ms: the prediction the run used, for the table; a live recording's recording.json says it)
Prints one Markdown table row. Exit 2 on bad input.
"""
import csv, json, math, os, sys


def fail(msg):
    print("predict_error: " + msg, file=sys.stderr)
    sys.exit(2)


def mat4(v):
    return [v[0:4], v[4:8], v[8:12], v[12:16] if len(v) >= 16 else [0.0, 0.0, 0.0, 1.0]]


def mul(a, b):
    return [[sum(a[i][k] * b[k][j] for k in range(4)) for j in range(4)] for i in range(4)]


def inv(t):
    r = [[t[j][i] for j in range(3)] for i in range(3)]
    p = [-sum(r[i][k] * t[k][3] for k in range(3)) for i in range(3)]
    return [r[0] + [p[0]], r[1] + [p[1]], r[2] + [p[2]], [0.0, 0.0, 0.0, 1.0]]


def apply(t, x):
    return [sum(t[i][k] * x[k] for k in range(3)) + t[i][3] for i in range(3)]


def pct(v, q):
    v = sorted(v)
    return v[min(len(v) - 1, int(q * len(v)))] if v else float("nan")


def main(argv):
    if len(argv) < 4:
        fail("usage: tools/predict_error.py RUN_DIR TRUTH_JSONL LATENCY_MS [--name NAME] [--predict-ms MS]")
    rdir, truth_path, lat_ms = argv[1], argv[2], float(argv[3])
    name = argv[argv.index("--name") + 1] if "--name" in argv else rdir
    try:
        truth = [json.loads(l) for l in open(truth_path) if l.strip()]
        rows = list(csv.DictReader(open(rdir + "/frames.csv")))
        live = os.path.exists(rdir + "/recording.json")
        meta = json.load(open(rdir + "/recording.json")) if live else {}
        station = json.load(open(rdir + "/station.json" if live else os.path.dirname(truth_path) + "/station.json"))
    except (OSError, ValueError) as e:
        fail(str(e))
    if "--predict-ms" in argv:
        meta["predict_ms"] = float(argv[argv.index("--predict-ms") + 1])
    if not truth or "T_cam_man" not in truth[0] or "T_cam_tooth" not in truth[0]:
        fail(truth_path + ": needs T_cam_man and T_cam_tooth per frame (dentar synth truth.jsonl)")
    cam = station["camera"]
    fx, fy, cx, cy = cam["fx"], cam["fy"], cam["cx"], cam["cy"]
    T_man_tooth = mul(inv(mat4(truth[0]["T_cam_man"])), mat4(truth[0]["T_cam_tooth"]))
    h = 5e-3
    box = [[sx * h, sy * h, sz * h] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)]
    dt = truth[1]["time_s"] - truth[0]["time_s"] if len(truth) > 1 else 1 / 30

    def project(T_cam_tooth):
        out = []
        for p in box:
            x = apply(T_cam_tooth, p)
            if x[2] <= 1e-6:
                return None
            out.append((fx * x[0] / x[2] + cx, fy * x[1] / x[2] + cy))
        return out

    def truth_px(t):  # the box's image points at footage time t (linear between frames)
        k = t / dt
        i = max(0, min(len(truth) - 2, int(math.floor(k))))
        a = min(1.0, max(0.0, k - i))
        pa, pb = project(mat4(truth[i]["T_cam_tooth"])), project(mat4(truth[i + 1]["T_cam_tooth"]))
        if pa is None or pb is None:
            return None
        return [((1 - a) * u0 + a * u1, (1 - a) * v0 + a * v1) for (u0, v0), (u1, v1) in zip(pa, pb)]

    def dist(p, q):
        return sum(math.hypot(a[0] - b[0], a[1] - b[1]) for a, b in zip(p, q)) / len(p)

    at_image, at_display, moved = [], [], []
    for r in rows:
        if r["man_state"] == "lost":
            continue
        if r.get("man_T"):
            m = [float(x) for x in r["man_T"].split()]
            if len(m) < 12:
                fail(rdir + "/frames.csv: man_T must hold 12 numbers (3x4 row-major)")
            T = mat4(m)
        elif r.get("man_tx_mm"):
            w, x, y, z = (float(r[k]) for k in ("man_qw", "man_qx", "man_qy", "man_qz"))
            t = [float(r[k]) * 1e-3 for k in ("man_tx_mm", "man_ty_mm", "man_tz_mm")]
            T = [[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w), t[0]],
                 [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w), t[1]],
                 [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y), t[2]], [0.0, 0.0, 0.0, 1.0]]
        else:
            continue
        i = int(round(float(r["time_s"]) / dt))  # the footage frame (its time; live source_index counts deliveries)
        drawn = project(mul(T, T_man_tooth))
        if drawn is None or i < 0 or i >= len(truth):
            continue
        t_img = truth[i]["time_s"]
        ti, td = truth_px(t_img), truth_px(t_img + lat_ms * 1e-3)
        if ti is None or td is None:
            continue
        at_image.append(dist(drawn, ti))
        at_display.append(dist(drawn, td))
        moved.append(dist(ti, td))
    if not at_image:
        fail(rdir + ": no frame with a drawn tooth and truth")
    f = lambda v: f"{pct(v, 0.5):.2f} / {pct(v, 0.95):.2f} / {max(v):.2f}"
    print(f"| {name} | {meta.get('predict_ms', 0):.1f} | {lat_ms:.1f} | {len(at_image)} | {f(at_image)} | {f(at_display)} | {f(moved)} |")


if __name__ == "__main__":
    main(sys.argv)
