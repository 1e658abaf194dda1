"""The oblique tension family built the way a user builds it (issue 66 item 2, round 36): the specimens of
``benchmarks/tension_oblique.py`` (the flat dog-bones 2:1 and 1.5:1 with their width along z, the bar L0.9 a0.15)
turned about z by 30 or 45 deg, but made through the scene as ``benchmarks/user_tension.py`` makes the aligned ones:

- the mesh is ``user_tension.specimen_mesh``'s (the aligned specimen's closed PLY), turned by the object's
  ``rotation = [90, 0, angle]`` in the scene (a flat dog-bone's width from y onto z, then the angle about z; a bar
  ``[0, 0, angle]``), its bounding box's bottom centre placed so that its middle is at the domain's centre;
- Gaussians laid on its faces, the ``default`` level's fill: a WORLD-aligned lattice of ``h = dx / 4^(1/3)``
  (``gasp_core.maps.fill``), the surface rule's passive vertices;
- held as ``tension_oblique.build`` holds it, with what a user writes: a ``fixed_region`` over the half-space ``x <=
  c`` and one ``[[impulse]] mode = "set"`` over ``x >= c'`` at ``PULL a`` (``a`` the axis), ``ramp = 0.1`` s (the
  faces through the section's corners at ``HOLD`` from the ends, then on the nearest node: :func:`faces`).

Measured along the axis as ``tension_oblique.run_case`` does: a layer is a slab of the rest axial ``s = (x - c) . a
+ L / 2`` ``LAYER`` cells wide (``dx / 2``); its force the volume mean of ``P_aa = a . P a`` times the section (the
fill's slabs at an angle hold one or two of its planes: their volume swings, the mean does not); its position the
volume mean of ``x . a``; the gauge, ``where``, the work and ``dissipated`` as there. ``spread``: when the gauge's
median stress first reaches ``SPREAD_AT`` f_t, its points' largest principal stress over their mean (percentiles,
extremes); ``--lattice``: the same on ``tension_oblique.build``'s rotated lattice.

Round 44: ``--constrain along`` writes the pull's set box with ``constrain = "along"`` (it imposes only the velocity
along the axis: a grip free across its pull, docs/colliders.md), ``--clamp set`` the clamp as a set box at rest
(every component held) instead of the ``fixed_region``. The work to separate is read on the fill's x planes where no
axial layer breaks through and an x plane does (``work_on``; ``benchmarks/crack_layers.py``: at 30 deg the crack runs
along them), else on the axial layers as before; ``work_axial`` and ``work_x`` keep both readings.

Run: ``python benchmarks/user_oblique.py --engine taichi_mpm`` (and ``warp_mpm``; ``--only``, ``--angles``,
``--n-grid``, ``--coarse-only``, ``--faces``, ``--start``, ``--lattice``, ``--constrain``, ``--clamp``); cases are
added to ``benchmarks/results/user_oblique.json`` and ``user_oblique.md`` is written from it. One engine per process.
"""
from __future__ import annotations

import json
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import crack_layers as cl       # noqa: E402
import tension_family as tf      # noqa: E402
import tension_oblique as to     # noqa: E402
import user_tension as ut        # noqa: E402
from gauge_spread import SPREAD_AT, lattice_spread, principal, spread_of   # noqa: E402,F401

RESULTS = Path(__file__).parent / "results"
SPECIMENS = {n: to.SPECIMENS[n] for n in ("dogbone_2to1", "dogbone_1.5to1", "bar_L0.9_a0.15")}
LAYER = 0.5         # a layer's width along the axis, cells (SPECIMENS: the flat dog-bones; the bar keeps a gauge)
FACES = "nearest"   # the held faces on the nearest node (faces: "nearest", "out" or "corners")
CONSTRAIN = "all"   # the set box's constrain key (round 44: "along", a grip free across its pull)
CLAMP = "fixed"     # the clamp: a fixed_region ("fixed") or a set box at rest ("set", round 44)


def section_half(sp: tf.Specimen) -> np.ndarray:
    """The widest section's half extents (m, (2,)) across the turning plane and along z (the width, if flat)."""
    return np.array([sp.gauge_w / 2, sp.grip / 2]) if sp.flat else np.array([sp.grip / 2, sp.grip / 2])


def faces(sp: tf.Specimen, angle: str, dx: float) -> tuple[float, float]:
    """The clamp's and the pulled box's faces (x, m): through the section's corners at ``HOLD`` from each end
    (``tension_oblique.build``'s), then (``FACES``) on the grid's nodes (spacing ``dx``, m) as ``user_tension``'s:
    ``"nearest"`` (a user's rounding: the held corner within half a cell of ``HOLD``), ``"out"`` (the next node
    outward: all within ``HOLD`` held) or ``"corners"`` (off the nodes; docs/fracture.md, round 36)."""
    R = to.axis_frame(angle)
    ey, ez = section_half(sp)
    corners = np.array([[0.0, sy * ey, sz * ez] for sy in (-1, 1) for sz in (-1, 1)])
    at = lambda s: to.CENTRE + (corners + [s - sp.length / 2, 0.0, 0.0]) @ R.T    # noqa: E731
    clamp, pulled = float(at(tf.HOLD)[:, 0].max()), float(at(sp.length - tf.HOLD)[:, 0].min())
    if FACES == "corners":
        return clamp, pulled
    if FACES == "out":
        return float(np.ceil(clamp / dx - 1e-9) * dx), float(np.floor(pulled / dx + 1e-9) * dx)
    return float(np.round(clamp / dx) * dx), float(np.round(pulled / dx) * dx)


def scene_toml(sp: tf.Specimen, n_grid: int, engine: str, mesh: str, angle: str, ramp: float = ut.RAMP_S) -> str:
    """The scene a user writes for ``sp`` at ``angle`` deg about z: the family's domain, material and pull (the set
    box's ``ramp``, s; 0: none), no gravity; the mesh turned by ``rotation``, held and pulled by x half-spaces
    (:func:`faces`)."""
    clamp, pulled = faces(sp, angle, tf.SIZE / n_grid)
    v = [float(c) for c in to.pull_velocity(to.axis_frame(angle)[:, 0])]
    rot = [90.0 if sp.flat else 0.0, 0.0, float(angle)]
    z0 = float(to.CENTRE[2] - section_half(sp)[1])
    S = tf.SIZE
    head = ut.scene_head(engine, n_grid, 0.0, clamp)
    if CLAMP == "set":   # the clamp's half-space as a set box at rest (every component held at 0)
        head = head[:head.index("[[boundary]]")] + f"""[[impulse]]
shape = "box"
lo = [0.0, 0.0, 0.0]
hi = [{clamp!r}, {S}, {S}]
velocity_change = [0.0, 0.0, 0.0]
t0 = 0.0
t1 = 100.0
mode = "set"
"""
    return head + f"""[[impulse]]
shape = "box"
lo = [{pulled!r}, 0.0, 0.0]
hi = [{S}, {S}, {S}]
velocity_change = [{v[0]!r}, {v[1]!r}, {v[2]!r}]
t0 = 0.0
t1 = 100.0
mode = "set"
ramp = {float(ramp)!r}
{'constrain = "along"' + chr(10) if CONSTRAIN == "along" else ""}[[object]]
mesh = "{mesh}"
up_axis = "+z"
rotation = {rot}
position = [{to.CENTRE[0]}, {to.CENTRE[1]}, {z0!r}]
""" + ut.MATERIAL_ROWS


def prepare(sp: tf.Specimen, n_grid: int, engine: str, angle: str, folder: Path | None = None,
            ramp: float = ut.RAMP_S):
    """Write ``sp``'s mesh and its scene at ``angle`` (:func:`scene_toml`) into ``folder`` (default: a temporary
    one) and prepare it. Returns the ``PreparedScene`` and the (aligned) mesh."""
    if folder is None:
        with tempfile.TemporaryDirectory(prefix="user_oblique_") as tmp:
            return prepare(sp, n_grid, engine, angle, Path(tmp), ramp)
    from gasp_core.prepare.scene import prepare_scene
    from gasp_core.scene.spec import load_scene
    mesh = ut.specimen_mesh(sp, n_grid)
    mesh.export(Path(folder) / f"{sp.name}.ply")
    path = Path(folder) / f"{sp.name}.toml"
    path.write_text(scene_toml(sp, n_grid, engine, f"{sp.name}.ply", angle, ramp))
    return prepare_scene(load_scene(path), engine), mesh


def layers(x0: np.ndarray, p_vol: np.ndarray, a: np.ndarray, L: float, w: float):
    """Each point's axial layer (n,) (-1: no volume), the layers' rest axial coordinate (volume mean, m from the
    specimen's end, (k,)), their volumes (k,) and each point's rest ``s`` (n,): slabs of ``s`` ``w`` wide."""
    s, mat = (x0 - to.CENTRE) @ a + L / 2, p_vol > 0
    keys, inv = np.unique(np.floor(s[mat] / w).astype(int), return_inverse=True)
    layer = np.full(len(s), -1)
    layer[mat] = inv
    vol = np.bincount(inv, p_vol[mat], len(keys))
    return layer, np.bincount(inv, s[mat] * p_vol[mat], len(keys)) / vol, vol, s


def record(e, pv, layer, gauge, frame_args) -> dict:
    """Step ``e`` up to ``n`` frames (until ``tf.AFTER`` frames after a layer is at ``d = 1``): per frame each
    layer's force (N: mean ``P_aa`` times ``area``), mean axial position, mean ``d``; broken through (``d >= 0.9``)
    and opened; the gauge points' spread (:func:`spread_of`) when its median stress first reaches ``SPREAD_AT`` f_t;
    ``diverged``: the engine's ``EngineDivergence`` that stopped it, if one did. ``frame_args``: ``(a (3,), area
    (k,), vol (k,), n, xl (n,), h)``: ``force_x``, ``pos_x``, ``dmean_x`` the same on the fill's x planes ``xl``
    (``crack_layers.x_planes``, ``h`` wide: force ``sum (a . P e_x) V / h``)."""
    from gasp_core.errors import EngineDivergence
    a, area, vol, n, xl, h = frame_args
    nl, li, mat = len(vol), np.maximum(layer, 0), layer >= 0
    pw, xli = np.where(mat, pv, 0.0), np.maximum(xl, 0)
    nx, vol_x = int(xl.max()) + 1, np.bincount(xli, np.where(mat, pv, 0.0), int(xl.max()) + 1)
    out = {k: [] for k in ("force", "pos", "dmean", "thru", "opened", "force_x", "pos_x", "dmean_x")}
    spread = diverged = None
    for _ in range(n):
        try:
            e.step_frame()
        except EngineDivergence as err:
            diverged = str(err)
            break
        F = np.asarray(e.to_setup_order(e.get_state()["F"]), np.float64)
        d = np.asarray(e.damage(), np.float64)
        xs = np.asarray(e.positions(), np.float64)
        Paa, Pax, P = np.zeros(len(pv)), np.zeros(len(pv)), to.nominal(F[mat], d[mat])
        Paa[mat], Pax[mat] = np.einsum("i,nij,j->n", a, P, a), P[:, :, 0] @ a
        mean = np.bincount(li, Paa * pw, nl) / vol
        out["force"].append(mean * area)
        out["pos"].append(np.bincount(li, (xs @ a) * pw, nl) / vol)
        out["dmean"].append(np.bincount(li, d * pw, nl) / vol)
        out["force_x"].append(np.bincount(xli, Pax * pw, nx) / h)
        out["pos_x"].append(np.bincount(xli, (xs @ a) * pw, nx) / np.maximum(vol_x, 1e-300))
        out["dmean_x"].append(np.bincount(xli, d * pw, nx) / np.maximum(vol_x, 1e-300))
        out["thru"].append(bool(np.any(np.bincount(li, (d >= 0.9) * pw, nl) >= vol * (1 - 1e-9))))
        out["opened"].append(bool(np.any(np.bincount(li, (d >= 1.0) * pw, nl) >= vol * (1 - 1e-9))))
        level = float(np.median(mean[gauge])) / tf.FT
        if spread is None and level >= SPREAD_AT:
            spread = spread_of(F, pv, mat & gauge[li], level)
        if len(out["opened"]) > tf.AFTER and out["opened"][-tf.AFTER]:
            break
    out = {k: np.array(v) for k, v in out.items()}
    out.update(d=d, xs=xs, spread=spread, diverged=diverged)
    return out


def stretch(sp: tf.Specimen, x: np.ndarray, a: np.ndarray, clamp: float, pulled: float) -> np.ndarray:
    """``tension_oblique.build``'s quasi-static start (m/s, (n, 3)) at rest positions ``x`` (n, 3): ``PULL a`` times
    the share of the compliance ``int ds / A`` between the faces' crossings of the axis and the point's ``s``."""
    xs, comp = ut._compliance(sp)
    s = (x - to.CENTRE) @ a + sp.length / 2 + tf.X0
    s_c, s_p = [(f - to.CENTRE[0]) / a[0] + sp.length / 2 + tf.X0 for f in (clamp, pulled)]
    c_cl, c_pu = np.interp([s_c, s_p], xs, comp)
    return to.pull_velocity(a) * np.clip((np.interp(s, xs, comp) - c_cl) / (c_pu - c_cl), 0.0, 1.0)[:, None]


def geometry(ps, mesh, sp: tf.Specimen, angle: str) -> dict:
    """A prepared specimen's layers (:func:`layers`), their sections (m^2), reach from the faces, free and gauge
    masks, and the fill's figures: ``mass_vs_mesh`` (sum ``p_vol`` over the mesh's volume, less 1),
    ``gauge_section`` (the fill's volume over the gauge's slabs, empty ones too, over ``int A ds`` there, less 1),
    ``centre_offset_mm`` (the fill's centroid from the domain's centre)."""
    st = ps.setup
    dx, a = st.dx, to.axis_frame(angle)[:, 0]
    x0, pv = np.asarray(st.x, np.float64), np.asarray(st.p_vol, np.float64)
    w = LAYER * dx
    layer, lx, vol, s = layers(x0, pv, a, sp.length, w)
    clamp, pulled = faces(sp, angle, dx)
    reach = to.layer_reach(x0[layer >= 0], layer[layer >= 0], len(lx), clamp, pulled)
    area = sp.area(lx + tf.X0)
    section = area / sp.gauge_w ** 2 - 1
    gauge = (reach > 1.5 * dx) & (section <= tf.SECTION_TOL if sp.gauge_l > 0 else True)
    if not gauge.any():
        raise ValueError(f"{sp.name} at {angle} deg, dx {dx:g}: no layer 1.5 cells from both faces")
    centroid, k = (x0 * pv[:, None]).sum(axis=0) / pv.sum(), np.floor(s / w)
    kg = k[(layer >= 0) & gauge[np.maximum(layer, 0)]]
    q = np.linspace(kg.min() * w, (kg.max() + 1) * w, 401)
    return {"a": a, "pv": pv, "w": w, "layer": layer, "lx": lx, "vol": vol, "area": area, "section": section,
            "reach": reach, "free": reach > 0, "gauge": gauge, "clamp": clamp, "pulled": pulled,
            "fill": {"mass_vs_mesh": float(pv.sum() / mesh.volume - 1),
                     "gauge_section": float(pv[(k >= kg.min()) & (k <= kg.max())].sum()
                                            / np.trapezoid(sp.area(q + tf.X0), q) - 1),
                     "centre_offset_mm": float(1e3 * np.linalg.norm(centroid - to.CENTRE))}}


def run_case(sp: tf.Specimen, n_grid: int, engine: str, angle: str, start: str = "ramp") -> dict:
    """One oblique specimen built through the scene, on one engine at one grid: ``tension_oblique.run_case``'s
    figures along the axis, the fill's (:func:`geometry`) and the gauge points' spread. ``start``: ``"ramp"`` (at
    rest, the set box ramped over ``RAMP_S``) or ``"stretch"`` (one set box at ``PULL a`` from t = 0, the setup's
    ``v`` set after ``prepare_scene`` to ``tension_oblique.build``'s quasi-static stretch: no scene key gives it)."""
    from gasp_core.seam.build import build_engine
    if start not in ("ramp", "stretch"):
        raise ValueError(f"start must be 'ramp' or 'stretch', got {start!r}")
    ps, mesh = prepare(sp, n_grid, engine, angle, ramp=ut.RAMP_S if start == "ramp" else 0.0)
    st, geo = ps.setup, geometry(ps, mesh, sp, angle)
    dx, (a, pv, w, layer, lx, vol, area, section, reach, free, gauge, clamp, pulled) = st.dx, (geo[k] for k in (
        "a", "pv", "w", "layer", "lx", "vol", "area", "section", "reach", "free", "gauge", "clamp", "pulled"))
    nl, a_gauge = len(lx), float(sp.gauge_w ** 2)
    free_len = float(np.ptp(lx[free])) + w
    t_peak = (tf.FT / tf.E) * free_len * (a_gauge / area[free]).max() / tf.PULL + (start == "ramp") * ut.RAMP_S / 2
    if start == "stretch":
        st.v = stretch(sp, np.asarray(st.x, np.float64), a, clamp, pulled)
    n_frames = int(np.ceil((t_peak + 1.5 * 2 * tf.GF / tf.FT / tf.PULL) / tf.FRAME_DT))
    e = build_engine(ps.info, st)
    t0 = time.time()
    h = dx / ps.scene.domain.particles_per_cell ** (1 / 3)
    xl = cl.x_planes(np.asarray(st.x, np.float64), pv, h)
    try:
        out = record(e, pv, layer, gauge, (a, area, vol, n_frames, xl, h))
    finally:
        e.close()
    force, pos, dmean, broken = out["force"], out["pos"], out["dmean"], out["thru"]
    k_end = int(np.argmax(broken)) if broken.any() else len(force)
    sig_g = np.median(force[:, gauge], axis=1) / a_gauge
    crack, span = cl.crack_zone(dmean, lx, free, dx)
    where = "gauge" if gauge[crack] else ("held edge" if reach[crack] < 1.5 * dx else "grip")
    work = work_axial = cl.work_to_separate(force, pos, lx, area, crack, span, a_gauge)
    d = out["d"]
    sf = to.point_sf(st, out["xs"], engine, a)
    Dp = np.where(layer >= 0, pv * tf.FT ** 2 * sf * d / (2 * tf.E * ((1 - d) * (sf - tf.FT) + tf.FT)), 0.0)
    D = np.bincount(np.maximum(layer, 0), Dp, nl) / a_gauge
    dissipated, on = float(D[span].sum()), "axial"
    x = cl.x_plane_work(out, xl, (pv, np.asarray(st.x, np.float64), a, d, Dp), sp, dx, (clamp, pulled))
    if not broken.any() and x is not None:     # the crack across the axial layers, through an x plane: read there
        work, dissipated, on = *x, "x planes"
    g = lx[gauge]
    return {"specimen": sp.name, "engine": engine, "n_grid": n_grid, "angle": angle, "start": start,
            "faces": FACES, "constrain": CONSTRAIN + ("" if CLAMP == "fixed" else f", clamp {CLAMP}"),
            "axis": a.round(6).tolist(),
            "dx": dx, "h": dx / ps.scene.domain.particles_per_cell ** (1 / 3), "points": int((pv > 0).sum()),
            "passive": int((pv == 0).sum()), "frames": n_frames, "seconds": round(time.time() - t0, 1),
            **geo["fill"],
            "peak": float(sig_g[:max(k_end, 1)].max()), "peak_vs_ft": float(sig_g[:max(k_end, 1)].max()) / tf.FT - 1,
            "crack_s": float(lx[crack]), "where": where, "section_at_crack": float(section[crack]),
            "clamp_face": clamp, "pulled_face": pulled, "gauge": [float(g.min()), float(g.max())],
            "work": work, "work_vs_gf": work / tf.GF - 1, "dissipated": dissipated, "work_on": on,
            "work_axial": work_axial, "work_x": x[0] if x else None, "dissipated_x": x[1] if x else None,
            "broken_through": bool(broken.any()), "final_stress": float(sig_g[-1]), "frames_run": len(force),
            "spread": out["spread"], "diverged": out["diverged"],
            "damaged_layers": [[round(float(lx[k]), 4), round(float(dmean[-1][k]), 3), round(float(D[k]), 3)]
                               for k in np.flatnonzero(dmean[-1] > 0.05)]}


def _key(r: dict) -> tuple:
    return (r["specimen"], r["angle"], r["engine"], r["n_grid"], r.get("start", "ramp"), r.get("faces", "nearest"),
            r.get("constrain", "all"))


def _sp(q: dict | None) -> str:
    return f"{q['p5']:.3f}-{q['p95']:.3f} ({q['min']:.2f}, {q['max']:.2f})" if q else ""


def table(rows: list[dict], spreads: list[dict]) -> str:
    """The Markdown tables: the cases with the must-show's lines, and the spreads (fill against rotated lattice)."""
    out = ["| specimen | angle | engine | n_grid | start | faces, constrain | fill mass vs rho V | gauge section | "
           "peak / f_t | breaks at (axial m) | gauge (axial m) | where | work (J/m^2) | vs G_f | N to 2N | "
           "dissipated (J/m^2) | gauge spread p5-p95 (min, max) | s |", "|---" * 18 + "|"]
    by = {_key(r): r for r in rows}
    for r in sorted(rows, key=_key):
        twin = by.get(_key(r)[:3] + (r["n_grid"] // 2,) + _key(r)[4:])
        conv = f"{100 * (r['work'] / twin['work'] - 1):+.1f} %" if twin else ""
        out.append(f"| {r['specimen']} | {r['angle']} | {r['engine']} | {r['n_grid']} | {r.get('start', 'ramp')} | "
                   f"{r.get('faces', 'nearest')}, {r.get('constrain', 'all')} | "
                   f"{100 * r['mass_vs_mesh']:+.2f} % | {100 * r['gauge_section']:+.2f} % | "
                   f"{r['peak'] / tf.FT:.3f} ({100 * r['peak_vs_ft']:+.1f} %) | {r['crack_s']:.3f} | "
                   f"{r['gauge'][0]:.3f}-{r['gauge'][1]:.3f} | {r['where']}{' (diverged)' * bool(r.get('diverged'))} | "
                   f"{r['work']:.1f}{' (x planes)' * (r.get('work_on') == 'x planes')} | "
                   f"{100 * r['work_vs_gf']:+.1f} % | {conv} | {r['dissipated']:.1f} | {_sp(r['spread'])} | "
                   f"{r['seconds']:.0f} |")
    out += ["", "| specimen | angle | engine | n_grid | points | gauge stress / f_t | the scene's fill p5-p95 "
            "(min, max) | rotated lattice p5-p95 (min, max) |", "|---" * 8 + "|"]
    for q in sorted(spreads, key=_key):
        r = by.get(_key(q))
        out.append(f"| {q['specimen']} | {q['angle']} | {q['engine']} | {q['n_grid']} | "
                   f"{r['spread']['points'] if r and r['spread'] else ''} / {q['points']} | "
                   f"{r['spread']['at'] if r and r['spread'] else ''} / {q['at']} | "
                   f"{_sp(r['spread'] if r else None)} | {_sp(q)} |")
    return "\n".join(out) + "\n"


def main() -> None:
    ap = tf.family_parser("dogbone_2to1,dogbone_1.5to1")
    ap.add_argument("--angles", default="30,45", help="comma-separated degrees about z")
    ap.add_argument("--lattice", action="store_true", help="the rotated lattice's spread only (lattice_spread)")
    ap.add_argument("--start", default="ramp", choices=("ramp", "stretch"), help="run_case")
    ap.add_argument("--faces", default="nearest", choices=("nearest", "out", "corners"), help="faces")
    ap.add_argument("--constrain", default="all", choices=("all", "along"), help="the set box's (CONSTRAIN)")
    ap.add_argument("--clamp", default="fixed", choices=("fixed", "set"), help="CLAMP")
    a = ap.parse_args()
    tf.name_check(a.engine)
    globals()["FACES"], globals()["CONSTRAIN"], globals()["CLAMP"] = a.faces, a.constrain, a.clamp
    RESULTS.mkdir(exist_ok=True)
    path = RESULTS / "user_oblique.json"
    data = json.loads(path.read_text()) if path.exists() else {}
    rows, spreads = data.get("cases", []), data.get("lattice_spreads", [])
    for name in filter(None, a.only.split(",")):     # --only "": the table from the JSON alone
        for angle in a.angles.split(","):
            for n in tf.grids(a):
                if a.lattice:
                    q = {"specimen": name, "angle": angle, "engine": a.engine, "n_grid": n,
                         **lattice_spread(SPECIMENS[name], n, a.engine, angle)}
                    spreads = [p for p in spreads if _key(p) != _key(q)] + [q]
                else:
                    q = run_case(SPECIMENS[name], n, a.engine, angle, a.start)
                    rows = [p for p in rows if _key(p) != _key(q)] + [q]
                print(json.dumps({k: v for k, v in q.items() if k != "damaged_layers"}), flush=True)
                path.write_text(json.dumps({"material": {"E": tf.E, "nu": tf.NU, "rho": tf.RHO, "f_t": tf.FT,
                                                         "G_f": tf.GF, "pull_m_s": tf.PULL},
                                            "cases": rows, "lattice_spreads": spreads}, indent=1))
    (RESULTS / "user_oblique.md").write_text(
        "# The oblique tension family built through the scene (issue 66, round 36)\n\n`python benchmarks/user_oblique"
        f".py` (docstring: the scene, the holds, the measures along the axis). E {tf.E:g} Pa, nu {tf.NU:g}, f_t "
        f"{tf.FT:g} Pa, G_f {tf.GF:g} J/m^2, pull {tf.PULL:g} m/s along the axis, ramped over {ut.RAMP_S:g} s, f64; "
        "user_tension.py's mesh turned by the object's `rotation`, the `default` level's world-aligned fill. \"gauge\":"
        " the layers 1.5 cells (along x) from both held faces, a dog-bone's within 2 % of its gauge's section. faces: "
        "on the nearest node (`nearest`), the next one outward (`out`), or through the section's corners at 0.1 m "
        "from the ends (`corners`, off the nodes). \"gauge section\": the fill's volume over the gauge's slabs against "
        "the specimen's (one fill plane more or less reads +-h over the gauge's length: up to 13 % at n_grid 24 "
        "aligned). start: `ramp` (a user's) or `stretch` (the hand-built quasi-static start). \"gauge spread\": when "
        f"the gauge's median stress first reaches {SPREAD_AT:g} f_t, its points' largest principal stress over their "
        "mean (5th-95th percentile, extremes); the second table: tension_oblique.py's rotated lattice (`--lattice`)."
        "\n\n" + table(rows, spreads))


if __name__ == "__main__":
    main()
