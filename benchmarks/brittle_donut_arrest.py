"""Why the cracks of the default brittle README donut stop (issue 66, "What a user sees"; docs/fracture.md "Round 45:
why the default donut's cracks stop").

``benchmarks/brittle_donut_speed.py``'s thrown-down donut (brittle defaults, the default contact) landing at each of
``--speeds`` (m/s; 4.43 is the 1 m drop, 5.0 the 1.27 m one), sampled every ``1 / --rate`` s for ``--frames`` frames
of 1/30 s. Each sample reads the engine's own points (``x, v, F, Jp``, setup order) and gives:

- **The energy budget** (J): kinetic (and its in-plane part about the axis: the spreading), gravitational (over the
  start's), stored (the Hencky energy ``V0 sum_i s'_i eps_i / 2`` of the stress the engine carries: ``s'_i = (1 - d)
  s_i`` where ``s_i > 0``; ``tension``: the terms with ``s'_i > 0``) and dissipated by damage (the engine's own
  linear softening: ``V0 f_t s(d) d / (2 E)``, ``s(d)`` the undamaged stress that gave ``d``, the point's own end of
  softening ``f_t + W (s_f - f_t)`` with ``W`` its band weight; ``G_f / h`` at ``d = 1``), against ``G_f`` times the
  ligament left in the two most broken 5-degree sections (the ring's cross-section ``A = V / (2 pi r_bar)``,
  Pappus, times the share not broken through).
- **The law** (``law_excess``): the largest undamaged principal stress of a point not broken through over the stress
  that gave its ``d`` at ``W = 1`` (an upper bound of its own), at most 1 where every point follows the softening
  law; ``carried_max``: the largest tension carried by such a point over ``f_t`` (at most 1).
- **The crack tips** (points not broken through with a broken-through rest neighbour, in the 4 most broken
  sections): the largest undamaged principal stress ``s_max`` over ``f_t`` (largest and median), the stress they carry
  ``(1 - d) s_max`` over ``f_t``, the share still softening (``s_max`` at 99 % or more of the stress that gave their
  ``d``), and the share of their tension along the hoop (``(n . e_theta)^2``).
- **The opening** of the most broken section: the hoop arc between the centres of its two neighbour sections over
  its rest length (m), against the crack's stress-free opening ``w_c = 2 G_f / f_t`` and ``dx``; and the hoop strain
  rate (``e_theta . C e_theta + v_r / r``, 1/s) of its broken-through points against its other points and the
  ring's mean: a crack the single velocity field glued would not open faster than the material around it.

Run: ``python benchmarks/brittle_donut_arrest.py`` (``--engines``, ``--grid``, ``--speeds``, ``--frames``,
``--rate``, ``--every``, ``--friction``: the ground's, ``--plot``: a PNG; ``--catch``: the law's check on taichi_mpm
with the softening capped at ``d = 0.5``, printed only); writes ``benchmarks/results/brittle_donut_arrest.{json,md}``. About 1-2 min a run on 2 cores.
"""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import brittle_readme_donut as bd   # noqa: E402
from brittle_donut_speed import at_speed   # noqa: E402
from brittle_donut_arrest_report import cracks_text, grady, plot, table   # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
OUT = ROOT / "benchmarks" / "results" / "brittle_donut_arrest"
SECTOR_DEG, G = 5.0, 9.81


class Ring:
    """The donut at rest: its axis (vertical through the centre of mass), each point's section (``SECTOR_DEG``),
    its rest neighbours (``gasp_core.run.pieces.LINK_RADIUS`` fill spacings) and the cross-section ``area`` (m^2)."""

    def __init__(self, setup):
        from scipy.spatial import cKDTree
        from gasp_core.run.pieces import LINK_RADIUS
        mat = setup.p_vol > 0
        self.mat, self.m, self.v0 = mat, setup.p_mass[mat], setup.p_vol[mat]
        x = setup.x[mat]
        self.c0 = np.average(x, axis=0, weights=self.m)
        th = np.degrees(np.arctan2(x[:, 1] - self.c0[1], x[:, 0] - self.c0[0])) % 360.0
        self.n_sec = int(round(360.0 / SECTOR_DEG))
        self.sec = np.minimum((th / SECTOR_DEG).astype(int), self.n_sec - 1)
        self.rbar = float(np.average(np.hypot(*(x[:, :2] - self.c0[:2]).T), weights=self.m))
        self.area = float(self.v0.sum() / (2 * np.pi * self.rbar))
        pairs = cKDTree(x).query_pairs(LINK_RADIUS * float(np.cbrt(self.v0.max())), output_type="ndarray")
        self.pairs = pairs
        self.z0 = x[:, 2] - x[:, 2].min()
        self.x0, self.th, self.r0 = x, th, np.hypot(*(x[:, :2] - self.c0[:2]).T)
        self.rest_arc = self.arcs(x)

    def sector_share(self, flag):
        """The mass share of each section where ``flag`` (n,) bool, shape (n_sec,)."""
        tot = np.bincount(self.sec, self.m, self.n_sec)
        return np.bincount(self.sec, self.m * flag, self.n_sec) / tot

    def arcs(self, x):
        """Hoop arc (m) between the mass centres of each section's two neighbours, shape (n_sec,)."""
        c = np.average(x, axis=0, weights=self.m)
        mx = np.bincount(self.sec, self.m * (x[:, 0] - c[0]), self.n_sec)
        my = np.bincount(self.sec, self.m * (x[:, 1] - c[1]), self.n_sec)
        ms = np.bincount(self.sec, self.m, self.n_sec)
        ang, r = np.arctan2(my, mx), np.hypot(mx, my) / ms
        da = (np.roll(ang, -1) - np.roll(ang, 1)) % (2 * np.pi)
        return da * 0.5 * (np.roll(r, -1) + np.roll(r, 1))


def crack_links(ring, x, d, dx: float, n_cracks: int = 3) -> list[dict]:
    """The links between rest neighbours across each of the ``n_cracks`` most broken sections (at least 3 sections
    apart), on the plane through it (offsets of -7.5 to 7.5 deg in 0.5 deg) that leaves fewest links whole: links
    across it, the share cut (longer than at rest by more than ``dx``, as the frames-only count cuts them), the whole
    ones' mean rest height (m, over the lowest point) and radius (m), the stretch (m: median, 90th percentile, largest)
    and the median stretch (m) in the lower, middle and upper third of the donut's height."""
    a, b = ring.pairs.T
    L0, L = np.linalg.norm(ring.x0[a] - ring.x0[b], axis=1), np.linalg.norm(x[a] - x[b], axis=1)
    st, cut = L - L0, L > L0 + dx
    share = ring.sector_share(d >= 1.0)
    picked = []
    for k in np.argsort(share)[::-1]:
        if all(min((k - j) % ring.n_sec, (j - k) % ring.n_sec) >= 3 for j in picked):
            picked.append(int(k))
        if len(picked) == n_cracks:
            break
    out, third = [], ring.z0.max() / 3
    for k in picked:
        best = None
        for off in np.arange(-7.5, 7.6, 0.5):
            da = (ring.th[a] - (k + 0.5) * SECTOR_DEG - off + 180) % 360 - 180
            db = (ring.th[b] - (k + 0.5) * SECTOR_DEG - off + 180) % 360 - 180
            cr = (np.sign(da) != np.sign(db)) & (np.abs(da) < 10) & (np.abs(db) < 10)
            if best is None or (cr & ~cut).sum() < (best & ~cut).sum():
                best = cr
        whole = best & ~cut
        zb = np.minimum((ring.z0[a[best]] / third).astype(int), 2)
        out.append({"section": k, "broken": float(share[k]), "links": int(best.sum()), "cut": float(cut[best].mean()),
                    "whole_z": float(ring.z0[a[whole]].mean()), "whole_r": float(ring.r0[a[whole]].mean()),
                    "section_z": float(np.average(ring.z0[ring.sec == k], weights=ring.m[ring.sec == k])),
                    "stretch": [float(np.median(st[best])), float(np.percentile(st[best], 90)), float(st[best].max())],
                    "stretch_by_height": [float(np.median(st[best][zb == i])) for i in range(3)]})
    return out


def stresses(F, d, x, mat, dx, lo):
    """Per point: Hencky strains ``eps`` (n, 3), undamaged principal stresses ``s`` (n, 3, Pa), the carried ones
    ``s'`` (n, 3), the largest's direction ``n`` (n, 3) and its band weight ``W`` (n,) (engine's ``band_sf``)."""
    from gasp_core.mpm.materials import band_weight
    U, sv, _ = np.linalg.svd(F)
    eps = np.log(np.maximum(sv, 1e-4))
    lam = mat.E * mat.nu / ((1 + mat.nu) * (1 - 2 * mat.nu))
    mu = mat.E / (2 * (1 + mat.nu))
    s = 2 * mu * eps + lam * eps.sum(1, keepdims=True)
    sc = np.where((s > 0) & (d[:, None] < 1), s * (1 - d[:, None]), s)
    im = np.argmax(s, 1)
    n = U[np.arange(len(U)), :, im]
    X = (x - lo) / dx
    return eps, s, sc, n, band_weight(X - np.floor(X - 0.5), n)


def sample(ring, st, mat, setup, t):
    """One sample's row (module notes) from the state ``st`` (``x, v, F, C, d``, setup order of the material rows)."""
    x, v, F, C, d = st["x"], st["v"], st["F"], st["C"], st["d"]
    m, v0, ft, gf, E = ring.m, ring.v0, mat.tensile_strength, mat.fracture_energy, mat.E
    h = float(setup.crack_band[0])
    sf = 2 * E * gf / (ft * h)
    eps, s, sc, n, W = stresses(F, d, x, mat, setup.dx, np.asarray(setup.domain_lo))
    sfp = ft + W * (sf - ft)
    sd = ft * sfp / ((1 - np.minimum(d, 1)) * (sfp - ft) + ft)              # the stress that gave d
    diss = v0 * ft * sd * d / (2 * E)
    sd_top = ft * sf / ((1 - np.minimum(d, 1)) * (sf - ft) + ft)          # the same at W = 1: its upper bound
    c = np.average(x, axis=0, weights=m)
    rel = x[:, :2] - c[:2]
    r = np.maximum(np.hypot(*rel.T), 1e-9)
    er = np.c_[rel / r[:, None], np.zeros(len(r))]
    et = np.c_[-er[:, 1], er[:, 0], np.zeros(len(r))]
    vc = np.average(v, axis=0, weights=m)
    vr = np.einsum("ij,ij->i", v - vc, er)
    hoop_rate = np.einsum("ij,ijk,ik->i", et, C, et) + vr / r
    broken = d >= 1.0
    share = ring.sector_share(broken)
    top = np.argsort(share)[::-1]
    far = [k for k in top[1:] if min((k - top[0]) % ring.n_sec, (top[0] - k) % ring.n_sec) >= 3]
    two = [int(top[0]), int(far[0])]
    tips = tip_rows(ring, broken, np.isin(ring.sec, top[:4]))
    near2 = np.isin(ring.sec, [(k + j) % ring.n_sec for k in two for j in range(-2, 3)])
    smax = s.max(1)
    inc = ring.sec == top[0]
    row = {"t": t, "kinetic": 0.5 * float(m @ (v * v).sum(1)), "spread": 0.5 * float(m @ vr ** 2),
           "potential": G * float(m @ x[:, 2]), "stored": 0.5 * float(v0 @ (sc * eps).sum(1)),
           "tension": 0.5 * float(v0 @ np.where(sc > 0, sc * eps, 0).sum(1)), "dissipated": float(diss.sum()),
           "broken": float(np.average(broken, weights=m)), "top_sections": two,
           "top_broken": [float(share[k]) for k in two], "sections_over_half": int((share > 0.5).sum()),
           "ligament_J": gf * ring.area * float(sum(1 - share[k] for k in two)), "cut_J": gf * ring.area,
           "dissipated_top2": float(diss[np.isin(ring.sec, two)].sum()),
           "opening": float(ring.arcs(x)[top[0]] - ring.rest_arc[top[0]]),
           "opening_mean": float(np.mean(ring.arcs(x) - ring.rest_arc)),
           "hoop_rate_broken": float(np.average(hoop_rate[inc & broken], weights=m[inc & broken]))
           if (inc & broken).any() else 0.0,
           "hoop_rate_rest": float(np.average(hoop_rate[inc & ~broken], weights=m[inc & ~broken])),
           "hoop_rate_ring": float(np.average(hoop_rate, weights=m)), "tips": int(tips.sum()),
           "damaged": float(np.average(d > 0, weights=m)), "partial_d_median": float(np.median(d[(d > 0) & ~broken]))
           if ((d > 0) & ~broken).any() else 0.0, "dissipated_partial": float(diss[~broken].sum()),
           "ligament_z": float(np.average(ring.z0[inc & ~broken], weights=m[inc & ~broken])),
           "section_z": float(np.average(ring.z0[inc], weights=m[inc])),
           "law_excess": float((smax[d < 1] / sd_top[d < 1]).max(initial=0.0)),
           "tension_near2": 0.5 * float(v0[near2] @ np.where(sc > 0, sc * eps, 0)[near2].sum(1)),
           "carried_max": float(sc[d < 1].max(initial=0.0) / ft)}
    if tips.any():
        ratio = smax[tips] / sd[tips]
        row.update(tip_smax=float(smax[tips].max() / ft), tip_smax_median=float(np.median(smax[tips]) / ft),
                   tip_carried=float(sc[tips].max() / ft), tip_softening=float(np.mean(ratio >= 0.99)),
                   tip_over_ft=float(np.mean(smax[tips] >= ft)),
                   tip_hoop=float(np.mean(np.einsum("ij,ij->i", n[tips], et[tips]) ** 2)))
    return row


def tip_rows(ring, broken, where):
    """Points not broken through with a broken-through rest neighbour, within ``where`` (n,) bool."""
    a, b = ring.pairs[:, 0], ring.pairs[:, 1]
    near = np.zeros(len(broken), bool)
    near[a[broken[b]]] = True
    near[b[broken[a]]] = True
    return near & ~broken & where


def state(e, mat_rows):
    """``x, v, F, C, d`` of the material points, setup order (the inner engine's internal arrays put back)."""
    get = lambda k: np.asarray(e.to_setup_order(e.read_array(k)), np.float64)[mat_rows]   # noqa: E731
    return {"x": get("x"), "v": get("v"), "F": get("F").reshape(-1, 3, 3), "C": get("C").reshape(-1, 3, 3),
            "d": np.minimum(get("Jp"), 1.0)}


def capped_softening(cap: float = 0.5):
    """The catch of the law's check (``--catch``, taichi_mpm only): ``Constitutive.brittle_tau`` with the damage it
    gives capped at ``cap`` (a softening that stops for a reason in the code); returns the original to put back."""
    import taichi as ti
    from gasp_taichi_mpm.constitutive import Constitutive
    orig = Constitutive.brittle_tau

    @ti.func
    def capped(self, U, eps, mu, lam, ft, sf, d):
        s = 2.0 * mu * eps + lam * eps.sum()
        smax = ti.max(s[0], s[1], s[2])
        if smax > ft:
            dt = ti.cast(1.0, self.real)
            if smax < sf:
                dt = 1.0 - ft * (sf - smax) / (smax * (sf - ft))
            d = ti.max(d, ti.min(dt, cap))
        for i in ti.static(range(3)):
            if s[i] > 0.0:
                s[i] *= 1.0 - d
        return self.udvt(U, s, U), d

    Constitutive.brittle_tau = capped
    return orig


def jelly_budget(engine: str, n_grid: int, v: float, frames: int, rate: int) -> list[dict]:
    """The same landing as ``jelly`` (the brittle defaults' E, nu, rho; corotated, no damage; ``--jelly``): kinetic,
    gravitational and stored (``V0 (mu |F - R|^2 + lam (J - 1)^2 / 2)``, the corotated energy) energy (J) over
    the start's kinetic + gravitational: what the contact and the transfers keep without any fracture."""
    from gasp_core.seam.build import build_engine
    from gasp_core.seam.plugins import engines
    from gasp_core.seam.setup import Material
    b = bd.brittle("new")
    m = Material("jelly", E=b.E, nu=b.nu, rho=b.rho)
    setup = at_speed(bd.donut_setup(engine, n_grid, m), v)
    ring = Ring(setup)
    setup.frame_dt = 1.0 / rate
    lam, mu = m.E * m.nu / ((1 + m.nu) * (1 - 2 * m.nu)), m.E / (2 * (1 + m.nu))
    e0 = 0.5 * float(ring.m.sum()) * v * v + G * float(ring.m @ setup.x[ring.mat, 2])
    e, rows = build_engine(engines()[engine], setup), []
    try:
        for k in range(1, frames * rate // 30 + 1):
            e.step_frame()
            st = state(e, ring.mat)
            U, sv, Vt = np.linalg.svd(st["F"])
            psi = mu * ((sv - 1) ** 2).sum(1) + 0.5 * lam * (sv.prod(1) - 1) ** 2
            row = {"t": k / rate, "kinetic": 0.5 * float(ring.m @ (st["v"] ** 2).sum(1)),
                   "potential": G * float(ring.m @ st["x"][:, 2]), "stored": float(ring.v0 @ psi)}
            rows.append({**row, "kept": (row["kinetic"] + row["potential"] + row["stored"]) / e0})
    finally:
        e.close()
    return rows


def run(engine: str, n_grid: int, v: float, frames: int, rate: int, save: str | None = None,
        friction: float | None = None) -> list[dict]:
    """The samples of one landing (module notes); the last one also has its ``cracks`` (:func:`crack_links`) and its
    parts from the frames alone (``parts_1``: of 1 % of the mass or more; ``largest``: the heaviest's share).
    ``save``: an ``.npz`` path for the rest positions ``x0``, the last sample's ``x, v, d, F, C`` and the sections
    ``sec`` (material points, setup order); ``friction``: the ground's friction instead of the scene's 0.5."""
    import dataclasses
    from gasp_core.run.pieces import LINK_RADIUS
    from gasp_core.seam.build import build_engine
    from gasp_core.seam.plugins import engines
    from gasp_core.testing.pieces_count import FramePieces
    mat = bd.brittle("new")
    setup = at_speed(bd.donut_setup(engine, n_grid, mat), v)
    if friction is not None:
        setup.boundaries = [dataclasses.replace(b, friction=friction) for b in setup.boundaries]
    ring = Ring(setup)
    ref = FramePieces(ring.x0, ring.m, LINK_RADIUS * float(np.cbrt(ring.v0.max())), setup.dx)
    setup.frame_dt = 1.0 / rate
    e = build_engine(engines()[engine], setup)
    rows = []
    try:
        for k in range(1, frames * rate // 30 + 1):
            e.step_frame()
            st = state(e, ring.mat)
            rows.append(sample(ring, st, mat, setup, k / rate))
        rows[-1]["cracks"] = crack_links(ring, st["x"], st["d"], setup.dx)
        parts = ref.masses(st["x"]) / ring.m.sum()
        rows[-1].update(parts_1=int((parts >= bd.SHARE).sum()), largest=float(parts[0]))
        if save:
            np.savez(save, x0=setup.x[ring.mat], m=ring.m, v0=ring.v0, sec=ring.sec, **st)
    finally:
        e.close()
    e0 = 0.5 * float(ring.m.sum()) * v * v + G * float(ring.m @ setup.x[ring.mat, 2])
    for r in rows:
        r["total"] = r["kinetic"] + r["potential"] + r["stored"] + r["dissipated"]
        r["start"] = e0
    return rows


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--engines", default="taichi_mpm")
    ap.add_argument("--grid", type=int, default=48)
    ap.add_argument("--speeds", default="4.43,5.0")
    ap.add_argument("--frames", type=int, default=8, help="frames of 1/30 s")
    ap.add_argument("--rate", type=int, default=300, help="samples a second (a multiple of 30)")
    ap.add_argument("--every", type=int, default=3, help="the Markdown table shows every n-th sample")
    ap.add_argument("--friction", type=float, default=None, help="the ground's friction (the scene's: 0.5)")
    ap.add_argument("--jelly", action="store_true", help="the first engine and speed's landing as jelly: its "
                    "energy kept (printed, not written)")
    ap.add_argument("--catch", action="store_true", help="taichi_mpm with the softening capped at d = 0.5 (the "
                    "law's check's catch); printed, not written")
    ap.add_argument("--plot", default="", help="also a PNG of the runs of --engines at --grid (a path)")
    a = ap.parse_args(argv)
    if a.jelly:
        for r in jelly_budget(a.engines.split(",")[0], a.grid, float(a.speeds.split(",")[0]), a.frames, a.rate):
            print(json.dumps({k: round(x, 4) for k, x in r.items()}))
        return 0
    if a.catch:
        from gasp_taichi_mpm.constitutive import Constitutive
        orig = capped_softening()
        try:
            rows = run("taichi_mpm", a.grid, float(a.speeds.split(",")[0]), a.frames, a.rate)
        finally:
            Constitutive.brittle_tau = orig
        print(json.dumps({"catch": "softening capped at d = 0.5", "law_excess": max(r["law_excess"] for r in rows),
                          "carried_max": max(r["carried_max"] for r in rows)}))
        return 0
    runs = json.loads(OUT.with_suffix(".json").read_text())["runs"] if OUT.with_suffix(".json").exists() else []
    for engine in a.engines.split(","):
        for v in (float(s) for s in a.speeds.split(",")):
            rows = run(engine, a.grid, v, a.frames, a.rate, friction=a.friction)
            key = (engine, a.grid, v, a.friction)
            runs = [r for r in runs if (r["engine"], r["n_grid"], r["speed"], r.get("friction")) != key]
            runs.append({"engine": engine, "n_grid": a.grid, "speed": v, "friction": a.friction, "rows": rows})
            last = rows[-1]
            print(json.dumps({"engine": engine, "speed": v, "broken": last["broken"], "top": last["top_broken"],
                              "dissipated": last["dissipated"], "cut_J": last["cut_J"]}), flush=True)
    OUT.with_suffix(".json").write_text(json.dumps({"runs": runs}, indent=0))
    lines = ["# Why the default brittle donut's cracks stop (`benchmarks/brittle_donut_arrest.py`)", "",
             "Energies in J (module notes). `G_f x ligament`: the work to finish cutting the two most broken 5-degree "
             "sections (at least 15 deg apart); one cut of the whole cross-section is `cut_J` below.", ""]
    for r in sorted(runs, key=lambda r: (r["engine"], r["n_grid"], r["speed"], r.get("friction") or -1)):
        rw = r["rows"]
        fr = "" if r.get("friction") is None else f", ground friction {r['friction']}"
        lines += [f"## {r['engine']}, n_grid {r['n_grid']}, landing {r['speed']} m/s (drop "
                  f"{r['speed'] ** 2 / (2 * G):.2f} m){fr}", "", cracks_text(rw[-1]), "",
                  f"Start {rw[0]['start']:.2f} J (kinetic + gravitational); one cut `G_f A` = {rw[0]['cut_J']:.3f} J;"
                  f" at the last sample the damage has dissipated {rw[-1]['dissipated']:.3f} J = "
                  f"{rw[-1]['dissipated'] / rw[0]['cut_J']:.1f} cuts, {rw[-1]['dissipated_top2']:.3f} J of it in the "
                  f"two most broken sections; {rw[-1]['sections_over_half']} of 72 sections over half broken through. "
                  f"Damaged (d > 0): {rw[-1]['damaged']:.2f} of the mass (median d {rw[-1]['partial_d_median']:.2f} "
                  f"where not broken through; {rw[-1]['dissipated_partial']:.3f} J dissipated there). The most broken "
                  f"section's ligament (not broken through) sits {rw[-1]['ligament_z'] * 1e3:.0f} mm above the "
                  f"donut's lowest point at rest (the section's mass centre: {rw[-1]['section_z'] * 1e3:.0f} mm). "
                  f"Law: the largest undamaged stress of a point not broken through over the stress that gave its d "
                  f"(at W = 1, an upper bound: at most 1 where the law holds), largest over the samples "
                  f"{max(w['law_excess'] for w in rw):.4f}; the largest stress carried "
                  f"{max(w['carried_max'] for w in rw):.3f} f_t. {grady(rw)}", ""] + table(rw, a.every) + [""]
    OUT.with_suffix(".md").write_text("\n".join(lines) + "\n")
    if a.plot:
        plot([r for r in runs if r["engine"] in a.engines.split(",") and r["n_grid"] == a.grid], a.plot)
    return 0


if __name__ == "__main__":
    sys.exit(main())
