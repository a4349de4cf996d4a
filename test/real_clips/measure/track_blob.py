"""Small-blob tracker with constant-velocity prediction (independent of the project's tracker).
Candidates: pixels with grey - background > THR (background = per-pixel median of every 2nd frame in [b0, b1)) and
grey > GMIN (or grey < GMAX for a dark object, --dark), inside a window of half-size WIN round the predicted position
(previous + last velocity); connected components (4-neighbour) of AREA_MIN..AREA_MAX px; the one nearest the
prediction wins; position = its centroid. Writes /tmp/clips/<clip>/<out>: i t_s x y area ncand.
usage: track_blob.py clip fps x0 y0 --f0 i --f1 i --thr 40 --gmin 120 --win 40 --amin 10 --amax 300 --bg b0,b1 --out f"""
import argparse
import numpy as np
from common import frame, n_frames, label, ROOT

ap = argparse.ArgumentParser()
ap.add_argument("clip"); ap.add_argument("fps", type=float); ap.add_argument("x", type=float); ap.add_argument("y", type=float)
ap.add_argument("--f0", type=int, default=0); ap.add_argument("--f1", type=int, default=None)
ap.add_argument("--thr", type=float, default=40); ap.add_argument("--gmin", type=float, default=120)
ap.add_argument("--dark", action="store_true"); ap.add_argument("--win", type=int, default=40)
ap.add_argument("--amin", type=int, default=10); ap.add_argument("--amax", type=int, default=300)
ap.add_argument("--bg", default=None); ap.add_argument("--out", default="track_blob.txt")
ap.add_argument("--roi", default=None); ap.add_argument("--v0", default="0,0")
a = ap.parse_args()
N = n_frames(a.clip); f1 = a.f1 or N
b0, b1 = (int(v) for v in a.bg.split(",")) if a.bg else (0, N)
grey = lambda i: frame(a.clip, i).mean(-1)
bg = np.median(np.stack([grey(i) for i in range(b0, b1, 2)]), 0)
roi = [int(v) for v in a.roi.split(",")] if a.roi else None
x, y = a.x, a.y; vx, vy = (float(v) for v in a.v0.split(","))
out = open(f"{ROOT}/{a.clip}/{a.out}", "w")
for i in range(a.f0, f1):
    G = grey(i); H, W = G.shape
    px, py = x + vx, y + vy
    x0, x1 = max(0, int(px) - a.win), min(W, int(px) + a.win + 1)
    y0, y1 = max(0, int(py) - a.win), min(H, int(py) + a.win + 1)
    if roi:
        x0, y0 = max(x0, roi[0]), max(y0, roi[1]); x1, y1 = min(x1, roi[0] + roi[2]), min(y1, roi[1] + roi[3])
    g, b = G[y0:y1, x0:x1], bg[y0:y1, x0:x1]
    m = ((b - g) > a.thr) & (g < a.gmin) if a.dark else ((g - b) > a.thr) & (g > a.gmin)
    lab, n = label(m)
    best = None
    for k in range(1, n + 1):
        ys, xs = np.nonzero(lab == k)
        if a.amin <= len(xs) <= a.amax:
            cx, cy = xs.mean() + x0, ys.mean() + y0
            dd = np.hypot(cx - px, cy - py)
            if best is None or dd < best[0]:
                best = (dd, cx, cy, len(xs))
    if best is None:
        out.write(f"{i} {i / a.fps:.4f} nan nan 0 {n}\n"); vx *= 0.5; vy *= 0.5; continue
    _, cx, cy, ar = best
    vx, vy = cx - x, cy - y
    x, y = cx, cy
    out.write(f"{i} {i / a.fps:.4f} {x:.2f} {y:.2f} {ar} {n}\n")
out.close()
