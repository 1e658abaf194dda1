"""Round 62: the sandwich traced (``docs/rigid.md`` "Round 62: the sandwich traced"): a jelly block between two rigid
ones (``scenes_rigid3.slide_setup`` with ``models`` rigid, elastic, rigid) slides 4-6 % past Coulomb's closed form.

Cases:

- ``rest``: the slide's blocks at rest (``--models``, top first; ``--drop-top``: the lower two only, a two-body
  scene) on the frictionless ground, 0.3 s; every 3 frames the gap of each touching pair (the lower body's highest
  point to the upper one's lowest, mm; the lattices start 7.39 mm apart at n_grid 32, half a cell less the faces'
  inset) and each body's lowest point's move (mm). ``--small``: a 6 x 6 x 3 cm jelly block on a 40 x 16 x 3 cm rigid
  slab instead (``tests/test_block_on_block.py``'s mixed pair's geometry).
- ``slide``: the thrown top block, per frame: the bodies' x velocities (m/s), the normal impulse the top block takes
  over the frame against its weight's (``m0 (dVz + g dt) / (m0 g dt)``), its friction impulse over that normal one,
  and the slide against Coulomb's.

    python benchmarks/studies/sandwich_trace.py --case rest --engine warp_mpm --n-grid 32 [--models rigid,elastic,rigid]
"""
from __future__ import annotations

import argparse

import numpy as np

from gasp_core.testing import scenes_rigid3 as S

G = 9.81


def _engine(engine: str, s):
    from gasp_core.seam.build import build_engine
    from gasp_core.seam.plugins import get_engine
    return build_engine(get_engine(engine), s)


def rest_setup(n_grid: int, models, drop_top: bool, small: bool):
    """The blocks at rest (top first), or the small jelly on the long rigid slab (``small``)."""
    h = S.MIDDLE_H
    boxes = [([-0.03, -0.03, 0.03 + h], [0.03, 0.03, 0.06 + h]), ([-0.10, -0.08, 0.03], [0.18, 0.08, 0.03 + h]),
             ([-0.12, -0.10, 0.0], [0.20, 0.10, 0.03])]
    if small:
        boxes, models = [([-0.03, -0.03, 0.03], [0.03, 0.03, 0.06]), ([-0.12, -0.08, 0.0], [0.28, 0.08, 0.03])], \
            ("elastic", "rigid")
    elif drop_top:
        boxes, models = boxes[1:], models[1:]
    return S._setup(boxes, models, [0.0, 0.0, 0.0], n_grid, 0.0, [None] * len(boxes))


def trace_rest(engine: str, s, T: float = 0.3, every: int = 3) -> list[str]:
    """Lines: every ``every`` frames the pairs' gaps and the bodies' lowest points' moves (mm)."""
    e = _engine(engine, s)
    body, X0 = np.asarray(s.body_id), np.asarray(s.x, float)
    nb = len(s.materials)

    def ext(X):
        return [X[body == k, 2].min() for k in range(nb)], [X[body == k, 2].max() for k in range(nb)]
    lo0, hi0 = ext(X0)
    out = [f"initial gaps {[round(float(1e3 * (lo0[k] - hi0[k + 1])), 3) for k in range(nb - 1)]} mm"]
    for f in range(round(T / s.frame_dt)):
        e.step_frame()
        if (f + 1) % every == 0:
            lo, hi = ext(e.positions().astype(float))
            out.append(f"t {(f + 1) * s.frame_dt:.3f} s: gaps {[round(float(1e3 * (lo[k] - hi[k + 1])), 3) for k in range(nb - 1)]}"
                       f" mm, lowest points moved {[round(float(1e3 * (lo[k] - lo0[k])), 3) for k in range(nb)]} mm")
    return out


def trace_slide(engine: str, s, T: float = 0.3) -> list[str]:
    """Lines: per frame the bodies' x velocities, the top block's normal impulse over its weight's and its friction
    over its normal impulse; then the slide."""
    e = _engine(engine, s)
    pm, body = np.asarray(s.p_mass, float), np.asarray(s.body_id)
    m = np.array([pm[body == k].sum() for k in range(3)])
    dt = s.frame_dt

    def mom(V):
        return np.array([(V[body == k] * pm[body == k, None]).sum(0) for k in range(3)])
    P = mom(np.asarray(s.v, float) * np.ones_like(np.asarray(s.x, float)))
    X0, out, jn = np.asarray(s.x, float), [], []
    for f in range(round(T / dt)):
        e.step_frame()
        Pn = mom(e.velocities().astype(float))
        d, P = Pn - P, Pn
        J = d[0, 2] + m[0] * G * dt
        jn.append(J / (m[0] * G * dt))
        out.append(f"frame {f + 1}: vx {np.round(Pn[:, 0] / m, 4).tolist()} m/s, top's normal impulse / weight's "
                   f"{jn[-1]:.3f}, friction / normal {-d[0, 0] / max(J, 1e-12):.3f}")
    X = e.positions().astype(float)
    cx = [(X[body == k, 0] * pm[body == k]).sum() / m[k] - (X0[body == k, 0] * pm[body == k]).sum() / m[k]
          for k in range(2)]
    closed = S.slide_closed_form(s)
    out.append(f"slide {1e3 * (cx[0] - cx[1]):.2f} mm against {1e3 * closed:.2f} ({100 * ((cx[0] - cx[1]) / closed - 1):+.2f}"
               f" %); the top's normal impulse over frames 1-6: {np.round(jn[:6], 3).tolist()} (sum {sum(jn[:6]):.3f})")
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--case", choices=("rest", "slide"), default="rest")
    ap.add_argument("--engine", default="warp_mpm")
    ap.add_argument("--n-grid", type=int, default=32)
    ap.add_argument("--models", default="rigid,elastic,rigid", help="the three bodies' models, top first")
    ap.add_argument("--drop-top", action="store_true", help="rest: the lower two only (two bodies)")
    ap.add_argument("--small", action="store_true", help="rest: a 6 cm jelly on a 40 cm rigid slab (two bodies)")
    a = ap.parse_args()
    models = tuple(a.models.split(","))
    print(f"{a.case} {a.engine} n_grid {a.n_grid} {a.models}{' drop-top' if a.drop_top else ''}"
          f"{' small' if a.small else ''}")
    if a.case == "rest":
        lines = trace_rest(a.engine, rest_setup(a.n_grid, models, a.drop_top, a.small))
    else:
        lines = trace_slide(a.engine, S.slide_setup(a.n_grid, None, models=models))
    print("\n".join(lines))


if __name__ == "__main__":
    main()
