"""The tension family built the way a user builds it (issue 66, round 34): closed triangle meshes written to files,
a scene TOML, ``gasp_core.prepare.scene.prepare_scene`` (Gaussians laid on the mesh's faces, the interior fill at the
scene's spacing, the surface rule), a ``fixed_region`` and an ``[[impulse]] mode = "set"``, then the engine.

The specimens, the material, the holds and the pull are ``benchmarks/tension_family.py``'s (``FAMILY``, ``HOLD``,
``PULL``, ``X0``; E 1 MPa, nu 0, rho 1000, f_t 10 kPa, G_f 20 J/m^2, no gravity); only the way in differs:

- the points are the fill's (:func:`gasp_core.maps.fill.fill_interior`, spacing ``dx / ppc^(1/3)``, the quality
  level's ``particles_per_cell``: 4 at ``default``), its cells at the faces holding their inside share at their
  share's centroid, and the mesh's vertices (passive or material, as the surface rule or the object's ``surface``
  says);
- the body starts at rest, pulled by one set box at ``PULL`` from t = 0 (``start = "step"``: a user's first scene;
  the pull starts a wave of ``rho c PULL``, 6.3 % of f_t, that doubles at the clamp) or by one set box whose ``ramp``
  key raises it linearly from 0 to ``PULL`` over ``RAMP_S`` (``"ramp"``: :func:`impulse_rows`, how a user starts
  slowly); ``"boxes"``, round 34's ramp before the key, ``RAMP_ROWS`` set boxes stepping up to ``PULL``, is kept to
  compare with; or, to part the pipeline's effect from the start's, in the family's quasi-static stretch
  (``"stretch"``: the setup's ``v`` set after ``prepare_scene`` as :func:`tension_family.build` sets it; no scene key
  gives it).

Measured with the family's measures (:func:`record` and :func:`figures`, :func:`tension_family.run_case`'s on the
fill's own layers: a layer is a slab of the fill's spacing ``h`` around one of its x layers, its force
``sum P_xx V / h``): the peak nominal stress in the gauge, where it breaks, the work to separate, N against 2N; and
(:func:`fill_figures`) the fill's mass against rho times the mesh's volume, its section in the gauge against the
specimen's, and where its first free layer sits past the clamp's face (a node).

Run: ``python benchmarks/user_tension.py --engine taichi_mpm`` (and ``warp_mpm``; ``--only``, ``--n-grid``,
``--surface``, ``--start``, ``--ppc``, ``--shift``); each engine's cases are added to
``benchmarks/results/user_tension.json`` and ``user_tension.md`` is written from it. One engine per process.
"""
from __future__ import annotations

import json
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import crack_place as cp      # noqa: E402
import tension_family as tf   # noqa: E402

RESULTS = Path(__file__).parent / "results"
#: the round's specimens: two bars of the family and its ASTM-like dog-bone
USER = [tf.FAMILY[1], tf.FAMILY[3], tf.FAMILY[5]]


def specimen_mesh(sp: tf.Specimen, n_grid: int):
    """A closed triangle mesh (trimesh.Trimesh, metres, world frame) of ``sp``: a bar's box, a dog-bone's flat prism
    (its outline ``tf.Specimen.width`` sampled every ``dx / 2``, the thickness the gauge's), its faces cut to at most
    ``dx / 2`` a side."""
    import trimesh
    dx = tf.SIZE / n_grid
    if sp.gauge_l == 0.0:
        m = trimesh.creation.box(extents=(sp.length, sp.grip, sp.grip))
        m.apply_translation((tf.X0 + sp.length / 2, tf.Y0, tf.Y0))
    else:
        xs = np.linspace(tf.X0, tf.X0 + sp.length, int(np.ceil(sp.length / (dx / 2))) + 1)
        m = prism(xs, sp.width(xs) / 2, float(sp.thickness(xs[:1])[0]) / 2)
    m = m.subdivide_to_size(dx / 2)
    if not (m.is_watertight and m.is_winding_consistent and m.volume > 0):
        raise RuntimeError(f"{sp.name}: mesh not closed or not outward")
    return m


def prism(xs: np.ndarray, half_w: np.ndarray, half_t: float):
    """A closed prism along x: its section ``|y - Y0| <= half_w(x)`` (``half_w`` (k,) at ``xs`` (k,)), ``|z - Y0| <=
    half_t``; faces outward."""
    import trimesh
    k = len(xs)
    ring = []                      # at each x: (y, z) of the section's four corners, counter-clockwise about +x
    for x, w in zip(xs, half_w):
        ring.append([(x, tf.Y0 - w, tf.Y0 - half_t), (x, tf.Y0 + w, tf.Y0 - half_t),
                     (x, tf.Y0 + w, tf.Y0 + half_t), (x, tf.Y0 - w, tf.Y0 + half_t)])
    v = np.array(ring, np.float64).reshape(-1, 3)
    f = []
    for i in range(k - 1):
        for j in range(4):
            a, b = 4 * i + j, 4 * i + (j + 1) % 4
            f += [(a, b, b + 4), (a, b + 4, a + 4)]
    last = 4 * (k - 1)
    f += [(0, 2, 1), (0, 3, 2), (last, last + 1, last + 2), (last, last + 2, last + 3)]
    return trimesh.Trimesh(v, np.array(f), process=True)


#: a ramped pull (``pull = "ramp"``): the imposed speed rises linearly to ``PULL`` over ``RAMP_S`` seconds (the set
#: impulse's ``ramp`` key), three round trips of the free length's wave (``2 L / c``, ``c = sqrt(E / rho)``: 0.032 s
#: for 0.5 m); ``"boxes"``: the same in ``RAMP_ROWS`` equal steps of set boxes (round 34, before the key)
RAMP_ROWS, RAMP_S = 20, 0.1
#: the pulls :func:`impulse_rows` writes
PULLS = ("step", "ramp", "boxes")


def impulse_rows(pulled: float, pull: str) -> str:
    """The ``[[impulse]]`` rows of the pull: one set box at ``PULL`` from t = 0 (``"step"``), one whose ``ramp =
    RAMP_S`` raises it from 0 (``"ramp"``), or ``RAMP_ROWS`` set boxes at ``PULL k / RAMP_ROWS`` each over its ``RAMP_S
    / RAMP_ROWS`` s, then ``PULL`` (``"boxes"``). ``ValueError`` for another ``pull``."""
    if pull not in PULLS:
        raise ValueError(f"pull must be one of {PULLS}, got {pull!r}")
    steps = [(tf.PULL, 0.0, 100.0, 0.0)] if pull == "step" else [(tf.PULL, 0.0, 100.0, RAMP_S)] if pull == "ramp" \
        else [(tf.PULL * (k + 1) / RAMP_ROWS, k * RAMP_S / RAMP_ROWS, (k + 1) * RAMP_S / RAMP_ROWS, 0.0)
              for k in range(RAMP_ROWS)] + [(tf.PULL, RAMP_S, 100.0, 0.0)]
    return "".join(f"""[[impulse]]
shape = "box"
lo = [{pulled}, 0.0, 0.0]
hi = [{tf.SIZE}, {tf.SIZE}, {tf.SIZE}]
velocity_change = [{v!r}, 0.0, 0.0]
t0 = {t0!r}
t1 = {t1!r}
mode = "set"
""" + (f"ramp = {ramp!r}\n" if ramp else "") for v, t0, t1, ramp in steps)


def faces(sp: tf.Specimen, n_grid: int, shift: float = 0.0) -> tuple[float, float]:
    """The clamp's and the pulled box's faces (x, m): ``HOLD`` from the specimen's ends, moved by ``-shift`` cells with
    the grid (so on nodes; ``shift`` moves the fill's layers against the nodes and the faces)."""
    dx = tf.SIZE / n_grid
    return tf.X0 + tf.HOLD - shift * dx, tf.X0 + sp.length - tf.HOLD - shift * dx


def scene_toml(sp: tf.Specimen, n_grid: int, engine: str, mesh: str, surface: str, ppc: int | None,
               pull: str = "step", shift: float = 0.0) -> str:
    """The scene file a user writes for ``sp``: the family's domain, clamp, pull and material, no gravity; the
    domain and the held faces moved by ``-shift`` cells (:func:`faces`)."""
    clamp, pulled = faces(sp, n_grid, shift)
    x_lo = -shift * tf.SIZE / n_grid
    dom = f"particles_per_cell = {ppc}\n" if ppc else ""
    obj = f'surface = "{surface}"\n' if surface != "auto" else ""
    z0 = tf.Y0 - float(sp.thickness(np.array([tf.X0]))[0]) / 2
    return scene_head(engine, n_grid, x_lo, clamp, dom) + impulse_rows(pulled, pull) + f"""[[object]]
mesh = "{mesh}"
up_axis = "+z"
position = [{tf.X0 + sp.length / 2}, {tf.Y0}, {z0}]
{obj}""" + MATERIAL_ROWS


def scene_head(engine: str, n_grid: int, x_lo: float, clamp: float, domain_rows: str = "") -> str:
    """The family's scene up to its pull: 10 frames of ``tf.FRAME_DT`` without gravity, ``engine`` in f64 (taichi_mpm
    on one thread), the cube of ``tf.SIZE`` from ``x_lo`` (m) at ``n_grid`` (and ``domain_rows``), held by a
    ``fixed_region`` up to x = ``clamp`` (m)."""
    opts = 'precision = "f64"' + (", threads = 1" if engine == "taichi_mpm" else "")
    return f"""frame_dt = {tf.FRAME_DT}
n_frames = 10
gravity = [0.0, 0.0, 0.0]
[engine]
name = "{engine}"
options = {{ {opts} }}
[domain]
lo = [{x_lo!r}, 0.0, 0.0]
hi = [{tf.SIZE + x_lo!r}, {tf.SIZE}, {tf.SIZE}]
n_grid = {n_grid}
{domain_rows}[[boundary]]
kind = "fixed_region"
lo = [{x_lo!r}, 0.0, 0.0]
hi = [{clamp!r}, {tf.SIZE}, {tf.SIZE}]
"""


#: the family's brittle material as a scene's ``[object.material]`` rows
MATERIAL_ROWS = f"""[object.material]
name = "brittle"
E = {tf.E}
nu = {tf.NU}
rho = {tf.RHO}
tensile_strength = {tf.FT}
fracture_energy = {tf.GF}
model = "elastic"
"""


def prepare(sp: tf.Specimen, n_grid: int, engine: str, surface: str = "auto", ppc: int | None = None,
            folder: Path | None = None, pull: str = "step", shift: float = 0.0):
    """Write ``sp``'s mesh and scene into ``folder`` (default: a temporary one, removed after) and prepare it.
    Returns the ``PreparedScene`` and the mesh."""
    if folder is None:
        with tempfile.TemporaryDirectory(prefix="user_tension_") as tmp:
            return prepare(sp, n_grid, engine, surface, ppc, Path(tmp), pull, shift)
    from gasp_core.prepare.scene import prepare_scene
    from gasp_core.scene.spec import load_scene
    folder = Path(folder)
    mesh = specimen_mesh(sp, n_grid)
    mesh.export(folder / f"{sp.name}.ply")
    path = folder / f"{sp.name}.toml"
    path.write_text(scene_toml(sp, n_grid, engine, f"{sp.name}.ply", surface, ppc, pull, shift))
    return prepare_scene(load_scene(path), engine), mesh


def layers(st, h: float) -> tuple[np.ndarray, np.ndarray]:
    """The fill's x layers: each point's layer (n,) int (-1: no volume) and the layers' rest x (k,), m. A layer is
    the slab of width ``h`` (the fill's spacing) around one of the fill grid's cell centres along x, found from the
    points of a whole cell (the largest ``p_vol``); a point at a face (its share's centroid) or a material
    vertex goes to the slab it lies in."""
    x = np.asarray(st.x, np.float64)[:, 0]
    pv = np.asarray(st.p_vol, np.float64)
    whole = pv >= (1 - 1e-6) * pv.max()
    ref = x[whole][0]
    k = np.round((x - ref) / h).astype(int)
    k0 = int(k[pv > 0].min())
    layer = np.where(pv > 0, k - k0, -1)
    return layer, ref + (np.arange(int(layer.max()) + 1) + k0) * h


def fill_figures(ps, mesh, sp: tf.Specimen, shift: float = 0.0) -> dict:
    """The fill of a prepared specimen (:func:`prepare`) against its mesh: ``mass_vs_mesh`` (sum ``p_vol`` over the
    mesh's volume, less 1), ``gauge_section`` (the median over the gauge's x layers of each layer's volume over ``h``
    against the section ``sp.area``, less 1), ``first_free_layer_cells`` (the first x layer past the clamp's face,
    cells), the fill's spacing ``h`` (m) and the layers (:func:`layers`)."""
    st = ps.setup
    n_grid = int(round(tf.SIZE / st.dx))
    h = st.dx / ps.scene.domain.particles_per_cell ** (1 / 3)
    layer, lx = layers(st, h)
    pv = np.asarray(st.p_vol, np.float64)
    clamp, pulled = faces(sp, n_grid, shift)
    g_lo, g_hi = (clamp + 1.5 * st.dx, pulled - 1.5 * st.dx) if sp.gauge_l == 0.0 else sp.gauge(st.dx)
    gl = np.flatnonzero((lx > g_lo) & (lx < g_hi))
    sec = np.bincount(np.maximum(layer, 0), np.where(layer >= 0, pv, 0.0), len(lx))[gl] / h / sp.area(lx[gl])
    return {"mass_vs_mesh": float(pv.sum() / mesh.volume - 1), "gauge_section": float(np.median(sec) - 1),
            "first_free_layer_cells": float((lx[lx > clamp][0] - clamp) / st.dx), "h": h, "layer": layer, "lx": lx}


def compliance_ramp(sp: tf.Specimen, x: np.ndarray, clamp: float, pulled: float) -> np.ndarray:
    """The family's quasi-static start: ``PULL`` times the share of the compliance ``int dx / A(x)`` between the
    clamp's face and ``x`` (n,), clipped to [0, 1] (:func:`tension_family.build`)."""
    xs, comp = _compliance(sp)
    c = np.interp(x, xs, comp)
    c_cl, c_pu = np.interp([clamp, pulled], xs, comp)
    return tf.PULL * np.clip((c - c_cl) / (c_pu - c_cl), 0.0, 1.0)


def record(e, st, layer: np.ndarray, nl: int, h: float, n_frames: int) -> dict:
    """Step the engine ``e`` up to ``n_frames`` frames (until ``tf.AFTER`` frames after a layer is at ``d = 1``
    throughout); each frame each layer's force (N), mean x (m) and mean damage (by volume), and whether a layer is
    broken through (all its volume at ``d >= 0.9``); ``free`` (nl,) the layers the scene does not hold."""
    pv = np.where(layer >= 0, np.asarray(st.p_vol, np.float64), 0.0)
    li = np.maximum(layer, 0)
    vol = np.bincount(li, pv, nl)
    out = {"force": [], "pos": [], "dmean": [], "thru": [], "opened": []}
    for _ in range(n_frames):
        e.step_frame()
        F = np.asarray(e.to_setup_order(e.get_state()["F"]), np.float64)
        d = np.asarray(e.damage(), np.float64)
        xs = np.asarray(e.positions(), np.float64)
        mat = pv > 0
        P = np.zeros(len(pv))
        P[mat] = tf.nominal_xx(F[mat], d[mat])
        out["force"].append(np.bincount(li, P * pv, nl) / h)
        out["pos"].append(np.bincount(li, xs[:, 0] * pv, nl) / vol)
        out["dmean"].append(np.bincount(li, d * pv, nl) / vol)
        out["thru"].append(bool(np.any(np.bincount(li, (d >= 0.9) * pv, nl) >= vol * (1 - 1e-9))))
        out["opened"].append(bool(np.any(np.bincount(li, (d >= 1.0) * pv, nl) >= vol * (1 - 1e-9))))
        if len(out["opened"]) > tf.AFTER and out["opened"][-tf.AFTER]:
            break
    out = {k: np.array(v) for k, v in out.items()}
    out["vol"], out["d"], out["xs"] = vol, d, xs
    out["free"] = cp.free_layers(layer, cp.held_points(st.x, st.boundaries, st.impulses), nl)
    return out


def figures(sp: tf.Specimen, rec: dict, lx: np.ndarray, h: float, dx: float, clamp: float, pulled: float) -> dict:
    """:func:`tension_family.run_case`'s figures from :func:`record`'s: the peak nominal stress in the gauge (the
    median over its layers, before a layer breaks through), where it breaks, the work to separate ``int sigma_c dw``
    over the crack's zone (2 cells either side). The crack's layer: :func:`crack_place.crack_layer` on the free
    layers (``rec["free"]``, else those between the faces), never a held one (its damage mirrors the crack's)."""
    force, pos, dmean = rec["force"], rec["pos"], rec["dmean"]
    a_gauge = float(sp.gauge_w ** 2)
    g_lo, g_hi = (clamp + 1.5 * dx, pulled - 1.5 * dx) if sp.gauge_l == 0.0 else sp.gauge(dx)
    gl = np.flatnonzero((lx > g_lo) & (lx < g_hi))
    free = rec["free"] if "free" in rec else (lx > clamp) & (lx < pulled)
    broken = rec["thru"]
    k_end = int(np.argmax(broken)) if broken.any() else len(force)
    sig_g = np.median(force[:, gl], axis=1) / a_gauge
    peak = float(sig_g[:max(k_end, 1)].max())
    crack = cp.crack_layer(dmean, free)
    x_c = float(lx[crack])
    section = float(sp.area(np.array([x_c]))[0] / a_gauge - 1)
    if (g_lo < x_c < g_hi) if sp.gauge_l == 0.0 else section <= tf.SECTION_TOL:
        where = "gauge"
    elif min(abs(x_c - clamp), abs(x_c - pulled)) < 1.5 * dx:
        where = "held edge"
    else:
        where = "grip"
    span = np.flatnonzero(free & (np.abs(lx - x_c) <= 2 * dx + 1e-9))
    area = rec["vol"] / h
    elastic = (force[:, span[:-1]] / area[span[:-1]] / tf.E * (lx[span[1:]] - lx[span[:-1]])).sum(axis=1)
    w = pos[:, span[-1]] - pos[:, span[0]] - (lx[span[-1]] - lx[span[0]]) - elastic
    sig_c = force[:, crack] / a_gauge
    work = float(np.sum(0.5 * (sig_c[1:] + sig_c[:-1]) * np.diff(w))) if crack in span else float("nan")
    return {"peak": peak, "peak_vs_ft": peak / tf.FT - 1, "crack_x": x_c, "where": where,
            "section_at_crack": section, "clamp_face": clamp, "pulled_face": pulled, "gauge": [g_lo, g_hi],
            "work": work, "work_vs_gf": work / tf.GF - 1, "broken_through": bool(broken.any()),
            "final_stress": float(sig_g[-1]), "frames_run": len(force),
            "gauge_layer_area": float(np.median(area[gl]) / a_gauge - 1),
            "damaged_layers": [[round(float(lx[k]), 4), round(float(dmean[-1][k]), 3)]
                               for k in np.flatnonzero(dmean[-1] > 0.05)]}


def run_user_case(sp: tf.Specimen, n_grid: int, engine: str, surface: str = "auto", start: str = "step",
                  ppc: int | None = None, shift: float = 0.0) -> dict:
    """One specimen built through the scene on one engine at one grid: :func:`figures` and :func:`fill_figures`.
    ``start``: ``"step"`` (at rest, one set box at ``PULL`` from t = 0), ``"ramp"`` (at rest, one set box with the
    ``ramp`` key), ``"boxes"`` (at rest, round 34's staircase of set boxes; :func:`impulse_rows`) or ``"stretch"``
    (one set box, the body's ``v`` set to the family's quasi-static stretch after ``prepare_scene``);
    ``shift``: :func:`faces`."""
    from gasp_core.seam.build import build_engine
    ps, mesh = prepare(sp, n_grid, engine, surface, ppc, pull=start if start in PULLS else "step", shift=shift)
    st = ps.setup
    dx = st.dx
    fill = fill_figures(ps, mesh, sp, shift)
    h, layer, lx = fill.pop("h"), fill.pop("layer"), fill.pop("lx")
    pv = np.asarray(st.p_vol, np.float64)
    clamp, pulled = faces(sp, n_grid, shift)
    if start == "stretch":
        st.v = np.zeros_like(np.asarray(st.v))
        st.v[:, 0] = compliance_ramp(sp, np.asarray(st.x, np.float64)[:, 0], clamp, pulled)
    a_gauge = float(sp.gauge_w ** 2)
    x_g = np.array([clamp, pulled])
    t_peak = (tf.FT / tf.E) * a_gauge * float(np.diff(np.interp(x_g, *_compliance(sp)))[0]) / tf.PULL
    t_peak += RAMP_S / 2 if start in ("ramp", "boxes") else 0.0
    n_frames = int(np.ceil((t_peak + 1.5 * 2 * tf.GF / tf.FT / tf.PULL) / tf.FRAME_DT))
    e = build_engine(ps.info, st)
    t0 = time.time()
    try:
        rec = record(e, st, layer, len(lx), h, n_frames)
    finally:
        e.close()
    rule = (ps.objects[0].surface_rule or {}).get("surface", surface) if hasattr(ps.objects[0], "surface_rule") \
        else surface
    return {"specimen": sp.name, "engine": engine, "n_grid": n_grid, "surface": rule, "surface_key": surface,
            "start": start, "ppc": ps.scene.domain.particles_per_cell, "shift": shift, "dx": dx, "h": h,
            "cells_across": sp.gauge_w / dx, "points": int((pv > 0).sum()), "passive": int((pv == 0).sum()),
            "frames": n_frames, "seconds": round(time.time() - t0, 1), **fill,
            **figures(sp, rec, lx, h, dx, clamp, pulled)}


def _compliance(sp: tf.Specimen) -> tuple[np.ndarray, np.ndarray]:
    """``(x, int_X0^x dx / A)``: the specimen's compliance along x (m, 1/m)."""
    xs = np.linspace(tf.X0, tf.X0 + sp.length, 4001)
    return xs, np.concatenate([[0.0], np.cumsum(np.diff(xs) / sp.area(0.5 * (xs[1:] + xs[:-1])))])


def _key(r: dict) -> tuple:
    return r["specimen"], r["engine"], r["n_grid"], r["start"], r["surface_key"], r["ppc"], r.get("shift", 0.0)


def table(rows: list[dict]) -> str:
    """The Markdown table of the cases, with the must-show's lines (peak, place, work, N to 2N)."""
    out = ["| specimen | engine | n_grid | start | surface | ppc | fill mass vs rho V | gauge section | first layer "
           "past clamp (cells) | peak / f_t | breaks at (x, m) | where | work (J/m^2) | vs G_f | N to 2N | s |",
           "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    by = {_key(r): r for r in rows}
    for r in sorted(rows, key=_key):
        k = _key(r)
        twin = by.get(k[:2] + (r["n_grid"] // 2,) + k[3:])
        conv = f"{100 * (r['work'] / twin['work'] - 1):+.1f} %" if twin else ""
        name = r["specimen"] + (f" shift {r['shift']:g}" if r.get("shift") else "")
        out.append(f"| {name} | {r['engine']} | {r['n_grid']} | {r['start']} | {r['surface']} | {r['ppc']} | "
                   f"{100 * r['mass_vs_mesh']:+.2f} % | {100 * r.get('gauge_section', float('nan')):+.2f} % | "
                   f"{r.get('first_free_layer_cells', float('nan')):.2f} | "
                   f"{r['peak'] / tf.FT:.3f} ({100 * r['peak_vs_ft']:+.1f} %) | {r['crack_x']:.3f} | {r['where']} | "
                   f"{r['work']:.1f} | {100 * r['work_vs_gf']:+.1f} % | {conv} | {r['seconds']:.0f} |")
    return "\n".join(out) + "\n"


def main() -> None:
    ap = tf.family_parser()
    ap.add_argument("--start", default="step,ramp", help="comma-separated: step, ramp, boxes, stretch (run_user_case)")
    ap.add_argument("--surface", default="auto", help="the object's surface: auto, passive, material")
    ap.add_argument("--ppc", type=int, default=0, help="particles_per_cell (0: the quality level's)")
    ap.add_argument("--shift", type=float, default=0.0, help="the grid and the held faces off the fill, cells (faces)")
    a = ap.parse_args()
    tf.name_check(a.engine)
    RESULTS.mkdir(exist_ok=True)
    path = RESULTS / "user_tension.json"
    rows = json.loads(path.read_text())["cases"] if path.exists() else []
    names = set(a.only.split(",")) if a.only else {sp.name for sp in USER}
    for sp in [sp for sp in USER if sp.name in names]:
        for start in a.start.split(","):
            for n in tf.grids(a):
                r = run_user_case(sp, n, a.engine, a.surface, start, a.ppc or None, a.shift)
                print(json.dumps(r), flush=True)
                rows = tf.save_case(path, rows, r, _key)
    (RESULTS / "user_tension.md").write_text(
        "# The tension family built through the scene (issue 66, round 34)\n\n`python benchmarks/user_tension.py` "
        "(docstring: how the specimens are built and measured; the measures are benchmarks/tension_family.py's). "
        f"E {tf.E:g} Pa, nu {tf.NU:g}, f_t {tf.FT:g} Pa, G_f {tf.GF:g} J/m^2, pull {tf.PULL:g} m/s, f64. "
        "start: `step` a user's scene at rest with one set box at the pull speed from t = 0; `ramp` at rest, one set "
        f"box whose `ramp = {RAMP_S:g}` s raises the pull linearly from 0; `boxes` at rest, the pull stepped up in "
        f"{RAMP_ROWS} set boxes over {RAMP_S:g} s (round 34, before the key); `stretch` the family's quasi-static "
        "start (the setup's v set after prepare_scene). surface: what the surface rule chose (or the object's "
        "`surface`). \"fill mass\": "
        "sum p_vol against the mesh's volume; \"gauge section\": the fill's section (each x layer's volume over h) "
        "against the specimen's, the median over the gauge; \"first layer past clamp\": the fill's first x layer past "
        "the clamp's face (a node), cells; the fill's layers are h = dx / ppc^(1/3) apart (0.63 dx at 4).\n\n"
        + table(rows))


if __name__ == "__main__":
    main()
