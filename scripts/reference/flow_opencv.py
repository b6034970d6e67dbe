#!/usr/bin/env python3
"""OpenCV reference flows for decompose::video::flow (issue 20, step 3).

Needs OpenCV with the contrib modules (cv2.optflow):
    pip install --user opencv-contrib-python-headless      # measured with 5.1.0.95

Two modes.

1. Fixtures (default): reads OpenCV's sample video `vtest.avi` (Debian package `opencv-doc`,
   /usr/share/doc/opencv-doc/examples/data/vtest.avi; `apt-get download opencv-doc` and
   `dpkg-deb -x` it if the package is not installed), cuts the PAIRS below (two consecutive
   frames, one crop around walking people each), and writes to fixtures/video/flow/:
   - `<name>_prev.png`, `<name>_next.png`: the RGB crops, lossless from the decoded frames;
   - `opencv_reference.json`: per pair, OpenCV's DualTVL1 flow (configured like the IPOL
     defaults our solver uses: tau 0.25, lambda 0.15, theta 0.3, 5 scales of ratio 0.5, 5 warps,
     epsilon 0.01, up to 300 iterations per warp as 10 outer x 30 inner, no median filter)
     sampled on a grid (every STRIDE-th pixel from OFFSET, to 0.01 px: the full flow would
     exceed the fixture budget), the mean u and v over the whole crop of it and of DIS flow
     (preset MEDIUM), and the mean endpoint error on the grid between DIS and DualTVL1 (how
     much two good methods disagree on this pair) and between the zero flow and DualTVL1.
   Both methods see the grey image decompose computes (`video::flow::grey`): the sRGB-encoded
   Rec. 709 luminance of the linearised frame (DualTVL1 as float in [0, 1], DIS rounded to
   8 bits, which it requires). Flow convention as ours: next(x + u, y + v) ~ prev(x, y).

2. Speed: `flow_opencv.py --speed DIR` times OpenCV on DIR/prev.png and DIR/next.png written
   by `cargo run --release -p decompose --example flow_speed -- DIR` (800x600, true flow
   (3.3, -1.7)) with 2 OpenCV threads and prints the median wall time of 3 runs, the mean CPU
   time (all threads) and the mean endpoint error on the interior (16 px border), for the
   ratio against the example's table.

Usage (from the workspace root):
    python3 scripts/reference/flow_opencv.py [PATH/TO/vtest.avi]
    python3 scripts/reference/flow_opencv.py --speed /tmp/flow_speed
"""

import datetime
import json
import pathlib
import sys
import time

import cv2
import numpy as np

ROOT = pathlib.Path(__file__).resolve().parents[2]
OUT = ROOT / "fixtures" / "video" / "flow"
DEFAULT_VIDEO = "/usr/share/doc/opencv-doc/examples/data/vtest.avi"

# (name, first frame index, x, y, width, height): crops around walking people.
PAIRS = [
    ("vtest_100_group", 100, 330, 150, 160, 128),
    ("vtest_100_walkers", 100, 470, 120, 160, 128),
    ("vtest_400_people", 400, None, None, 160, 128),
]
STRIDE = 4
OFFSET = 2
SPEED_SHIFT = (3.3, -1.7)


def srgb_to_linear(v):
    return np.where(v <= 0.04045, v / 12.92, ((v + 0.055) / 1.055) ** 2.4)


def linear_to_srgb(v):
    v = np.clip(v, 0.0, 1.0)
    return np.where(v <= 0.0031308, v * 12.92, 1.055 * v ** (1.0 / 2.4) - 0.055)


def grey(rgb8):
    """decompose's flow input: sRGB-encoded luminance of the linearised RGB, in [0, 1]."""
    lin = srgb_to_linear(rgb8.astype(np.float64) / 255.0)
    y = 0.2126 * lin[..., 0] + 0.7152 * lin[..., 1] + 0.0722 * lin[..., 2]
    return linear_to_srgb(y).astype(np.float32)


def tvl1():
    f = cv2.optflow.DualTVL1OpticalFlow_create(
        tau=0.25,
        lambda_=0.15,
        theta=0.3,
        nscales=5,
        warps=5,
        epsilon=0.01,
        innnerIterations=30,
        outerIterations=10,
        scaleStep=0.5,
        gamma=0.0,
        medianFiltering=1,
        useInitialFlow=False,
    )
    return f


def dis():
    return cv2.DISOpticalFlow_create(cv2.DISOPTICAL_FLOW_PRESET_MEDIUM)


def run_tvl1(g0, g1):
    return tvl1().calc(g0, g1, None)


def run_dis(g0, g1):
    q = lambda g: np.clip(np.round(g * 255.0), 0, 255).astype(np.uint8)
    return dis().calc(q(g0), q(g1), None)


def epe(a, b):
    return float(np.mean(np.hypot(a[..., 0] - b[..., 0], a[..., 1] - b[..., 1])))


def read_frames(video, indices):
    cap = cv2.VideoCapture(str(video))
    if not cap.isOpened():
        sys.exit(f"cannot open {video}")
    frames, i = {}, 0
    last = max(indices)
    while i <= last:
        ok, bgr = cap.read()
        if not ok:
            sys.exit(f"{video} ends before frame {last}")
        if i in indices:
            frames[i] = cv2.cvtColor(bgr, cv2.COLOR_BGR2RGB)
        i += 1
    return frames


def busiest_crop(f0, f1, w, h):
    """The crop with the largest temporal change (a window around moving people)."""
    d = np.abs(grey(f1).astype(np.float64) - grey(f0))
    integral = cv2.integral(d)
    best, pos = -1.0, (0, 0)
    for y in range(0, d.shape[0] - h, 8):
        for x in range(0, d.shape[1] - w, 8):
            s = integral[y + h, x + w] - integral[y, x + w] - integral[y + h, x] + integral[y, x]
            if s > best:
                best, pos = s, (x, y)
    return pos


def fixtures(video):
    cv2.setNumThreads(1)
    OUT.mkdir(parents=True, exist_ok=True)
    indices = {p[1] for p in PAIRS} | {p[1] + 1 for p in PAIRS}
    frames = read_frames(video, indices)
    out = {
        "provenance": {
            "script": "scripts/reference/flow_opencv.py",
            "opencv": cv2.__version__,
            "numpy": np.__version__,
            "date": datetime.date.today().isoformat(),
            "video": "vtest.avi from OpenCV's samples/data (Debian opencv-doc 4.6.0+dfsg-12)",
            "tvl1": "cv2.optflow.DualTVL1OpticalFlow_create(tau=0.25, lambda_=0.15, theta=0.3, "
            "nscales=5, warps=5, epsilon=0.01, innnerIterations=30, outerIterations=10, "
            "scaleStep=0.5, gamma=0, medianFiltering=1) on float grey in [0, 1]",
            "dis": "cv2.DISOpticalFlow_create(DISOPTICAL_FLOW_PRESET_MEDIUM) on 8-bit grey",
            "grey": "sRGB-encoded Rec. 709 luminance of the linearised RGB (decompose's)",
            "convention": "next(x + u, y + v) ~ prev(x, y); grid samples at pixel "
            "(OFFSET + STRIDE*i, OFFSET + STRIDE*j), row-major, rounded to 0.01 px",
        },
        "stride": STRIDE,
        "offset": OFFSET,
        "pairs": [],
    }
    for name, k, x, y, w, h in PAIRS:
        f0, f1 = frames[k], frames[k + 1]
        if x is None:
            x, y = busiest_crop(f0, f1, w, h)
        c0, c1 = f0[y : y + h, x : x + w], f1[y : y + h, x : x + w]
        cv2.imwrite(str(OUT / f"{name}_prev.png"), cv2.cvtColor(c0, cv2.COLOR_RGB2BGR))
        cv2.imwrite(str(OUT / f"{name}_next.png"), cv2.cvtColor(c1, cv2.COLOR_RGB2BGR))
        g0, g1 = grey(c0), grey(c1)
        ft, fd = run_tvl1(g0, g1), run_dis(g0, g1)
        grid = (slice(OFFSET, None, STRIDE), slice(OFFSET, None, STRIDE))
        gt, gd = ft[grid], fd[grid]
        rnd = lambda a: [round(float(v), 2) for v in a.ravel()]
        mag = np.hypot(gt[..., 0], gt[..., 1])
        out["pairs"].append(
            {
                "name": name,
                "frames": [k, k + 1],
                "crop": {"x": int(x), "y": int(y), "width": w, "height": h},
                "grid": {"width": int(gt.shape[1]), "height": int(gt.shape[0])},
                "tvl1": {
                    "mean_u": float(ft[..., 0].mean()),
                    "mean_v": float(ft[..., 1].mean()),
                    "u": rnd(gt[..., 0]),
                    "v": rnd(gt[..., 1]),
                },
                "dis": {
                    "mean_u": float(fd[..., 0].mean()),
                    "mean_v": float(fd[..., 1].mean()),
                },
                "epe_dis_vs_tvl1_grid": epe(gd, gt),
                "epe_zero_vs_tvl1_grid": float(mag.mean()),
                "max_tvl1_magnitude_grid": float(mag.max()),
            }
        )
        p = out["pairs"][-1]
        print(
            f"{name}: crop ({x}, {y}) {w}x{h}, TV-L1 mean ({p['tvl1']['mean_u']:.3f}, "
            f"{p['tvl1']['mean_v']:.3f}), max |flow| {p['max_tvl1_magnitude_grid']:.2f}, "
            f"EPE DIS vs TV-L1 {p['epe_dis_vs_tvl1_grid']:.3f}, "
            f"zero vs TV-L1 {p['epe_zero_vs_tvl1_grid']:.3f}"
        )
    path = OUT / "opencv_reference.json"
    path.write_text(json.dumps(out, separators=(",", ":")) + "\n")
    print(f"wrote {path} ({path.stat().st_size} bytes)")


def speed(folder):
    cv2.setNumThreads(2)
    folder = pathlib.Path(folder)
    g = []
    for n in ("prev", "next"):
        img = cv2.imread(str(folder / f"{n}.png"), cv2.IMREAD_GRAYSCALE)
        if img is None:
            sys.exit(f"cannot read {folder / n}.png: run the flow_speed example first")
        g.append(img)
    truth = np.empty(g[0].shape + (2,), np.float32)
    truth[..., 0], truth[..., 1] = SPEED_SHIFT
    b = 16
    print(f"{g[0].shape[1]}x{g[0].shape[0]}, OpenCV {cv2.__version__}, {cv2.getNumThreads()} threads")
    print(f"{'method':<28} {'wall s':>8} {'CPU s':>8} {'mean EPE':>9}")
    cases = [
        ("DualTVL1, IPOL-like params", lambda: tvl1().calc(g[0], g[1], None)),
        ("DualTVL1, OpenCV defaults", lambda: cv2.optflow.DualTVL1OpticalFlow_create().calc(g[0], g[1], None)),
        ("DIS preset MEDIUM", lambda: dis().calc(g[0], g[1], None)),
        ("DIS preset FAST", lambda: cv2.DISOpticalFlow_create(cv2.DISOPTICAL_FLOW_PRESET_FAST).calc(g[0], g[1], None)),
    ]
    for name, f in cases:
        times, flow = [], None
        cpu = time.process_time()
        for _ in range(3):
            t = time.perf_counter()
            flow = f()
            times.append(time.perf_counter() - t)
        cpu = (time.process_time() - cpu) / 3
        e = epe(flow[b:-b, b:-b], truth[b:-b, b:-b])
        print(f"{name:<28} {sorted(times)[1]:8.3f} {cpu:8.2f} {e:9.4f}")


if __name__ == "__main__":
    args = sys.argv[1:]
    if args and args[0] == "--speed":
        speed(args[1] if len(args) > 1 else "/tmp/flow_speed")
    else:
        fixtures(args[0] if args else DEFAULT_VIDEO)
