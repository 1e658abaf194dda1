"""Helpers for building conformance scenes: lattices of points, one-body setups, checks with figures."""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from gasp_core.seam.engine import EngineInfo
from gasp_core.seam.setup import Boundary, Material, SimSetup

#: Standard gravity, m/s^2.
GRAVITY = 9.81


@dataclass
class Check:
    """One named check of a scene with its measured figures."""

    name: str
    passed: bool
    message: str
    figures: dict[str, float] = field(default_factory=dict)

    def __str__(self) -> str:
        return f"[{'ok' if self.passed else 'FAIL'}] {self.name}: {self.message}"




def box_points(lo, hi, spacing: float) -> tuple[np.ndarray, float]:
    """Points on a regular lattice filling the box ``[lo, hi]``, cell-centred.

    Returns
    -------
    x : ndarray, shape (n, 3), float64
        Metres.
    p_vol : float
        Volume per point, m^3 (the box volume divided by n).
    """
    lo, hi = np.asarray(lo, float), np.asarray(hi, float)
    counts = np.maximum(1, np.round((hi - lo) / spacing).astype(int))
    axes = [lo[d] + (np.arange(counts[d]) + 0.5) * (hi[d] - lo[d]) / counts[d] for d in range(3)]
    x = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 3)
    return x, float(np.prod(hi - lo)) / len(x)


def box_face_samples(lo, hi, spacing: float, rng) -> tuple[list, list]:
    """Random points on the six faces of the box ``[lo, hi]`` (m), about ``spacing`` apart, and their outward unit
    normals: per face (axis by axis, low side first) an array of shape (k, 3) each, drawn from ``rng``
    (``numpy.random.Generator``) in that order."""
    lo, hi = np.asarray(lo, float), np.asarray(hi, float)
    pts, nrms = [], []
    for ax in range(3):
        o = [a for a in range(3) if a != ax]
        n = max(1, int((hi[o[0]] - lo[o[0]]) * (hi[o[1]] - lo[o[1]]) / spacing ** 2))
        for side, val in ((-1.0, lo[ax]), (1.0, hi[ax])):
            q = lo + rng.random((n, 3)) * (hi - lo)
            q[:, ax] = val
            nn = np.zeros((n, 3))
            nn[:, ax] = side
            pts.append(q)
            nrms.append(nn)
    return pts, nrms


def sphere_points(center, radius: float, spacing: float) -> tuple[np.ndarray, float]:
    """Lattice points inside a ball; ``p_vol`` = ball volume / n."""
    c = np.asarray(center, float)
    x, _ = box_points(c - radius, c + radius, spacing)
    x = x[np.linalg.norm(x - c, axis=1) <= radius]
    return x, (4.0 / 3.0) * math.pi * radius ** 3 / len(x)


def wall_margin(info: EngineInfo, dx: float) -> float:
    """Where a body must start to touch the ``walls``: ``3 dx`` inside the domain for grid engines.

    docs/mpm.md makes the grid nodes within ``3 dx`` of a domain face wall nodes (feature
    ``"grid"``); other engines put the wall on the face itself.
    """
    return 3.0 * dx if "grid" in info.capabilities.features else 0.0


def make_setup(x, p_vol, material: Material, *, v=0.0, gravity=(0.0, 0.0, -GRAVITY), lo=(0, 0, 0), hi=(1, 1, 1),
               n_grid=16, boundaries=(), frame_dt=1.0 / 30.0, options=None, C=None) -> SimSetup:
    """A one-body :class:`SimSetup` in the domain ``[lo, hi]`` (default the unit cube), SI units."""
    return SimSetup(x=x, v=v, p_vol=p_vol, body_id=0, materials=[material],
                    gravity=np.asarray(gravity, float), domain_lo=np.asarray(lo, float),
                    domain_hi=np.asarray(hi, float), n_grid=n_grid, boundaries=list(boundaries),
                    frame_dt=frame_dt, options=dict(options or {}), C=C)


def check(name: str, value: float, limit: float, what: str, unit: str = "", **figures) -> Check:
    """A :class:`Check` that passes when ``value <= limit`` (and is finite), with the figures."""
    passed = bool(np.isfinite(value) and value <= limit)
    return Check(name, passed, f"{what} = {value:.4g}{unit} (limit {limit:.4g}{unit})",
                 {"value": float(value), "limit": float(limit), **{k: float(v) for k, v in figures.items()}})


def body_over_box(shape: str = "ball", half: float = 0.06, n_grid: int = 32, gap: float = 0.010,
                  n_substeps: int | None = None) -> tuple[SimSetup, int]:
    """Two jelly bodies on the particle contact (``tests/test_contact_fine_step.py``, ``benchmarks/studies/
    gap_fall.py``): a box (half-width ``half`` m, 6 cm tall, E 1e5 Pa, rho 700 kg/m^3) on the ground at z = 0 and,
    ``gap`` m above it at rest, a ``Material("jelly")`` body, ``shape`` "ball" (R 5 cm), "cube" (8 cm) or
    "cylinder" (R 4 cm, 8 cm long, on its side: its axis along y); points at
    half a cell (``0.6 / n_grid / 2`` m), gravity -z (9.81 m/s^2), ground friction 0.5, a 0.6 m grid of ``n_grid``
    cells, ``frame_dt`` 1/30 s, ``options["n_substeps"]`` when given. Returns ``(setup, n_box)``: the box's points
    come first."""
    dx = 0.6 / n_grid
    s = dx / 2
    xb, _ = box_points((-half, -half, 0.0), (half, half, 0.06), s)
    top = 0.06 + gap
    if shape == "ball":
        g = np.mgrid[-0.05:0.05:s, -0.05:0.05:s, -0.05:0.05:s].reshape(3, -1).T + s / 2
        xs = g[np.linalg.norm(g, axis=1) <= 0.05] + np.array([0.0, 0.0, top + 0.05])
    elif shape == "cylinder":
        g = np.mgrid[-0.04:0.04:s, -0.04:0.04:s, -0.04:0.04:s].reshape(3, -1).T + s / 2
        xs = g[np.hypot(g[:, 0], g[:, 2]) <= 0.04] + np.array([0.0, 0.0, top + 0.04])
    else:
        xs, _ = box_points((-0.04, -0.04, top), (0.04, 0.04, top + 0.08), s)
    x = np.vstack([xb, xs])
    opts = {} if n_substeps is None else {"n_substeps": int(n_substeps)}
    setup = SimSetup(x=x, v=np.zeros_like(x), p_vol=np.full(len(x), s ** 3),
                     body_id=np.r_[np.zeros(len(xb), int), np.ones(len(xs), int)],
                     materials=[Material("jelly", E=1e5, rho=700.0), Material("jelly")],
                     gravity=np.array([0.0, 0.0, -GRAVITY]), domain_lo=np.array([-0.3, -0.3, -0.02]),
                     domain_hi=np.array([0.3, 0.3, 0.58]), n_grid=n_grid,
                     boundaries=[Boundary("ground", height=0.0, friction=0.5)], frame_dt=1.0 / 30.0, options=opts)
    return setup, len(xb)
