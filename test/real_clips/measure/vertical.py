"""Vertical oscillation features from a track (i t x y ...): damped-sine least squares of y(t) (common.damped_sine_fit,
with offset and linear drift), turning points (parabola through +-2 samples round each extreme of y), and the
logarithmic decrement of successive half peak-to-peak amplitudes. usage: vertical.py track.txt t0 t1"""
import sys
import numpy as np
sys.path.insert(0, __file__.rsplit("/", 1)[0])
from common import damped_sine_fit
d = np.loadtxt(sys.argv[1]); t0, t1 = float(sys.argv[2]), float(sys.argv[3])
d = d[(d[:, 1] >= t0) & (d[:, 1] <= t1) & np.isfinite(d[:, 3])]
t, y = d[:, 1], d[:, 3]
ym = y - y.mean(); zc = np.nonzero(np.diff(np.sign(ym)))[0]
f0 = (len(zc) - 1) / 2 / (t[zc[-1]] - t[zc[0]])
fit = damped_sine_fit(t - t[0], y, f0)
w = 2 * np.pi / fit["period"]
print(f"damped sine: period {fit['period']:.4f} +- {fit['sd_period']:.4f} s, gamma {fit['gamma']:.4f} +- {fit['sd_gamma']:.4f} 1/s, "
      f"zeta {fit['gamma']/np.hypot(w, fit['gamma']):.4f}, amplitude at t0 {fit['amp0']:.1f} px, rms {fit['resid_rms']:.2f} px, "
      f"equilibrium {fit['params'][0]:.1f} px (drift {fit['params'][1]:.2f} px/s)")
ext = []
for k in range(2, len(t) - 2):
    s = y[k - 2:k + 3]
    if (s[2] == s.max() or s[2] == s.min()) and np.ptp(s) > 0:
        c = np.polyfit(t[k - 2:k + 3] - t[k], s, 2)
        tt = -c[1] / (2 * c[0])
        if abs(tt) < 0.05:
            ext.append((t[k] + tt, np.polyval(c, tt), 1 if c[0] < 0 else -1))
clean = []
for e in ext:
    if clean and e[2] == clean[-1][2]:
        if (e[2] > 0) == (e[1] > clean[-1][1]):
            clean[-1] = e
        continue
    clean.append(e)
te = np.array([e[0] for e in clean]); ve = np.array([e[1] for e in clean])
print("turning points (t s, y px; y down):", " ".join(f"({a:.3f},{b:.1f})" for a, b in zip(te, ve)))
hp = np.abs(np.diff(ve)) / 2
print("half peak-to-peak per half cycle (px):", " ".join(f"{v:.1f}" for v in hp))
print(f"period from turning points: {2 * (te[-1] - te[0]) / (len(te) - 1):.4f} s, per half cycle: " + " ".join(f"{2*v:.3f}" for v in np.diff(te)))
if len(hp) > 2:
    r = np.log(hp[:-1] / hp[1:])
    print("log decrement per half cycle:", " ".join(f"{v:.3f}" for v in r), f"-> zeta ~ {np.mean(r) / np.pi:.4f} (small-damping approx)")
