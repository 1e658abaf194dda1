"""What moves: the selected part of an object's file, and the static rest (GASP issue 9, part A).

An object may simulate only part of its file (``select = {...}``, :class:`gasp_core.scene.spec.SelectSpec`)
or none of it (``static = true``). The rest is the static background: it is never handed to the
engine, and every output frame writes it unchanged beside the moving part, so that each frame is
the whole file, Gaussians in the input order, the static rows bit for bit those of frame 0.

Conventions
-----------
* Placement (:func:`gasp_core.prepare.placement.place`) is computed from the whole file, so the
  background stays where it is; a region in ``frame = "world"`` is tested after placement.
* A Gaussian is in a box or sphere when its centre (``means``) is (bounds inclusive). For a
  dynamic model the centres are those at ``dynamic_time`` (``psi(V, s)`` first, then the selection).
* ``grow = true`` adds every Gaussian connected to the selection through overlapping splats
  (:func:`grow_selection`).

:func:`static_splats` hands the static Gaussians' world-frame triangles to whoever builds
collider occupancy from them.
"""
from __future__ import annotations

import dataclasses
import itertools
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from gasp_core.errors import SceneError
from gasp_core.maps.games import flatten, gaussians_to_triangles
from gasp_core.gs.gaussians import Gaussians
from gasp_core.prepare.editor_cut import cut_rows
from gasp_core.prepare.placed import Placement, PreparedObject

if TYPE_CHECKING:
    from gasp_core.scene.spec import ObjectSpec

__all__ = ["GROW_SIGMAS", "component_labels", "grow_selection", "moving_rows", "region_rows", "scatter", "selection_record",
           "selection_totals", "static_rows", "static_splats", "world_triangles", "flat_world"]

#: Splat radius used by :func:`grow_selection`: this many times the Gaussian's largest scale (2 sigma).
GROW_SIGMAS = 2.0


def flat_world(g: Gaussians, pl: Placement):
    """Gaussians placed, flattened and triangulated in the world frame: the one map (flatten, then ``T``).

    Returns
    -------
    scales : ndarray, shape (n, 3), float64
        Flat scales ``[eps, s2, s3]``, metres.
    rotmats : ndarray, shape (n, 3, 3), float64
        World rotations, column 0 the normal.
    means : ndarray, shape (n, 3), float64
        World positions, metres.
    tri : ndarray, shape (n, 3, 3), float64
        GaMeS triangles, world frame, metres.
    report : FlattenReport
    """
    scales, rot, report = flatten(g.scales * pl.scale, pl.R @ g.rotmats())
    means = pl.to_world(g.means)
    return scales, rot, means, gaussians_to_triangles(means, rot, scales), report


def world_triangles(g: Gaussians, pl: Placement) -> np.ndarray:
    """GaMeS triangles of Gaussians flattened in the world frame, shape (n, 3, 3), metres (:func:`flat_world`)."""
    return flat_world(g, pl)[3]


def _load_mask(path: Path, n: int, where: str) -> np.ndarray:
    try:
        with open(path, "rb") as f:
            head = f.read(6)
    except OSError as e:
        raise SceneError(f"{where}: cannot read '{path}': {e.strerror}") from None
    if head != b"\x93NUMPY" and not head.startswith(b"PK"):   # numpy reads any other file as pickled data
        raise SceneError(f"{where}: '{path}' is not a .npy file (no numpy header); expected an array written by "
                         f"numpy.save: bool, one per Gaussian ({n}), or integer row indices")
    try:
        a = np.load(path, allow_pickle=False)
    except (OSError, ValueError, EOFError) as e:
        raise SceneError(f"{where}: cannot read '{path}' as a .npy array: {e}") from None
    if not isinstance(a, np.ndarray):
        raise SceneError(f"{where}: '{path}' holds several arrays (.npz); expected one .npy array")
    if a.dtype == bool:
        if a.shape != (n,):
            raise SceneError(f"{where}: boolean mask '{path}' has shape {a.shape}; expected ({n},), one "
                             f"entry per Gaussian of the file")
        return np.flatnonzero(a)
    if np.issubdtype(a.dtype, np.integer):
        if a.ndim != 1:
            raise SceneError(f"{where}: index array '{path}' has shape {a.shape}; expected a 1-D array")
        return _check_indices(a, n, where)
    raise SceneError(f"{where}: '{path}' has dtype {a.dtype}; expected bool (one per Gaussian, {n}) "
                     f"or integer row indices")


def _check_indices(idx, n: int, where: str) -> np.ndarray:
    idx = np.asarray(idx, dtype=np.int64)
    bad = (idx < 0) | (idx >= n)
    if bad.any():
        raise SceneError(f"{where}: index {int(idx[bad][0])} out of range for a file of {n} Gaussians "
                         f"(expected 0 to {n - 1}); {int(bad.sum())} bad index(es)")
    return np.unique(idx)


def region_rows(spec: ObjectSpec, g: Gaussians, pl: Placement) -> np.ndarray:
    """Rows of ``g`` that ``spec.select`` picks, before growing.

    Parameters
    ----------
    spec : ObjectSpec
        With ``spec.select`` set.
    g : Gaussians
        The whole file as read (file frame; a dynamic model at ``dynamic_time``).
    pl : Placement
        The whole file's placement (used with ``frame = "world"``).

    Returns
    -------
    rows : ndarray, shape (k,), int64
        Sorted, unique, ``k >= 1``.

    Raises
    ------
    SceneError
        The region holds no Gaussian ("select box holds 0 of N Gaussians", with the centres'
        bounds in that frame); an index out of range; a mask that is not a boolean array of one
        entry per Gaussian nor a 1-D integer array, not a .npy file (a text file: one line naming it), or
        cannot be read.
    """
    sel, n = spec.select, g.n
    where = f"{spec.file}: select {sel.kind}"
    if sel.kind == "indices":
        return _check_indices(sel.indices, n, where)
    if sel.kind == "mask":
        rows = _load_mask(sel.mask, n, where)
    elif sel.kind == "file":
        rows = cut_rows(sel, g.means, where)
    else:
        x = g.means if sel.frame == "file" else pl.to_world(g.means)
        if sel.kind == "box":
            inside = np.all((x >= sel.lo) & (x <= sel.hi), axis=1)
        else:
            inside = np.sum((x - np.asarray(sel.centre)) ** 2, axis=1) <= sel.radius ** 2
        rows = np.flatnonzero(inside)
        if not len(rows):
            lo, hi = x.min(axis=0), x.max(axis=0)
            raise SceneError(f"{where} holds 0 of {n} Gaussians; their centres span "
                             f"{np.round(lo, 4).tolist()} to {np.round(hi, 4).tolist()} in the "
                             f"{sel.frame} frame{' (metres)' if sel.frame == 'world' else ''}")
    if not len(rows):
        raise SceneError(f"{where} holds 0 of {n} Gaussians")
    return rows


def grow_selection(rows: np.ndarray, means: np.ndarray, radii: np.ndarray,
                   linking: np.ndarray | None = None) -> np.ndarray:
    """Grow a selection to the whole connected pieces it touches.

    Two Gaussians are linked when the centre of one lies within the other's splat,
    ``|m_i - m_j| <= max(r_i, r_j)``; the selection becomes every connected component (of the
    graph of links) that holds a selected Gaussian.

    Parameters
    ----------
    rows : ndarray, shape (k,), int
        Selected rows.
    means : ndarray, shape (n, 3)
        Centres (any frame; metres in the pipeline).
    radii : ndarray, shape (n,)
        Splat radii, same unit (the pipeline uses :data:`GROW_SIGMAS` times the largest scale).
    linking : ndarray, shape (n,), bool, optional
        Gaussians that may link (the pipeline: activated opacity at least ``min_opacity``); the
        others join only if selected themselves. Default: all.

    Returns
    -------
    rows : ndarray, int64
        Sorted; a superset of the input rows.

    Notes
    -----
    Radius graph from :meth:`scipy.spatial.cKDTree.query_ball_point` (each Gaussian queried at
    its own radius; the graph is taken as undirected), then
    :func:`scipy.sparse.csgraph.connected_components`. On the real donut (39,963 opaque
    Gaussians) this is 6.5 million links and one component, about 3 s. A large splat links
    everything its radius covers: in a scene with big background splats, growing can take in
    much of the scene (``run.json`` records ``n_selected``).
    """
    label = component_labels(means, radii, linking)
    keep = np.isin(label, np.unique(label[rows]))
    keep[rows] = True
    return np.flatnonzero(keep)


def component_labels(means: np.ndarray, radii: np.ndarray, linking: np.ndarray | None = None) -> np.ndarray:
    """The connected piece of every Gaussian under :func:`grow_selection`'s rule (its label), shape (n,), int.

    Two Gaussians are linked when the centre of one lies within the other's splat,
    ``|m_i - m_j| <= max(r_i, r_j)``; only Gaussians marked in ``linking`` (default all) link, the others are
    pieces of their own. Labels from :func:`scipy.sparse.csgraph.connected_components`. Linking Gaussians at
    one centre are searched once (:func:`gasp_core.maps.occupancy.distinct_points`): the links grow with the
    distinct centres, not with the square of a pile of equal ones.
    """
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components
    from scipy.spatial import cKDTree

    from gasp_core.maps.occupancy import distinct_points

    n = len(means)
    nodes = np.arange(n) if linking is None else np.flatnonzero(linking)
    # linking Gaussians at one centre are one piece, searched once at their largest radius (the rule links
    # i and j when |m_i - m_j| <= max(r_i, r_j)): 20,000 at one point made 4e8 links and 5.5 GB
    points, inverse, _ = distinct_points(means[nodes])
    radius = np.zeros(len(points))
    np.maximum.at(radius, inverse, np.asarray(radii, dtype=np.float64)[nodes])
    first = np.full(len(points), n, np.int64)
    np.minimum.at(first, inverse, nodes)              # the row that stands for each distinct centre
    tree = cKDTree(points)
    src, dst = [nodes], [first[inverse]]              # each linking row to its centre's row
    for start in range(0, len(points), 20000):
        stop = min(start + 20000, len(points))
        hits = tree.query_ball_point(points[start:stop], radius[start:stop], return_sorted=False)
        counts = np.fromiter(map(len, hits), dtype=np.int64, count=len(hits))
        src.append(first[np.repeat(np.arange(start, stop), counts)])
        dst.append(first[np.fromiter(itertools.chain.from_iterable(hits), dtype=np.int64,
                                     count=int(counts.sum()))])
    src, dst = np.concatenate(src), np.concatenate(dst)
    graph = coo_matrix((np.ones(len(src), np.int8), (src, dst)), shape=(n, n))
    return connected_components(graph, directed=False)[1]


def moving_rows(spec: ObjectSpec, g: Gaussians, pl: Placement,
                tri: np.ndarray | None = None) -> tuple[np.ndarray | None, np.ndarray]:
    """Which rows of an object's file move, and the static rest's world triangles.

    ``tri`` : ndarray, shape (g.n, 3, 3), optional
        The whole file's :func:`world_triangles`, when the caller has them (computed here otherwise):
        an object is flattened once (:func:`gasp_core.prepare.placement.prepare_object`).

    Returns
    -------
    moving : ndarray of int64, or None
        Sorted rows that are simulated; None when the whole file moves (no ``select``); empty
        for a ``static`` object.
    static_tri : ndarray, shape (m, 3, 3), float64
        World-frame triangles (metres) of the static rows, in row order.

    Raises
    ------
    SceneError
        See :func:`region_rows`.
    """
    if spec.select is None and not spec.static:
        return None, np.zeros((0, 3, 3))
    tri = world_triangles(g, pl) if tri is None else tri
    if spec.static:
        return np.zeros(0, np.int64), tri
    rows = region_rows(spec, g, pl)
    if spec.select.grow:
        alpha = 1.0 / (1.0 + np.exp(-g.opacities.astype(np.float64)))
        rows = grow_selection(rows, tri[:, 0], GROW_SIGMAS * pl.scale * g.scales.max(axis=1),
                              linking=alpha >= spec.min_opacity)
    static = np.ones(g.n, bool)
    static[rows] = False
    return rows, tri[static]


def static_rows(o: PreparedObject) -> np.ndarray:
    """Rows of ``o``'s file that never move, sorted, int64."""
    if o.moving is None:
        return np.zeros(0, np.int64)
    keep = np.ones(o.gaussians.n, bool)
    keep[o.moving] = False
    return np.flatnonzero(keep)


def scatter(o: PreparedObject, means: np.ndarray, scales: np.ndarray, rotations: np.ndarray) -> Gaussians:
    """The whole file at one frame: the moving rows replaced, every other row as read.

    Parameters
    ----------
    o : PreparedObject
    means, scales, rotations : ndarray, shapes (k, 3), (k, 3), (k, 4)
        The moving rows' new values, file frame, in the order of ``o.moving`` (all rows when
        ``o.moving`` is None).

    Returns
    -------
    Gaussians
        ``o.gaussians.n`` rows in the input order. Opacity, SH and extra fields are shared with
        the input; the static rows' means, scales and rotations are the input's values, so the
        writer gives them the same bytes in every frame.
    """
    g = o.gaussians
    if o.moving is None:
        return dataclasses.replace(g, means=means, scales=scales, rotations=rotations)
    m, s, q = g.means.copy(), g.scales.copy(), g.rotations.copy()
    m[o.moving], s[o.moving], q[o.moving] = means, scales, rotations
    return dataclasses.replace(g, means=m, scales=s, rotations=q)


def static_splats(prep) -> list[tuple[str, np.ndarray, np.ndarray]]:
    """The static Gaussians of a prepared scene, per object, for collider occupancy.

    Parameters
    ----------
    prep : PreparedScene

    Returns
    -------
    list of (name, tri_world, opacities)
        One entry per object with static Gaussians (``static = true`` objects whole, selected
        objects their unselected rest), in scene order. ``name`` is the object's output folder
        name; ``tri_world`` (m, 3, 3) float64 the flattened GaMeS triangles, world frame, metres;
        ``opacities`` (m,) float32 the raw opacity logits as stored (``sigmoid`` gives the
        opacity; compare with the object's ``spec.min_opacity``).
    """
    out = []
    for o, name in zip(prep.objects, prep.names):
        rows = static_rows(o)
        if len(rows):
            out.append((name, o.static_tri, o.gaussians.opacities[rows]))
    return out


def selection_record(o: PreparedObject) -> dict:
    """``run.json`` fields of one object: ``static``, ``select``, ``n_selected``, ``n_static`` (floaters included)
    and ``n_floaters``."""
    n_sel = o.gaussians.n if o.moving is None else len(o.moving)
    return {"static": o.spec.static, "select": None if o.spec.select is None else o.spec.select.describe(),
            "n_selected": n_sel, "n_static": o.gaussians.n - n_sel, "n_floaters": o.n_floaters}


def selection_totals(prep) -> dict:
    """``run.json`` totals: ``n_gaussians`` (all files), ``n_selected`` (simulated) and ``n_static``."""
    recs = [selection_record(o) for o in prep.objects]
    return {"n_gaussians": sum(o.gaussians.n for o in prep.objects),
            "n_selected": sum(r["n_selected"] for r in recs), "n_static": sum(r["n_static"] for r in recs)}
