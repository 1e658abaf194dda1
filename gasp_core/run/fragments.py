"""A stiff brittle body's break on impact into fragments (issue 66 item 5; ``docs/fracture.md`` "Stiff brittle
bodies: fragments"): whether an impact breaks it, how large its fragments are, and which point goes to which.

A ``brittle`` body at handbook stiffness moves as one rigid body (``docs/rigid.md``). When a frame shows an impact
(its mean velocity changed by more than gravity explains), the approach speed ``v_n`` along the impulse gives:

* **the break**, when the plane-wave stress ``sigma = rho c v_n`` (``c = sqrt(E / rho)``: the stress behind a
  wave front in a bar that meets a rigid wall at ``v_n``, the same bound the rigid route's strain estimate takes,
  ``gasp_core.prepare.route``) reaches the tensile strength ``f_t``, and the kinetic energy of the approach
  ``M v_n^2 / 2`` pays the cracks of two fragments at least (:func:`break_check`);
* **the fragment size**, Grady's energy balance of a body expanding at strain rate ``epsdot``
  (Grady 1982, "Local inertial effects in dynamic fragmentation", J. Appl. Phys. 53, 322, Eq. 8):
  ``s = (sqrt(24) K_Ic / (rho c epsdot))^(2/3)``, the same as ``s = (24 G_f / (rho epsdot^2))^(1/3)`` with
  ``K_Ic^2 = E G_f`` (Irwin) and ``E = rho c^2`` (:func:`grady_size`). The impact's strain rate is taken as
  ``epsdot = v_n / L``, ``L`` the body's extent along the impulse (the body stops over its own length);
* **the fragments**, Voronoi cells of ``N = V / s^3`` seeds (at least 2, at most :data:`MAX_FRAGMENTS`) drawn
  among the body's points with a weight ``1 / (d + s)^2`` of their distance ``d`` to the impact point (smaller
  cells where the stress is highest), each cell split further into its connected parts (a cell of a hollow body
  may hold two walls) and parts under :data:`MIN_POINTS` points joined to a neighbour (:func:`split_body`).

The fragments go on as rigid bodies (``gasp_core.run.fragment_run``).
"""
from __future__ import annotations

import math

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components
from scipy.spatial import cKDTree

#: Most fragments one break makes (each is a rigid body of the engine).
MAX_FRAGMENTS = 48
#: A connected part of a cell with fewer material points is joined to the fragment of its nearest other point.
MIN_POINTS = 8
#: Rest neighbours are closer than this times the fill spacing (the pieces' links, ``gasp_core.run.pieces``).
LINK_RADIUS = 1.5


def grady_size(rho: float, fracture_energy: float, strain_rate: float) -> float:
    """Grady's fragment size (module notes), m.

    Parameters
    ----------
    rho : float
        Density, kg/m^3.
    fracture_energy : float
        ``G_f``, J/m^2.
    strain_rate : float
        1/s, positive.

    Returns
    -------
    float
        ``(24 G_f / (rho epsdot^2))^(1/3)``; ``inf`` at zero strain rate.
    """
    if strain_rate <= 0.0:
        return math.inf
    return (24.0 * fracture_energy / (rho * strain_rate * strain_rate)) ** (1.0 / 3.0)


def break_check(m, mass: float, volume: float, length: float, v_n: float) -> dict:
    """Whether an impact at approach speed ``v_n`` breaks a body of material ``m``, and its fragments' size.

    Parameters
    ----------
    m : Material
        ``E``, ``rho``, ``tensile_strength``, ``fracture_energy``.
    mass : float
        kg.
    volume : float
        m^3.
    length : float
        The body's extent along the impulse, m (the strain rate ``v_n / length``).
    v_n : float
        Approach speed along the impulse, m/s.

    Returns
    -------
    dict
        ``breaks`` (bool), ``stress`` (``rho c v_n``, Pa), ``strain_rate`` (1/s), ``size`` (m), ``count`` (the
        fragments, 0 when it does not break), ``energy`` (``M v_n^2 / 2``, J), ``crack_energy`` (``G_f`` times the
        cracks' area ``3 V^(2/3) (N^(1/3) - 1)``, J: ``N`` cubes of the body's volume have ``6 V^(2/3) N^(1/3)`` of
        faces, the body's own ``6 V^(2/3)``, each new face shared by two cubes). The count is lowered until the
        energy pays its cracks; a body whose energy does not pay two fragments' does not break.
    """
    c = math.sqrt(m.E / m.rho)
    stress = m.rho * c * max(v_n, 0.0)
    rate = max(v_n, 0.0) / max(length, 1e-12)
    size = grady_size(m.rho, m.fracture_energy, rate)
    energy = 0.5 * mass * v_n * v_n
    count = int(min(MAX_FRAGMENTS, max(2, round(volume / size ** 3)))) if math.isfinite(size) else 0
    crack = lambda n: m.fracture_energy * 3.0 * volume ** (2.0 / 3.0) * (n ** (1.0 / 3.0) - 1.0)
    while count > 2 and crack(count) > energy:   # the energy pays no more cracks than this
        count -= 1
    breaks = bool(stress >= m.tensile_strength and count >= 2 and crack(2) <= energy)
    return {"breaks": breaks, "stress": stress, "strain_rate": rate, "size": size, "count": count if breaks else 0,
            "energy": energy, "crack_energy": crack(count) if breaks else 0.0}


def ground_hit(height: float, vz: float, g: float, dt: float) -> float | None:
    """The speed (m/s) at which a body whose lowest point is ``height`` (m) over a ground, moving at ``vz`` (m/s,
    up positive) under gravity ``g`` (m/s^2, downwards positive) meets it within ``dt`` (s) in free fall; None when
    it does not (``height + vz t - g t^2 / 2 = 0`` has no root in ``[0, dt]``)."""
    if height < 0.0 or not np.isfinite(height):
        return None
    disc = vz * vz + 2.0 * g * height
    if disc < 0.0:
        return None
    v_hit = float(np.sqrt(disc))
    t = (vz + v_hit) / g if g > 0.0 else (height / -vz if vz < 0.0 else np.inf)
    return v_hit if t <= dt else None


def split_body(x: np.ndarray, material: np.ndarray, spacing: float, impact: np.ndarray, count: int, size: float,
               seed: int = 0) -> np.ndarray:
    """Each point's fragment (module notes), shape (n,), int64, ``0 .. k - 1`` numbered by mass share (largest 0).

    Parameters
    ----------
    x : ndarray, shape (n, 3)
        The body's points, m.
    material : ndarray, shape (n,), bool
        Points that carry mass (the others, passive, take the fragment of their nearest material point).
    spacing : float
        The body's fill spacing, m (its rest links: :data:`LINK_RADIUS` spacings).
    impact : ndarray, shape (3,)
        The impact point, m.
    count : int
        Seeds (Voronoi cells), at least 1.
    size : float
        The fragment size ``s`` of the seeds' weights, m.
    seed : int
        The random draw's seed (a run is repeatable).

    Returns
    -------
    ndarray, shape (n,), int64
    """
    x = np.asarray(x, np.float64)
    mat = np.flatnonzero(material)
    rng = np.random.default_rng(seed)
    d = np.linalg.norm(x[mat] - np.asarray(impact, np.float64), axis=1)
    w = 1.0 / (d + size) ** 2
    seeds = rng.choice(len(mat), size=min(count, len(mat)), replace=False, p=w / w.sum())
    out = np.zeros(len(x), np.int64)
    out[mat] = cKDTree(x[mat][seeds]).query(x[mat])[1]
    return connected_cells(x, material, spacing, out)


def connected_cells(x: np.ndarray, material: np.ndarray, spacing: float, cell: np.ndarray) -> np.ndarray:
    """Each point's fragment, shape (n,), int64, ``0 .. k - 1`` numbered by points (largest 0): the connected parts
    (rest links closer than :data:`LINK_RADIUS` ``spacing``, m) of each of the material points' cells ``cell`` (n,)
    int, parts under :data:`MIN_POINTS` points joined to the part of their nearest point in a larger one, and the
    passive points (not ``material``) in the fragment of their nearest material point. ``x`` (n, 3), m."""
    x = np.asarray(x, np.float64)
    mat = np.flatnonzero(material)
    cell = np.asarray(cell, np.int64)[mat]
    pairs = cKDTree(x[mat]).query_pairs(LINK_RADIUS * spacing, output_type="ndarray")
    same = cell[pairs[:, 0]] == cell[pairs[:, 1]]
    p = pairs[same]
    graph = coo_matrix((np.ones(len(p)), (p[:, 0], p[:, 1])), shape=(len(mat), len(mat)))
    part = connected_components(graph, directed=False)[1]
    sizes = np.bincount(part)
    small = sizes[part] < MIN_POINTS
    if small.any() and (~small).any():   # a small part joins the part of its nearest point in a large one
        big = np.flatnonzero(~small)
        part[small] = part[big[cKDTree(x[mat][big]).query(x[mat][small])[1]]]
    _, part = np.unique(part, return_inverse=True)
    order = np.argsort(-np.bincount(part), kind="stable")   # largest first
    part = np.argsort(order)[part]
    out = np.empty(len(x), np.int64)
    out[mat] = part
    rest = np.flatnonzero(~np.asarray(material, bool))
    if len(rest):
        out[rest] = part[cKDTree(x[mat]).query(x[rest])[1]]
    return out


def cut_damage(x: np.ndarray, fragment: np.ndarray, material: np.ndarray, spacing: float) -> np.ndarray:
    """A damage field that cuts the pieces' links between fragments: 1 on every material point with a rest neighbour
    (closer than :data:`LINK_RADIUS` spacings) in another fragment, 0 elsewhere, shape (n,), float64. The pieces
    (``gasp_core.run.pieces``) then label the fragments and the crack faces (``gasp_core.maps.crack_faces``) show on
    the points next to the cut, on both sides."""
    x = np.asarray(x, np.float64)
    mat = np.flatnonzero(material)
    pairs = cKDTree(x[mat]).query_pairs(LINK_RADIUS * spacing, output_type="ndarray")
    cross = pairs[fragment[mat][pairs[:, 0]] != fragment[mat][pairs[:, 1]]]
    d = np.zeros(len(x))
    d[mat[cross.ravel()]] = 1.0
    return d


def encode(cell: np.ndarray, band: np.ndarray) -> np.ndarray:
    """``SimSetup.cells`` (Grady's cells on a soft body, ``gasp_core.run.grady_cells``) from each point's cell ``cell``
    (n,) int >= 0 and whether it is a band point ``band`` (n,) bool: the cell for a band point, ``-2 - cell`` for an
    inside point (it never damages); shape (n,), int32."""
    cell = np.asarray(cell, np.int64)
    return np.where(np.asarray(band, bool), cell, -2 - cell).astype(np.int32)


def decode(cells: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(cell, inside)`` of ``SimSetup.cells`` (:func:`encode`): each point's cell (n,) int64, -1 where none
    (``grady_cells.NO_CELL``), and whether it is a cell's inside (n,) bool."""
    c = np.asarray(cells, np.int64)
    inside = c <= -2
    return np.where(inside, -2 - c, c), inside
