"""The scene around a selection (issue 54 item 2): a user states neither a domain, nor a ground, nor a collider for a
selection (``select``) in a capture.

- **The rest is a collider** (:func:`with_rest_colliders`): an object with ``select`` collides with its unselected
  rest, built as an open surface clipped to the domain and carved free around the simulated points
  (:func:`gasp_core.prepare.colliders.build_colliders`; none where none of it lies within the domain), unless the object sets ``rest_collider = false``, a
  ``[[collider]] object = ...`` already names it, or the engine lacks :data:`FEATURES` (said in the line).
- **A ground under the selection** (:func:`with_support_ground`): with no ``[[boundary]] kind = "ground"`` and no
  ``[domain]``, a ground plane at the support beneath the first selection
  (:func:`gasp_core.prepare.ground.support_height`: the unselected Gaussians under it, a pan's bottom); none where
  nothing lies beneath it.
- **The domain around what moves and where it can reach** (:func:`reach_domain`), with no ``[domain]`` lo/hi: the
  box of the moving footprints and of every simulated point's free flight ``x + v t + g t^2 / 2`` (and its apex),
  for ``t`` up to the run's duration or until it falls to the ground, the fall bounded by the support; then
  :data:`MARGIN` of the moving extent and :data:`STENCIL_CELLS` cells on each side, three cells below the ground,
  cubic. Its side is at most :data:`REACH_LIMIT` times the moving footprints' largest extent (a fall with no support
  is cut there, with a warning): the work a bad value can ask for is bounded.

An explicit ``[domain]``, ``[[boundary]]`` or ``[[collider]]`` wins. Figures on the bundled kitchen:
``docs/colliders.md``.
"""
from __future__ import annotations

import dataclasses
import warnings
from pathlib import Path

import numpy as np

from gasp_core.errors import SceneError
from gasp_core.prepare.dynamic import vertex_velocities
from gasp_core.prepare.placed import PreparedObject
from gasp_core.scene.extras import ColliderSpec
from gasp_core.seam.setup import Boundary, grid_spacing

#: Grid cells kept free below a ground plane and above the points in a default domain: the quadratic stencil's
#: reach (base node ``floor(x/dx - 0.5)`` in ``[0, n_grid - 3]``) plus room to move.
STENCIL_CELLS = 3.0
#: Room to settle and spread around the reach, a share of the moving footprints' largest extent (each side).
MARGIN = 0.1
#: The reach domain's side is at most this many times the moving footprints' largest extent.
REACH_LIMIT = 4.0
#: The engine features a rest collider needs (:data:`gasp_core.seam.engine.FEATURES`): static colliders applied on a
#: grid's nodes from their distance field (an engine that makes a convex hull of the field would fill the pan).
FEATURES = frozenset({"static_colliders", "grid"})


def selected(scene) -> list[int]:
    """Indices of the scene's simulated objects with a ``select``ion."""
    return [i for i, o in enumerate(scene.objects) if o.select is not None and not o.static]


def whole_selections(scene, objects: list[PreparedObject]):
    """``scene`` and ``objects`` where a ``select`` holds every row of its object's file: that object runs as the
    whole object (no ``select``: no rest to collide with, no ground under the selection, no reach domain from it),
    and the lines that say so (issue 68: the studio's click on a donut whose connected piece is the whole donut, then
    Run, failed building a collider from the empty rest). ``objects[i].spec`` keeps the ``select`` as stated (it is
    recorded in ``run.json``); ``objects[i].moving`` becomes None and ``scene.objects[i].select`` None.

    Returns
    -------
    (Scene, list of PreparedObject, list of str)
    """
    specs, objects, lines = list(scene.objects), list(objects), []
    for i, o in enumerate(objects):
        if o.spec.static or o.spec.select is None or o.moving is None or len(o.moving) != o.gaussians.n:
            continue
        objects[i] = dataclasses.replace(o, moving=None, static_tri=np.zeros((0, 3, 3)))
        specs[i] = dataclasses.replace(specs[i], select=None)
        lines.append(f"object '{o.name}': its selection holds all {o.gaussians.n:,} Gaussians: it runs as the whole "
                     "object (no rest to collide with)")
    return (dataclasses.replace(scene, objects=specs) if lines else scene), objects, lines


def _named(scene, i: int) -> bool:
    stem = Path(scene.objects[i].file).stem
    return any(c.object in (i + 1, stem) for c in scene.colliders)


def with_rest_colliders(scene, features=None):
    """``scene`` with a ``[[collider]] object = i`` for every selected object ``i`` whose rest is a collider by
    default (module notes), and the lines that say so.

    Parameters
    ----------
    scene : gasp_core.scene.spec.Scene
    features : collection of str or None
        The engine's features; None: assumed to have :data:`FEATURES`.

    Returns
    -------
    (Scene, list of str)
    """
    add, lines = [], []
    for i in selected(scene):
        o = scene.objects[i]
        if not o.rest_collider or _named(scene, i):
            continue
        name = f"[[object]] #{i + 1} '{Path(o.file).stem}'"
        if features is not None and not FEATURES <= set(features):
            lines.append(f"{name}: its unselected rest is not a collider: the engine does not apply a collider's "
                         "distance field on a grid (an open surface, a pan or a counter, needs it)")
            continue
        add.append(ColliderSpec(where=f"the rest of {name}", object=i + 1, by_default=True))
        lines.append(f"{name}: its unselected rest is a collider (by default; rest_collider = false turns it off)")
    if not add:
        return scene, lines
    return dataclasses.replace(scene, colliders=list(scene.colliders) + add), lines


def with_support_ground(scene, objects: list[PreparedObject]):
    """``scene`` with a ground at the support beneath its first selection where it states neither a ground nor a
    ``[domain]`` (module notes), and the line that says so (``""`` where none is added).

    Returns
    -------
    (Scene, str)
    """
    from gasp_core.prepare.ground import support_height
    picks = selected(scene)
    if not picks or scene.domain.lo is not None or any(b.kind == "ground" for b in scene.boundaries):
        return scene, ""
    o = objects[picks[0]]
    try:
        h, how = support_height(o)
    except SceneError as e:
        return scene, f"object '{o.name}': no ground under the selection ({str(e).split(': ', 1)[-1]})"
    ground = Boundary(kind="ground", height=h)
    return (dataclasses.replace(scene, boundaries=list(scene.boundaries) + [ground]),
            f"object '{o.name}': a ground at z = {h:.4g} m, {how} (no [[boundary]] ground stated)")


def uses_reach(scene) -> bool:
    """Whether :func:`reach_domain` sets the scene's domain: no ``[domain]`` lo/hi and a selection."""
    return scene.domain.lo is None and bool(selected(scene))


def _velocities(o: PreparedObject, frame_dt: float) -> np.ndarray:
    x = o.surface.points()
    if o.spec.velocity_from_model:
        return vertex_velocities(o, frame_dt)
    w = np.asarray(o.spec.angular_velocity, float)
    return np.asarray(o.spec.velocity, float) + np.cross(w, x - x.mean(axis=0))


def flight_reach(x: np.ndarray, v: np.ndarray, gravity, duration: float, floor: float | None) -> np.ndarray:
    """Where points fly in free fall, metres, shape (2 n, 3): each point ``x`` (n, 3) with velocity ``v`` (n, 3,
    m/s) under ``gravity`` (3,, m/s^2) at the end of its flight, ``x + v t + g t^2 / 2`` with ``t`` the run's
    ``duration`` (s) or, when a ground at height ``floor`` (m) lies below it, the time it falls to it (the point
    then held at the ground); and at its apex against gravity."""
    g = np.asarray(gravity, float)
    gz = -float(g[2])
    t = np.full(len(x), float(duration))
    if floor is not None and gz > 0:       # z(t) = z + vz t - gz t^2 / 2 = floor, the later root
        drop = np.maximum(x[:, 2] - floor, 0.0)
        t = np.minimum(t, (v[:, 2] + np.sqrt(v[:, 2] ** 2 + 2 * gz * drop)) / gz)
    end = x + v * t[:, None] + 0.5 * g * (t ** 2)[:, None]
    if floor is not None:
        end[:, 2] = np.maximum(end[:, 2], min(floor, float(x[:, 2].min())))
    up = np.clip(-v @ g, 0.0, None) / max(float(g @ g), 1e-12)     # time to the apex along -g
    apex = x + v * np.minimum(up, duration)[:, None] + 0.5 * g * (np.minimum(up, duration) ** 2)[:, None]
    return np.concatenate([end, apex])


def reach_domain(scene, objects: list[PreparedObject], footprints: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The cubic domain around what moves and where it can reach in the run (module notes), metres.

    Parameters
    ----------
    scene : gasp_core.scene.spec.Scene
    objects : list of PreparedObject
        The simulated objects.
    footprints : ndarray, shape (k, 3)
        Their footprints (:func:`gasp_core.prepare.assembly.footprints`), metres.

    Returns
    -------
    (lo, hi) : ndarray, shape (3,) each, ``hi - lo`` equal on every axis.
    """
    grounds = [float(b.height) for b in scene.boundaries if b.kind == "ground"]
    floor = min(grounds) if grounds else None
    x = np.concatenate([o.surface.points() for o in objects])
    v = np.concatenate([_velocities(o, scene.frame_dt) for o in objects])
    flight = flight_reach(x, v, scene.gravity, scene.n_frames * scene.frame_dt, floor)
    f_lo, f_hi = footprints.min(axis=0), footprints.max(axis=0)
    ext = max(float(np.max(f_hi - f_lo)), 1e-3)
    lo = np.minimum(f_lo, flight.min(axis=0)) - MARGIN * ext
    hi = np.maximum(f_hi, flight.max(axis=0)) + MARGIN * ext
    bottom = None if floor is None else min(floor, float(f_lo[2]))
    if bottom is not None:
        lo[2] = bottom
    limit = REACH_LIMIT * ext
    n = scene.domain.n_grid
    side = float(np.max(hi - lo)) / (1.0 - 2.0 * STENCIL_CELLS / n)
    if side > limit:   # cut the reach, keeping what moves inside
        warnings.warn(f"{scene.path}: what moves could reach {side:.3g} m across in the run's "
                      f"{scene.n_frames * scene.frame_dt:.3g} s (a fall with nothing beneath it); the domain is "
                      f"cut to {limit:.3g} m ({REACH_LIMIT:g} x the moving part's {ext:.3g} m): state [domain] "
                      f"lo/hi or a [[boundary]] ground", stacklevel=3)
        side = limit
        centre = np.clip((lo + hi) / 2, f_hi - side / 2 + STENCIL_CELLS * side / n,
                         f_lo + side / 2 - STENCIL_CELLS * side / n)
        lo, hi = centre - side / 2 + STENCIL_CELLS * side / n, centre + side / 2 - STENCIL_CELLS * side / n
    dx = side / n
    centre = (lo + hi) / 2
    dlo = centre - side / 2
    if bottom is not None:
        dlo[2] = bottom - STENCIL_CELLS * dx
    return dlo, dlo + side


def reach_line(setup, scene) -> str:
    """The line a run prints for a reach domain: its box, side, ``n_grid`` and ``dx``."""
    side = float(np.max(setup.domain_hi - setup.domain_lo))
    return (f"the domain around what moves and where it can reach in {scene.n_frames * scene.frame_dt:.3g} s: "
            f"{np.round(setup.domain_lo, 3).tolist()} - {np.round(setup.domain_hi, 3).tolist()}, {side:.3g} m a side, "
            f"n_grid {setup.n_grid}, dx {grid_spacing(setup.domain_lo, setup.domain_hi, setup.n_grid) * 1e3:.3g} mm "
            f"(no [domain] stated; at most {REACH_LIMIT:g} x the moving part's extent)")
