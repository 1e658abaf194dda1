"""Why the donut shatter example stopped shattering when the fill gave the cells at the faces their shares (issue 66).

``examples/donut_shatter.toml`` prepared twice, with the whole-cell fill (``gasp_core.maps.fill_shares.cell_fractions``
made to answer "the planes do not hold the splats", the old rule) and with the shares (the default); each body's
material points alone (its passive surface carries no mass) landed for one frame at 64 samples, once undamaged
(``f_t`` 1e8 Pa) and once with the scene's own ``f_t`` and ``G_f``. Bodies built from the two fills isolate what
matters: the old fill's points in cells the shares leave out (outside the surface: the old flat base), the shares'
points where the old fill had none, the shares' volumes made whole.

    python benchmarks/studies/donut_shatter_fill.py [--engine taichi_mpm]

Prints per body: points, mass (kg), rebound (m/s), the share of the volume whose largest principal Hencky stress
passed ``f_t`` (27 kPa) and ``s_f`` (48.5 kPa) at any sample undamaged, and the share broken through (``d >= 0.9``)
with damage. Figures in docs/fracture.md, "The donut shatter example".
"""
from __future__ import annotations

import argparse
import dataclasses
from pathlib import Path

import numpy as np
from scipy.spatial import cKDTree

ROOT = Path(__file__).resolve().parents[2]
SUB = 64


def prepared(old: bool, engine: str):
    """The example prepared for ``engine``, with the whole-cell fill when ``old``."""
    import gasp_core.maps.fill_shares as fs
    from gasp_core.prepare.scene import prepare_scene
    from gasp_core.scene.spec import load_scene
    keep = fs.cell_fractions
    if old:
        fs.cell_fractions = lambda *a, **k: (None, None, None)
    try:
        return prepare_scene(load_scene(ROOT / "examples" / "donut_shatter.toml"), engine)
    finally:
        fs.cell_fractions = keep


def land(prep, x: np.ndarray, pv: np.ndarray, elastic: bool) -> dict:
    """The material points ``x`` (n, 3, m) of volumes ``pv`` (n, m^3) landed for one frame (``SUB`` samples)."""
    from gasp_core.seam.build import build_engine
    s0, m = prep.setup, prep.setup.materials[0]
    ft, sf = m.tensile_strength, 2 * m.E * m.fracture_energy / (m.tensile_strength * float(s0.crack_band[0]))
    if elastic:
        m = dataclasses.replace(m, tensile_strength=1e8, fracture_energy=1e9)
    s = dataclasses.replace(s0, x=x, v=np.tile(s0.v[s0.p_vol > 0][0], (len(x), 1)), p_vol=pv,
                            body_id=np.zeros(len(x), np.int32), passive=None, faint=None, C=None, n_render=-1,
                            materials=[m], frame_dt=s0.frame_dt / SUB)
    mu, lam = m.E / (2 * (1 + m.nu)), m.E * m.nu / ((1 + m.nu) * (1 - 2 * m.nu))
    e = build_engine(prep.info, s)
    peak = np.zeros(len(x))
    try:
        for _ in range(SUB):
            e.step_frame()
            F = np.asarray(e.to_setup_order(e.get_state()["F"]), np.float64)
            eps = np.log(np.maximum(np.linalg.svd(F, compute_uv=False), 1e-4))
            peak = np.maximum(peak, (2 * mu * eps + lam * eps.sum(1, keepdims=True)).max(1))
        v, d = e.velocities(), e.damage()
    finally:
        e.close()
    return {"points": len(x), "mass": float(m.rho * pv.sum()), "rebound": float(np.average(v[:, 2], weights=pv)),
            "past_ft": float(np.average(peak > ft, weights=pv)), "past_sf": float(np.average(peak > sf, weights=pv)),
            "broken": float(np.average(d >= 0.9, weights=pv))}


def bodies(po, pn) -> dict:
    """The point sets compared: name -> (x, p_vol)."""
    so, sn = po.setup, pn.setup
    mo, mn = so.p_vol > 0, sn.p_vol > 0
    xo, vo, xn, vn = so.x[mo], so.p_vol[mo], sn.x[mn], sn.p_vol[mn]
    h = float(np.cbrt(vo.max()))
    snap = xo[0] + np.round((xn - xo[0]) / h) * h            # each shares' point to its cell's centre
    out_old = cKDTree(snap).query(xo)[0] > 0.5 * h           # old points in cells the shares leave out
    new_only = cKDTree(xo).query(xn)[0] > 0.5 * h            # shares' points where the old fill had none
    return {"whole cells (before)": (xo, vo), "shares (now)": (xn, vn),
            "shares + the old points outside them": (np.vstack([xn, xo[out_old]]), np.concatenate([vn, vo[out_old]])),
            "whole cells less those points": (xo[~out_old], vo[~out_old]),
            "whole cells + the shares' new points": (np.vstack([xo, xn[new_only]]),
                                                     np.concatenate([vo, vn[new_only]])),
            "shares, every volume whole": (xn, np.full(len(xn), vo.max()))}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--engine", default="taichi_mpm")
    a = ap.parse_args(argv)
    po, pn = prepared(True, a.engine), prepared(False, a.engine)
    print("| body | points | mass (kg) | rebound (m/s) | volume past f_t, undamaged | past s_f | broken through |")
    print("|---|---|---|---|---|---|---|")
    for name, (x, pv) in bodies(po, pn).items():
        el, br = land(pn, x, pv, True), land(pn, x, pv, False)
        print(f"| {name} | {el['points']} | {el['mass']:.3f} | {el['rebound']:+.2f} | {el['past_ft']:.0%} | "
              f"{el['past_sf']:.0%} | {br['broken']:.0%} |", flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
