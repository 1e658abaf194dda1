"""Tension over a family of specimens (issue 66, "Tension, over a family"): straight bars of three lengths and two
sections and dog-bones of two proportions, held by a ``fixed_region`` at one end and pulled at the other by an
``Impulse`` of ``mode = "set"``, at n_grid N and 2N, on the MPM engines.

The material is a physicist's, not one chosen to pass: E 1 MPa, nu 0 (no lateral effect, so a clamp concentrates no
stress in the continuum), rho 1000 kg/m^3, ``tensile_strength`` f_t 10 kPa, ``fracture_energy`` G_f 20 J/m^2, a
slow pull (the pulled end at ``PULL`` m/s, the body starting in the quasi-static stretch that pull gives, so no wave
starts it: the velocity rises from 0 at the clamp's face to ``PULL`` at the pulled box's face as the compliance
``int dx / A(x)`` does). No gravity. The domain is [0, 1.2]^3 m (dx 0.05 m at n_grid 24), the points a lattice of
spacing dx / 2 (8 per cell, at ``Y0 +- (k + 1/2) dx / 2`` across every section) cut by the shape: each point keeps the
part of its lattice cube inside the section, its volume and position that part's (:func:`cut_cubes`), so every
layer's section is the specimen's to 1e-15 (whole cubes in or out made a staircase; a bar's points are all whole).

**The dog-bones** are flat (the width along y goes from the gauge's ``d`` to the grip's ``D``, the thickness stays
``d``), with circular fillets tangent to the gauge, as the standard tension specimens: ISO 527-2 type 1A (``D / d``
20 / 10 mm, its fillet ``r / d`` 2-2.5; here 2:1 at ``r / d`` 3) and ASTM D638 type I (``D / d`` 19 / 13 mm, ``R / d``
76 / 13 = 5.8; here 1.5:1 at 6). **Why:** a shoulder concentrates stress, and a brittle specimen breaks where the
stress is largest, so the gauge measures f_t only if its shoulders' elastic ``Kt`` is near 1 (W. D. Pilkey, D. F.
Pilkey, "Peterson's Stress Concentration Factors", 3rd ed., Wiley 2008, ch. 3: a shoulder fillet's ``Kt`` falls
toward 1 as ``r / d`` grows). The dog-bones before round 30 (``OLD_BONES``: square sections, cosine shoulders as long
as the gauge is wide) have ``Kt`` 1.52 in the plane-stress continuum (``benchmarks/shoulder_kt.py``) and 1.38 (n_grid
24) to 1.71 (48) in the engines' field with their staircase fill; they broke in the shoulder at 0.92 f_t. These
fillets: ``Kt`` 1.09 (2:1) and 1.05 (1.5:1) in the continuum, at the fillet's start (0.025 m past the gauge's end,
where the section is 0.2-0.5 % over the gauge's); 1.03-1.07 in the engines' field. Under 1.02 needs ``R / d`` about 15:
no such specimen fits the domain. So a dog-bone breaks at its gauge's end, as real ones often do, and "in the gauge"
means where its section is within ``SECTION_TOL`` (2 %) of the gauge's.

Measured per case, from the engine's state each frame (``F`` and ``d`` of every point, the brittle model's stress
``P = tau F^-T``, ``tau`` the Hencky stress with its tensile principal values scaled by ``1 - d``):

- ``peak``: the largest nominal stress in the gauge, the median over the gauge's lattice layers of each layer's
  force (``sum P_xx`` times its points' share of the section) over the gauge's area, before any layer breaks through
  (all its volume at ``d >= 0.9``); against f_t.
- ``where``: the rest x of the layer with the largest mean ``d`` (by volume) at the end: ``gauge`` (a dog-bone's
  section there within ``SECTION_TOL`` of the gauge's, ``section_at_crack``; a bar's free length more than 1.5 cells
  from both held faces), ``held edge`` (within 1.5 cells of the clamp's or the pulled box's face), else ``grip`` (the
  dog-bone's shoulders and grips).
- ``work``: the work to separate over the section, ``int sigma_c dw``: ``sigma_c`` the nominal stress of the crack's
  layer, ``w`` the crack's inelastic opening (the stretch between the layers 2 cells either side of it, less each
  layer's elastic ``P / E`` share), trapezoid over the frames until that layer is at ``d = 1`` throughout; against
  G_f.
- ``dissipated``: the damage's own account over the same zone, ``sum V f_t s d / (2 E)`` (``s`` the effective
  stress the point's ``d`` stands for, linear softening) per gauge area; against G_f (``dissipated_everywhere``:
  over the whole body, the damage the waves leave after the break included).

Run: ``python benchmarks/tension_family.py --engine taichi_mpm`` (and ``--engine warp_mpm``; ``--n-grid 24``,
``--only NAME``, ``--shift 0.25,0.25``: the lattice and the faces off the nodes); each engine's cases are added to
``benchmarks/results/tension_family.json`` and the table ``tension_family.md`` is written from it. One engine per
process (taichi_mpm flushes subnormals in its process).
"""
from __future__ import annotations

import argparse
import json
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

import crack_place as cp

E, NU, RHO, FT, GF = 1e6, 0.0, 1000.0, 1e4, 20.0
PULL, FRAME_DT, SIZE, Y0 = 0.02, 0.0005, 1.2, 0.6
X0, HOLD = 0.2, 0.1       # the specimen starts at x = X0; the clamp and the pulled box take HOLD m of its ends
RESULTS = Path(__file__).parent / "results"
AFTER = 40                # frames run after a layer is at d = 1 throughout (the crack open)


@dataclass(frozen=True)
class Specimen:
    """A body along x from ``X0``: ``width(x)`` its section's side along y (m) at rest x, ``thickness(x)`` along z
    (``flat``: the gauge's throughout, a flat specimen as ASTM D638's and ISO 527-2's; else square);
    ``gauge`` (lo, hi) its narrow part's rest x (m, a bar's: its free length)."""
    name: str
    length: float
    grip: float
    gauge_w: float
    gauge_l: float = 0.0     # dog-bones: the narrow part's length (m); 0: a straight bar
    taper: float = 0.0       # dog-bones: each shoulder's length (cosine), m
    fillet: float = 0.0      # dog-bones: a circular fillet of this radius (m) tangent to the gauge, instead of a cosine
    flat: bool = False       # dog-bones: only the width (y) changes; the thickness (z) is the gauge's

    def shoulder(self) -> float:
        """Each shoulder's length along x (m): the cosine's ``taper``, or the fillet's ``sqrt(2 R h - h^2)`` for
        its rise ``h = (grip - gauge_w) / 2``."""
        h = (self.grip - self.gauge_w) / 2
        return self.taper if self.fillet == 0.0 else float(np.sqrt(2 * self.fillet * h - h * h))

    def width(self, x: np.ndarray) -> np.ndarray:
        if self.gauge_l == 0.0:
            return np.full_like(x, self.gauge_w)
        mid = X0 + self.length / 2
        r = np.abs(x - mid) - self.gauge_l / 2          # past the gauge's end
        if self.fillet > 0.0:
            rr = np.clip(r, 0.0, self.shoulder())
            rise = self.fillet - np.sqrt(self.fillet ** 2 - rr ** 2)
            return np.minimum(self.gauge_w + 2 * rise, self.grip)
        t = np.clip(r / self.taper, 0.0, 1.0)
        return self.gauge_w + (self.grip - self.gauge_w) * 0.5 * (1 - np.cos(np.pi * t))

    def thickness(self, x: np.ndarray) -> np.ndarray:
        return np.full_like(x, self.gauge_w) if self.flat else self.width(x)

    def area(self, x: np.ndarray) -> np.ndarray:
        """The section's area (m^2) at rest x."""
        return self.width(x) * self.thickness(x)

    def gauge(self, dx: float) -> tuple[float, float]:
        if self.gauge_l == 0.0:
            return X0 + HOLD + 1.5 * dx, X0 + self.length - HOLD - 1.5 * dx
        mid = X0 + self.length / 2
        return mid - self.gauge_l / 2, mid + self.gauge_l / 2


FAMILY = [
    Specimen("bar_L0.5_a0.15", 0.5, 0.15, 0.15),
    Specimen("bar_L0.7_a0.15", 0.7, 0.15, 0.15),
    Specimen("bar_L0.9_a0.15", 0.9, 0.15, 0.15),
    Specimen("bar_L0.7_a0.30", 0.7, 0.30, 0.30),
    # flat, circular fillets tangent to the gauge: ISO 527-2 type 1A's 2:1 (its r / b1 2-2.5, here 3) and ASTM D638
    # type I's 1.5:1 (its W / WO 13 / 19 mm, R 76 mm: R / d 5.8, here 6); elastic Kt 1.09 and 1.05 (shoulder_kt.py)
    Specimen("dogbone_2to1", 0.9, 0.30, 0.15, gauge_l=0.2, fillet=0.45, flat=True),
    Specimen("dogbone_1.5to1", 0.9, 0.225, 0.15, gauge_l=0.18, fillet=0.9, flat=True),
]
#: the dog-bones before round 30: square sections, cosine shoulders as long as the gauge is wide (elastic Kt 1.5)
OLD_BONES = [
    Specimen("dogbone_2to1_cosine", 0.9, 0.30, 0.15, gauge_l=0.3, taper=0.15),
    Specimen("dogbone_1.5to1_cosine", 0.75, 0.225, 0.15, gauge_l=0.2, taper=0.1),
]
SECTION_TOL = 0.02        # "in the gauge": where the section is within 2 % of the gauge's


def build(sp: Specimen, n_grid: int, engine: str, ft: float = FT, partial: bool = True,
          shift: tuple[float, float] = (0.0, 0.0)):
    """The setup: the lattice (spacing dx/2) inside the specimen, held over its first ``HOLD`` m, pulled over its
    last, starting in the quasi-static stretch of the pull. ``shift``: the lattice's offset from the grid's nodes
    along x and the held faces' (cells; (0, 0): the specimen's end and both faces on nodes, the lattice's layers a
    quarter cell off them): the grid's origin moves by ``-shift[0] dx`` and the faces by ``shift[1] - shift[0]``
    cells against the specimen. Returns ``(setup, layer index of each point, layer rest x, clamp face x, pulled
    face x)``."""
    from gasp_core.colliders.model import Impulse
    from gasp_core.seam.setup import Boundary, Material
    from gasp_core.testing.helpers import make_setup
    dx = SIZE / n_grid
    s = dx / 2
    nx = int(round(sp.length / s))
    lx = X0 + (np.arange(nx) + 0.5) * s
    ny = int(np.ceil(sp.grip / (2 * s) - 1e-9))           # the same lattice across every section: at Y0 +- (k + 1/2) s
    half = sp.grip / 2 if abs(sp.grip / 2 - ny * s) < 1e-9 else ny * s
    ly = Y0 - half + (np.arange(2 * ny) + 0.5) * s
    X, Yg, Zg = np.meshgrid(lx, ly, ly, indexing="ij")
    x = np.stack([X.ravel(), Yg.ravel(), Zg.ravel()], axis=1)
    w = sp.width(x[:, 0])
    th = sp.thickness(x[:, 0])
    if partial:
        x, p_vol = cut_cubes(x, w, th, s)
    else:
        keep = (np.abs(x[:, 1] - Y0) <= w / 2 + 1e-9) & (np.abs(x[:, 2] - Y0) <= th / 2 + 1e-9)
        x, p_vol = x[keep], np.full(int(keep.sum()), s ** 3)
    lat, face = shift
    clamp, pulled = X0 + HOLD + (face - lat) * dx, X0 + sp.length - HOLD + (face - lat) * dx
    comp = np.cumsum(1.0 / sp.area(lx))               # the compliance int dx / A(x), per layer
    c_cl, c_pu = np.interp([clamp, pulled], lx, comp)
    layer = np.round((x[:, 0] - X0) / s - 0.5).astype(int)
    v = np.zeros_like(x)
    v[:, 0] = PULL * np.clip((comp[layer] - c_cl) / (c_pu - c_cl), 0.0, 1.0)
    m = Material("brittle", E=E, nu=NU, rho=RHO, tensile_strength=ft, fracture_energy=GF)
    opts = {"precision": "f64", **({"threads": 1} if engine == "taichi_mpm" else {})}
    st = make_setup(x, p_vol, m, v=v, gravity=(0, 0, 0), lo=(-lat * dx, 0, 0), hi=(SIZE - lat * dx, SIZE, SIZE),
                    n_grid=n_grid,
                    frame_dt=FRAME_DT, boundaries=[Boundary("fixed_region", lo=(0, 0, 0), hi=(clamp, SIZE, SIZE))],
                    options=opts)
    st.impulses = [Impulse("box", (PULL, 0, 0), 0.0, 100.0, lo=(pulled, 0, 0), hi=(SIZE, SIZE, SIZE), mode="set")]
    return st, layer, lx, clamp, pulled


def cut_cubes(x: np.ndarray, w: np.ndarray, th: np.ndarray, s: float) -> tuple[np.ndarray, np.ndarray]:
    """The lattice points ``x`` (n, 3), each the centre of a cube of side ``s`` (m), cut by the section ``|y - Y0| <=
    w / 2``, ``|z - Y0| <= th / 2`` (``w``, ``th``: (n,) at each point's x): each point keeps the part of its cube
    inside, its volume ``s^3 f_y f_z`` (``f`` the inside fraction of its side, in (0, 1]) at that part's centroid.
    Returns ``(x, p_vol)`` of the points with any part inside."""
    out = x.copy()
    frac = np.ones(len(x))
    for a, half in ((1, w / 2), (2, th / 2)):
        r = np.abs(x[:, a] - Y0)
        f = np.clip((half - r) / s + 0.5, 0.0, 1.0)
        f = np.where(f > 1 - 1e-9, 1.0, np.where(f < 1e-9, 0.0, f))
        edge = np.minimum(r + s / 2, half)                      # the cube's inside part ends here
        centre = np.where(f < 1.0, (r - s / 2 + edge) / 2, r)
        out[:, a] = Y0 + np.sign(x[:, a] - Y0) * centre
        frac *= f
    keep = frac > 0
    return out[keep], s ** 3 * frac[keep]


def nominal_xx(F: np.ndarray, d: np.ndarray) -> np.ndarray:
    """``P_xx`` (Pa) of the brittle model (nu 0: ``tau_i = 2 mu eps_i``) at ``F`` (n, 3, 3) and damage ``d`` (n,)."""
    U, sig, _ = np.linalg.svd(F)
    s = E * np.log(np.clip(sig, 1e-9, None))
    s = np.where(s > 0, (1 - d[:, None]) * s, s)
    tau = np.einsum("nij,nj,nkj->nik", U, s, U)
    return np.einsum("nij,nkj->nik", tau, np.linalg.inv(F))[:, 0, 0]


def run_case(sp: Specimen, n_grid: int, engine: str, build_fn=build, shift: tuple[float, float] = (0.0, 0.0)) -> dict:
    """One specimen on one engine at one grid (``shift``: :func:`build`'s): the figures of the module's docstring."""
    from gasp_core.seam.build import build_engine
    from gasp_core.seam.plugins import engines
    st, layer, lx, clamp, pulled = build_fn(sp, n_grid, engine, shift=tuple(shift))
    dx, s = st.dx, st.dx / 2
    nl = len(lx)
    wgt = np.asarray(st.p_vol, np.float64) / s ** 3            # each point's share of a full lattice cube
    count = np.bincount(layer, wgt, nl)                        # each layer's volume, in full cubes
    a_gauge = float(sp.gauge_w ** 2)
    g_lo, g_hi = (clamp + 1.5 * dx, pulled - 1.5 * dx) if sp.gauge_l == 0.0 else sp.gauge(dx)
    gauge = (lx > g_lo) & (lx < g_hi)
    gl = np.flatnonzero(gauge)
    free = cp.free_layers(layer, cp.held_points(st.x, st.boundaries, st.impulses), nl)   # no point held
    t_peak = (FT / E) * (np.interp(pulled, lx, np.cumsum(a_gauge / sp.area(lx))) -
                         np.interp(clamp, lx, np.cumsum(a_gauge / sp.area(lx)))) * s / PULL
    # until the crack has opened past 1.5 w_c = 3 G_f / f_t beyond the peak's stretch, or 20 ms after it is open
    n_frames = int(np.ceil((t_peak + 1.5 * 2 * GF / FT / PULL) / FRAME_DT))
    e = build_engine(engines()[name_check(engine)], st)
    force, pos, dmean, thru, opened = [], [], [], [], []
    t0 = time.time()
    try:
        for _ in range(n_frames):
            e.step_frame()
            F = np.asarray(e.to_setup_order(e.get_state()["F"]), np.float64)
            d = np.asarray(e.damage(), np.float64)
            xs = np.asarray(e.positions(), np.float64)
            P = nominal_xx(F, d)
            force.append(np.bincount(layer, P * wgt, nl) * s * s)
            pos.append(np.bincount(layer, xs[:, 0] * wgt, nl) / np.maximum(count, 1e-12))
            dmean.append(np.bincount(layer, d * wgt, nl) / np.maximum(count, 1e-12))
            # a layer broken through (all its volume at d >= 0.9), a layer at d = 1 throughout
            thru.append(bool(np.any(np.bincount(layer, (d >= 0.9) * wgt, nl) >= count * (1 - 1e-9))))
            opened.append(bool(np.any(np.bincount(layer, (d >= 1.0) * wgt, nl) >= count * (1 - 1e-9))))
            if len(opened) > AFTER and opened[-AFTER]:
                break
    finally:
        e.close()
    wall = time.time() - t0
    force, pos, dmean = np.array(force), np.array(pos), np.array(dmean)
    broken = np.array(thru)
    k_end = int(np.argmax(broken)) if broken.any() else len(force)
    sig_g = np.median(force[:, gl], axis=1) / a_gauge
    peak = float(sig_g[:max(k_end, 1)].max())
    crack = cp.crack_layer(dmean, free)      # the free layer first at the most damage
    span = np.flatnonzero(free & (np.abs(lx - lx[crack]) <= 2 * dx + 1e-9))   # the crack's zone: 2 cells each side
    x_c = float(lx[crack])
    section = float(sp.area(np.array([x_c]))[0] / a_gauge - 1)
    if (g_lo < x_c < g_hi) if sp.gauge_l == 0.0 else section <= SECTION_TOL:
        where = "gauge"
    elif min(abs(x_c - clamp), abs(x_c - pulled)) < 1.5 * dx:
        where = "held edge"
    else:
        where = "grip"
    # the inelastic opening over the span of the gauge's end layers, and the crack layer's nominal stress
    area = count * s * s
    elastic = (force[:, span[:-1]] / area[span[:-1]] / E * (lx[span[1:]] - lx[span[:-1]])).sum(axis=1)
    stretch = pos[:, span[-1]] - pos[:, span[0]]
    w = stretch - (lx[span[-1]] - lx[span[0]]) - elastic
    sig_c = force[:, crack] / a_gauge
    work = float(np.sum(0.5 * (sig_c[1:] + sig_c[:-1]) * np.diff(w))) if crack in span else float("nan")
    sf = point_sf(st, xs, engine)
    dl = dmean[-1]
    # each point's own account (its d and its own s_f): V f_t s d / (2 E), s the stress its d stands for
    Dp = np.asarray(st.p_vol) * FT ** 2 * sf * d / (2 * E * ((1 - d) * (sf - FT) + FT))
    D = np.bincount(layer, Dp, nl) / a_gauge
    dissipated = float(D[span].sum())
    dissipated_all = float(D.sum())
    return {"specimen": sp.name, "engine": engine, "n_grid": n_grid, "shift": list(shift), "dx": dx,
            "cells_across": sp.gauge_w / dx,
            "points": int(len(st.x)), "frames": n_frames, "seconds": round(wall, 1),
            "peak": peak, "peak_vs_ft": peak / FT - 1, "crack_x": x_c, "where": where, "section_at_crack": section,
            "clamp_face": clamp, "pulled_face": pulled, "gauge": [g_lo, g_hi],
            "work": work, "work_vs_gf": work / GF - 1,
            "dissipated": dissipated, "dissipated_vs_gf": dissipated / GF - 1,
            "dissipated_everywhere": dissipated_all,
            "broken_through": bool(broken.any()), "final_stress": float(sig_g[-1]), "frames_run": len(force),
            "damaged_layers": [[round(float(lx[k]), 4), round(float(dl[k]), 3)] for k in np.flatnonzero(dl > 0.05)]}


def point_sf(st, xs: np.ndarray, engine: str) -> np.ndarray:
    """Each point's end of softening (Pa, (n,)) at positions ``xs`` (n, 3), its crack normal along x: ``s_f`` of the
    band ``dx`` scaled by the crack band weight (``gasp_core.mpm.materials.band_weight``) where the engine's
    ``weighted_band`` is on, else ``s_f``."""
    from gasp_core.mpm.materials import band_softening_stress, band_weight, softening_stress
    sf = softening_stress(st.materials[0], float(st.crack_band[0]))
    if not weighted(engine):
        return np.full(len(xs), sf)
    X = (xs - np.asarray(st.domain_lo, np.float64)) / st.dx
    return band_softening_stress(FT, sf, band_weight(X - np.floor(X - 0.5), np.array([1.0, 0.0, 0.0])))


def weighted(engine: str) -> bool:
    """Whether ``engine``'s crack band weight (round 33) is on."""
    if engine == "taichi_mpm":
        from gasp_taichi_mpm.constitutive import Constitutive
        return bool(Constitutive.weighted_band)
    from gasp_warp_mpm.held_rule import HeldRule
    return bool(HeldRule.weighted_band)


def name_check(engine: str) -> str:
    if engine not in ("taichi_mpm", "warp_mpm"):
        raise SystemExit(f"engine {engine!r}: taichi_mpm or warp_mpm")
    return engine


def _key(r: dict) -> tuple:
    """A case's key in the results: specimen, engine, n_grid, shift (cells; :func:`build`'s)."""
    return r["specimen"], r["engine"], r["n_grid"], tuple(r.get("shift", (0.0, 0.0)))


def table(rows: list[dict]) -> str:
    """The Markdown table of the cases, with the must-show's verdicts."""
    out = ["| specimen | engine | n_grid | cells across | peak / f_t | breaks at (x, m) | section there | where | work "
           "to separate (J/m^2) | vs G_f | N to 2N | dissipated (J/m^2) | s |",
           "|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    by = {_key(r): r for r in rows}
    for r in sorted(rows, key=_key):
        twin = by.get(_key(r)[:2] + (r["n_grid"] // 2, _key(r)[3]))
        conv = f"{100 * (r['work'] / twin['work'] - 1):+.1f} %" if twin else ""
        section = f"{100 * r['section_at_crack']:+.1f} %" if "section_at_crack" in r else ""
        sh = _key(r)[3]
        name = r["specimen"] + (f" shift ({sh[0]:g}, {sh[1]:g})" if any(sh) else "")
        out.append(f"| {name} | {r['engine']} | {r['n_grid']} | {r['cells_across']:.0f} | "
                   f"{r['peak'] / FT:.3f} ({100 * r['peak_vs_ft']:+.1f} %) | {r['crack_x']:.3f} | {section} | "
                   f"{r['where']} | "
                   f"{r['work']:.1f} | {100 * r['work_vs_gf']:+.1f} % | {conv} | {r['dissipated']:.1f} | "
                   f"{r['seconds']:.0f} |")
    return "\n".join(out) + "\n"


def family_parser(only: str = "") -> argparse.ArgumentParser:
    """The arguments every tension benchmark takes: ``--engine``, ``--n-grid`` (N: the cases run at N and 2N),
    ``--only`` (specimen names, default ``only``), ``--coarse-only`` (N alone; :func:`grids`)."""
    ap = argparse.ArgumentParser()
    ap.add_argument("--engine", default="taichi_mpm")
    ap.add_argument("--n-grid", type=int, default=24, help="N (the cases run at N and 2N)")
    ap.add_argument("--only", default=only, help="comma-separated specimen names")
    ap.add_argument("--coarse-only", action="store_true", help="N only")
    return ap


def grids(a) -> tuple[int, ...]:
    """The n_grids :func:`family_parser`'s arguments ``a`` ask for: N and 2N, or N alone."""
    return (a.n_grid,) if a.coarse_only else (a.n_grid, 2 * a.n_grid)


def save_case(path: Path, rows: list, r: dict, key) -> list:
    """``rows`` with ``r`` in place of any row of the same ``key``, written to the results JSON ``path`` under the
    family's material; returns the new rows."""
    rows = [q for q in rows if key(q) != key(r)] + [r]
    path.write_text(json.dumps({"material": {"E": E, "nu": NU, "rho": RHO, "f_t": FT, "G_f": GF, "pull_m_s": PULL},
                                "cases": rows}, indent=1))
    return rows


def main() -> None:
    ap = family_parser()
    ap.add_argument("--shift", default="0,0", help="the lattice's and the faces' shift off the nodes, cells (build)")
    a = ap.parse_args()
    RESULTS.mkdir(exist_ok=True)
    path = RESULTS / "tension_family.json"
    rows = json.loads(path.read_text())["cases"] if path.exists() else []
    names = set(a.only.split(",")) if a.only else {sp.name for sp in FAMILY}
    shift = tuple(float(c) for c in a.shift.split(","))
    for sp in FAMILY:
        if sp.name not in names:
            continue
        for n in grids(a):
            r = run_case(sp, n, a.engine, shift=shift)
            print(json.dumps(r), flush=True)
            rows = save_case(path, rows, r, _key)
    (RESULTS / "tension_family.md").write_text(
        f"# Tension over a family (issue 66)\n\n`python benchmarks/tension_family.py` (docstring: the specimens and "
        f"the measures). E {E:g} Pa, nu {NU:g}, f_t {FT:g} Pa, G_f {GF:g} J/m^2, pull {PULL:g} m/s, f64. "
        f"\"section there\": the dog-bone's section at the break over its gauge's; \"where\" is the gauge within "
        f"{100 * SECTION_TOL:g} %. The dog-bones are flat with circular fillets since round 30 (before: square, cosine "
        f"shoulders, Kt 1.5; docs/fracture.md \"The dog-bones' shoulders\"). A row named with a shift: the lattice and "
        f"the held faces off the grid's nodes (``--shift``, cells; docs/fracture.md \"The held region\").\n\n"
        + table(rows))


if __name__ == "__main__":
    main()
