"""Background-median subtraction tracker (independent of the project's tracker).
Background = per-pixel median of every K-th frame (optionally only frames in [bg_t0, bg_t1]). Foreground = max channel
|frame - background| > THR, optionally AND an HSV gate (OpenCV convention). Position = centroid of the foreground
pixels inside a window of half-size WIN around the previous position (and inside the ROI).
Writes /tmp/clips/<clip>/track_bgsub.txt: i t_s x y area w h xmid ymid wp hp
(x y = centroid; xmid ymid = middle of the profile extent wp x hp, see below).
usage: track_bgsub.py clip fps x0 y0 --thr 40 --win 80 --roi x,y,w,h --hsv JSON --bgk 3 --bgrange i0,i1 --step 1 --min 30"""
import argparse, json
import numpy as np
from common import frame, n_frames, rgb_to_hsv_cv, hsv_mask, ROOT

ap = argparse.ArgumentParser()
ap.add_argument("clip"); ap.add_argument("fps", type=float); ap.add_argument("x", type=float); ap.add_argument("y", type=float)
ap.add_argument("--thr", type=float, default=40); ap.add_argument("--win", type=int, default=80)
ap.add_argument("--roi", default=None); ap.add_argument("--hsv", default=None); ap.add_argument("--bgk", type=int, default=3)
ap.add_argument("--bgrange", default=None); ap.add_argument("--step", type=int, default=1); ap.add_argument("--min", type=int, default=30)
ap.add_argument("--frames", default=None, help="i0,i1 range to track")
ap.add_argument("--out", default="track_bgsub.txt")
ap.add_argument("--predict", action="store_true", help="centre the window on previous + last velocity")
a = ap.parse_args()
N = n_frames(a.clip)
b0, b1 = (int(v) for v in a.bgrange.split(",")) if a.bgrange else (0, N)
bg = np.median(np.stack([frame(a.clip, i) for i in range(b0, b1, a.bgk)]), 0)
np.save(f"{ROOT}/{a.clip}/background.npy", bg)
roi = [int(v) for v in a.roi.split(",")] if a.roi else None
ranges = json.loads(a.hsv) if a.hsv else None
f0, f1 = (int(v) for v in a.frames.split(",")) if a.frames else (0, N)
x, y = a.x, a.y
vx = vy = 0.0
out = open(f"{ROOT}/{a.clip}/{a.out}", "w")
for i in range(f0, f1, a.step):
    img = frame(a.clip, i)
    H, W = img.shape[:2]
    cx, cy = (x + vx, y + vy) if a.predict else (x, y)
    x0, x1 = max(0, int(cx) - a.win), min(W, int(cx) + a.win + 1)
    y0, y1 = max(0, int(cy) - a.win), min(H, int(cy) + a.win + 1)
    if roi:
        x0, y0 = max(x0, roi[0]), max(y0, roi[1]); x1, y1 = min(x1, roi[0] + roi[2]), min(y1, roi[1] + roi[3])
    sub = img[y0:y1, x0:x1]
    m = np.abs(sub - bg[y0:y1, x0:x1]).max(-1) > a.thr
    if ranges:
        m &= hsv_mask(rgb_to_hsv_cv(sub), ranges)
    ys, xs = np.nonzero(m)
    if len(xs) < a.min:
        out.write(f"{i} {i / a.fps:.4f} nan nan {len(xs)} 0 0 nan nan 0 0\n"); continue
    vx, vy = xs.mean() + x0 - x, ys.mean() + y0 - y
    x, y = xs.mean() + x0, ys.mean() + y0
    # extent from the row/column profiles: rows (columns) holding >= 25 % of the fullest row's (column's) pixels;
    # the middle of that extent is the geometric centre, insensitive to shading that thins one side of the mask
    rows, cols = m.sum(1), m.sum(0)
    r = np.nonzero(rows >= 0.25 * rows.max())[0]; c = np.nonzero(cols >= 0.25 * cols.max())[0]
    xm, ym = (c[0] + c[-1]) / 2 + x0, (r[0] + r[-1]) / 2 + y0
    out.write(f"{i} {i / a.fps:.4f} {x:.2f} {y:.2f} {len(xs)} {xs.max() - xs.min() + 1} {ys.max() - ys.min() + 1}"
              f" {xm:.1f} {ym:.1f} {c[-1] - c[0] + 1} {r[-1] - r[0] + 1}\n")
out.close()
