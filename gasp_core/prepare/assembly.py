"""Point assembly: every object's simulated triangle vertices and fill points become one :class:`SimSetup`."""
from __future__ import annotations

import dataclasses
import warnings

import numpy as np
from scipy.special import expit

from gasp_core.errors import SceneError
from gasp_core.seam.setup import SimSetup, grid_spacing
from gasp_core.maps.fill import fill_interior, fill_spacing
from gasp_core.maps.occupancy import SPLAT_SIGMA
from gasp_core.prepare.around import STENCIL_CELLS, reach_domain, uses_reach
from gasp_core.prepare.checks import check_kept_floaters, check_overlap, check_resolution
from gasp_core.prepare.dynamic import fill_velocities, vertex_velocities
from gasp_core.prepare.placed import PreparedObject
from gasp_core.prepare.runout import RUNOUT_SAFETY, pile_warnings, runout_reach, widen
from gasp_core.prepare.thickness import thin_part_warnings
from gasp_core.prepare.surface import ELASTIC, brittle_skin_warning, surface_rule
from gasp_core.seam.memory import check_fill
from gasp_core.scene.spec import Scene

#: Smallest default domain side, metres (a single Gaussian, or all Gaussians at one point).
MIN_DOMAIN_SIDE = 1e-3
#: An object must span at least this many grid cells: below it the grid cannot resolve its shape at all
#: (one cell, as :func:`gasp_core.prepare.checks.check_resolution` says after the fill; checked here before
#: the fill so that a tiny object costs nothing; under 8 cells is a warning there).
MIN_OBJECT_CELLS = 1.0


def check_resolved(name: str, points: np.ndarray, dx: float, n_grid: int) -> None:
    """Refuse an object smaller than :data:`MIN_OBJECT_CELLS` grid cells (its largest side, metres).

    Raises
    ------
    SceneError
        Naming the object, its size, ``dx`` and the ways out.
    """
    size = float(np.max(points.max(axis=0) - points.min(axis=0)))
    if not size >= MIN_OBJECT_CELLS * dx:
        raise SceneError(f"object '{name}' is {size:.3g} m across, less than {MIN_OBJECT_CELLS:g} grid cell(s) "
                         f"(dx = {dx:.3g} m at n_grid {n_grid}): the grid cannot resolve it; scale the object "
                         f"up ('scale'), shrink the domain ([domain] lo/hi) or raise n_grid")


def default_domain(scene: Scene, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """A cubic domain around ``points`` padded by ``domain.padding`` times their extent.

    With a ground plane the extent reaches down to the ground (an object dropped from a height
    stays inside), and the box starts three cells below it, so points resting on the ground stay
    inside the grid's interpolation stencil; the side is then large enough to leave three cells
    above the points too (at a coarse ``n_grid`` the shift down would otherwise put the top of the
    object in the grid's last cells, outside every MPM stencil). The side is at least
    :data:`MIN_DOMAIN_SIDE`.
    """
    if scene.domain.lo is not None:
        return np.array(scene.domain.lo, float), np.array(scene.domain.hi, float)
    lo, hi = points.min(axis=0), points.max(axis=0)
    grounds = [b.height for b in scene.boundaries if b.kind == "ground"]
    if grounds:
        lo[2] = min(lo[2], min(grounds))
    ext = max(float(np.max(hi - lo)), MIN_DOMAIN_SIDE)
    side = ext * (1.0 + 2.0 * scene.domain.padding)
    n_grid = scene.domain.n_grid
    if grounds:   # three cells below the ground and three above the points (n_grid >= 8)
        side = max(side, (hi[2] - lo[2]) / (1.0 - 2.0 * STENCIL_CELLS / n_grid))
    centre = (lo + hi) / 2
    dlo = centre - side / 2
    if grounds:
        dlo[2] = min(grounds) - STENCIL_CELLS * side / n_grid
    return dlo, dlo + side


def footprints(o: PreparedObject) -> np.ndarray:
    """Points the object's simulated points can reach: its triangle vertices and the ends of its opaque
    splats' footprint axes (``SPLAT_SIGMA`` standard deviations, where a shell's fill points may lie), metres,
    shape (k, 3)."""
    tri = o.tri_rest[expit(o.simulated_rows(o.gaussians.opacities).astype(np.float64)) >= o.spec.min_opacity]
    axes = SPLAT_SIGMA * (tri[:, 1:] - tri[:, :1])
    return np.concatenate([o.tri_rest.reshape(-1, 3), (tri[:, :1] + axes).reshape(-1, 3),
                           (tri[:, :1] - axes).reshape(-1, 3), o.surface.reach()])


def domain_for(scene: Scene, objects: list[PreparedObject]) -> tuple[np.ndarray, np.ndarray]:
    """The domain (lo, hi), metres, shape (3,) each, of the simulated ``objects``: ``[domain]`` lo/hi where stated,
    else with a selection around what moves and where it can reach in the run
    (:func:`gasp_core.prepare.around.reach_domain`), else :func:`default_domain` around their :func:`footprints`,
    widened to where a sand body spreads on the ground (:mod:`gasp_core.prepare.runout`)."""
    reach = np.concatenate([footprints(o) for o in objects])
    if uses_reach(scene):
        return reach_domain(scene, objects, reach)
    lo, hi = default_domain(scene, reach)
    if scene.domain.lo is not None:
        return lo, hi
    grounds = [float(b.height) for b in scene.boundaries if b.kind == "ground"]
    spread = runout_reach([o.surface.points() for o in objects], [o.spec.material for o in objects],
                          min(grounds) if grounds else None)   # a sand body's collapse on the ground (runout.py)
    lo2, hi2 = widen(lo, hi, spread, scene.domain.n_grid, STENCIL_CELLS)
    side, side2 = float(hi[0] - lo[0]), float(hi2[0] - lo2[0])
    if side2 > side:
        warnings.warn(f"{scene.path}: the default domain is widened from {side:.3g} to {side2:.3g} m a side (dx "
                      f"{side2 / scene.domain.n_grid * 1e3:.3g} mm) to hold where its sand can spread on the ground "
                      f"(Lube et al. 2004's runout x {RUNOUT_SAFETY:g}); state [domain] lo/hi to choose it", stacklevel=3)
    return lo2, hi2


def piles(scene: Scene, o: PreparedObject, verts: np.ndarray, dx: float) -> list[str]:
    """:func:`gasp_core.prepare.runout.pile_warnings` of object ``o`` (its points ``verts``, m, shape (n, 3)) on the
    scene's lowest ground at grid spacing ``dx`` (m)."""
    grounds = [float(b.height) for b in scene.boundaries if b.kind == "ground"]
    return pile_warnings([o.name], [verts], [o.spec.material], min(grounds) if grounds else None, dx,
                         scene.domain.n_grid)


def build_setup(scene: Scene, objects: list[PreparedObject]) -> tuple[SimSetup, list[PreparedObject]]:
    """Assemble the engine's point set: all objects' surface points (``T``), then their fill points.

    Returns the setup and the objects as assembled (new records: their rows in ``SimSetup.x``, fill, surface
    rule, and the surface map bound to its fill, :meth:`gasp_core.maps.surface.SurfaceMap.with_fill`), static ones
    as given, in the given order.

    Static objects (``static = true``) take no part; a selected object brings its selected rows only
    (:mod:`gasp_core.prepare.selection`), and the default domain is around what moves (with a selection, and where
    it can reach: :func:`gasp_core.prepare.around.reach_domain`). A dynamic model's points start with the model's
    velocity unless the scene sets one (:mod:`gasp_core.prepare.dynamic`).

    Raises
    ------
    SceneError
        If an object lies outside the domain (named: below the ground, splats far larger than the object,
        outside ``[domain] lo/hi``), or floaters it keeps would size the default domain
        (:func:`gasp_core.prepare.checks.check_kept_floaters`).
    """
    scenery, objects = objects, [o for o in objects if not o.spec.static]
    vertices = [o.surface.points() for o in objects]
    if scene.domain.lo is None:
        check_kept_floaters(scene.path, objects)
    lo, hi = domain_for(scene, objects)
    n_grid = scene.domain.n_grid
    dx = grid_spacing(lo, hi, n_grid)
    check_fill(str(scene.path), sum(map(len, vertices)), n_grid, scene.domain.particles_per_cell,
               str(scene.engine.options.get("precision", "f32")))     # the grid alone, before any fill
    xs, vols, bodies, vels, fills, passives, assembled = [], [], [], [], [], [], []
    start = 0
    for i, (o, verts) in enumerate(zip(objects, vertices)):
        check_resolved(o.name, o.tri_rest.reshape(-1, 3), dx, n_grid)
        others = sum(map(len, vertices)) - len(verts) + sum(len(f.fill_x) for f in fills)
        fr, passive, rule = fill_object(scene, o, verts, dx, others, float(lo[2]))
        reach = footprints(o)
        thin = (thin_part_warnings(o.name, np.concatenate([verts, fr.fill_x]), fr.h, dx, n_grid)   # issue 54
                if len(fr.fill_x) else []) + piles(scene, o, verts, dx) + [brittle_skin_warning(o.name, rule, n_grid)]
        for msg in [fr.report.warning] + check_resolution(o.name, np.ptp(reach, axis=0), dx, n_grid, fr.report) + thin:
            if msg:
                warnings.warn(msg, stacklevel=2)
        assembled.append(dict(vertex_slice=slice(start, start + len(verts)), fill_report=fr.report,
                              surface_rule=rule))
        start += len(verts)
        xs.append(verts)
        vols.append(np.zeros(len(verts)) if passive else fr.p_vol_surface)
        bodies.append(np.full(len(verts), i))
        vels.append(vertex_velocities(o, scene.frame_dt) if o.spec.velocity_from_model
                    else np.broadcast_to(o.spec.velocity, verts.shape))
        passives.append(np.full(len(verts), passive))
        fills.append(fr)
    for i, fr in enumerate(fills):
        assembled[i]["fill_slice"] = slice(start, start + len(fr.fill_x))
        start += len(fr.fill_x)
        xs.append(fr.fill_x)
        vols.append(fr.p_vol_fill)
        bodies.append(np.full(len(fr.fill_x), i))
        vels.append(fill_velocities(xs[i], vels[i], fr.fill_x) if objects[i].spec.velocity_from_model
                    else np.broadcast_to(objects[i].spec.velocity, fr.fill_x.shape))
        passives.append(np.zeros(len(fr.fill_x), bool))
    x = np.concatenate(xs)
    passive = np.concatenate(passives)
    v, p_vol, body_id = np.concatenate(vels), np.concatenate(vols), np.concatenate(bodies)
    C = spin(objects, x, v, p_vol, body_id)
    outside = ((x < lo) | (x > hi)).any(axis=1)
    if outside.any():
        raise SceneError(_outside_message(scene, objects, x, np.concatenate(bodies), outside, lo, hi))
    check_overlap(scene.path, x, body_id, [o.name for o in objects], lo, dx)   # two bodies fused into one
    extras = scene_extras(scene, scenery, x, dx, lo, hi, cut_from(objects, x, body_id))
    made = iter([dataclasses.replace(o, surface=o.surface.with_fill(fr.fill_x), **a)   # the map bound to its fill
                 for o, fr, a in zip(objects, fills, assembled)])
    for o in objects:   # the crack band's snap-back limit, named by file and object (SimSetup names an index)
        o.spec.material.check_band(dx, f"{scene.path}: object '{o.name}': material")
    setup = SimSetup(
        **extras, x=x, v=v, p_vol=p_vol, body_id=body_id, C=C, passive=passive if passive.any() else None,
        faint=np.concatenate([faint_rows(o) for o in objects] + [np.zeros(len(f.fill_x), bool) for f in fills]),
        materials=[o.spec.material for o in objects], gravity=np.array(scene.gravity),
        domain_lo=lo, domain_hi=hi, n_grid=n_grid, boundaries=list(scene.boundaries),
        frame_dt=scene.frame_dt, n_render=sum(len(v) for v in vertices), options=dict(scene.engine.options))
    return setup, [o if o.spec.static else next(made) for o in scenery]


def faint_rows(o: PreparedObject) -> np.ndarray:
    """Which of the object's simulated points (:meth:`~gasp_core.maps.surface.SurfaceMap.points`) only faint
    Gaussians move: each Gaussian rebuilt from them (``shape_rows``) has an activated opacity below the object's
    ``min_opacity`` (a capture's floaters; :attr:`gasp_core.seam.setup.SimSetup.faint`). Shape (k,), bool."""
    rows = o.surface.shape_rows()
    opaque = expit(o.simulated_rows(o.gaussians.opacities).astype(np.float64)) >= o.spec.min_opacity
    seen = np.zeros(len(o.surface.points()), bool)
    seen[rows[opaque].ravel()] = True
    return ~seen


def fill_object(scene: Scene, o: PreparedObject, verts: np.ndarray, dx: float, others: int, lo_z: float = -np.inf):
    """One object's interior fill (:func:`gasp_core.maps.fill.fill_interior`) and whether its surface is passive.

    ``surface = "auto"`` starts passive unless the material alone already decides for the full model (one
    fill, not two). Before the fill points are allocated, the scene's point count (``others`` points of the
    other objects plus this object's) is checked against this machine's memory
    (:func:`gasp_core.seam.memory.check_fill`). No fill point starts under a ground (the highest ``kind = "ground"``
    boundary is the fill's ``floor``); a fill that reached under the domain's floor ``lo_z`` (metres: splats far
    larger than the object) is refused as :func:`_below_ground` says.

    Returns
    -------
    (FillResult, bool, dict or None)
        The fill, whether the surface is passive, and ``surface = "auto"``'s rule
        (:func:`gasp_core.prepare.surface.surface_rule`; None for another ``surface``).

    Raises
    ------
    SceneError
        From :func:`gasp_core.maps.fill.fill_interior` and the memory check, or a fill reaching under ``lo_z``.
    """
    n_grid, ppc = scene.domain.n_grid, scene.domain.particles_per_cell
    precision = str(scene.engine.options.get("precision", "f32"))

    def check_points(n: int) -> None:
        check_fill(f"{scene.path}: object '{o.name}'", others + n, n_grid, ppc, precision)

    h = fill_spacing(dx, ppc, o.spec.core_fraction)
    floor = max((float(b.height) for b in scene.boundaries if b.kind == "ground"), default=None)  # no fill in it
    opaque = expit(o.simulated_rows(o.gaussians.opacities).astype(np.float64)) >= o.spec.min_opacity
    passive = o.spec.surface == "passive" or (o.spec.surface == "auto" and o.spec.material.name not in ELASTIC)
    # a passive surface carries no mass: its fill is the vertex layout's whichever points it hands the engine
    own = o.tri_rest.reshape(-1, 3) if passive and o.surface.per_gaussian else verts
    fr = fill_interior(own, h, splats=o.tri_rest[opaque], fill=o.spec.fill, name=o.name,
                       if_open=o.spec.if_open, surface_mass=not passive, check_points=check_points, floor=floor)
    rule = None
    if o.spec.surface == "auto":
        was_passive = passive
        passive, rule = surface_rule(o.spec.fill, len(verts), fr, dx, o.spec.material.name)
        if was_passive and not passive:
            fr = fill_interior(verts, h, splats=o.tri_rest[opaque], fill=o.spec.fill, name=o.name,
                               if_open=o.spec.if_open, surface_mass=True, check_points=check_points, floor=floor)
    if fr.n_floored and fr.floored_low < lo_z:     # the fill reached further under the ground than the domain
        raise SceneError(_below_ground(scene, o, fr.n_floored, fr.floored_low))
    return fr, passive, rule


def cut_from(objects: list[PreparedObject], x: np.ndarray, body_id: np.ndarray) -> np.ndarray | None:
    """Where the points of selections moved by ``select.offset`` were cut from, shape (k, 3), metres (``x`` less the
    offset); None when no selection is moved. The rest's collider is carved free there too: the space a selection
    left in its capture is free (the kitchen's spinach lifted and dropped falls back into its pocket)."""
    moved = [(i, o.spec.select.offset) for i, o in enumerate(objects)
             if o.spec.select is not None and o.spec.select.offset is not None]
    if not moved:
        return None
    return np.concatenate([x[body_id == i] - np.asarray(off) for i, off in moved])


def scene_extras(scene: Scene, objects: list[PreparedObject], x: np.ndarray, dx: float, lo=None, hi=None,
                 cut: np.ndarray | None = None) -> dict:
    """``colliders``, ``forces`` and ``impulses`` of the setup (:mod:`gasp_core.colliders.model`); ``cut`` (k, 3),
    metres: where moved selections were cut from (:func:`cut_from`), carved free in their rest's collider too.

    Raises
    ------
    SceneError
        A collider that cannot be built, or simulated points that start inside a collider.
    """
    if not (scene.colliders or scene.forces or scene.impulses):
        return {}
    from gasp_core.colliders.model import check_start
    from gasp_core.prepare.colliders import build_colliders
    colliders = build_colliders(scene, objects, dx, lo, hi, x if cut is None else np.concatenate([x, cut]))
    check_start(colliders, x)
    return {"colliders": colliders, "forces": list(scene.forces), "impulses": list(scene.impulses)}


def skew(w) -> np.ndarray:
    """Cross-product matrix ``[w]_x`` (``[w]_x r = w x r``), shape (3, 3)."""
    wx, wy, wz = w
    return np.array([[0.0, -wz, wy], [wz, 0.0, -wx], [-wy, wx, 0.0]])


def spin(objects: list[PreparedObject], x: np.ndarray, v: np.ndarray, p_vol: np.ndarray,
         body_id: np.ndarray) -> np.ndarray | None:
    """Add each object's rigid spin ``w x (x - c)`` to ``v`` (in place); return ``C`` or None.

    ``c`` is the object's centre of mass (volume-weighted mean of its points: one density per
    object). ``C`` (shape (n, 3, 3), 1/s) is ``[w]_x`` on the object's points, the velocity
    gradient of the rigid spin, which engines with the feature ``initial_C`` start from.
    None when no object spins.
    """
    if not any(np.any(o.spec.angular_velocity) for o in objects):
        return None
    C = np.zeros((len(x), 3, 3))
    for i, o in enumerate(objects):
        w = np.asarray(o.spec.angular_velocity, dtype=np.float64)
        if not np.any(w):
            continue
        rows = body_id == i
        c = np.average(x[rows], axis=0, weights=p_vol[rows])
        v[rows] += np.cross(w, x[rows] - c)
        C[rows] = skew(w)
    return C


def _below_ground(scene: Scene, o: PreparedObject, n: int, z_low: float) -> str:
    """Why ``n`` points of ``o`` would start below the ground (the lowest at ``z_low``, metres): the object placed
    under it, or, its Gaussians' centres above it, splats far larger than the object (whose fill reached deeper
    than the domain holds under the ground; the fill's floor takes out only what lies within it)."""
    ground = min(b.height for b in scene.boundaries if b.kind == "ground")
    head = (f"{scene.path}: {n} point(s) of object '{o.name}' start below the ground at height {ground:g} m "
            f"(lowest at z = {z_low:.4g} m)")
    centres = o.tri_rest[:, 0]
    if centres[:, 2].min() >= ground:   # the Gaussians' centres are above: their footprints reach down
        reach = 2 * SPLAT_SIGMA * float(np.linalg.norm(o.tri_rest[:, 1:] - o.tri_rest[:, :1], axis=2).max())
        return (f"{head}, though every Gaussian's centre is above it: its splats are up to {reach:.3g} m across "
                f"on an object {float(np.ptp(centres, axis=0).max()):.3g} m across; check the file's scales "
                f"(or raise min_opacity to leave the largest out), or lower the ground's height")
    return (f"{head}: raise the object's position by at least {ground - z_low:.3g} m or lower the ground's height "
            f"([[boundary]] kind = \"ground\")")


def _outside_message(scene: Scene, objects: list[PreparedObject], x: np.ndarray, body: np.ndarray,
                     outside: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> str:
    """Why points start outside the domain, naming the object and the key that fixes it: below a ground
    plane (the object placed under it, or the ground set above it), else outside ``[domain] lo/hi`` (a point
    above every ground but below an explicit ``lo`` is outside the domain, not below the ground)."""
    k = int(np.flatnonzero(outside)[0])
    name = objects[int(body[k])].name
    grounds = [b.height for b in scene.boundaries if b.kind == "ground"]
    below = outside & (x[:, 2] < lo[2]) & (x[:, 2] < min(grounds)) if grounds else np.zeros(len(x), bool)
    if below.any():
        k = int(np.flatnonzero(below)[0])
        return _below_ground(scene, objects[int(body[k])], int(below.sum()), float(x[below, 2].min()))
    where = "[domain] lo/hi" if scene.domain.lo is not None else "the default domain around the objects"
    return (f"{scene.path}: {int(outside.sum())} point(s) of object '{name}' start outside {where} "
            f"[{lo.tolist()}, {hi.tolist()}] (first at {x[k].tolist()}); enlarge [domain] lo/hi or move the object")
