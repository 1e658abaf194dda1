"""The spread of an oblique gauge's stress over its points (issue 66 round 36; ``benchmarks/user_oblique.py``'s
``spread`` and ``--lattice``, moved here in round 44): when the gauge's median stress first reaches ``SPREAD_AT`` f_t,
its points' largest principal stress over their mean."""
from __future__ import annotations

import numpy as np

import tension_family as tf
import tension_oblique as to

SPREAD_AT = 0.6     # the gauge's median stress (of f_t) at which the points' spread is taken


def principal(F: np.ndarray) -> np.ndarray:
    """The largest principal Hencky (Kirchhoff, nu 0, undamaged) stress ``E log sigma_max`` (Pa, (n,)) at ``F``."""
    return tf.E * np.log(np.clip(np.linalg.svd(F, compute_uv=False)[:, 0], 1e-9, None))


def spread_of(F: np.ndarray, pv: np.ndarray, pts: np.ndarray, level: float) -> dict:
    """The points ``pts``' (bool (n,)) largest principal stress over their volume mean: percentiles and extremes,
    over all of them and (``whole``, ``cut``) over those holding a whole cell of the lattice (the largest
    ``p_vol``) and the rest (the cells the surface cuts)."""
    q = principal(F[pts])
    r = q / (np.sum(q * pv[pts]) / pv[pts].sum())
    whole = pv[pts] >= (1 - 1e-6) * pv.max()

    def pct(v: np.ndarray) -> dict:
        p = np.percentile(v, [5, 50, 95]) if len(v) else [np.nan] * 3
        return {"p5": float(p[0]), "p50": float(p[1]), "p95": float(p[2]), "min": float(v.min(initial=np.inf)),
                "max": float(v.max(initial=-np.inf)), "points": int(len(v))}
    return {"at": round(level, 3), **pct(r), "whole": pct(r[whole]), "cut": pct(r[~whole])}


def lattice_spread(sp: tf.Specimen, n_grid: int, engine: str, angle: str) -> dict:
    """:func:`spread_of` on ``tension_oblique.build``'s rotated lattice (``dx / 2`` in the specimen's frame, started
    in the quasi-static stretch) when its gauge's median ``P_aa`` first reaches ``SPREAD_AT`` f_t."""
    from gasp_core.seam.build import build_engine
    from gasp_core.seam.plugins import engines
    st, layer, lx, R, clamp, pulled = to.build(sp, n_grid, engine, angle)
    a, nl, dx, pv = R[:, 0], len(lx), st.dx, np.asarray(st.p_vol, np.float64)
    reach = to.layer_reach(np.asarray(st.x, np.float64), layer, nl, clamp, pulled)
    gauge, vol = (reach > 1.5 * dx) & (sp.area(lx + tf.X0) / sp.gauge_w ** 2 - 1 <= tf.SECTION_TOL), np.bincount(
        layer, pv, nl)
    e = build_engine(engines()[tf.name_check(engine)], st)
    try:
        for _ in range(4000):
            e.step_frame()
            F = np.asarray(e.to_setup_order(e.get_state()["F"]), np.float64)
            Paa = np.einsum("i,nij,j->n", a, to.nominal(F, np.zeros(len(pv))), a)
            level = float(np.median((np.bincount(layer, Paa * pv, nl) / vol)[gauge])) / tf.FT
            if level >= SPREAD_AT:
                return spread_of(F, pv, gauge[layer], level)
    finally:
        e.close()
    raise RuntimeError(f"{sp.name} at {angle} deg: the gauge never reached {SPREAD_AT} f_t")
