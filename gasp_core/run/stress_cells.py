"""Cells seeded by the impact and the stress (issue 66 item 5: "Voronoi cells seeded by the impact and the stress,
sized by the energy available against G_f"; ``docs/fracture.md`` "Round 103: cells seeded by the impact and the
stress").

Grady's cells (:mod:`gasp_core.run.grady_cells`) are sized by the impact's energy and seeded around the impact point:
right where the landing breaks a body everywhere (a ball), short where its structure decides where it breaks too (a
ring landing on its edge fails in bending at the contact and its sides, thin-ring theory; laid out in Grady's cells,
whose insides never damage, it can part only at their faces). Where the structure breaks it is read from a *probe*:
the landing run on the engine with no cells for up to :data:`PROBE_FRAMES` frames, until the parts of unbroken
material (damage under :data:`gasp_core.run.pieces.BROKEN`, joined by their rest links) keep their count from one
frame to the next once damage has begun.

* The probe's parts (:func:`cells_of_parts`) are its unbroken parts of :data:`PART_SHARE` of the mass or more and its
  crushed ones of that share (broken material further than a crack band's width, ``dx``, from every unbroken part:
  the region a landing crushes is one part, not shared out among its neighbours); every other point joins the part of
  its nearest point at rest. Where there are at least two, the cells are the intersections of Grady's cells with
  them (:func:`union`): their faces are Grady's and the probe's cracks both.
* Otherwise (one part with a crushed cap, or dust: the landing breaks the body everywhere, which the grid cannot
  resolve into fragments) Grady's cells stand alone.

The probe's frames are discarded: the run goes on from the state before them. It costs up to :data:`PROBE_FRAMES`
frames of the engine, once, where cells are laid.
"""
from __future__ import annotations

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components
from scipy.spatial import cKDTree

from gasp_core.run.fragments import connected_cells
from gasp_core.run.pieces import BROKEN, LINK_RADIUS

#: A part of unbroken material this share of the body's mass or more is a cell (the pieces family's threshold for
#: a piece a user counts, issue 66 "pieces of 5 % or more").
PART_SHARE = 0.05
#: The probe runs at most this many frames (the landing's damage is set within two frames on the donut shatter
#: example and the pieces family's ball; docs/fracture.md "Round 103").
PROBE_FRAMES = 4


def unbroken_parts(x: np.ndarray, material: np.ndarray, p_mass: np.ndarray, damage: np.ndarray,
                   spacing: float) -> tuple[np.ndarray, np.ndarray]:
    """The parts of the unbroken material points (``damage`` < :data:`BROKEN`) joined by their rest links (closer
    than :data:`LINK_RADIUS` ``spacing`` at the positions ``x`` (n, 3), m): each point's part, shape (n,), int64
    (-1 for a broken or passive point), and each part's share of the mass of the points ``material`` (n,) bool,
    shape (k,), float64. ``p_mass`` (n,) kg; ``damage`` (n,) in [0, 1]."""
    x = np.asarray(x, np.float64)
    d = np.asarray(damage, np.float64)
    live = np.flatnonzero(np.asarray(material, bool) & (d < BROKEN))
    lab = np.full(len(x), -1, np.int64)
    if not len(live):
        return lab, np.zeros(0)
    pairs = cKDTree(x[live]).query_pairs(LINK_RADIUS * spacing, output_type="ndarray")
    graph = coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(len(live), len(live)))
    k, part = connected_components(graph, directed=False)
    lab[live] = part
    m = np.asarray(p_mass, np.float64)
    return lab, np.bincount(part, weights=m[live], minlength=k) / m[np.asarray(material, bool)].sum()


def cells_of_parts(x: np.ndarray, material: np.ndarray, p_mass: np.ndarray, lab: np.ndarray, share: np.ndarray,
                   spacing: float, reach: float) -> np.ndarray | None:
    """Each point's part, shape (n,), int64, ``0 .. k - 1``, from :func:`unbroken_parts`' ``lab`` and ``share`` at the
    rest positions ``x`` (n, 3), m (``material`` (n,) bool, ``p_mass`` (n,) kg): the unbroken parts of
    :data:`PART_SHARE` of the mass or more, and the crushed ones: the connected parts (rest links within
    :data:`LINK_RADIUS` ``spacing``, m) of the other material further than ``reach`` (m: the crack band's width) from
    every such unbroken part, of that share or more. Every other point (a crack band's, a smaller part's, passive)
    takes the part of its nearest point in one. None where there are fewer than two parts (module notes)."""
    x = np.asarray(x, np.float64)
    material = np.asarray(material, bool)
    m = np.asarray(p_mass, np.float64)
    big = np.flatnonzero(share >= PART_SHARE)
    part = np.full(len(x), -1, np.int64)
    held = np.isin(lab, big)
    part[held] = np.searchsorted(big, lab[held])
    far = np.flatnonzero(material & ~held)
    if len(far) and held.any():
        far = far[cKDTree(x[held]).query(x[far])[0] > reach]
    if len(far) > 1:
        pairs = cKDTree(x[far]).query_pairs(LINK_RADIUS * spacing, output_type="ndarray")
        graph = coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(len(far), len(far)))
        k, crushed = connected_components(graph, directed=False)
        bulk = np.bincount(crushed, weights=m[far], minlength=k) >= PART_SHARE * m[material].sum()
        keep = bulk[crushed]
        part[far[keep]] = len(big) + np.searchsorted(np.flatnonzero(bulk), crushed[keep])
    if len(np.unique(part[part >= 0])) < 2:
        return None
    held = np.flatnonzero(part >= 0)
    other = np.flatnonzero(part < 0)
    part[other] = part[held[cKDTree(x[held]).query(x[other])[1]]]
    return part


def probe(info, setup, spacing: float, frame: int = 0) -> tuple[np.ndarray | None, dict]:
    """Run ``setup`` (its cells unset) on engine ``info`` for up to :data:`PROBE_FRAMES` frames and read where the
    landing breaks it (module notes): ``(part, record)``, ``part`` as :func:`cells_of_parts` at the frame where the
    parts' count, once damage has begun, is the frame before's (None: fewer than two parts) and ``record`` the
    probe's figures (``probe_frames``; ``parts``: the parts' shares of the mass; ``broken``: the share of the material
    broken). ``spacing``: the body's fill spacing, m; ``frame``: the run's frame ``setup`` stands at. The engine is
    closed after; its errors are raised as the run's (:func:`gasp_core.seam.engine.call_engine`), a blow-up
    (:class:`~gasp_core.errors.EngineDivergence`) at the run's frame it was probing, named as the probe's."""
    from gasp_core.errors import EngineDivergence, shifted
    from gasp_core.seam.build import build_engine
    from gasp_core.seam.engine import call_engine
    mat = setup.material_mask
    e = build_engine(info, setup.replace(cells=None))
    last, part, d = None, None, np.zeros(len(setup.p_mass))
    try:
        for f in range(1, PROBE_FRAMES + 1):
            call_engine(info, "step_frame", e.step_frame)
            d = np.asarray(call_engine(info, "damage", e.damage), np.float64)
            if d[mat].max(initial=0.0) <= 0:
                continue
            part = cells_of_parts(setup.x, mat, setup.p_mass, *unbroken_parts(setup.x, mat, setup.p_mass, d, spacing),
                                  spacing, setup.dx)
            n = 0 if part is None else int(part.max()) + 1
            if n == last:
                break
            last = n
    except EngineDivergence as err:
        raise shifted(err, frame, "in the landing's probe (the body run on without its cells)") from err
    finally:
        e.close()
    shares = [] if part is None else np.bincount(part[mat], weights=setup.p_mass[mat]) / setup.p_mass[mat].sum()
    record = {"probe_frames": f, "parts": [round(float(s), 4) for s in sorted(shares, reverse=True)],
              "broken": round(float(np.mean(d[mat] >= BROKEN)), 4)}
    return part, record


def union(x: np.ndarray, material: np.ndarray, spacing: float, grady: np.ndarray, parts: np.ndarray) -> np.ndarray:
    """Each point's cell, shape (n,), int64, ``0 .. k - 1`` (largest first): the connected parts of the intersections
    of Grady's cells ``grady`` (n,) int >= 0 and the probe's parts ``parts`` (n,) int >= 0
    (:func:`gasp_core.run.fragments.connected_cells`, rest links within :data:`LINK_RADIUS` ``spacing`` m at ``x``
    (n, 3), m; its :data:`~gasp_core.run.fragments.MIN_POINTS` rule for slivers)."""
    key = np.asarray(grady, np.int64) * (int(np.max(parts)) + 1) + np.asarray(parts, np.int64)
    return connected_cells(x, material, spacing, key)
