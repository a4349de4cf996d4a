"""Colour-mask centroid tracker (independent of the project's tracker).
For each frame: OpenCV-convention HSV mask (common.hsv_mask), restricted to the ROI and to a square window of
half-size WIN around the previous position; position = centroid of the mask pixels in the window; also area and
the bounding box of those pixels. Writes /tmp/clips/<clip>/track_color.txt: i t_s x y area w h total_mask_in_roi xmid ymid wp hp
(x y = centroid; xmid ymid = middle of the row/column-profile extent wp x hp).
usage: track_color.py clip fps 'json-hsv-ranges' x0 y0 [win=40] [roi x,y,w,h] [step=1] [min_area=5]"""
import json, sys
import numpy as np
from common import frame, n_frames, rgb_to_hsv_cv, hsv_mask, ROOT

clip, fps, ranges = sys.argv[1], float(sys.argv[2]), json.loads(sys.argv[3])
x, y = float(sys.argv[4]), float(sys.argv[5])
win = int(sys.argv[6]) if len(sys.argv) > 6 else 40
roi = [int(v) for v in sys.argv[7].split(",")] if len(sys.argv) > 7 and sys.argv[7] != "-" else None
step = int(sys.argv[8]) if len(sys.argv) > 8 else 1
min_area = int(sys.argv[9]) if len(sys.argv) > 9 else 5
out = open(f"{ROOT}/{clip}/track_color.txt", "w")
for i in range(0, n_frames(clip), step):
    img = frame(clip, i)
    H, W = img.shape[:2]
    x0, x1 = max(0, int(x) - win), min(W, int(x) + win + 1)
    y0, y1 = max(0, int(y) - win), min(H, int(y) + win + 1)
    if roi:
        x0, y0 = max(x0, roi[0]), max(y0, roi[1]); x1, y1 = min(x1, roi[0] + roi[2]), min(y1, roi[1] + roi[3])
    full = hsv_mask(rgb_to_hsv_cv(img), ranges)
    if roi:
        full[:roi[1]] = False; full[roi[1] + roi[3]:] = False; full[:, :roi[0]] = False; full[:, roi[0] + roi[2]:] = False
    m = full[y0:y1, x0:x1]
    total = int(full.sum())  # mask pixels anywhere in the ROI (frame): checks that the range selects only the object
    ys, xs = np.nonzero(m)
    if len(xs) < min_area:
        out.write(f"{i} {i / fps:.4f} nan nan {len(xs)} 0 0 {total} nan nan 0 0\n"); continue
    x, y = xs.mean() + x0, ys.mean() + y0
    # extent from the row/column profiles (rows/columns holding >= 25 % of the fullest one): its middle is the
    # geometric centre, insensitive to shading that thins one side of the mask; its bottom is used at bounces
    rows, cols = m.sum(1), m.sum(0)
    r = np.nonzero(rows >= 0.25 * rows.max())[0]; c = np.nonzero(cols >= 0.25 * cols.max())[0]
    out.write(f"{i} {i / fps:.4f} {x:.2f} {y:.2f} {len(xs)} {xs.max() - xs.min() + 1} {ys.max() - ys.min() + 1} {total}"
              f" {(c[0] + c[-1]) / 2 + x0:.1f} {(r[0] + r[-1]) / 2 + y0:.1f} {c[-1] - c[0] + 1} {r[-1] - r[0] + 1}\n")
out.close()
