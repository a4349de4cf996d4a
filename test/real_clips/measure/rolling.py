"""cylinder_rolling_incline: acceleration along the path from the background-subtraction track (track_bgsub.txt).
Path = line fit y(x) over frames 80-320; s = position along it; least-squares parabola s(t) per frame range.
usage: rolling.py"""
import numpy as np
d = np.loadtxt("/tmp/clips/cylinder_rolling_incline/track_bgsub.txt")
t, x, y = d[:, 0] / 29.97, d[:, 2], d[:, 3]
m = (d[:, 0] >= 80) & (d[:, 0] <= 320)
k = np.polyfit(x[m], y[m], 1)
print(f"path y = {k[0]:.4f} x + {k[1]:.1f}  ({np.degrees(np.arctan(k[0])):.2f} deg in the image)")
u = np.array([1, k[0]]) / np.hypot(1, k[0])
s = (x - x[0]) * u[0] + (y - y[0]) * u[1]
for a, b in ((75, 320), (100, 320), (75, 200), (200, 320), (350, 440), (450, 530), (350, 530)):
    m = (d[:, 0] >= a) & (d[:, 0] <= b)
    c = np.polyfit(t[m], s[m], 2); r = s[m] - np.polyval(c, t[m])
    print(f"frames {a}-{b}: acceleration along the path {2*c[0]:.3f} px/s^2 (negative = down-left), rms {np.sqrt(np.mean(r**2)):.2f} px, "
          f"vertex t {-c[1]/2/c[0]:.2f} s")
