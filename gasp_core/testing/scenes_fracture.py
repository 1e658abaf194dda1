"""Conformance scenes of the ``brittle`` material (issue 52 item 4, docs/fracture.md): a bar in tension, its work
of fracture, loads below the strength and in compression, and a free break.

Every scene needs the material ``brittle`` and the features ``damage`` (``damage()``: each point's ``d``) and
``impulse``; an engine without them skips naming what it lacks. The bar is the one of ``tests/test_brittle.py``:
0.6 m long along x, section 0.125 m square, E 1 MPa, nu 0.25, rho 1000 kg/m^3, ``tensile_strength`` ``FT`` = 10 kPa,
``fracture_energy`` ``GF`` = 5 J/m^2, a lattice of 8 points per cell on the unit cube at n_grid 32, held by a
``fixed_region`` over x < 0.25 m and driven over x > 0.75 m by an ``Impulse`` with ``mode = "set"``, no gravity.

The stresses are the model's (docs/fracture.md): the Hencky principal stresses ``s_i = 2 mu eps_i + lam tr(eps)``,
their tensile part scaled by ``1 - d``. The kit estimates each point's ``F`` from the positions of its lattice
neighbours (central differences), so no scene reads an engine's internal state.

- ``brittle_bar_strength``: pulled at 0.05 m/s, the largest section-mean nominal stress ``P_xx`` (over the frames
  before any point breaks through) is ``FT`` within 5 %, the bar breaks through (a section of points all at ``d >= 0.9``), and no point's ``d`` ever decreases
  between frames (damage never heals).
- ``brittle_fracture_energy``: the bar at ``FT_GF`` = 3 kPa and nu 0 (stable softening: it stores less elastic
  energy than its crack needs), notched at mid-length (a ligament of a quarter of its section, ``LIGAMENT``),
  started in its pull's quasi-static stretch: the work to separate its first crack, ``int sigma dw`` of the force
  entering the crack's zone against its inelastic opening, per ligament area, is ``GF`` within 20 % at n_grid 32 and
  within 15 % of itself at n_grid 64 (the crack band ``h = dx``, ``gasp_core.seam.setup.crack_band``). Slow tier.
- ``brittle_below_strength``: pulled to about half ``FT`` and let go, nothing damages and the energy (kinetic +
  elastic) at each of the 40 frames after the release is the same bar's as Hencky elasticity that never yields
  within 1 % (the elastic energy returned: the MPM's own 11 % loss is common to both runs) and gains none; the bar, free, given the velocity field of a uniform uniaxial compression (ends at
  4.8 m/s), nothing damages until its middle is most compressed, past 10 ``FT``.
- ``brittle_free_break``: no boundary, the half x > 0.5 m thrown at 1 m/s: it breaks through, its momentum stays
  within 1 % of the start's, and its energy never rises above 1.01 times the start's.
"""
from __future__ import annotations

import numpy as np

from gasp_core.colliders.model import Impulse
from gasp_core.seam.build import build_engine
from gasp_core.seam.engine import EngineInfo
from gasp_core.seam.setup import Boundary, Material, SimSetup
from gasp_core.testing.helpers import Check, box_points, check, make_setup
from gasp_core.testing.kit import Requires, Scene
from gasp_core.mpm.materials import softening_stress

E, NU, RHO, FT, GF = 1e6, 0.25, 1000.0, 1e4, 5.0
MU, LAM = E / (2 * (1 + NU)), E * NU / ((1 + NU) * (1 - 2 * NU))
N_GRID, FRAME_DT = 32, 0.0025
BAR_LO, BAR_HI = np.array([0.2, 0.4375, 0.4375]), np.array([0.8, 0.5625, 0.5625])
AREA = 0.125 ** 2
#: Tolerances (issue 52): strength 5 %, fracture energy 20 %, its change from n_grid 32 to 64 15 %, momentum 1 %.
STRENGTH_TOL, GF_TOL, REGULAR_TOL, MOMENTUM_TOL = 0.05, 0.20, 0.15, 0.01
#: The bar let go below its strength: its energy (kinetic + elastic) at each frame after the release against the same
#: bar as Hencky elasticity that never yields (``metal`` with an unreachable yield stress: the brittle model's
#: undamaged stress, docs/fracture.md), within 1 %, two-sided. The MPM's own dissipation (11 % over the 40 frames on
#: both, 7 % before issue 66's held region: docs/tolerances.md) is common to the two runs, so what is left is what the
#: damage model returns or keeps of the elastic energy.
ENERGY_TOL = 0.01
BRITTLE = Material("brittle", E=E, nu=NU, rho=RHO, tensile_strength=FT, fracture_energy=GF)


def bar_setup(n_grid: int = N_GRID, pull: float = 0.05, t_pull: float = 10.0, held: bool = True) -> SimSetup:
    """The bar on the unit cube (points at spacing dx/2), pulled along +x at ``pull`` m/s (negative: pushed) over
    ``[0, t_pull]`` s; ``held=False``: no boundary and no impulse."""
    dx = 1.0 / n_grid
    x, pv = box_points(BAR_LO, BAR_HI, dx / 2)
    s = make_setup(x, pv, BRITTLE, gravity=(0, 0, 0), n_grid=n_grid, frame_dt=FRAME_DT,
                   boundaries=[Boundary("fixed_region", lo=(0, 0, 0), hi=(0.25, 1, 1))] if held else [])
    if held:
        s.impulses = [Impulse("box", (pull, 0, 0), 0.0, t_pull, lo=(0.75, 0, 0), hi=(1, 1, 1), mode="set")]
    return s


class Lattice:
    """The bar's lattice: each point's index along each axis, for central-difference ``F`` and sections."""

    def __init__(self, setup: SimSetup):
        X = setup.x
        self.X = X
        self.spacing = float(np.cbrt(setup.p_vol[0]))
        idx = np.round((X - X.min(axis=0)) / self.spacing).astype(int)
        self.shape = tuple(idx.max(axis=0) + 1)
        grid = np.full(self.shape, -1)
        grid[tuple(idx.T)] = np.arange(len(X))
        self.idx, self.grid = idx, grid
        self.layer = idx[:, 0]

    def F(self, x: np.ndarray, d: np.ndarray) -> np.ndarray:
        """Deformation gradients (n, 3, 3) from the current positions ``x`` (n, 3): central differences over the
        lattice neighbours, one-sided at the faces and where a neighbour is broken (``d >= 0.9``: not across a
        crack)."""
        out = np.empty((len(x), 3, 3))
        me = np.arange(len(x))
        for a in range(3):
            hi, lo = self.idx.copy(), self.idx.copy()
            hi[:, a] = np.minimum(hi[:, a] + 1, self.shape[a] - 1)
            lo[:, a] = np.maximum(lo[:, a] - 1, 0)
            p, m = self.grid[tuple(hi.T)], self.grid[tuple(lo.T)]
            p, m = np.where(p < 0, me, p), np.where(m < 0, me, m)     # no point there (a notch): one-sided
            p_bad, m_bad = (d[p] >= 0.9) & (d[m] < 0.9), (d[m] >= 0.9) & (d[p] < 0.9)
            p, m = np.where(p_bad, me, p), np.where(m_bad, me, m)
            alone = (p == m) & (self.grid[tuple(hi.T)] >= 0) & (self.grid[tuple(lo.T)] >= 0)
            p = np.where(alone, self.grid[tuple(hi.T)], p)    # a point alone between two broken ones
            m = np.where(alone, self.grid[tuple(lo.T)], m)
            out[:, :, a] = (x[p] - x[m]) / (self.X[p, a] - self.X[m, a])[:, None]
        return out

    def broken_through(self, d: np.ndarray) -> bool:
        """Whether some section (layer across x) has every point at ``d >= 0.9``."""
        return bool(any((d[self.layer == k] >= 0.9).all() for k in range(self.shape[0])))


def principal(F: np.ndarray, d: np.ndarray, mu: float = MU, lam: float = LAM):
    """``U``, the Hencky strains ``eps`` (n, 3) and the damaged principal stresses ``s'`` (n, 3), Pa (Lame ``mu``,
    ``lam``: the bar's unless given)."""
    U, sig, _ = np.linalg.svd(F)
    eps = np.log(np.clip(sig, 1e-6, None))
    s = 2 * mu * eps + lam * eps.sum(axis=1, keepdims=True)
    return U, eps, np.where(s > 0, (1 - d[:, None]) * s, s)


def section_stress(lat: Lattice, x: np.ndarray, d: np.ndarray, gauge: np.ndarray, nu: float = NU) -> np.ndarray:
    """Section-mean nominal stress ``P_xx`` (Pa) of each lattice layer in ``gauge`` (``P = tau F^-T``). The bar
    carries one force through every section when it moves slowly; the scenes take the median over the sections,
    which a few layers' differences across a localising crack do not move."""
    F = lat.F(x, d)
    U, _, s = principal(F, d, E / (2 * (1 + nu)), E * nu / ((1 + nu) * (1 - 2 * nu)))
    tau = np.einsum("nij,nj,nkj->nik", U, s, U)
    P = np.einsum("nij,nkj->nik", tau, np.linalg.inv(F))[:, 0, 0]
    return np.array([P[gauge & (lat.layer == k)].mean() for k in np.unique(lat.layer[gauge])])


def energy(setup: SimSetup, lat: Lattice, x: np.ndarray, v: np.ndarray, d: np.ndarray) -> float:
    """Kinetic + elastic energy, J: the elastic energy density ``1/2 sum_i s'_i eps_i`` (Hencky, damaged)."""
    _, eps, s = principal(lat.F(x, d), d)
    return 0.5 * float((setup.p_mass * (v ** 2).sum(1)).sum() + (setup.p_vol * (s * eps).sum(1)).sum())


def frames(info: EngineInfo, setup: SimSetup, n_frames: int):
    """Yield ``(x, v, d)`` of frame 0 and of each frame after it (float64, setup order)."""
    e = build_engine(info, setup)
    try:
        yield setup.x, setup.v, np.zeros(len(setup.x))
        for _ in range(n_frames):
            e.step_frame()
            yield (np.asarray(e.positions(), np.float64), np.asarray(e.velocities(), np.float64),
                   np.asarray(e.damage(), np.float64))
    finally:
        e.close()


def _within(name: str, value: float, want: float, tol: float, what: str, unit: str = "") -> Check:
    """Two-sided: ``|value / want - 1| <= tol``."""
    err = value / want - 1 if np.isfinite(value) else np.inf
    return Check(name, bool(abs(err) <= tol), f"{what} = {value:.4g}{unit} against {want:.4g}{unit} "
                 f"({100 * err:+.1f} %, tolerance {100 * tol:g} %)",
                 {"value": float(value), "signed": float(err), "limit": tol})


def _bar_strength(info: EngineInfo) -> list[Check]:
    s = bar_setup()
    lat = Lattice(s)
    gauge = (s.x[:, 0] > 0.27) & (s.x[:, 0] < 0.73)
    peak, drop, d_last = 0.0, 0.0, np.zeros(len(s.x))
    for x, v, d in frames(info, s, 60):
        if d_last.max() < 0.9:                     # the peak, before any point breaks through
            peak = max(peak, float(section_stress(lat, x, d, gauge).max()))
        drop, d_last = max(drop, float((d_last - d).max())), d
    return [_within("tensile_strength", peak, FT, STRENGTH_TOL, "largest section-mean nominal stress", " Pa"),
            Check("breaks", lat.broken_through(d_last), f"a section broken through (d >= 0.9): "
                  f"{lat.broken_through(d_last)}; largest d {d_last.max():.3f}", {"d_max": float(d_last.max())}),
            check("never_heals", drop, 1e-6, "largest fall of a point's d between frames")]


#: Cells each side of a crack's broken-through layers over which its work is summed (the crack's zone, as
#: ``benchmarks/tension_family.py``'s).
CRACK_ZONE_CELLS = 2


def broken_runs(layer: np.ndarray, d: np.ndarray) -> list[tuple[int, int]]:
    """The runs of consecutive lattice layers broken through (every point at ``d >= 0.9``), as (first, last)."""
    broken = [int(k) for k in np.unique(layer) if (d[layer == k] >= 0.9).all()]
    if not broken:
        return []
    runs = np.split(np.array(broken), np.flatnonzero(np.diff(broken) > 1) + 1)
    return [(int(r[0]), int(r[-1])) for r in runs]


def work_per_crack(layer: np.ndarray, work: np.ndarray, cracks: list[tuple[int, int]], zone: int) -> float:
    """The work (J) the damage dissipated per crack: ``work`` (per point) summed over the zones of ``cracks`` (their
    layers and ``zone`` layers each side) over their number; with none, over the whole body. ``cracks`` are the
    first to part (:func:`broken_runs` at the first frame with any): once the bar parts it sheds the elastic energy
    it stored (``f_t^2 L / (2 E)`` = 30 J/m^2 here, six times ``G_f``) as waves, which may damage it elsewhere (with
    ``nu`` 0.25 both grips pin the section's lateral contraction and concentrate the stress alike, and the waves
    part the bar at the other grip too at n_grid 32): damage that is not the first crack's work of fracture."""
    if not cracks:
        return float(work.sum())
    near = np.zeros(len(layer), dtype=bool)
    for lo, hi in cracks:
        near |= (layer >= lo - zone) & (layer <= hi + zone)
    return float(work[near].sum() / len(cracks))


#: The fracture-energy bar's strength: low enough that the bar between the grips (0.5 m) stores less elastic energy
#: at its peak than its crack needs, ``FT_GF^2 L / (2 E)`` = 2.25 J/m^2 against ``GF`` = 5 (``L < 2 l_ch``,
#: ``l_ch = E G_f / f_t^2`` = 0.56 m): its softening is stable under the pull, so the crack takes the work the pull
#: gives it as it opens and no wave shed at a snap-back breaks the bar a second time (at ``FT``, 10 kPa, it would store
#: 25 J/m^2, five times ``GF``).
FT_GF, NU_GF = 3e3, 0.0


#: The fracture-energy bar's notch: the layer of points nearest mid-length keeps only its middle ``LIGAMENT`` x
#: ``LIGAMENT`` m (a quarter of the section), so the crack forms in free material, not at a grip's face (a crack
#: there breaks the free layers within 1.5 cells of it, 1.5 ``dx`` at 8 points a cell, where the band is ``dx``:
#: docs/fracture.md "The crack band"); a notched specimen is how G_f is measured (RILEM TC-50, Hillerborg 1985).
#: The band is wider than the notch, so the crack parts the full section at the notch's cell (measured: the notch's
#: layer and the two before it broken through at n_grid 32, the notch's and the one after at 64).
LIGAMENT, NOTCH_X = 0.0625, 0.5


def fracture_setup(n_grid: int) -> SimSetup:
    """The bar of :func:`bar_setup` at ``FT_GF``, notched at ``NOTCH_X`` (its ligament ``LIGAMENT`` square),
    starting in the quasi-static stretch of its pull (the velocity rising linearly from 0 at the clamp's face to the
    pull at the pulled box's), so no wave starts it (a sudden pull of 0.05 m/s is a 1.6 kPa wave, doubled where it
    meets the clamp: past ``FT_GF``)."""
    s = bar_setup(n_grid)
    s = s.replace(materials=[Material("brittle", E=E, nu=NU_GF, rho=RHO, tensile_strength=FT_GF, fracture_energy=GF)])
    lx = np.unique(s.x[:, 0])
    notch = (s.x[:, 0] == lx[np.argmin(np.abs(lx - NOTCH_X))]) & (
        np.abs(s.x[:, 1:] - 0.5).max(axis=1) > LIGAMENT / 2)
    s = s.replace(x=s.x[~notch], v=s.v[~notch], p_vol=s.p_vol[~notch], body_id=s.body_id[~notch])
    ramp = np.clip((s.x[:, 0] - 0.25) / 0.5, 0.0, 1.0)
    return s.replace(v=0.05 * ramp[:, None] * np.array([1.0, 0.0, 0.0]))


def work_to_separate(info: EngineInfo, n_grid: int, n_frames: int = 60) -> float:
    """The work to separate the bar's first crack per area, J/m^2: ``int sigma dw`` over the frames until the crack's
    layer is at ``d = 1`` throughout (open). The notch (one layer, half a cell) is narrower than the crack's band
    (the cell, two layers), so the crack parts the whole section beside it: per area of the section. The crack's zone is the layers ``CRACK_ZONE_CELLS`` cells each side of
    the layer that first broke through; ``sigma`` the force that enters it, the mean section ``P_xx`` of the two
    free layers beside each of its ends (far-field sections lag the crack when it opens fast); ``w`` its inelastic
    opening, the zone's stretch less its elastic ``sigma / E`` share. It is the work the softening took, whatever
    the ``s_f`` the engine softens with (a band's ``d`` alone cannot show that: read with the setup's ``s_f``, the
    ``d`` of n_grid 32's softening at 64 reads ``G_f``); a later break elsewhere does not enter it."""
    s = fracture_setup(n_grid)
    lat = Lattice(s)
    free = (s.x[:, 0] > 0.25) & (s.x[:, 0] < 0.75)
    lx = np.array([s.x[lat.layer == k, 0].mean() for k in range(lat.shape[0])])
    zone = int(round(CRACK_ZONE_CELLS * s.dx / lat.spacing))
    hist, crack = [], None
    for x, _, d in frames(info, s, n_frames):
        if crack is None and lat.broken_through(d):
            runs = broken_runs(lat.layer, d)
            lo, hi = runs[0]
            crack = lo + int(np.argmax([d[lat.layer == k].mean() for k in range(lo, hi + 1)]))
        hist.append((x[:, 0].copy(), d.copy(), x))
        if crack is not None and (d[lat.layer == crack] >= 1.0).all():
            break
    if crack is None:
        return 0.0
    lo, hi = max(crack - zone, 0), min(crack + zone, lat.shape[0] - 1)
    outside = free & (((lat.layer >= lo - 2) & (lat.layer < lo)) | ((lat.layer > hi) & (lat.layer <= hi + 2)))
    sig, w = [], []
    for xx, d, x in hist:
        sig.append(float(np.mean(section_stress(lat, x, d, outside, NU_GF))))
        stretch = xx[lat.layer == hi].mean() - xx[lat.layer == lo].mean()
        w.append(stretch - (lx[hi] - lx[lo]) * (1 + sig[-1] / E))
    sig, w = np.array(sig), np.array(w)
    return float(np.sum(0.5 * (sig[1:] + sig[:-1]) * np.diff(w)))


def _fracture_energy(info: EngineInfo) -> list[Check]:
    w32, w64 = work_to_separate(info, N_GRID), work_to_separate(info, 2 * N_GRID)
    return [_within("fracture_energy", w32, GF, GF_TOL, f"work to separate the first crack per area at n_grid "
                    f"{N_GRID}", " J/m^2"),
            _within("regularised", w64, w32, REGULAR_TOL, f"the same at n_grid {2 * N_GRID}", " J/m^2")]


#: The free bar's compression: the velocity field of a uniform uniaxial-stress strain rate ``-RATE`` along x
#: (lateral ``+nu RATE``), so no section is held laterally; the ends at 4.8 m/s, ``rho c v`` = 152 kPa.
RATE, SHORT_DT = 16.0, 0.0005


def _below_strength(info: EngineInfo) -> list[Check]:
    s = bar_setup(pull=0.05, t_pull=0.05)         # 2.5 mm over the 0.5 m gauge: about half the strength
    lat = Lattice(s)
    gauge = (s.x[:, 0] > 0.27) & (s.x[:, 0] < 0.73)
    release = round(0.05 / FRAME_DT)
    peak, d_max, en = 0.0, 0.0, []
    for k, (x, v, d) in enumerate(frames(info, s, release + 40)):
        peak = max(peak, float(np.median(section_stress(lat, x, d, gauge))))
        d_max = max(d_max, float(d.max()))
        if k >= release:
            en.append(energy(s, lat, x, v, d))
    en = np.array(en)
    elastic = s.replace(materials=[Material("metal", E=E, nu=NU, rho=RHO, yield_stress=1e3 * E)])   # never reached
    ref = np.array([energy(elastic, lat, x, v, np.zeros(len(x)))
                    for k, (x, v, _) in enumerate(frames(info, elastic, release + 40)) if k >= release])
    dev = en / ref - 1
    k = int(np.argmax(np.abs(dev)))
    lost, lost_ref = float(1 - en.min() / en[0]), float(1 - ref.min() / ref[0])
    out = [check("tension_no_damage", d_max, 0.0, f"largest d with the section stress at most {peak:.0f} Pa"),
           Check("load_below", peak < FT, f"largest section stress {peak:.0f} Pa, below {FT:.0f}", {"peak": peak}),
           Check("energy_as_elastic", bool(abs(dev[k]) <= ENERGY_TOL),
                 f"energy after the release against the same bar as Hencky elasticity: largest difference "
                 f"{100 * dev[k]:+.2f} % (frame {k} after it; tolerance {100 * ENERGY_TOL:g} %); lost over the 40 "
                 f"frames {100 * lost:.1f} % against the elastic bar's {100 * lost_ref:.1f} %",
                 {"value": float(dev[k]), "signed": float(dev[k]), "limit": ENERGY_TOL}),
           check("energy_not_gained", float(en.max() / en[0]), 1.01, "largest energy after the release / at it")]
    s = bar_setup(held=False).replace(frame_dt=SHORT_DT)
    c = s.x.mean(axis=0)
    s = s.replace(v=RATE * (s.x - c) * np.array([-1.0, NU, NU]))
    lat = Lattice(s)
    mid = np.abs(s.x[:, 0] - c[0]) < 0.1
    low, d_at, d_max = [], [], 0.0
    for x, v, d in frames(info, s, 24):
        low.append(float(np.median(section_stress(lat, x, d, mid))))
        d_max = max(d_max, float(d.max()))
        d_at.append(d_max)
    k = int(np.argmin(low))                       # the most compressed frame; it springs back into tension after
    return out + [Check("compression_reached", low[k] <= -10 * FT, f"most compressive middle section stress "
                        f"{low[k]:.0f} Pa (must pass {-10 * FT:.0f})", {"low": low[k]}),
                  check("compression_no_damage", d_at[k], 0.0, f"largest d until then (frame {k} of 0.5 ms)")]


def _free_break(info: EngineInfo) -> list[Check]:
    s = bar_setup(held=False)
    v0 = np.where(s.x[:, :1] > 0.5, [[1.0, 0.0, 0.0]], 0.0)
    s = s.replace(v=v0)
    lat = Lattice(s)
    p, en = [], []
    for x, v, d in frames(info, s, 30):
        p.append(float((s.p_mass[:, None] * v).sum(0)[0]))
        en.append(energy(s, lat, x, v, d))
    p = np.array(p)
    return [Check("breaks", lat.broken_through(d), f"a section broken through (d >= 0.9): {lat.broken_through(d)}",
                  {"d_max": float(d.max())}),
            check("momentum", float(np.abs(p / p[0] - 1).max()), MOMENTUM_TOL, "largest relative change of the "
                  "x momentum"),
            check("energy_not_gained", float(max(en[1:]) / en[0]), 1.01, "largest energy / the start's")]


_REQ = Requires(frozenset({"brittle"}), frozenset({"fixed_region"}), frozenset({"damage", "impulse"}))
_REQ_FREE = Requires(frozenset({"brittle"}), frozenset(), frozenset({"damage"}))

SCENES_FRACTURE: list[Scene] = [
    Scene("brittle_bar_strength", f"a brittle bar pulled at 0.05 m/s: peak section stress tensile_strength within "
          f"{100 * STRENGTH_TOL:g} %, it breaks through, d never decreases", _REQ, run=_bar_strength),
    Scene("brittle_fracture_energy", f"the work to separate the bar's first crack per area: fracture_energy within "
          f"{100 * GF_TOL:g} % at n_grid {N_GRID}, within {100 * REGULAR_TOL:g} % of itself at {2 * N_GRID}",
          _REQ, run=_fracture_energy, slow=True),
    Scene("brittle_below_strength", "the bar pulled to half its strength and let go: no damage, the elastic energy "
          "returned; pushed past 10 tensile_strength in compression: no damage", _REQ, run=_below_strength),
    Scene("brittle_free_break", f"a free bar, one half thrown at 1 m/s: it breaks, momentum within "
          f"{100 * MOMENTUM_TOL:g} %, no energy gained", _REQ_FREE, run=_free_break),
]
