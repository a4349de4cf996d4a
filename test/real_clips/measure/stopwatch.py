"""pendulum_green_bg_small_bob: reads the stopwatch's sweep hand (independent check of the time base). Red pixels
(R > 80, R - G > 40, R - B > 25, B - G > 8: crimson, not skin) in the dial annulus 18..55 px from the hub (hub found as the red blob centroid
within 10 px of the hand's pivot, read by eye at (955, 563) in frame 0) -> direction angle clockwise from 12 o'clock
-> seconds = angle / 6. usage: stopwatch.py [step=25]"""
import sys
import numpy as np
from common import frame, n_frames
step = int(sys.argv[1]) if len(sys.argv) > 1 else 25
cx, cy = 955.0, 563.0
rows = []
for i in range(0, n_frames("pendulum_green_bg_small_bob"), step):
    f = frame("pendulum_green_bg_small_bob", i)[cy.__int__() - 70:int(cy) + 70, int(cx) - 70:int(cx) + 70]
    r, g, b = f[..., 0], f[..., 1], f[..., 2]
    m = (r > 80) & (r - g > 40) & (r - b > 25) & (b - g > 8)   # crimson: B > G, unlike the skin of the thumb
    ys, xs = np.nonzero(m)
    dx, dy = xs - 70 + (int(cx) - cx), ys - 70 + (int(cy) - cy)
    d = np.hypot(dx, dy)
    hub = d < 10
    hx, hy = (dx[hub].mean(), dy[hub].mean()) if hub.sum() > 5 else (0.0, 0.0)
    # exclude the small sub-dial (its hub 24 px below the main hub) and take the modal direction (2-deg histogram,
    # then the mean of the pixels within 8 deg of the mode), so the lower sub-dial and dial marks do not pull it
    sel = (np.hypot(dx - hx, dy - hy) > 18) & (np.hypot(dx - hx, dy - hy) < 55) & (np.hypot(dx - hx, dy - hy - 24) > 16)
    if sel.sum() < 5:
        print(i, "no hand pixels"); continue
    a = np.degrees(np.arctan2(dx[sel] - hx, -(dy[sel] - hy))) % 360
    hist = np.bincount((a // 2).astype(int), minlength=180)
    mode = (np.argmax(np.convolve(np.r_[hist, hist[:4]], np.ones(5), "valid")[:180]) + 2) * 2 + 1
    near = np.abs((a - mode + 180) % 360 - 180) < 8
    ang = (mode + np.mean((a[near] - mode + 180) % 360 - 180)) % 360
    rows.append((i, ang / 6.0))
    print(f"frame {i}: hand at {ang:6.1f} deg = {ang/6:5.2f} s  ({sel.sum()} px)")
rows = np.array(rows)
ok = rows[:, 1] > 0.3
if ok.sum() > 2:
    c = np.polyfit(rows[ok, 0], rows[ok, 1], 1)
    print(f"stopwatch seconds per video frame: {c[0]:.5f} -> {1/c[0]:.2f} frames per real second (fit over frames with the hand off zero)")
