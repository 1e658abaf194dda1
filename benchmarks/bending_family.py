"""Bending (issue 66, must-show "Bending"): a cantilever under its own weight (held by a ``fixed_region`` over its
first cells) and a simply supported beam (two frictionless box colliders under its ends), each at two depths, with a
small ``fracture_energy``; and a rod hanging from a ``fixed_region`` at ``tensile_strength = 2 rho g L``. Gravity is
switched on at once (the bodies start at rest, unstrained). On the MPM engines.

Beam theory (Euler-Bernoulli, a b x h section, density rho): the largest bending stress of a cantilever of length
``L`` under its weight is at its root, ``sigma_max = M c / I = 3 rho g L^2 / h``; of a beam simply supported over
the span ``S`` at mid-span, ``3 rho g S^2 / (4 h)``. Gravity switched on at once takes the stress up to twice the
static one (the first mode's overshoot). A hanging rod's largest stress is ``rho g L`` at its top (up to ``2 rho g L``
dynamically).

The material: E 50 MPa, nu 0, rho 1000 kg/m^3 (the static tip deflection of the cantilevers L/218 and L/145);
``tensile_strength`` f_t = ``ratio * sigma_max``; ``fracture_energy`` from the characteristic length
``l_ch = E G_f / f_t^2 = LCH dx`` (``LCH`` = 0.78 cells): under a tenth of the depth at 8 cells (0.0975 h) and
12 cells (0.065 h). The crack band refuses ``l_ch`` at or under ``(dx + p_vol^(1/3)) / 2 = 0.75 dx`` (the snap-back
limit, ``Material.check_band``), so ``l_ch < h / 10`` needs a depth of more than 7.5 cells at 8 points per cell:
a depth of 4 cells cannot be run with it (docs/fracture.md "Bending").

The lattice: spacing dx / 2 (8 points a cell), dx = 1/64 m, the section 2 cells wide (y) and ``depth`` cells deep
(z, gravity -z); the cantilever ``5 depth`` cells long past its root (3 cells held), the beam ``6 depth`` cells
between its supports' centres (2 cells past each), the rod 40 cells long under 3 held cells, its section 2 x 2
cells. The domain is a cube just big enough (``n_grid`` per case). The run: 1.5 periods of the first mode (the
dynamic stress peaks at half a period), 30 frames, stopped ``AFTER`` = 4 frames after a layer is broken through (what
follows a full break is ``benchmarks/run_on_family.py``'s).

Measured per case: ``broke`` (a lattice layer across the long axis with every point at ``d >= 0.9``: a crack
through, or two or more pieces), ``where`` (the rest coordinate of the layer broken through farthest from where the
stress is largest, else of the layer with the most points at ``d >= 0.9``: its distance from the root face over
``L``, from mid-span over ``S``, from the held face over ``L``; ``through_at``: every layer broken through, so;
``broken_reach``: the farthest layer with any point at ``d >= 0.9``), ``pieces``
(:class:`gasp_core.testing.pieces_count.FramePieces`, the frames alone: links of 1.5 spacings at rest, cut past rest
+ dx; parts of 1 % of the mass or more, at the end), ``d_max``, ``peak`` (the largest principal Kirchhoff stress ``E
ln(sigma_1(F))`` (nu 0) of any point in the frames before any point damages, over ``sigma_max``: the dynamic
overshoot and the held face's or support's concentration together; sampled once a frame), the process's CPU seconds.

Run: ``python benchmarks/bending_family.py --engine taichi_mpm`` (and ``--engine warp_mpm``; ``--only NAME,...``);
each engine's cases are added to ``benchmarks/results/bending_family.json``, the table ``bending_family.md`` is
written from it. One engine per process.
"""
from __future__ import annotations

import argparse
import json
import math
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

E, NU, RHO, G = 5e7, 0.0, 1000.0, 9.81
DX = 1.0 / 64
LCH = 0.78            # the characteristic length E G_f / f_t^2, in cells (the snap-back limit: 0.75)
WIDE, HELD, ROD_L, ROD_A = 2, 3, 40, 2     # cells: the section's width, the held length, the rod's length and side
BROKEN = 0.9          # a point at d >= BROKEN is broken
FRAMES, PERIODS = 30, 1.5
AFTER = 4             # frames run after a layer is broken through
RESULTS = Path(__file__).parent / "results"


@dataclass(frozen=True)
class Case:
    """One body: ``shape`` ``cantilever``, ``beam`` or ``rod``; ``depth`` cells (z); ``ratio`` f_t / sigma_max."""
    shape: str
    depth: int
    ratio: float

    @property
    def name(self) -> str:
        return f"{self.shape}_h{self.depth}_ft{self.ratio:g}"

    @property
    def span(self) -> int:
        """The free length (cantilever, rod) or the span between the supports (beam), cells."""
        return {"cantilever": 5 * self.depth, "beam": 6 * self.depth, "rod": ROD_L}[self.shape]

    def sigma_max(self) -> float:
        """Beam theory's largest static stress, Pa (module notes)."""
        L, h = self.span * DX, self.depth * DX
        return {"cantilever": 3 * RHO * G * L ** 2 / h, "beam": 3 * RHO * G * L ** 2 / (4 * h),
                "rod": RHO * G * L}[self.shape]

    def period(self) -> float:
        """The first mode's period, s (Euler-Bernoulli; the rod's axial ``4 L / c``)."""
        L, h, k = self.span * DX, self.depth * DX, math.sqrt(E / (12 * RHO))
        if self.shape == "rod":
            return 4 * L / math.sqrt(E / RHO)
        f = (1.8751 ** 2 / (2 * math.pi) if self.shape == "cantilever" else math.pi / 2) * h / L ** 2 * k
        return 1.0 / f


FAMILY = ([Case(s, h, r) for s in ("cantilever", "beam") for h in (8, 12) for r in (0.6, 2.2)]
          + [Case("rod", ROD_A, 2.0)])


def material(c: Case, ft: float | None = None):
    """The brittle material of case ``c`` (module notes); ``ft`` overrides its strength."""
    from gasp_core.seam.setup import Material
    ft = c.ratio * c.sigma_max() if ft is None else ft
    return Material("brittle", E=E, nu=NU, rho=RHO, tensile_strength=ft, fracture_energy=LCH * DX * ft ** 2 / E)


def build(c: Case, engine: str, margin: int = 5):
    """The setup of case ``c``. Returns ``(setup, long axis, rest coordinate of the measuring face, n_grid)``: the
    root face (cantilever), mid-span (beam), the held face (rod). ``margin``: cells of the cube past the body's far
    end (and so, the body being centred across, about half that below it)."""
    from gasp_core.colliders.sdf import SDF_SPACING, box_collider
    from gasp_core.seam.setup import Boundary
    from gasp_core.testing.helpers import box_points, make_setup
    s = DX / 2
    a0 = 4                                             # cells: where the body starts along its long axis
    length = {"cantilever": HELD + c.span, "beam": c.span + 4, "rod": HELD + c.span}[c.shape]
    n = a0 + length + margin
    mid = n * DX / 2
    across = (mid - WIDE * DX / 2, mid + WIDE * DX / 2)
    deep = (mid - c.depth * DX / 2, mid + c.depth * DX / 2)
    colliders, bounds = [], []
    if c.shape == "rod":
        top = (a0 + 1 + length) * DX
        x, pv = box_points((across[0], across[0], top - length * DX), (across[1], across[1], top), s)
        face = top - HELD * DX
        bounds = [Boundary("fixed_region", lo=(0, 0, face), hi=(n * DX,) * 3)]
        axis = 2
    else:
        x, pv = box_points((a0 * DX, across[0], deep[0]), ((a0 + length) * DX, across[1], deep[1]), s)
        axis = 0
        if c.shape == "cantilever":
            face = (a0 + HELD) * DX
            bounds = [Boundary("fixed_region", lo=(0, 0, 0), hi=(face, n * DX, n * DX))]
        else:
            face = (a0 + 2 + c.span / 2) * DX
            half = np.array([DX, mid - 3.5 * DX, 2 * DX])
            colliders = [box_collider(half, SDF_SPACING * DX, name=f"support{k}", friction=0.0,
                                      position=((a0 + 2 + k * c.span) * DX, mid, deep[0] - half[2]))
                         for k in (0, 1)]
    opts = {"precision": "f64", **({"threads": 1} if engine == "taichi_mpm" else {})}
    st = make_setup(x, pv, material(c), gravity=(0, 0, -G), hi=(n * DX,) * 3, n_grid=n,
                    frame_dt=PERIODS * c.period() / FRAMES, boundaries=bounds, options=opts)
    st.colliders = colliders
    return st, axis, face, n


def run_case(c: Case, engine: str, build_fn=build) -> dict:
    """Case ``c`` on ``engine``: the figures of the module's notes."""
    from gasp_core.errors import EngineDivergence
    from gasp_core.seam.build import build_engine
    from gasp_core.seam.plugins import engines
    from gasp_core.testing.pieces_count import FramePieces
    st, axis, face, n = build_fn(c, engine)
    s = DX / 2
    x0 = np.asarray(st.x, np.float64)
    layer = np.round((x0[:, axis] - x0[:, axis].min()) / s).astype(int)
    nl = int(layer.max()) + 1
    count = np.bincount(layer, minlength=nl)
    rest = np.bincount(layer, x0[:, axis], nl) / count
    cpu, t0 = time.process_time(), time.time()
    e = build_engine(engines()[engine], st)
    through, frames, diverged = None, 0, None
    d, xs, peak = np.zeros(len(x0)), x0, 0.0
    try:
        for frames in range(1, FRAMES + 1):
            try:
                e.step_frame()
            except EngineDivergence as err:
                diverged = str(err).split(" (likely")[0]
                break
            d = np.asarray(e.damage(), np.float64)
            xs = np.asarray(e.positions(), np.float64)
            if d.max() == 0.0:
                F = np.asarray(e.to_setup_order(e.get_state()["F"]), np.float64)
                peak = max(peak, float(E * np.log(np.linalg.svd(F, compute_uv=False).max())))
            if through is None and np.any(np.bincount(layer, d >= BROKEN, nl) == count):
                through = frames
            if through is not None and frames >= through + AFTER:
                break
    finally:
        e.close()
    cpu, wall = time.process_time() - cpu, time.time() - t0
    pieces = FramePieces(x0, np.full(len(x0), RHO * float(np.mean(st.p_vol))), 1.5 * s, DX).count(xs)
    nb = np.bincount(layer, d >= BROKEN, nl)
    k = int(np.argmax(nb + np.bincount(layer, d, nl) / count / 2)) if nb.any() else None
    span = c.span * DX
    off = np.abs(rest - face) / span
    thr = np.flatnonzero(nb == count)
    # the farthest layer broken through (else the most broken one) from where the stress is largest
    where = float(off[thr].max()) if len(thr) else (None if k is None else float(off[k]))
    return {"case": c.name, "engine": engine, "shape": c.shape, "depth_cells": c.depth, "depth_m": c.depth * DX,
            "span_m": span, "n_grid": n, "points": len(x0), "sigma_max_pa": c.sigma_max(),
            "ft_over_sigma_max": c.ratio, "f_t": st.materials[0].tensile_strength,
            "G_f": st.materials[0].fracture_energy, "l_ch_over_depth": LCH / c.depth,
            "broke": bool(through is not None or pieces > 1), "crack_through": through is not None,
            "through_frame": through, "frames_run": frames, "diverged": diverged, "pieces": pieces,
            "where": where, "through_at": sorted({round(float(o), 4) for o in off[thr]}),
            "broken_reach": float(off[nb > 0].max()) if nb.any() else None, "broken_points": int((d >= BROKEN).sum()),
            "peak_over_sigma_max": peak / c.sigma_max(), "d_max": float(d.max()),
            "seconds_cpu": round(cpu, 1), "seconds_wall": round(wall, 1), "run_s": FRAMES * st.frame_dt}


def verdict(r: dict) -> str:
    """The must-show on one case: ``ok`` or what is wrong (``breaks below``, ``where``, ``stays whole``)."""
    below = r["ft_over_sigma_max"] < 1.0
    bad = [f"{r['case']} on {r['engine']}: diverged at {r['diverged']}"] if r.get("diverged") else []
    if below and not r["broke"]:
        bad.append(f"{r['case']} on {r['engine']}: f_t = {r['ft_over_sigma_max']:g} sigma_max and it did not break "
                   f"(d_max {r['d_max']:.3f}, pieces {r['pieces']})")
    if below and r["broke"] and not (r["where"] is not None and r["where"] <= WHERE[r["shape"]]):
        bad.append(f"{r['case']} on {r['engine']}: broke at {r['where']} of the span from the "
                   f"{'root face' if r['shape'] == 'cantilever' else 'mid-span'} (limit {WHERE[r['shape']]:g})")
    if not below and r["broke"]:
        bad.append(f"{r['case']} on {r['engine']}: f_t = {r['ft_over_sigma_max']:g} sigma_max and it broke (crack "
                   f"through {r['crack_through']}, pieces {r['pieces']}, d_max {r['d_max']:.3f}, at {r['where']})")
    return "; ".join(bad) or "ok"


#: How far the crack may be from where beam theory puts the largest stress, a share of the span: the cantilever's
#: root (within a tenth of L), the beam's mid-span (a quarter of S, the must-show's), the rod's held face (a tenth).
WHERE = {"cantilever": 0.1, "beam": 0.25, "rod": 0.1}


def table(rows: list[dict]) -> str:
    """The Markdown table of the cases with the must-show's verdict."""
    out = ["| case | engine | depth (cells, m) | span (m) | n_grid | sigma_max (kPa) | f_t / sigma_max | l_ch / h | "
           "peak / sigma_max | broke | where (share of span) | through at | broken reach | pieces | d_max | CPU s | "
           "verdict |", "|" + "---|" * 17]
    for r in sorted(rows, key=lambda r: (r["shape"], r["depth_cells"], r["ft_over_sigma_max"], r["engine"])):
        w = "" if r["where"] is None else f"{r['where']:.3f}"
        out.append(f"| {r['case']} | {r['engine']} | {r['depth_cells']}, {r['depth_m']:.4f} | {r['span_m']:.3f} | "
                   f"{r['n_grid']} | {r['sigma_max_pa'] / 1e3:.2f} | {r['ft_over_sigma_max']:g} | "
                   f"{r['l_ch_over_depth']:.3f} | {r['peak_over_sigma_max']:.2f} | {'yes' if r['broke'] else 'no'} | "
                   f"{w} | {', '.join(f'{o:.3f}' for o in r.get('through_at', []))} | "
                   f"{'' if r.get('broken_reach') is None else format(r['broken_reach'], '.3f')} | {r['pieces']} | "
                   f"{r['d_max']:.3f} | {r['seconds_cpu']:.0f} | {verdict(r)} |")
    return "\n".join(out) + "\n"


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--engine", default="taichi_mpm")
    ap.add_argument("--only", default="", help="comma-separated case names")
    a = ap.parse_args()
    if a.engine not in ("taichi_mpm", "warp_mpm"):
        raise SystemExit(f"engine {a.engine!r}: taichi_mpm or warp_mpm")
    RESULTS.mkdir(exist_ok=True)
    path = RESULTS / "bending_family.json"
    rows = json.loads(path.read_text())["cases"] if path.exists() else []
    names = set(a.only.split(",")) if a.only else {c.name for c in FAMILY}
    for c in FAMILY:
        if c.name not in names:
            continue
        r = run_case(c, a.engine)
        print(json.dumps(r), flush=True)
        rows = [q for q in rows if (q["case"], q["engine"]) != (c.name, a.engine)] + [r]
        path.write_text("{\n \"material\": " + json.dumps({"E": E, "nu": NU, "rho": RHO, "dx": DX, "l_ch_cells": LCH})
                        + ",\n \"cases\": [\n" + ",\n".join("  " + json.dumps(q) for q in rows) + "\n ]\n}\n")
        (RESULTS / "bending_family.md").write_text(
            f"# Bending (issue 66)\n\n`python benchmarks/bending_family.py` (docstring: the bodies and the measures). "
            f"E {E:g} Pa, nu {NU:g}, rho {RHO:g} kg/m^3, dx {DX:g} m, l_ch = E G_f / f_t^2 = {LCH:g} dx, f64, "
            f"gravity switched on at once. `where`: the crack's distance from the root face (cantilever), mid-span "
            f"(beam), the held face (rod), a share of the span.\n\n" + table(rows))


if __name__ == "__main__":
    main()
