"""Shared helpers for the real-clip ground truth: read the PPM frames written by dump_frames, time base, fits.
Only numpy. Frames live in /tmp/clips/<clip>/f%05d.ppm (see dump_frames.cpp)."""
import os
import numpy as np

ROOT = os.environ.get("CLIPS", "/tmp/clips")


def read_ppm(path):
    with open(path, "rb") as f:
        data = f.read()
    # header: P6 <w> <h> <maxval> then one whitespace byte
    parts, pos = [], 0
    while len(parts) < 4:
        while data[pos:pos + 1].isspace():
            pos += 1
        if data[pos:pos + 1] == b"#":
            pos = data.index(b"\n", pos) + 1
            continue
        end = pos
        while not data[end:end + 1].isspace():
            end += 1
        parts.append(data[pos:end]); pos = end
    pos += 1
    assert parts[0] == b"P6"
    w, h = int(parts[1]), int(parts[2])
    return np.frombuffer(data, np.uint8, w * h * 3, pos).reshape(h, w, 3).astype(np.float32)  # RGB


def frame(clip, i):
    return read_ppm(os.path.join(ROOT, clip, "f%05d.ppm" % i))


def n_frames(clip):
    for line in open(os.path.join(ROOT, clip, "index.txt")):
        if line.startswith("decoded"):
            return int(line.split()[1])


def rgb_to_hsv_cv(img):
    """OpenCV-convention HSV of an RGB float image: H 0..180, S 0..255, V 0..255."""
    r, g, b = img[..., 0], img[..., 1], img[..., 2]
    v = img.max(-1); mn = img.min(-1); d = v - mn
    s = np.where(v > 0, 255.0 * d / np.maximum(v, 1e-6), 0)
    h = np.zeros_like(v)
    dd = np.maximum(d, 1e-6)
    h = np.where(v == r, 60 * (g - b) / dd, h)
    h = np.where((v == g) & (v != r), 120 + 60 * (b - r) / dd, h)
    h = np.where((v == b) & (v != r) & (v != g), 240 + 60 * (r - g) / dd, h)
    h = np.where(d == 0, 0, h)
    h = np.mod(h, 360) / 2
    return np.stack([h, s, v], -1)


def hsv_mask(hsv, ranges):
    m = np.zeros(hsv.shape[:2], bool)
    for lo, hi in ranges:
        m |= np.all((hsv >= np.array(lo)) & (hsv <= np.array(hi)), -1)
    return m


def label(mask):
    """4-connected components (simple two-pass union-find on runs). Returns (labels, n)."""
    h, w = mask.shape
    lab = np.zeros((h, w), np.int32)
    parent = [0]
    def find(a):
        while parent[a] != a:
            parent[a] = parent[parent[a]]; a = parent[a]
        return a
    nxt = 1
    ys, xs = np.nonzero(mask)
    for y, x in zip(ys, xs):
        up = lab[y - 1, x] if y > 0 else 0
        lf = lab[y, x - 1] if x > 0 else 0
        if up == 0 and lf == 0:
            parent.append(nxt); lab[y, x] = nxt; nxt += 1
        elif up and lf:
            a, b = find(up), find(lf); lab[y, x] = min(a, b); parent[max(a, b)] = min(a, b)
        else:
            lab[y, x] = up or lf
    roots = np.array([find(i) for i in range(nxt)])
    uniq, inv = np.unique(roots, return_inverse=True)
    return inv[lab], len(uniq) - 1


def components(mask, min_area=1):
    lab, n = label(mask)
    out = []
    for k in range(1, n + 1):
        ys, xs = np.nonzero(lab == k)
        if len(xs) >= min_area:
            out.append(dict(area=len(xs), cx=xs.mean(), cy=ys.mean(), x0=xs.min(), x1=xs.max(), y0=ys.min(), y1=ys.max()))
    return out


def damped_sine_fit(t, y, f0):
    """Least squares y = c + e^{-g t}(a cos wt + b sin wt) (+ linear drift d t), Gauss-Newton on (w, g) with a grid start.
    Returns dict(period, gamma, amp0, resid_rms, params)."""
    best = None
    for w in 2 * np.pi * f0 * np.linspace(0.8, 1.2, 81):
        for g in (0.0,):
            A = np.stack([np.ones_like(t), t, np.exp(-g * t) * np.cos(w * t), np.exp(-g * t) * np.sin(w * t)], 1)
            p, *_ = np.linalg.lstsq(A, y, rcond=None)
            r = np.sum((A @ p - y) ** 2)
            if best is None or r < best[0]:
                best = (r, w, g)
    _, w, g = best
    def model(w, g):
        A = np.stack([np.ones_like(t), t, np.exp(-g * t) * np.cos(w * t), np.exp(-g * t) * np.sin(w * t)], 1)
        p, *_ = np.linalg.lstsq(A, y, rcond=None)
        return A @ p - y, p
    for _ in range(60):
        r0, p = model(w, g)
        J = np.stack([(model(w + 1e-6, g)[0] - r0) / 1e-6, (model(w, g + 1e-6)[0] - r0) / 1e-6], 1)
        step, *_ = np.linalg.lstsq(J, -r0, rcond=None)
        w, g = w + step[0], g + step[1]
        if np.abs(step).max() < 1e-10:
            break
    r, p = model(w, g)
    # parameter uncertainty from the Jacobian (white-noise assumption)
    J = np.stack([(model(w + 1e-6, g)[0] - r) / 1e-6, (model(w, g + 1e-6)[0] - r) / 1e-6], 1)
    s2 = np.sum(r ** 2) / max(1, len(t) - 6)
    cov = np.linalg.inv(J.T @ J) * s2
    return dict(period=2 * np.pi / w, gamma=g, amp0=float(np.hypot(p[2], p[3])), resid_rms=float(np.sqrt(np.mean(r ** 2))),
                sd_period=float(2 * np.pi / w ** 2 * np.sqrt(cov[0, 0])), sd_gamma=float(np.sqrt(cov[1, 1])), w=w, params=p)
