"""Frame-to-frame mean absolute difference (on every 4th pixel): finds duplicated frames (almost no pixel changes) that break the
time base. usage: dupframes.py clip"""
import sys
import numpy as np
from common import frame, n_frames
c = sys.argv[1]
prev = None
dup = []
for i in range(n_frames(c)):
    f = frame(c, i)[::4, ::4]
    if prev is not None:
        d = np.percentile(np.abs(f - prev).max(-1), 99.95)
        if d < 6:
            dup.append(i)
            print(f"{c}: frame {i} ~= frame {i-1} (99.95th percentile abs diff {d:.1f})")
    prev = f
print(c, "duplicates:", len(dup))
