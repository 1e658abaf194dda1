"""Numba kernel for front-to-back Gaussian compositing (imported only when numba is installed).

The image is cut into horizontal bands rendered in parallel (``prange``); inside a band each
Gaussian, taken near to far, updates the pixels of its footprint whose transmittance is still
above ``t_min``. The maths is that of :mod:`gasp_core.gs.splat_numpy`.
"""
import math

import numba
import numpy as np

ALPHA_MIN = 1.0 / 255.0
ALPHA_MAX = 0.99


@numba.njit(parallel=True, cache=True, fastmath=False)
def composite(u, v, conic, m2, opacity, rgb, x0, x1, y0, y1, width, height, colour, T, t_min, num, den, gather):
    """Front-to-back compositing in bands of 16 rows; with ``gather`` each band's per-Gaussian ``sum alpha T``
    (``num``) and ``sum alpha`` (``den``), shapes (n_bands, n) (:func:`gasp_core.gs.splat_numpy.shares`: pass
    ``t_min`` 0 so every pixel counts), else ``num`` and ``den`` are not touched (any shape)."""
    band = 16
    n_bands = (height + band - 1) // band
    n = u.shape[0]
    for b in numba.prange(n_bands):
        r0 = b * band
        r1 = min(height, r0 + band)
        for i in range(n):
            ya = max(y0[i], r0)
            yb = min(y1[i], r1)
            if ya >= yb:
                continue
            A = conic[i, 0]
            B = conic[i, 1]
            C = conic[i, 2]
            for py in range(ya, yb):
                dy = py + 0.5 - v[i]
                for px in range(x0[i], x1[i]):
                    p = py * width + px
                    t = T[p]
                    if t < t_min:
                        continue
                    dx = px + 0.5 - u[i]
                    m = A * dx * dx + 2.0 * B * dx * dy + C * dy * dy
                    if m > m2[i]:
                        continue
                    a = opacity[i] * math.exp(-0.5 * m)
                    if a < ALPHA_MIN:
                        continue
                    if a > ALPHA_MAX:
                        a = ALPHA_MAX
                    w = a * t
                    colour[p, 0] += w * rgb[i, 0]
                    colour[p, 1] += w * rgb[i, 1]
                    colour[p, 2] += w * rgb[i, 2]
                    T[p] = t * (1.0 - a)
                    if gather:
                        num[b, i] += w
                        den[b, i] += a
