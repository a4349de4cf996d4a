"""Pendulum features from a position track (i t x y ...): circle fit of the path -> pivot and length; angle about the
pivot (atan2(dx, dy), image y down, so positive = bob to the image right); damped-sine least squares of the angle ->
period, damping; amplitude = mean half peak-to-peak of the angle over the window (turning points by local extrema of
the sine-fit-smoothed angle, refined by a parabola through the 5 samples around each).
usage: pendulum.py track.txt t0 t1 [pivot_x pivot_y]   (pivot given -> no circle fit)"""
import sys
import numpy as np
sys.path.insert(0, __file__.rsplit("/", 1)[0])
from common import damped_sine_fit

d = np.loadtxt(sys.argv[1])
t0, t1 = float(sys.argv[2]), float(sys.argv[3])
d = d[(d[:, 1] >= t0) & (d[:, 1] <= t1) & np.isfinite(d[:, 2])]
t, x, y = d[:, 1], d[:, 2], d[:, 3]


def circle_fit(x, y):
    A = np.stack([x, y, np.ones_like(x)], 1)
    b = x ** 2 + y ** 2
    p, *_ = np.linalg.lstsq(A, b, rcond=None)
    xc, yc = p[0] / 2, p[1] / 2
    R = np.sqrt(p[2] + xc ** 2 + yc ** 2)
    for _ in range(50):  # geometric refinement (Gauss-Newton on distances)
        r = np.hypot(x - xc, y - yc)
        J = np.stack([-(x - xc) / r, -(y - yc) / r, -np.ones_like(r)], 1)
        s, *_ = np.linalg.lstsq(J, -(r - R), rcond=None)
        xc, yc, R = xc + s[0], yc + s[1], R + s[2]
    res = np.hypot(x - xc, y - yc) - R
    return xc, yc, R, res


if len(sys.argv) > 5:
    xc, yc = float(sys.argv[4]), float(sys.argv[5]); R = np.median(np.hypot(x - xc, y - yc))
    res = np.hypot(x - xc, y - yc) - R
else:
    xc, yc, R, res = circle_fit(x, y)
# bootstrap the pivot over halves of the data (independent segments) for a spread
print(f"pivot ({xc:.1f}, {yc:.1f}) length {R:.1f} px, radial residual rms {np.sqrt(np.mean(res**2)):.2f} px")
if len(sys.argv) <= 5:
    n = len(t)
    for a, b in ((0, n // 2), (n // 2, n), (0, n // 3), (n // 3, 2 * n // 3), (2 * n // 3, n)):
        if b - a > 10:
            xa, ya, Ra, _ = circle_fit(x[a:b], y[a:b])
            print(f"  pivot from samples {a}:{b}: ({xa:.1f}, {ya:.1f}) R {Ra:.1f}")
th = np.degrees(np.unwrap(np.arctan2(x - xc, y - yc)))
# coarse frequency from zero crossings of x
xm = x - np.mean(x)
zc = np.nonzero(np.diff(np.sign(xm)))[0]
f0 = (len(zc) - 1) / 2 / (t[zc[-1]] - t[zc[0]]) if len(zc) > 2 else 1.0
fit = damped_sine_fit(t - t[0], th, f0)
w = 2 * np.pi / fit["period"]
zeta = fit["gamma"] / np.sqrt(w ** 2 + fit["gamma"] ** 2)
print(f"angle fit: period {fit['period']:.4f} +- {fit['sd_period']:.4f} s, gamma {fit['gamma']:.4f} +- {fit['sd_gamma']:.4f} 1/s,"
      f" zeta {zeta:.5f}, amp0 {fit['amp0']:.2f} deg, resid rms {fit['resid_rms']:.3f} deg, n={len(t)}")
# turning points: local extrema of the raw angle, refined by a parabola through +-2 samples
ext = []
for k in range(2, len(th) - 2):
    seg = th[k - 2:k + 3]
    if (seg[2] == seg.max() or seg[2] == seg.min()) and np.ptp(seg) > 0:
        c = np.polyfit(t[k - 2:k + 3] - t[k], seg, 2)
        if c[0] != 0:
            tt = -c[1] / (2 * c[0]); ext.append((t[k] + tt, np.polyval(c, tt), 1 if c[0] < 0 else -1))
# keep alternating extrema separated by > period/4
clean = []
for e in ext:
    if clean and e[2] == clean[-1][2]:
        if (e[2] > 0 and e[1] > clean[-1][1]) or (e[2] < 0 and e[1] < clean[-1][1]):
            clean[-1] = e
        continue
    if clean and e[0] - clean[-1][0] < fit["period"] / 4:
        continue
    clean.append(e)
te = np.array([e[0] for e in clean]); ve = np.array([e[1] for e in clean])
print("turning points (t, deg):", " ".join(f"({a:.3f},{b:.2f})" for a, b in zip(te, ve)))
hp = np.abs(np.diff(ve)) / 2
print(f"half peak-to-peak per half swing: mean {hp.mean():.3f} deg, first {hp[0]:.3f}, last {hp[-1]:.3f}, sd {hp.std():.3f}")
hp_px = np.abs(np.diff(np.interp(te, t, x))) / 2
print(f"half peak-to-peak of x at the turning points: mean {hp_px.mean():.1f} px")
if len(te) > 2:
    per = 2 * np.diff(te)
    print(f"period from turning points: mean {per.mean():.4f}, sd {per.std():.4f}, (last-first)/n {2*(te[-1]-te[0])/(len(te)-1):.4f}")
np.savetxt(sys.argv[1].replace(".txt", "_angle.txt"), np.stack([t, x, y, th], 1), fmt="%.4f")
