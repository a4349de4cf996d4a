"""Print a track (i t x y ...) subsampled to <= N rows as YAML sample lines: - [t, x, y].
usage: samples.py track.txt [N=80] [t0] [t1]"""
import sys
import numpy as np
d = np.loadtxt(sys.argv[1])
n = int(sys.argv[2]) if len(sys.argv) > 2 else 80
if len(sys.argv) > 4:
    d = d[(d[:, 1] >= float(sys.argv[3])) & (d[:, 1] <= float(sys.argv[4]))]
d = d[np.isfinite(d[:, 2])]
step = int(np.ceil(len(d) / n))
for r in d[::step]:
    print(f"  - [{r[1]:.3f}, {r[2]:.1f}, {r[3]:.1f}]")
