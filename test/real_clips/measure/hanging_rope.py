"""hanging_ball_rope_handheld: ball position relative to the hook (camera shake removed by the NCC track of the hook),
angle about the pivot (rope leaves the hook bracket at hook-template centre + (-3, +16) px, read by eye in frame 200),
left turning points (parabola through +-2 samples) and right extremes (wall contacts).
usage: hanging_rope.py   (reads track_color.txt and track_hook.txt of the clip)"""
import numpy as np
R = "/tmp/clips/hanging_ball_rope_handheld/"
b = np.loadtxt(R + "track_color.txt"); h = np.loadtxt(R + "track_hook.txt")
fps = 29.921
i = b[:, 0]; t = i / fps
px, py = h[:, 2] - 3, h[:, 3] + 16
dx, dy = b[:, 2] - px, b[:, 3] - py
ang = np.degrees(np.arctan2(dx, dy))          # + = ball to the image right of the pivot
L = np.hypot(dx, dy)
print(f"pivot (image) x {px.min():.1f}..{px.max():.1f}, y {py.min():.1f}..{py.max():.1f}; rope length {np.median(L):.1f} px "
      f"(5-95 %: {np.percentile(L, 5):.1f}..{np.percentile(L, 95):.1f})")
print(f"rest (frames 280-333): angle {ang[280:].mean():.2f} +- {ang[280:].std():.2f} deg")
left, right = [], []
sm = np.convolve(ang, np.ones(3) / 3, "same")   # 3-frame mean only to find the extremes; values from the raw angle
for k in range(10, len(t) - 2):
    seg = ang[k - 2:k + 3]
    if sm[k] == sm[k - 2:k + 3].min() and np.ptp(seg) > 0.1:
        c = np.polyfit(t[k - 2:k + 3] - t[k], seg, 2); tt = -c[1] / (2 * c[0])
        left.append((t[k] + tt, np.polyval(c, tt), k))
    if sm[k] == sm[k - 2:k + 3].max() and np.ptp(seg) > 0.1:
        k = k - 2 + int(np.argmax(seg))
        right.append((t[k], ang[k], k))
print("left turning points (t s, deg, frame):", " ".join(f"({a:.3f},{v:.1f},{k})" for a, v, k in left))
print("right extremes = wall contacts (t s, deg, frame):", " ".join(f"({a:.3f},{v:.1f},{k})" for a, v, k in right))
tl = np.array([a for a, _, _ in left])
print("intervals between left turning points (s):", " ".join(f"{v:.3f}" for v in np.diff(tl)))
np.savetxt(R + "rel_angle.txt", np.stack([i, t, dx, dy, ang], 1), fmt="%.3f")
