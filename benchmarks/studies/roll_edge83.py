"""Round 83 (issue 67 item 2, ``docs/rigid.md`` "Round 83: a soft body's edge under a round body"): round bodies on
the option ``roll_contact`` where the soft body's face ends under them, on either engine, with
``gasp_core.mpm.roll_contact.DOMAIN`` on (each soft point read as its domain) or off (rounds 70-72's patch normal to
the grid's mass gradient, the broken variant).

Scenes (``roll_neighbours.slab_setup``'s: rigid bodies rho 1000 on a jelly slab 32 cm long and 3 cm thick, E 1e5,
nu 0.3, on a ground of friction 1; frames of 1/240 s):

* ``rest``: a rigid cylinder (R, L along y) set on the slab, gravity straight down, 16 frames: its mean height's change
  each frame (m). On a slab narrower than the cylinder against the same on a slab wider than it (no edge under it):
  the edges should not lift it.
* ``slope``: the cylinder released on the slab under gravity tilted 20 degrees (``roll_cylinder.slope`` on a slab of
  ``width``; ``two``: two slabs of ``width`` each, ``gap`` apart, the cylinder across both: three bodies), 0.2 s:
  its acceleration against ``g sin / (1 + I / M R^2)`` (mu 0.5, rolling) or ``g (sin - mu cos)`` (mu 0.05, slipping).
* ``ball``: a rigid ball R 3 cm released at ``y`` on a slab 12 cm wide (its edge at y 6 cm), the same figures.

    python benchmarks/studies/roll_edge83.py --engine warp_mpm taichi_mpm --grid 24 32 --domain 1 0 --out rows.json

``benchmarks/results/roll_edge83.json`` holds round 83's runs merged, each row's ``run`` naming its run: the patch
(``--domain 0``) on both engines, the domain on each engine, and the cube turned with ``F`` (tried, not kept).
"""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

THETA = 20.0
#: ``(R, L, slab width)`` m: cylinders whose ends lie over the slab's edges or beyond them.
CYLS = [(0.03, 0.12, 0.12), (0.03, 0.12, 0.08), (0.03, 0.18, 0.16), (0.045, 0.18, 0.16)]


def _domain(on: bool):
    import gasp_core.mpm.roll_contact as roll
    old = roll.DOMAIN
    roll.DOMAIN = int(on)
    return roll, old


def _closed(n_grid: int, R: float, L: float, mu: float) -> float:
    from roll_cylinder import G, k_ratio
    k = k_ratio(n_grid, R, L)
    th = np.radians(THETA)
    rolls = mu >= np.tan(th) / (1.0 + 1.0 / k)
    return float(G * np.sin(th) / (1.0 + k) if rolls else G * (np.sin(th) - mu * np.cos(th)))


def _two_slabs(s, width: float, gap: float):
    """``s`` (one slab, body 1, ``2 width + gap`` wide) cut into two slabs ``gap`` apart (bodies 1 and 2)."""
    body, x = np.asarray(s.body_id).copy(), np.asarray(s.x)
    slab = body == 1
    keep = ~slab | (np.abs(x[:, 1]) >= gap / 2)
    body[slab & (x[:, 1] > 0)] = 2
    out = s.replace(x=x[keep], v=np.asarray(s.v)[keep], p_vol=np.asarray(s.p_vol)[keep], body_id=body[keep],
                    C=np.asarray(s.C)[keep], materials=list(s.materials) + [s.materials[1]])
    out.n_render = 0
    return out


def _run(engine: str, s, body: int, R: float, frames: int) -> dict:
    """Body ``body``'s speed along x relative to the soft bodies' mean, its spin times ``R`` and its mean height, per
    frame."""
    from roll_neighbours import _engine, _spin
    b = np.asarray(s.body_id)
    m = np.broadcast_to(np.asarray(s.p_vol, float), b.shape) * 1000.0
    q, soft = b == body, b != body
    z0 = float(np.asarray(s.x)[q, 2].mean())
    e = _engine(engine, s, True)
    out = {"t": [], "v": [], "wR": [], "dz": []}
    try:
        for f in range(frames):
            e.step_frame()
            x, v = e.positions().astype(float), e.velocities().astype(float)
            out["t"].append((f + 1) * s.frame_dt)
            out["v"].append(float(m[q] @ v[q, 0] / m[q].sum() - m[soft] @ v[soft, 0] / m[soft].sum()))
            out["wR"].append(_spin(x[q], v[q], m[q]) * R)
            out["dz"].append(float(x[q, 2].mean()) - z0)
    finally:
        e.close()
    return out


def rest(engine: str, n_grid: int, R: float, L: float, width: float, domain: bool = True, frames: int = 16) -> list:
    """The ``rest`` scene: the cylinder's mean height's change at each frame, m."""
    from roll_neighbours import slab_setup
    from roll_cylinder import _shape
    roll, old = _domain(domain)
    try:
        s = slab_setup(n_grid, [(_shape(L), R, (-0.06, 0.0), 0.0, 0.0)], mu=0.5, theta=0.0, width=width)
        return _run(engine, s, 0, R, frames)["dz"]
    finally:
        roll.DOMAIN = old


def slope(engine: str, n_grid: int, R: float, L: float, width: float, mu: float, domain: bool = True,
          two: bool = False, gap: float = 0.04, T: float = 0.2) -> dict:
    """The ``slope`` scene's figures: ``err`` (the acceleration over the closed form, less 1), ``wR_over_v`` at the
    end, ``rolls``."""
    from roll_cylinder import _fit, _shape
    from roll_neighbours import slab_setup
    roll, old = _domain(domain)
    try:
        s = slab_setup(n_grid, [(_shape(L), R, (-0.06, 0.0), 0.0, 0.0)], mu=mu, theta=THETA,
                       width=2 * width + gap if two else width)
        s = _two_slabs(s, width, gap) if two else s
        r = _run(engine, s, 0, R, round(T / s.frame_dt))
    finally:
        roll.DOMAIN = old
    closed = _closed(n_grid, R, L, mu)
    return {"rolls": bool(mu >= 0.5), "err": _fit(r["t"], r["v"]) / closed - 1.0, "wR_over_v": r["wR"][-1] / r["v"][-1]}


def ball(engine: str, n_grid: int, y: float, mu: float, domain: bool = True, width: float = 0.12,
         T: float = 0.2) -> dict:
    """The ``ball`` scene's figures (as :func:`slope`'s)."""
    from roll_cylinder import _fit
    from roll_neighbours import slab_setup
    roll, old = _domain(domain)
    try:
        s = slab_setup(n_grid, [("ball", 0.03, (-0.06, y), 0.0, 0.0)], mu=mu, theta=THETA, width=width)
        r = _run(engine, s, 0, 0.03, round(T / s.frame_dt))
    finally:
        roll.DOMAIN = old
    closed = _closed(n_grid, 0.03, 0.0, mu)
    return {"rolls": bool(mu >= 0.5), "err": _fit(r["t"], r["v"]) / closed - 1.0, "wR_over_v": r["wR"][-1] / r["v"][-1]}


def main(argv=None) -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--engine", nargs="+", default=["warp_mpm"])
    p.add_argument("--grid", type=int, nargs="+", default=[24])
    p.add_argument("--domain", type=int, nargs="+", default=[1, 0])
    p.add_argument("--out", help="write the rows to this JSON file (refused if it exists: the round's file, "
                                 "benchmarks/results/roll_edge83.json, merges several runs, each row's 'run' names it)")
    a = p.parse_args(argv)
    if a.out and Path(a.out).exists():
        p.error(f"--out {a.out}: the file exists; name a new one")
    rows = []
    for engine in a.engine:
        for n_grid in a.grid:
            for dom in a.domain:
                def add(scene, **r):
                    rows.append({"engine": engine, "n_grid": n_grid, "domain": dom, "scene": scene, **r})
                    print(json.dumps(rows[-1]), flush=True)
                for w in (0.10, 0.20):
                    dz = rest(engine, n_grid, 0.03, 0.12, w, bool(dom))
                    add("rest", R=0.03, L=0.12, width=w, dz_max_mm=1e3 * max(dz), dz_min_mm=1e3 * min(dz))
                for mu in (0.5, 0.05):
                    for R, L, w in CYLS:
                        add("slope", R=R, L=L, width=w, mu=mu, **slope(engine, n_grid, R, L, w, mu, bool(dom)))
                    add("two_slabs", R=0.03, L=0.18, width=0.06, mu=mu,
                        **slope(engine, n_grid, 0.03, 0.18, 0.06, mu, bool(dom), two=True))
                    for y in (0.0, 0.04, 0.05, 0.06):
                        add("ball", y=y, mu=mu, **ball(engine, n_grid, y, mu, bool(dom)))
    if a.out:
        out = Path(a.out)
        tmp = out.with_suffix(".tmp")
        tmp.write_text(json.dumps(rows, indent=1))
        tmp.replace(out)


if __name__ == "__main__":
    main()
