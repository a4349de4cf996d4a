"""Normalised cross-correlation tracker for a template cut by hand from one frame (independent of the project's
tracker). Grey = mean of RGB. The template (x,y,w,h in frame REF) is searched in a +-S px window around its previous
position in every frame; the best integer offset is refined by a parabola through the NCC peak and its neighbours.
Writes /tmp/clips/<clip>/<out>: i t_s x y ncc  (x, y = template centre).
usage: track_ncc.py clip fps ref x,y,w,h S out.txt [step]"""
import sys
import numpy as np
from common import frame, n_frames, ROOT

clip, fps, ref = sys.argv[1], float(sys.argv[2]), int(sys.argv[3])
tx, ty, tw, th = (int(v) for v in sys.argv[4].split(","))
S, outname = int(sys.argv[5]), sys.argv[6]
step = int(sys.argv[7]) if len(sys.argv) > 7 else 1
g = lambda i: frame(clip, i).mean(-1)
T = g(ref)[ty:ty + th, tx:tx + tw]
T = (T - T.mean()) / (T.std() * T.size)
px, py = tx, ty
out = open(f"{ROOT}/{clip}/{outname}", "w")
for i in range(0, n_frames(clip), step):
    G = g(i)
    H, W = G.shape
    best = None
    sc = np.full((2 * S + 1, 2 * S + 1), -1.0)
    for dy in range(-S, S + 1):
        for dx in range(-S, S + 1):
            x0, y0 = px + dx, py + dy
            if x0 < 0 or y0 < 0 or x0 + tw > W or y0 + th > H:
                continue
            P = G[y0:y0 + th, x0:x0 + tw]
            s = P.std()
            if s == 0:
                continue
            sc[dy + S, dx + S] = np.sum(T * (P - P.mean())) / s
    k = np.unravel_index(np.argmax(sc), sc.shape)
    c = sc[k]
    fx = fy = 0.0
    if 0 < k[1] < 2 * S:
        a, b, d = sc[k[0], k[1] - 1], c, sc[k[0], k[1] + 1]
        fx = 0.5 * (a - d) / (a - 2 * b + d) if (a - 2 * b + d) != 0 else 0
    if 0 < k[0] < 2 * S:
        a, b, d = sc[k[0] - 1, k[1]], c, sc[k[0] + 1, k[1]]
        fy = 0.5 * (a - d) / (a - 2 * b + d) if (a - 2 * b + d) != 0 else 0
    px, py = px + k[1] - S, py + k[0] - S
    out.write(f"{i} {i / fps:.4f} {px + fx + tw / 2:.2f} {py + fy + th / 2:.2f} {c:.3f}\n")
out.close()
