"""The tension family at an angle to the grid (issue 66, "Tension, over a family", round 34): the family's specimens
(``benchmarks/tension_family.py``: the same material, pull, lattice spacing ``dx / 2`` cut to the specimen's shape by
``cut_cubes``, the same measures) with their axis ``a`` at an angle to the grid's x axis: rotated about z by 30 or 45
deg, or along (1, 1, 1) / sqrt(3) (``"111"``), the specimen's middle at the domain's centre.

**The holds a user can write.** A ``fixed_region`` holds the points that start inside its box, and a box ``Impulse``
of ``mode = "set"`` sets the velocity of the nodes inside its box (and moves its points with them); both boxes are
axis-aligned (``gasp_core.mpm.points.fixed_mask``, ``held_codes``; the engines' ghost nodes mirror across the box's
nearest face, ``MIRROR_CELLS``). No box's face can be normal to an oblique specimen's axis, so the ends are held as a
user would: the clamp is the half-space ``x <= c_clamp`` and the pull the half-space ``x >= c_pull`` at the velocity
``PULL a``, their faces placed so that every point within ``HOLD`` (0.1 m) of the specimen's end along its axis is
held (``c`` the largest/least x of the section at ``HOLD`` from the end). A face then crosses the specimen obliquely:
along the axis the held part runs from ``HOLD`` to ``HOLD`` plus the section's extent along x over ``a_x`` (0.087 m
for a 0.15 m section at 30 deg, 0.15 m at 45 deg), so the free length is shorter than the aligned bar's and an
oblique specimen needs to be longer for a gauge (the bar L0.7 a0.15 at 45 deg keeps none 1.5 cells from both faces).

**Free grips (round 40, ``--grip free``).** Those holds bend the gauge: each face crosses the section obliquely, so
the fibres at its two faces are held over lengths that differ by the section's thickness times ``tan(theta)``, and
the free length carries a transverse force and a moment (the continuum's gauge strain 0.899-1.104 of its median at 45
deg, ``oblique_grip.py``). ``grip="free"`` holds both ends by set boxes (the clamp's at rest) and drifts the pulled
one across the axis by the ``beta`` at which it carries no transverse force (docs/fracture.md "Round 40").

Measured in the specimen's frame, as ``tension_family.run_case`` does along x: a point's layer is its rest axial
coordinate's lattice layer; ``P_aa = a . P a``; a layer's position is its points' mean ``x . a``; the gauge is the
layers whose every point is more than 1.5 cells (along x, the faces' normal) from both faces (a dog-bone's: its
section within ``SECTION_TOL`` of the gauge's and free); ``held edge`` a free layer closer than that; ``dissipated``
takes each point's crack band weight along ``a`` (its principal direction).

Run: ``python benchmarks/tension_oblique.py --engine taichi_mpm --angles 30,45 --only bar_L0.9_a0.15`` (and
``--engine warp_mpm``); the cases are added to ``benchmarks/results/tension_oblique.json`` and the table
``tension_oblique.md`` is written from it. One engine per process.
"""
from __future__ import annotations

import json
import time
from pathlib import Path

import numpy as np

import crack_place as cp
import tension_family as tf

RESULTS = Path(__file__).parent / "results"
CENTRE = np.full(3, tf.SIZE / 2)
#: the oblique family: the bars that keep a gauge at 30 and 45 deg, and the 1.5:1 dog-bone
SPECIMENS = {sp.name: sp for sp in tf.FAMILY}


def axis_frame(angle: str) -> np.ndarray:
    """The rotation ``R`` (3, 3) taking the specimen's frame (axis e_x, section e_y, e_z) to the grid's: about z by
    ``angle`` deg, or (``"111"``) the least rotation taking e_x to (1, 1, 1) / sqrt(3) (Rodrigues)."""
    if angle == "111":
        a = np.ones(3) / np.sqrt(3)
        k = np.cross([1.0, 0, 0], a)
        sn, c = np.linalg.norm(k), a[0]
        k /= sn
        K = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
        return np.eye(3) + sn * K + (1 - c) * K @ K
    t = np.radians(float(angle))
    return np.array([[np.cos(t), -np.sin(t), 0], [np.sin(t), np.cos(t), 0], [0, 0, 1]])


def local_lattice(sp: tf.Specimen, s: float) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The specimen's lattice in its own frame, as ``tension_family.build`` makes it along x (``cut_cubes``):
    ``(x (n, 3) with the axis from 0 and the section about 0, p_vol (n,), layer (n,), layer rest axial (nl,))``."""
    nx = int(round(sp.length / s))
    lx = tf.X0 + (np.arange(nx) + 0.5) * s
    ny = int(np.ceil(sp.grip / (2 * s) - 1e-9))
    half = sp.grip / 2 if abs(sp.grip / 2 - ny * s) < 1e-9 else ny * s
    ly = tf.Y0 - half + (np.arange(2 * ny) + 0.5) * s
    X, Yg, Zg = np.meshgrid(lx, ly, ly, indexing="ij")
    x = np.stack([X.ravel(), Yg.ravel(), Zg.ravel()], axis=1)
    x, p_vol = tf.cut_cubes(x, sp.width(x[:, 0]), sp.thickness(x[:, 0]), s)
    layer = np.round((x[:, 0] - tf.X0) / s - 0.5).astype(int)
    x = x - np.array([tf.X0, tf.Y0, tf.Y0])
    if sp.flat:                  # a dog-bone's width along z: across the plane it turns in, its thickness in it
        x = x[:, [0, 2, 1]]
    return x, p_vol, layer, lx - tf.X0


def build(sp: tf.Specimen, n_grid: int, engine: str, angle: str = "45", grip: str = "along"):
    """The oblique setup (the module's docstring). ``grip``: ``"along"`` (round 34) holds the clamp's half-space by a
    ``fixed_region`` and pulls along the axis ``a``; ``"free"`` (round 40) holds both ends alike, by set boxes, the
    clamp's at rest and the pulled one along ``a + beta n`` (``n = R e_y``, in the plane it turns in), ``beta`` the
    drift at which the pulled grip carries no transverse force in the elastic continuum (``oblique_grip.free_drift``),
    the body starting in that continuum's quasi-static field (``oblique_grip.static_velocity``). Returns ``(setup,
    layer of each point, layer rest axial (m from the end), R, clamp face x, pulled face x)``. Raises ValueError on
    another ``grip``."""
    from gasp_core.colliders.model import Impulse
    from gasp_core.seam.setup import Boundary, Material
    from gasp_core.testing.helpers import make_setup
    dx = tf.SIZE / n_grid
    xl, p_vol, layer, lx = local_lattice(sp, dx / 2)
    R = axis_frame(angle)
    mid = np.array([sp.length / 2, 0.0, 0.0])
    to_grid = lambda q: CENTRE + (q - mid) @ R.T              # noqa: E731
    x = to_grid(xl)
    a = R[:, 0]
    if grip not in ("along", "free") or (grip == "free" and angle == "111"):
        raise ValueError(f"grip {grip!r} at {angle}: 'along', or 'free' about z (its drift is solved in that plane)")
    from oblique_grip import free_drift, static_velocity
    beta = free_drift(sp, angle, n_grid) if grip == "free" else 0.0
    a_pull = a + beta * R[:, 1]
    # the faces: every point within HOLD of an end along the axis is held (the section's corners at HOLD)
    ext = np.abs(xl[:, 1:]).max(axis=0)                    # the section's half extents at its widest
    corners = np.array([[0, sy * ext[0], sz * ext[1]] for sy in (-1, 1) for sz in (-1, 1)])
    clamp = float(to_grid(corners + [tf.HOLD, 0, 0])[:, 0].max())
    pulled = float(to_grid(corners + [sp.length - tf.HOLD, 0, 0])[:, 0].min())
    # the quasi-static stretch of the pull along the axis, between the faces' crossings of the axis
    s_c, s_p = [float((f - to_grid(np.zeros(3))[0]) / a[0]) for f in (clamp, pulled)]
    comp = np.cumsum(1.0 / sp.area(lx + tf.X0))
    c_cl, c_pu = np.interp([s_c, s_p], lx, comp)
    v = pull_velocity(a_pull) * np.clip((comp[layer] - c_cl) / (c_pu - c_cl), 0.0, 1.0)[:, None]
    if grip == "free":           # the elastic solution's quasi-static field (no bending wave started by the ramp)
        vs = static_velocity(sp, angle, n_grid, beta, xl)
        v = vs[:, :1] * a + vs[:, 1:] * R[:, 1]
    m = Material("brittle", E=tf.E, nu=tf.NU, rho=tf.RHO, tensile_strength=tf.FT, fracture_energy=tf.GF)
    opts = {"precision": "f64", **({"threads": 1} if engine == "taichi_mpm" else {})}
    S = tf.SIZE
    held = [] if grip == "free" else [Boundary("fixed_region", lo=(0, 0, 0), hi=(clamp, S, S))]
    st = make_setup(x, p_vol, m, v=v, gravity=(0, 0, 0), lo=(0, 0, 0), hi=(S, S, S), n_grid=n_grid,
                    frame_dt=tf.FRAME_DT, boundaries=held, options=opts)
    st.impulses = [Impulse("box", tuple(pull_velocity(a_pull)), 0.0, 100.0, lo=(pulled, 0, 0), hi=(S, S, S),
                           mode="set")]
    if grip == "free":           # the clamp held as the pulled grip is: a set box at rest
        st.impulses.append(Impulse("box", (0.0, 0.0, 0.0), 0.0, 100.0, lo=(0, 0, 0), hi=(clamp, S, S), mode="set"))
    return st, layer, lx, R, clamp, pulled


def pull_velocity(a: np.ndarray) -> np.ndarray:
    """The pulled end's velocity (m/s, (3,)): ``PULL`` along the axis ``a``."""
    return tf.PULL * np.asarray(a, np.float64)


def nominal(F: np.ndarray, d: np.ndarray) -> np.ndarray:
    """The brittle model's nominal stress ``P = tau F^-T`` (Pa, (n, 3, 3)) at ``F`` (n, 3, 3), ``d`` (n,); nu 0."""
    U, sig, _ = np.linalg.svd(F)
    s = tf.E * np.log(np.clip(sig, 1e-9, None))
    s = np.where(s > 0, (1 - d[:, None]) * s, s)
    tau = np.einsum("nij,nj,nkj->nik", U, s, U)
    return np.einsum("nij,nkj->nik", tau, np.linalg.inv(F))


def layer_reach(x0: np.ndarray, layer: np.ndarray, nl: int, clamp: float, pulled: float) -> np.ndarray:
    """Each layer's least distance (m, along x) of its points' rest positions ``x0`` (n, 3) from the nearer face
    (negative: some of it held)."""
    dist = np.minimum(x0[:, 0] - clamp, pulled - x0[:, 0])
    out = np.full(nl, np.inf)
    np.minimum.at(out, layer, dist)
    return out


def frames(st, layer, angle_case) -> dict:
    """Step the engine until a layer has been at ``d = 1`` throughout for ``tf.AFTER`` frames (or ``n``): per frame
    each layer's force ``sum P_aa`` (N), mean axial position (m), mean ``d``; whether any layer is broken through
    (``d >= 0.9``) and opened (``d = 1``). ``angle_case``: ``(engine, a (3,), count (nl,), wgt (n,), n frames)``."""
    from gasp_core.seam.build import build_engine
    from gasp_core.seam.plugins import engines
    engine, a, count, wgt, n_frames = angle_case
    s, nl = st.dx / 2, len(count)
    e = build_engine(engines()[tf.name_check(engine)], st)
    force, pos, dmean, thru, opened = [], [], [], [], []
    t0 = time.time()
    try:
        for _ in range(n_frames):
            e.step_frame()
            F = np.asarray(e.to_setup_order(e.get_state()["F"]), np.float64)
            d = np.asarray(e.damage(), np.float64)
            xs = np.asarray(e.positions(), np.float64)
            Paa = np.einsum("i,nij,j->n", a, nominal(F, d), a)
            force.append(np.bincount(layer, Paa * wgt, nl) * s * s)
            pos.append(np.bincount(layer, (xs @ a) * wgt, nl) / np.maximum(count, 1e-12))
            dmean.append(np.bincount(layer, d * wgt, nl) / np.maximum(count, 1e-12))
            thru.append(bool(np.any(np.bincount(layer, (d >= 0.9) * wgt, nl) >= count * (1 - 1e-9))))
            opened.append(bool(np.any(np.bincount(layer, (d >= 1.0) * wgt, nl) >= count * (1 - 1e-9))))
            if len(opened) > tf.AFTER and opened[-tf.AFTER]:
                break
    finally:
        e.close()
    return {"force": np.array(force), "pos": np.array(pos), "dmean": np.array(dmean), "thru": np.array(thru),
            "d": d, "xs": xs, "seconds": time.time() - t0}


def run_case(sp: tf.Specimen, n_grid: int, engine: str, angle: str = "45", build_fn=build,
             grip: str = "along") -> dict:
    """One oblique specimen on one engine at one grid: ``tension_family.run_case``'s figures along the axis;
    ``grip``: :func:`build`'s (``"free"`` passed on to ``build_fn``)."""
    extra = {"grip": grip} if grip != "along" else {}
    st, layer, lx, R, clamp, pulled = build_fn(sp, n_grid, engine, angle, **extra)
    dx, s, a, nl = st.dx, st.dx / 2, R[:, 0], len(lx)
    wgt = np.asarray(st.p_vol, np.float64) / s ** 3
    count = np.bincount(layer, wgt, nl)
    a_gauge = float(sp.gauge_w ** 2)
    reach = layer_reach(np.asarray(st.x, np.float64), layer, nl, clamp, pulled)
    free = reach > 0
    section = sp.area(lx + tf.X0) / a_gauge - 1
    gauge = (reach > 1.5 * dx) & (section <= tf.SECTION_TOL if sp.gauge_l > 0 else True)
    if not gauge.any():
        raise ValueError(f"{sp.name} at {angle} deg, n_grid {n_grid}: no layer 1.5 cells from both faces")
    free_len = float(np.ptp(lx[free])) + s          # the free length along the axis, its longest
    t_peak = (tf.FT / tf.E) * free_len * (sp.gauge_w ** 2 / sp.area(lx + tf.X0)[free]).max() / tf.PULL
    n_frames = int(np.ceil((t_peak + 1.5 * 2 * tf.GF / tf.FT / tf.PULL) / tf.FRAME_DT))
    out = frames(st, layer, (engine, a, count, wgt, n_frames))
    force, pos, dmean, broken = out["force"], out["pos"], out["dmean"], out["thru"]
    k_end = int(np.argmax(broken)) if broken.any() else len(force)
    sig_g = np.median(force[:, gauge], axis=1) / a_gauge
    peak = float(sig_g[:max(k_end, 1)].max())
    crack = cp.crack_layer(dmean, free)      # the free layer first at the most damage
    where = "gauge" if gauge[crack] else ("held edge" if reach[crack] < 1.5 * dx else "grip")
    span = np.flatnonzero(free & (np.abs(lx - lx[crack]) <= 2 * dx + 1e-9))
    area = count * s * s
    elastic = (force[:, span[:-1]] / area[span[:-1]] / tf.E * np.diff(lx[span])).sum(axis=1)
    w = pos[:, span[-1]] - pos[:, span[0]] - (lx[span[-1]] - lx[span[0]]) - elastic
    sig_c = force[:, crack] / a_gauge
    work = float(np.sum(0.5 * (sig_c[1:] + sig_c[:-1]) * np.diff(w)))
    sf = point_sf(st, out["xs"], engine, a)
    d = out["d"]
    Dp = np.asarray(st.p_vol) * tf.FT ** 2 * sf * d / (2 * tf.E * ((1 - d) * (sf - tf.FT) + tf.FT))
    D = np.bincount(layer, Dp, nl) / a_gauge
    g = lx[gauge]
    return {"specimen": sp.name, "engine": engine, "n_grid": n_grid, "angle": angle, "axis": a.round(6).tolist(),
            "band": "projected" if oblique(engine) else "dx", "grip": grip,
            "dx": dx, "cells_across": sp.gauge_w / dx, "points": int(len(st.x)), "frames": n_frames,
            "seconds": round(out["seconds"], 1), "peak": peak, "peak_vs_ft": peak / tf.FT - 1,
            "crack_s": float(lx[crack]), "where": where, "section_at_crack": float(section[crack]),
            "clamp_face": clamp, "pulled_face": pulled, "gauge": [float(g.min()), float(g.max())],
            "work": work, "work_vs_gf": work / tf.GF - 1, "dissipated": float(D[span].sum()),
            "dissipated_everywhere": float(D.sum()), "broken_through": bool(broken.any()),
            "final_stress": float(sig_g[-1]), "frames_run": len(force),
            "damaged_layers": [[round(float(lx[k]), 4), round(float(dmean[-1][k]), 3), round(float(D[k]), 3)]
                               for k in np.flatnonzero(dmean[-1] > 0.05)]}


def point_sf(st, xs: np.ndarray, engine: str, a: np.ndarray) -> np.ndarray:
    """``tension_family.point_sf`` with the crack normal along the specimen's axis ``a`` (3,), and the band's
    projection on it where the engine's ``oblique_band`` is on (``gasp_core.mpm.materials.band_projection``)."""
    from gasp_core.mpm.materials import band_projection, band_softening_stress, band_weight, softening_stress
    sf = softening_stress(st.materials[0], float(st.crack_band[0]))
    if not tf.weighted(engine):
        return np.full(len(xs), sf)
    if oblique(engine) and sf / band_projection(a) > tf.FT:
        sf = sf / float(band_projection(a))
    X = (xs - np.asarray(st.domain_lo, np.float64)) / st.dx
    return band_softening_stress(tf.FT, sf, band_weight(X - np.floor(X - 0.5), np.asarray(a, np.float64)))


def oblique(engine: str) -> bool:
    """Whether ``engine``'s band projection (round 34) is on."""
    if engine == "taichi_mpm":
        from gasp_taichi_mpm.constitutive import Constitutive
        return bool(Constitutive.oblique_band)
    from gasp_warp_mpm.held_rule import HeldRule
    return bool(HeldRule.oblique_band)


def projected(engine: str, on: bool) -> None:
    """Turn ``engine``'s band projection (round 34, ``oblique_band``; off by default) on or off in this process."""
    if engine == "taichi_mpm":
        from gasp_taichi_mpm.constitutive import Constitutive
        Constitutive.oblique_band = on
    else:
        from gasp_warp_mpm.held_rule import HeldRule
        HeldRule.oblique_band = on


def _key(r: dict) -> tuple:
    return r["specimen"], r["angle"], r.get("band", "dx"), r.get("grip", "along"), r["engine"], r["n_grid"]


def table(rows: list[dict]) -> str:
    """The Markdown table of the oblique cases."""
    out = ["| specimen | angle | band | grip | engine | n_grid | peak / f_t | breaks at (axial m) | gauge (axial m) | "
           "where | work to separate (J/m^2) | vs G_f | N to 2N | dissipated (J/m^2) | s |",
           "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    by = {_key(r): r for r in rows}
    for r in sorted(rows, key=_key):
        twin = by.get(_key(r)[:5] + (r["n_grid"] // 2,))
        conv = f"{100 * (r['work'] / twin['work'] - 1):+.1f} %" if twin else ""
        out.append(f"| {r['specimen']} | {r['angle']} | {r.get('band', 'dx')} | {r.get('grip', 'along')} | "
                   f"{r['engine']} | {r['n_grid']} | "
                   f"{r['peak'] / tf.FT:.3f} ({100 * r['peak_vs_ft']:+.1f} %) | {r['crack_s']:.3f} | "
                   f"{r['gauge'][0]:.3f}-{r['gauge'][1]:.3f} | {r['where']} | {r['work']:.1f} | "
                   f"{100 * r['work_vs_gf']:+.1f} % | {conv} | {r['dissipated']:.1f} | {r['seconds']:.0f} |")
    return "\n".join(out) + "\n"


def main() -> None:
    ap = tf.family_parser("bar_L0.9_a0.15")
    ap.add_argument("--angles", default="30,45", help="comma-separated: degrees about z, or 111")
    ap.add_argument("--projected", action="store_true", help="the band's projection on (round 34, off by default)")
    ap.add_argument("--grip", default="along", choices=["along", "free"],
                    help="along: a fixed_region and a pull along the axis (round 34); free: both ends set boxes, the "
                         "pulled one drifting across the axis so it carries no transverse force (round 40)")
    a = ap.parse_args()
    projected(a.engine, a.projected)
    RESULTS.mkdir(exist_ok=True)
    path = RESULTS / "tension_oblique.json"
    rows = json.loads(path.read_text())["cases"] if path.exists() else []
    for name in a.only.split(","):
        for angle in a.angles.split(","):
            for n in tf.grids(a):
                r = run_case(SPECIMENS[name], n, a.engine, angle, grip=a.grip)
                print(json.dumps({k: v for k, v in r.items() if k != "damaged_layers"}), flush=True)
                rows = tf.save_case(path, rows, r, _key)
    write_md(rows)


def write_md(rows: list[dict]) -> None:
    """``results/tension_oblique.md`` from the cases ``rows``."""
    (RESULTS / "tension_oblique.md").write_text(
        "# Tension at an angle to the grid (issue 66, round 34)\n\n`python benchmarks/tension_oblique.py` (docstring: "
        "the holds and the measures, in the specimen's frame). The family's material and pull "
        "(`tension_family.py`); angle: the axis about z in degrees, or 111 along (1, 1, 1) / sqrt(3). \"gauge\": the "
        "layers 1.5 cells (along x) from both held faces, a dog-bone's within 2 % of its gauge's section. band: dx "
        "(the default) or projected (`--projected`: the band the cell's projection on the crack's normal, the engines' "
        "`oblique_band`). grip: along (round 34: a `fixed_region` and a set box pulled along the axis) or free "
        "(`--grip free`, round 40: both ends set boxes, the pulled one drifting across the axis by `oblique_grip.py`'s "
        "`beta` so it carries no transverse force).\n\n"
        + table(rows))


if __name__ == "__main__":
    main()
