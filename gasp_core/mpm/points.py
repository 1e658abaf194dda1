"""The points of a grid (MPM) engine: those held by ``fixed_region`` boundaries, their order by grid cell,
their mass statistics, the passive points no material carries any more and the box the boundaries keep
passive points in (:func:`passive_bounds`, :func:`hold_passive`)."""
from __future__ import annotations

import itertools
import math
from typing import Any, Iterable

import numpy as np

from gasp_core.seam.passive import mass_properties
from gasp_core.seam.setup import Boundary


#: Cells: a boundary plane within this of a node layer passes through it (ties are exact ties).
NODE_TIE = 1e-9
#: ``walls``: their planes lie this many cells inside the domain's faces (docs/mpm.md step 3; the wall nodes are
#: ``gasp_core.mpm.contact.wall_grid_cells``').
WALL_NODES = 3


def ground_top_node(height: float, domain_lo_z: float, dx: float) -> int:
    """The highest node layer of a ``ground``: nodes with ``k <= ground_top_node(...)`` are ground nodes.

    The test ``X_z <= height`` of docs/mpm.md, decided once in float64 on the node index, so that
    the node lying on the plane is a ground node in every engine and at every precision. (Decided
    per node in float32, ``lo + k dx`` lands a few 1e-9 m above or below the plane by rounding, and
    the ground moves by a whole cell: the body then sinks one cell deeper and rocks.)

    Parameters
    ----------
    height, domain_lo_z : float
        Ground height and the grid origin's z, metres.
    dx : float
        Cell size, metres.

    Returns
    -------
    int
        ``floor((height - domain_lo_z) / dx + NODE_TIE)``; negative when the ground is below the grid.
    """
    return int(math.floor((float(height) - float(domain_lo_z)) / float(dx) + NODE_TIE))


def fixed_mask(x: np.ndarray, boundaries: Iterable[Boundary]) -> np.ndarray:
    """Points held still: those inside the box ``[lo, hi]`` (closed) of any ``fixed_region``.

    Parameters
    ----------
    x : ndarray, shape (n, 3)
        Initial positions, metres.
    boundaries : iterable of Boundary

    Returns
    -------
    ndarray, shape (n,), bool
    """
    x = np.asarray(x, dtype=np.float64)
    mask = np.zeros(len(x), dtype=bool)
    for b in boundaries:
        if b.kind == "fixed_region":
            mask |= np.all((x >= np.asarray(b.lo, float)) & (x <= np.asarray(b.hi, float)), axis=1)
    return mask


#: Cells: how deep inside a held box's faces its nodes are ghost nodes (``fixed_region`` and box impulses of
#: ``mode = "set"``, the engines' ``mirror_held``): each takes the velocity of its mirror image across the box's
#: nearest face, reflected about the held velocity, so the grid field meets the held velocity on the face itself and a
#: uniform strain crosses it (docs/fracture.md, "The held region"). Twice :data:`HELD_STRAIN_CELLS`: the stencils of the
#: held points that deform reach that far.
MIRROR_CELLS = 3.0
#: Cells: held points (``fixed_region``) within this of their box's nearest face keep the grid's velocity gradient
#: (their ``F`` follows it, so they carry the stress of the material beside them); deeper ones keep ``F``. The free
#: material's stencils reach 1.5 cells past the face. The points of a box impulse of ``mode = "set"`` move with the grid
#: (whose nodes in the box are at its velocity; since round 32, docs/fracture.md "The held region"), and this near its
#: face take the same image gradient (:data:`HELD_STRAINED`) while it acts.
HELD_STRAIN_CELLS = 1.5
#: :func:`held_codes` of a held point within :data:`HELD_STRAIN_CELLS` of its region's face: ``HELD_STRAINED + a``, ``a``
#: the axis of that face's normal. The grid's gradient ``G`` there is the ghost field's, ``2 v_set - v(X')`` with
#: ``X' = R X`` the mirror image (``R`` the reflection across the face), so ``G = -grad v(X') R``: its column along the
#: normal is the image's, its columns along the face are the image's negated. Such a point takes ``G`` with those two
#: columns negated, the gradient of the material beside the face (:func:`image_gradient`; P2G advances ``F`` by it and
#: scatters the stress ``tau D`` that pairs with it). With the raw ``G`` a bar's lateral contraction (``nu > 0``)
#: reverses into an expansion in the held points: at ``nu`` 0.25 their stress along the bar is 1.3-1.4 times the
#: section's, and they damaged at half the strength (conformance ``brittle_below_strength``). A brittle point a box
#: holds keeps its damage: its stress is its mirror image's, not a crack of the body (docs/fracture.md); but once that
#: stress passes the full softening's (``d`` 1: the material beside the face is broken through) it stays broken
#: through, and a fixed region's nodes about it become a free-slip face (:func:`cuts_held_faces`).
HELD_STRAINED = 2
#: Cells: a free node this near outside the face of a set box that holds a brittle body (along the face's normal, within
#: its extent along the face) takes ``(v_set + s v_out) / (1 + s)``, ``s`` its distance in cells, ``v_out`` the next node
#: outward, so the linear field meets ``v_set`` on the face (docs/fracture.md "The held region", round 32).
SET_FACE_CELLS = 0.5


#: Cells: a free point not broken through this near a fixed region (past its box, along every axis) keeps the nodes of
#: its stencil from being a broken face (:func:`cuts_held_faces`): the face lets go only where every free point that
#: reads the node is broken through, so the crack's band beside it has broken across its width (1.5 cells at 8 points
#: a cell at a clamp's face). Marked by the held points alone (they break through with the band's first layer),
#: the face let go of the rest of the band early: the bar of ``tests/test_brittle.py`` dissipated 3.2 and 2.8 J/m^2
#: for ``G_f`` 5 (8 and 27 points a cell) instead of 5.06 and 4.99.
CUT_REACH = 1.5


def cuts_held_faces(kinds: Iterable[int], n_regions: int) -> bool:
    """Whether an engine marks its fixed regions' broken faces (docs/fracture.md, "The held region"): with a brittle
    material (``kinds``: the material kind codes in use, :data:`gasp_core.mpm.materials.BRITTLE`) and at least one
    ``fixed_region``, each substep a strained held point broken through (``Jp >= 1``) marks its stencil's nodes, and
    a ghost node so marked whose face's last node no intact free point reads (:data:`CUT_REACH`) takes the velocity
    of the first node past the face, less its normal part into the region, instead of its mirror image's reflected:
    the face of a body broken through there is free of traction. Without it the ghosts reflect the falling piece's
    velocity into the region (a no-slip face that drags the piece at 0.8 g and flings the crack's points up: a broken
    cantilever ran off the grid at frame 45)."""
    from gasp_core.mpm.materials import BRITTLE
    return n_regions > 0 and BRITTLE in {int(k) for k in kinds}


#: Cells: :func:`held_codes` strains a held point near its region's face only where the points sample the face's
#: normal finer than this about its mirror image (:func:`image_gap`: the widest gap along the normal within 1.5 cells
#: of it); else it stays rigid, as every held point was before issue 66. A cantilever of points 1.6 cells apart along
#: its length (a plugin test of a held cantilever) diverged on both MPM engines with strained held points (their ``J``
#: 1.6 by frame 4), the grid field between its layers being unresolved; held rigidly it behaves as before.
HELD_IMAGE_GAP = 1.0


def image_gradient(C: np.ndarray, axis: int) -> np.ndarray:
    """The velocity gradient ``C`` (..., 3, 3) of a ghost field at a held point, as the gradient at its mirror image
    across a face of normal ``axis`` (the engines do the same in their P2G, :data:`HELD_STRAINED`): the columns other
    than ``axis`` negated."""
    out = -np.array(C, dtype=np.float64)
    out[..., :, axis] *= -1
    return out


def held_codes(x: np.ndarray, boundaries: Iterable[Boundary], dx: float,
               sampled: bool = False) -> np.ndarray:
    """Each point's hold: 0 free, 1 held rigidly (inside a ``fixed_region``, :func:`fixed_mask`), ``HELD_STRAINED
    + a`` held within :data:`HELD_STRAIN_CELLS` cells of the nearest face of the region that holds it, ``a`` the axis
    of that face's normal (it keeps its position and ``v = 0``, but its ``F`` follows the grid's velocity gradient as
    the material beside the face: :data:`HELD_STRAINED`). A point deep inside one region is held rigidly though near
    the face of another. With ``sampled``, a point near a face is strained only where the points sample the normal
    about its mirror image across that face at least once a cell (:func:`image_gap` under :data:`HELD_IMAGE_GAP`);
    else it is held rigidly, as before issue 66 (a sparse cloud, or no material past the face).

    Parameters
    ----------
    x : ndarray, shape (n, 3)
        Initial positions, metres.
    boundaries : iterable of Boundary
    dx : float
        Grid spacing, metres.
    sampled : bool
        Whether to check the sampling about each image (:func:`image_gap`); without it every point near a face is
        strained.

    Returns
    -------
    ndarray, shape (n,), int8
    """
    x = np.asarray(x, dtype=np.float64)
    code = np.zeros(len(x), dtype=np.int8)
    deep = np.zeros(len(x), dtype=bool)
    for b in boundaries:
        if b.kind == "fixed_region":
            lo, hi = np.asarray(b.lo, float), np.asarray(b.hi, float)
            inside = np.all((x >= lo) & (x <= hi), axis=1)
            dist = np.minimum(x - lo, hi - x)
            near = inside & (dist.min(axis=1) < HELD_STRAIN_CELLS * dx)
            deep |= inside & ~near
            axis = dist.argmin(axis=1)
            if sampled and near.any():
                idx = np.flatnonzero(near)
                img = x[idx].copy()
                a, r = axis[idx], np.arange(len(idx))
                # the mirror image across the nearest face: 2 face - X along its normal
                face = np.where(img[r, a] - lo[a] < hi[a] - img[r, a], lo[a], hi[a])
                img[r, a] = 2.0 * face - img[r, a]
                sparse = image_gap(x, img, a, dx) >= HELD_IMAGE_GAP
                deep[idx[sparse]] = True
                near[idx[sparse]] = False
            code = np.where(near & (code == 0), HELD_STRAINED + axis, code).astype(np.int8)
    code[deep] = 1
    return code


def image_gap(x: np.ndarray, at: np.ndarray, axis: np.ndarray, dx: float) -> np.ndarray:
    """How finely the points ``x`` sample the normal about each of ``at`` (m, shape (m, 3)), in cells: the widest gap
    along ``axis`` (each row's normal axis) between the normal coordinates of the points within ``1.5 dx`` of it and
    the ends of that span, ``at -+ 1.5 dx`` (3 where no point is that near). :func:`held_codes` strains a held point
    only where this is under :data:`HELD_IMAGE_GAP` at its mirror image."""
    from scipy.spatial import cKDTree

    x = np.asarray(x, dtype=np.float64)
    at = np.asarray(at, dtype=np.float64).reshape(-1, 3)
    out = np.full(len(at), 3.0)
    for i, nb in enumerate(cKDTree(x).query_ball_point(at, 1.5 * dx)):
        if nb:
            c = np.sort(np.concatenate([[at[i, axis[i]] - 1.5 * dx, at[i, axis[i]] + 1.5 * dx],
                                        x[nb, axis[i]]]))
            out[i] = float(np.diff(c).max()) / dx
    return out


def cell_order(x: np.ndarray, domain_lo: np.ndarray, dx: float, n_grid: int) -> np.ndarray:
    """Stable order of the points by flat grid-cell index ``(i n_grid + j) n_grid + k``.

    Scatter and gather then touch neighbouring memory (cache locality); being stable, the order
    is the same on every run. Cells are ``floor((x - domain_lo) * (1 / dx))`` clipped to the grid;
    a non-finite position counts as cell 0.

    Parameters
    ----------
    x : ndarray, shape (n, 3)
        Positions, metres.
    domain_lo : ndarray, shape (3,)
        Grid origin, metres.
    dx : float
        Grid spacing, metres.
    n_grid : int

    Returns
    -------
    ndarray, shape (n,), int64
        ``order[i]`` is the index in ``x`` of the i-th point in cell order.
    """
    X = (np.asarray(x, dtype=np.float64) - domain_lo) * (1.0 / dx)
    with np.errstate(invalid="ignore"):
        c = np.clip(np.nan_to_num(np.floor(X), nan=0.0), 0, n_grid - 1).astype(np.int64)
    key = (c[:, 0] * n_grid + c[:, 1]) * n_grid + c[:, 2]
    return np.argsort(key, kind="stable")


def material_first_order(setup, dx: float) -> tuple[np.ndarray, int]:
    """Point order of a grid engine: material points by cell, then passive points by cell.

    Parameters
    ----------
    setup : SimSetup
        ``setup.passive`` marks the passive rows (G2P only).
    dx : float
        Grid spacing, metres.

    Returns
    -------
    order : ndarray, shape (n,), int64
        ``order[i]`` is the setup row of the engine's i-th point (:func:`cell_order` within each group).
    n_material : int
        Engine points ``[:n_material]`` are material points.
    """
    if setup.passive is None:
        return cell_order(setup.x, setup.domain_lo, dx, setup.n_grid), len(setup.x)
    mat = np.flatnonzero(~setup.passive)
    pas = np.flatnonzero(setup.passive)
    order = np.concatenate([mat[cell_order(setup.x[mat], setup.domain_lo, dx, setup.n_grid)],
                            pas[cell_order(setup.x[pas], setup.domain_lo, dx, setup.n_grid)]])
    return order, len(mat)


def engine_mass_stats(x: np.ndarray, p_mass: np.ndarray) -> dict[str, Any]:
    """``mass`` (kg), ``centre_of_mass`` (m) and ``inertia`` (kg m^2, about the centre of mass) of a grid
    engine's points, for its ``stats()``.

    Parameters
    ----------
    x : ndarray, shape (n, 3)
        Current positions, metres, read back from the engine.
    p_mass : ndarray, shape (n,)
        The point masses the engine's P2G scatters, kg, read back from the engine in the same
        order (passive points hold 0).
    """
    return mass_properties(x, p_mass)


def stranded_passive(x: np.ndarray, grid_m: np.ndarray, domain_lo: np.ndarray, dx: float) -> int:
    """How many passive points see no node with mass in their quadratic stencil (27 nodes).

    Such a point gathers no velocity (it stays where it is) because the material has moved away
    from it: a surface left hanging where sand or liquid flowed off. Engines report it in
    ``stats()`` as ``passive_stranded``, from the last grid update.

    Parameters
    ----------
    x : ndarray, shape (m, 3)
        Passive points, metres.
    grid_m : ndarray, shape (n_grid, n_grid, n_grid)
        Node masses of the last grid update, kg (index ``[i, j, k]`` = node at ``lo + (i, j, k) dx``).
    domain_lo : ndarray, shape (3,)
        Grid origin, metres.
    dx : float
        Grid spacing, metres.
    """
    if len(x) == 0:
        return 0
    ng = grid_m.shape[0]
    base = np.floor((np.asarray(x, np.float64) - domain_lo) / dx - 0.5).astype(np.int64)
    has = grid_m > 0
    seen = np.zeros(len(x), bool)
    for o in itertools.product(range(3), repeat=3):
        idx = np.clip(base + np.array(o), 0, ng - 1)
        seen |= has[idx[:, 0], idx[:, 1], idx[:, 2]]
    return int((~seen).sum())


def passive_bounds(setup, contact: str = "grid") -> tuple[np.ndarray, np.ndarray]:
    """The box ``[lo, hi]`` (metres, float64, shape (3,) each) the boundaries keep passive points in.

    A passive point (``SimSetup.passive``) is a massless marker of the body's surface: it has no P2G, so the
    ground's particle contact, which acts on material points, never holds it, and below the material it
    reads an extrapolation of the grid velocity. The draft README donut's surface vertices lie 1.2 dx below
    its lowest fill point, so once it rests on the ground they are inside the ground, and its impact
    (``dv_z/dz > 0``: a compression extrapolated downwards sends them faster down) drove them 1.9 dx deep;
    there they were left behind when the donut bounced and, when it landed again, carried out of the grid
    (``docs/contact.md``, "Passive points"). The marker of a body's surface cannot be where the body cannot
    be, so the engines put a passive point that ends an update outside this box back on its face (the
    closest admissible point) and remove the velocity it stores into that face (:func:`hold_passive`). It has no
    mass: no momentum or energy of the simulated body changes. (The material points' hold, ``box_hold``, reads it too.)

    - ``ground``: ``z >= height`` (the plane itself, with either contact model; the highest of several);
    - ``walls``: ``lo_d + 3 dx <= x_d <= hi_d - 3 dx`` on each axis, the walls' planes (:data:`WALL_NODES`), but no
      floor face with a ground, which is then the floor (``contact.wall_floor``, ``wall_faces``; round 97: for the
      particle contact too, whose passive points were held on the floor's plane up to 3 cells above a lower ground;
      ``contact`` no longer changes the box): with ``contact = "grid"`` the walls' grid rule stops the node layers on the planes and
      behind them (``gasp_core.mpm.contact.wall_grid_cells``); with ``contact = "particle"`` its points meet the
      planes (``contact.contact_planes``);
    - ``fixed_region``: nothing (its passive points are held where they start, like its material points);
    - no boundary on a side: ``-inf`` / ``+inf`` (a point that leaves the grid there is still reported).
    """
    lo = np.full(3, -np.inf)
    hi = np.full(3, np.inf)
    d_lo = np.asarray(setup.domain_lo, dtype=np.float64)
    d_hi = np.asarray(setup.domain_hi, dtype=np.float64)
    dx = float(setup.dx)
    for b in setup.boundaries:
        if b.kind == "walls":   # the walls' planes (contact.contact_planes, contact.wall_grid_cells, wall_floor)
            planes = d_lo + WALL_NODES * dx
            if any(g.kind == "ground" for g in setup.boundaries):
                planes[2] = -np.inf   # the ground is the floor (contact.wall_floor, contact.wall_faces)
            lo = np.maximum(lo, planes)
            hi = np.minimum(hi, d_hi - WALL_NODES * dx)
        elif b.kind == "ground":
            lo[2] = max(lo[2], float(b.height))
    return lo, hi


def passive_floor_friction(setup, contact: str = "grid") -> float:
    """The Coulomb coefficient of the face :func:`passive_bounds` holds passive points on from below (its ``lo[2]``):
    the highest ground's ``friction``, or the walls' where their floor is higher; 0 with neither (dimensionless)."""
    floor = passive_bounds(setup, contact)[0][2]
    grounds = [b for b in setup.boundaries if b.kind == "ground" and float(b.height) == floor]
    walls = [b for b in setup.boundaries if b.kind == "walls"]
    return float((grounds or walls)[0].friction) if grounds or walls else 0.0


def hold_passive(x: np.ndarray, v: np.ndarray, lo: np.ndarray, hi: np.ndarray, stranded=None,
                 mu: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    """Passive points after an update, held in the box of :func:`passive_bounds` (the kernels' reference).

    Parameters
    ----------
    x, v : ndarray, shape (m, 3)
        Positions (m) and stored velocities (m/s) after the update.
    lo, hi : ndarray, shape (3,)
        :func:`passive_bounds`.

    Returns
    -------
    x, v : ndarray, shape (m, 3)
        On each axis, a point below ``lo_d`` is put at ``lo_d`` and its velocity's component ``v_d`` made
        ``max(v_d, 0)`` (it may leave the face, never go into it); above ``hi_d`` likewise with ``min``.
        The tangential velocity is the grid's (with the ground's friction in it); nothing else changes, except:
    stranded : ndarray of bool, shape (m,), optional
        Points that read no node with mass (:func:`stranded_passive`): one held on the floor (``lo_2``) is slowed by
        Coulomb friction ``mu`` (:func:`passive_floor_friction`), its horizontal speed less by ``mu`` times the speed
        into the floor removed (issue 53: at n_grid 48 a quarter of a sand column's surface points, left on the ground
        by the collapse, kept sliding at 0.5 m/s and left the grid).
    """
    x = np.array(x, dtype=np.float64)
    v = np.array(v, dtype=np.float64)
    below, above = x < lo, x > hi
    x = np.clip(x, lo, hi)
    held = np.where(below, np.maximum(v, 0.0), np.where(above, np.minimum(v, 0.0), v))
    if stranded is not None:
        floor = np.asarray(stranded, bool) & below[:, 2]
        vt = np.linalg.norm(held[:, :2], axis=1)
        cut = np.minimum(vt, mu * (held[:, 2] - v[:, 2])) / np.maximum(vt, 1e-30)
        held[floor, :2] *= 1.0 - cut[floor, None]
    return x, held


def blow_up_rows(v: np.ndarray, passive) -> np.ndarray:
    """The rows of ``v`` (shape (n, 3), m/s, setup order) whose speed decides whether points out of the grid are a
    blow-up (faster than a cell a substep) or drifted out (feature ``left_domain``): the material points', not the
    passive ones' (``passive``: ``SimSetup.passive``, shape (n,) bool, or None). A passive point adds nothing to the
    grid, so its speed is no sign of an unstable step: it reads the grid's affine field ``v + C y`` beyond the
    material, which a crushed body's release makes steep (issue 66, ``docs/fracture.md``: the brittle README donut
    at 20 m/s, its material at most 0.85 of a cell a substep, its surface points 1.28 cells). So the engines count
    material points out of the grid only; a passive one drops out, counted as ``left_domain`` (docs/fracture.md r36).
    """
    return v if passive is None else np.asarray(v)[~np.asarray(passive, dtype=bool)]
