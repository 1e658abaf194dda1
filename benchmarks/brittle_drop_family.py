"""Brittle drops with a known answer (issue 66, "the donut shatter"): bodies filled as a scene fills them (the faces'
shares, ``gasp_core.maps.fill.fill_interior``) land flat on the ground at ``v``; a tensile strength well under the
plane-wave impact stress ``rho c_p v`` must break them, one well over it must leave them undamaged.

The impact stress of a body landing on a rigid floor is at most the plane-wave stress ``rho c_p v`` (``c_p =
sqrt(M / rho)``, ``M = E (1 - nu) / ((1 + nu) (1 - 2 nu))`` the P-wave modulus; Kolsky, "Stress Waves in Solids",
1963, ch. 4); the tension in the body comes from the compression's release and lateral expansion, of the same order
and no larger. So at ``f_t = 2 rho c_p v`` no point may reach ``f_t`` (damage 0 everywhere), and at ``f_t = rho c_p
v / 4`` the body must break through (points with ``d >= 0.9``). The bodies: a box landing on a face, a ball, and the
README donut as ``examples/donut_shatter.toml`` prepares it (its ``f_t`` set to the same ratios). ``fracture_energy``
is twice the snap-back limit at the crack band (``Material.snap_back_limit``), so the softening is short.

    python benchmarks/brittle_drop_family.py [--engines taichi_mpm,warp_mpm] [--frames 2]

Prints one row per body, engine and ratio: the share of the volume broken through, the largest damage, the pieces
(``gasp_core.run.pieces``) and the rebound speed. Writes ``benchmarks/results/brittle_drop_family.json``.
"""
from __future__ import annotations

import argparse
import dataclasses
import json
import sys
from pathlib import Path

import numpy as np

from gasp_core.testing.helpers import box_face_samples

ROOT = Path(__file__).resolve().parents[1]
E, NU, RHO, V = 1.0e6, 0.25, 300.0, 4.43          # the donut shatter's biscuit and landing speed (SI)
LO, HI, N_GRID = (-0.3, -0.3, -0.02), (0.3, 0.3, 0.58), 64
RATIOS = (0.25, 2.0)                                # f_t / (rho c_p v)


def impact_stress(E: float = E, nu: float = NU, rho: float = RHO, v: float = V) -> float:
    """The plane-wave impact stress ``rho c_p v``, Pa."""
    m = E * (1 - nu) / ((1 + nu) * (1 - 2 * nu))
    return rho * np.sqrt(m / rho) * v


def _flat_splats(p: np.ndarray, nrm: np.ndarray, size: float, rng) -> np.ndarray:
    """GaMeS triangles (m, 3, 3) of flat splats at ``p`` with normals ``nrm``, ``size`` across."""
    a = np.where(np.abs(nrm[:, :1]) < 0.9, [[1.0, 0, 0]], [[0, 1.0, 0]])
    r2 = np.cross(nrm, a)
    r2 /= np.linalg.norm(r2, axis=1, keepdims=True)
    r3 = np.cross(nrm, r2)
    return np.stack([p, p + size * r2, p + size * r3], 1)


def box_splats(lo, hi, spacing: float = 0.004, seed: int = 0) -> np.ndarray:
    """Splats on the faces of the box ``[lo, hi]`` (m), about ``spacing`` apart."""
    rng = np.random.default_rng(seed)
    pts, nrms = box_face_samples(lo, hi, spacing, rng)
    return _flat_splats(np.concatenate(pts), np.concatenate(nrms), 0.5 * spacing, rng)


def ball_splats(centre, radius: float, spacing: float = 0.004, seed: int = 0) -> np.ndarray:
    """Splats on the sphere of ``radius`` (m) about ``centre``, about ``spacing`` apart (a Fibonacci lattice)."""
    n = int(4 * np.pi * radius ** 2 / spacing ** 2)
    k = np.arange(n) + 0.5
    z = 1 - 2 * k / n
    phi = np.pi * (1 + 5 ** 0.5) * k
    nrm = np.stack([np.sqrt(1 - z ** 2) * np.cos(phi), np.sqrt(1 - z ** 2) * np.sin(phi), z], 1)
    return _flat_splats(np.asarray(centre, float) + radius * nrm, nrm, 0.5 * spacing, np.random.default_rng(seed))


def filled_setup(splats: np.ndarray, ratio: float, options: dict | None = None):
    """A :class:`SimSetup` of the body the ``splats`` enclose, filled with the faces' shares at the donut scene's
    spacing (``n_grid`` 64, ``h = dx / 4^(1/3)``), landing at ``V`` on a ground (friction 0.5) with the grid
    contact, ``f_t = ratio rho c_p v``."""
    from gasp_core.maps.fill import fill_interior
    from gasp_core.seam.setup import Boundary
    from gasp_core.testing.helpers import make_setup
    dx = (HI[0] - LO[0]) / N_GRID
    fr = fill_interior(splats.reshape(-1, 3), dx / 4 ** (1 / 3), splats=splats, surface_mass=False)
    return make_setup(fr.fill_x, fr.p_vol_fill, material(ratio, dx + float(np.cbrt(fr.p_vol_fill.max()))),
                      v=(0.0, 0.0, -V), lo=LO, hi=HI, n_grid=N_GRID, frame_dt=1 / 30,
                      boundaries=[Boundary("ground", height=0.0, friction=0.5)],
                      options=dict(options or {"contact": "grid"}))


def material(ratio: float, band: float, base=None):
    """The biscuit (or ``base``, a :class:`Material`) with ``f_t = ratio rho c_p v`` and ``G_f`` twice the snap-back
    limit at the crack band ``band`` (m)."""
    from gasp_core.seam.setup import Material
    ft = ratio * impact_stress()
    m = base or Material("brittle", E=E, nu=NU, rho=RHO, tensile_strength=ft, fracture_energy=1.0)
    m = dataclasses.replace(m, tensile_strength=ft, fracture_energy=1.0)
    return dataclasses.replace(m, fracture_energy=2.0 * m.snap_back_limit(band))


def donut_setup(engine: str, ratio: float):
    """``examples/donut_shatter.toml`` as prepared for ``engine``, its biscuit's ``f_t`` at ``ratio``."""
    from gasp_core.prepare.scene import prepare_scene
    from gasp_core.scene.spec import load_scene
    prep = prepare_scene(load_scene(ROOT / "examples" / "donut_shatter.toml"), engine)
    s = prep.setup
    s.materials = [material(ratio, float(s.crack_band[0]), s.materials[0])]
    return s


def drop(engine: str, setup, frames: int) -> dict:
    """Run ``setup`` ``frames`` frames on ``engine``: broken share of the volume, largest damage, pieces, rebound."""
    from gasp_core.run.pieces import tracker_for
    from gasp_core.seam.build import build_engine
    from gasp_core.seam.plugins import engines
    e = build_engine(engines()[engine], setup)
    tracker = tracker_for(setup)
    mat = setup.p_vol > 0
    try:
        for _ in range(frames):
            e.step_frame()
            row, _ = tracker.row(e.positions(), e.damage())
        d, v = e.damage()[mat], e.velocities()[mat]
    finally:
        e.close()
    w = setup.p_vol[mat]
    return {"broken": float(np.average(d >= 0.9, weights=w)), "d_max": float(d.max()), "pieces": row["pieces"],
            "debris": row["debris"], "rebound": float(np.average(v[:, 2], weights=w)), "points": int(mat.sum()),
            "mass": float(setup.p_mass[mat].sum())}


BODIES = {
    "box 12 x 12 x 5 cm on a face": lambda r: filled_setup(box_splats((-0.06, -0.06, 0.005), (0.06, 0.06, 0.055)), r),
    "ball R 5 cm": lambda r: filled_setup(ball_splats((0.0, 0.0, 0.055), 0.05), r),
    "ball R 3 cm": lambda r: filled_setup(ball_splats((0.0, 0.0, 0.035), 0.03), r),
}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--engines", default="taichi_mpm,warp_mpm")
    ap.add_argument("--frames", type=int, default=2)
    ap.add_argument("--no-donut", action="store_true")
    a = ap.parse_args(argv)
    rows = []
    for engine in a.engines.split(","):
        for ratio in RATIOS:
            cases = dict(BODIES) if a.no_donut else {**BODIES, "README donut": lambda r, e=engine: donut_setup(e, r)}
            for name, make in cases.items():
                r = {"engine": engine, "body": name, "ft_ratio": ratio, **drop(engine, make(ratio), a.frames)}
                rows.append(r)
                print(json.dumps(r), flush=True)
    out = ROOT / "benchmarks" / "results" / "brittle_drop_family.json"
    out.write_text(json.dumps({"frames": a.frames, "impact_stress_pa": impact_stress(), "rows": rows}, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
