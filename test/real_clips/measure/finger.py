"""tendon_finger_bending: signed bend of the finger = tip direction - base direction (image angles, atan2(dy, dx) with
y down, in degrees; positive = the tip points more downward than the base, i.e. the finger curls down/clockwise on
screen). Base direction = principal axis of the dark pixels (grey < DARK) of the first black bar (on the base link),
tip direction = the same for the third (last) bar; each bar's box follows its NCC track (track_bar1.txt,
track_bar3.txt, templates cut by hand from frame 0 of the half-scale dump). Frames are the half-scale dump
(960x540); angles do not depend on the scale. usage: finger.py [DARK=70]"""
import sys
import numpy as np
from common import frame, n_frames
C = "tendon_finger_bending"
dark = float(sys.argv[1]) if len(sys.argv) > 1 else 70
b1 = np.loadtxt(f"/tmp/clips/{C}/track_bar1.txt"); b3 = np.loadtxt(f"/tmp/clips/{C}/track_bar3.txt")


def axis_angle(g, cx, cy, hw, hh, a0):
    """Bar axis: dark pixels in the box, kept only within BAND px of the current line estimate (start: through the
    box centre at angle a0) and within the bar's half-length hw along it; principal axis; 4 iterations."""
    x0, y0 = int(round(cx - hw)), int(round(cy - hh))
    sub = g[y0:y0 + 2 * hh + 1, x0:x0 + 2 * hw + 1]
    ys, xs = np.nonzero(sub < dark)
    xs, ys = xs + x0, ys + y0
    px, py, a = cx, cy, np.radians(a0)
    for _ in range(4):
        d = np.array([np.cos(a), np.sin(a)])
        along = (xs - px) * d[0] + (ys - py) * d[1]
        across = -(xs - px) * d[1] + (ys - py) * d[0]
        k = (np.abs(across) < 4) & (np.abs(along) < hw)
        if k.sum() < 30:
            return np.nan, int(k.sum())
        X = np.stack([xs[k] - xs[k].mean(), ys[k] - ys[k].mean()])
        w, v = np.linalg.eigh(X @ X.T)
        e = v[:, 1] if v[0, 1] > 0 else -v[:, 1]     # point the axis to the right (towards the tip)
        px, py, a = xs[k].mean(), ys[k].mean(), np.arctan2(e[1], e[0])
    return np.degrees(a), int(k.sum())


out = []
for i in range(n_frames(C)):
    g = frame(C, i).mean(-1)
    a1, n1 = axis_angle(g, b1[i, 2], b1[i, 3], 30, 12, 12.0)
    a3, n3 = axis_angle(g, b3[i, 2], b3[i, 3], 30, 24, 28.0)
    out.append((i, i / 30, a1, a3, a3 - a1, n1, n3))
out = np.array(out)
np.savetxt(f"/tmp/clips/{C}/bend.txt", out, fmt="%.3f", header="i t base_deg tip_deg bend_deg n_base n_tip")
for r in out[::15]:
    print(f"frame {int(r[0])} t {r[1]:.2f}: base {r[2]:6.2f} tip {r[3]:6.2f} bend {r[4]:6.2f}  ({int(r[5])}, {int(r[6])} px)")
