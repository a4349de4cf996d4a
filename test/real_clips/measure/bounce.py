"""Bounce features from a position track (i t x y ...): a parabola y = a t^2 + b t + c is fitted by least squares to
every flight arc (frame ranges given by hand after looking at the track and the frames); a bounce time is where the
arcs before and after meet (the root of their difference nearest the contact frame); the floor line is the arc value
there; apex = vertex of each arc; g = 2a (px/s^2). Restitution from heights e = sqrt(h_k+1 / h_k) and from flight
times e = T_k+1 / T_k (T = time between bounces, or 2 x (apex - bounce) for an arc that the clip cuts after its apex).
usage: bounce.py track.txt fps ARCS [--exclude i,j] [--shift i0:k]
  ARCS = "i0-i1,i0-i1,..." frame ranges of the flight arcs, in order; --shift i0:k subtracts k frames from the
  time of every frame >= i0 (for a duplicated frame); --exclude drops frames."""
import argparse
import numpy as np

ap = argparse.ArgumentParser()
ap.add_argument("track"); ap.add_argument("fps", type=float); ap.add_argument("arcs")
ap.add_argument("--exclude", default=""); ap.add_argument("--shift", default=None)
ap.add_argument("--ycol", type=int, default=3, help="column of y in the track file (3 = centroid, 8 = profile middle)")
a = ap.parse_args()
d = np.loadtxt(a.track)
idx = d[:, 0].astype(int)
t = idx / a.fps
if a.shift:
    i0, k = (int(v) for v in a.shift.split(":")); t = np.where(idx >= i0, t - k / a.fps, t)
excl = {int(v) for v in a.exclude.split(",") if v}
arcs = []
for s in a.arcs.split(","):
    i0, i1 = (int(v) for v in s.split("-"))
    m = (idx >= i0) & (idx <= i1) & np.isfinite(d[:, a.ycol]) & ~np.isin(idx, list(excl))
    c = np.polyfit(t[m], d[m, a.ycol], 2)
    r = d[m, a.ycol] - np.polyval(c, t[m])
    arcs.append(dict(c=c, t0=t[m][0], t1=t[m][-1], rms=np.sqrt(np.mean(r ** 2)), n=m.sum(), maxres=np.abs(r).max()))
    tv = -c[1] / (2 * c[0])
    print(f"arc {s}: g = {2*c[0]:.0f} px/s^2, vertex t {tv:.4f} s y {np.polyval(c, tv):.1f}, rms {arcs[-1]['rms']:.2f} px "
          f"(max {arcs[-1]['maxres']:.2f}), n {m.sum()}")
bt, fy = [], []
for A, B in zip(arcs, arcs[1:]):
    roots = np.roots(A["c"] - B["c"])
    roots = roots[np.isreal(roots)].real
    r = roots[np.argmin(np.abs(roots - (A["t1"] + B["t0"]) / 2))]
    bt.append(r); fy.append(np.polyval(A["c"], r))
    print(f"bounce at {r:.4f} s (between {A['t1']:.3f} and {B['t0']:.3f}), floor y {fy[-1]:.1f}; "
          f"speed in {2*A['c'][0]*r + A['c'][1]:.0f}, out {2*B['c'][0]*r + B['c'][1]:.0f} px/s")
for k, B in enumerate(arcs[1:]):
    tv = -B["c"][1] / (2 * B["c"][0]); yv = np.polyval(B["c"], tv)
    h = fy[k] - yv
    h2 = (fy[k + 1] if k + 1 < len(fy) else fy[k]) - yv
    T = (bt[k + 1] - bt[k]) if k + 1 < len(bt) else 2 * (tv - bt[k])
    print(f"flight {k+1}: apex at {tv:.4f} s, apex y {yv:.1f}, height above previous floor {h:.1f}, above next {h2:.1f}, "
          f"flight time {T:.4f} s{' (2 x rise, clip ends)' if k + 1 >= len(bt) else ''}")
    B.update(h=h, T=T, tv=tv, yv=yv)
A0 = arcs[0]
tv0 = -A0["c"][1] / (2 * A0["c"][0])
print(f"drop arc: vertex (rest) at {tv0:.4f} s y {np.polyval(A0['c'], tv0):.1f}: release height above floor {fy[0]-np.polyval(A0['c'], tv0):.1f}; "
      f"fall time {bt[0]-tv0:.4f} s")
A0.update(h=fy[0] - np.polyval(A0["c"], tv0), T=2 * (bt[0] - tv0))
for k in range(len(arcs) - 1):
    print(f"restitution at bounce {k+1}: from heights {np.sqrt(arcs[k+1]['h']/arcs[k]['h']):.4f}, "
          f"from flight times {arcs[k+1]['T']/arcs[k]['T']:.4f}, from speeds (out/in) see above")
