"""A grid velocity field per solid body against the bodies it touches, by colouring (round 61, issue 67 item 4,
``docs/contact.md`` "Round 61: a field per body by colouring"; the switch :data:`COLOUR`).

The two-field contact (:mod:`gasp_core.mpm.fields`) has two grid velocity fields, A and B, and a table ``in_a`` (one
int per body) that says which field a body scatters to and reads from. Two bodies take a field each; before round 61
three or more solids shared one field and were welded wherever they touched. Two fields serve any number of bodies
when no two bodies of the same field come within reach of each other: the bodies are the vertices of a graph whose
edges join bodies within reach, and a 2-colouring of that graph is a valid ``in_a``.

**Reach.** Two points share a grid node of the quadratic B-spline when they are less than 3 cells apart along every
axis (each reaches 1.5 cells); two bodies of one field that share a node move as one there. The reach is
``3 dx`` plus what the pair can close in :data:`TRAVEL_FRAMES` frames from their initial speeds under gravity
(:func:`reach`). Candidate pairs are those whose bounding boxes, padded by the reach, overlap; for those only, a
k-d tree of one body's points (Chebyshev metric) is asked for the other's nearest point within reach (bounded:
``O(n log n)`` per candidate pair; 1 ms for 840 points, 120 ms for 116,000).

**Colouring.** Breadth-first per connected component over a spanning forest of its closest pairs (Kruskal, the
pairs in order of their nearest points' distance), so that where the graph has an odd cycle the pair left in one
field is the cycle's farthest (in a settling stack of three, the bottom and top bodies came within the padded reach of
each other, and the colouring of the whole graph left a touching pair in one field for those frames); each component
has two colourings (one the other's flip).
Which goes to B matters: field B's mass gradient gives the contact normal at every node both fields share
(``fields.py``: the larger body's face; a small block's own edges tilt the normal and it ploughs, round 22). For each
edge the larger body (by volume) should be in B; on a path of three bodies of falling size (a block on a block on a
block) one edge cannot have it. The colouring whose correctly oriented edges carry the most relative speed (the
bodies' mean initial velocities) is taken, so the edge that slides has its larger body's normal; where the speeds tie
(within :data:`SPEED_TIE` m/s), the one that puts the component's largest body in B (measured: the thrown block on a
block on a block slides within 0.5 % of Coulomb's distance either way, ``docs/contact.md``; flat faces do not tilt
the normal much). A component that is not bipartite (an odd cycle: three bodies touching each other) leaves some
edges within one colour: those pairs share a field as before (:func:`colour`'s ``shared``; the engines warn, naming
them, ``gasp_core.mpm.shared_fields``).

**Friction.** The two fields' contact takes one coefficient for the whole grid (``fields.field_friction``): here the
smallest of the graph's pairs' (``combine_friction``); bodies of several coefficients are not covered per pair.

The colouring is made when an engine is built, from the setup's points and velocities, and again at the start of every
frame from the last frame's (:data:`RECOLOUR`, :func:`recolour`; the engines write ``in_a`` between frames, the grid
fields are rebuilt every substep from the points): the reach covers :data:`TRAVEL_FRAMES` frames' travel, so a body
cannot come within a node of another of its field unseen within the frame. Per frame a component takes the
orientation that keeps more of its bodies in the field they had (the speeds' rule only on a tie): with the speeds'
rule alone, the relative speeds of bodies settling in a stack (noise) flipped whole stacks between frames, and their
rest gaps moved by up to 0.06 dx (``docs/contact.md``).
"""
from __future__ import annotations

from collections import deque

import numpy as np

#: Round 61's colouring (three or more soft bodies on the particle contact take the two fields by a 2-colouring of
#: the graph of bodies within reach). False: one field for them all (the rule before, the catch of the tests).
COLOUR = True
#: The colouring made again at each frame from the last frame's points and velocities (:func:`recolour`, the engines'
#: ``step_frame``). False: once, at build, from the setup's (the colouring of the setup then holds for the run).
RECOLOUR = True
#: The frames of free travel added to the reach (see the module notes).
TRAVEL_FRAMES = 1.0
#: Round 62 (:mod:`gasp_core.mpm.rigid_pairs`): rigid bodies among three or more take the colouring, their touching
#: pairs the two-body law solved together. False: one field for a scene of three or more bodies with a rigid one (the
#: rule before, the catch of ``tests/test_rigid_three.py``).
RIGID_PAIRS = True
#: Relative speeds (m/s) closer than this are a tie in the choice of the colouring that goes to B.
SPEED_TIE = 1e-6


def _material_view(setup):
    """``(x (n, 3), v (n, 3), vol (n,), body (n,))`` of the setup's material points (``n_material`` first ones)."""
    n_mat = getattr(setup, "n_material", None)
    n = len(setup.x) if n_mat is None else int(n_mat)
    x = np.asarray(setup.x, float)[:n]
    v = np.broadcast_to(np.asarray(setup.v, float), np.asarray(setup.x).shape)[:n]
    vol = np.broadcast_to(np.asarray(setup.p_vol, float), (len(setup.x),))[:n]
    body = np.broadcast_to(np.asarray(setup.body_id), (len(setup.x),))[:n]
    return x, v, vol, body


def reach(setup) -> np.ndarray:
    """The distance (m, Chebyshev) within which two bodies must take different fields, per pair (shape (n_materials,
    n_materials)): ``3 dx`` plus what the two can close over :data:`TRAVEL_FRAMES` frames, ``(s_i + s_j) t + |g|
    t^2``, ``s`` a body's largest initial point speed (m/s), ``t`` the frames' duration (one body falling freely
    beside one held: ``|g| t^2 / 2``, taken twice)."""
    x, v, _, body = _material_view(setup)
    nb = len(setup.materials)
    t = float(TRAVEL_FRAMES) * float(setup.frame_dt)
    g = float(np.linalg.norm(np.asarray(setup.gravity, float)))
    speed = np.sqrt((np.asarray(v, float) ** 2).sum(1))
    vmax = np.zeros(nb)   # a body's largest speed (0 without points; round 64: one pass, not a mask a body)
    np.maximum.at(vmax, np.asarray(body), speed)
    return 3.0 * float(setup.dx) + (vmax[:, None] + vmax[None, :]) * t + g * t * t


def contact_graph(setup, r=None) -> list[tuple[int, int]]:
    """The pairs ``(i, j)``, ``i < j``, of bodies whose material points come within ``r[i, j]`` (m, Chebyshev;
    default :func:`reach`) of each other, the closest pair first: bounding boxes padded by ``r`` first, then a k-d
    tree on the candidates (the nearest point within reach, the tree on the pair's larger body). Round 64 (the same
    pairs, the same distances, the same order): the points split by body once, the boxes' test on all pairs at once,
    and only the smaller body's points inside the larger's box padded by ``r`` asked, nearest the box first,
    until the rest are farther than the least distance found (:func:`_near_box`, :func:`_nearest`)."""
    from scipy.spatial import cKDTree
    x, _, _, body = _material_view(setup)
    nb = len(setup.materials)
    r = reach(setup) if r is None else np.broadcast_to(np.asarray(r, float), (nb, nb))
    pts = body_points(x, body, nb)
    has = np.array([len(p) > 0 for p in pts])
    lo = np.array([p.min(0) if len(p) else np.zeros(3) for p in pts]).reshape(nb, 3)
    hi = np.array([p.max(0) if len(p) else np.zeros(3) for p in pts]).reshape(nb, 3)
    # apart: i's box padded by r[i, j] below j's, or j's padded by r[i, j] below i's, along an axis
    apart = np.any(hi[:, None, :] + r[:, :, None] < lo[None, :, :], axis=2)
    apart |= np.any(hi[None, :, :] + r[:, :, None] < lo[:, None, :], axis=2)
    cand = np.triu(~apart & has[:, None] & has[None, :], 1)
    trees: dict[int, object] = {}
    edges = []
    for i, j in zip(*np.nonzero(cand)):
        i, j = int(i), int(j)
        a, b = (i, j) if len(pts[i]) >= len(pts[j]) else (j, i)   # the tree on the larger body
        q, low = _near_box(pts[b], lo[a], hi[a], r[i, j])
        if not len(q):
            continue
        if a not in trees:
            trees[a] = cKDTree(pts[a])
        d = _nearest(trees[a], q, low, r[i, j], _margin(lo[a], hi[a]))
        if np.isfinite(d):
            edges.append((d, i, j))
    return [(i, j) for _, i, j in sorted(edges)]


def body_points(x: np.ndarray, body: np.ndarray, nb: int) -> list[np.ndarray]:
    """Each body's points (``x[body == b]`` for ``b < nb``, in their order; shape (n_b, 3)), by one stable sort."""
    body = np.asarray(body)
    order = np.argsort(body, kind="stable")
    counts = np.bincount(body, minlength=nb)
    return np.split(x[order], np.cumsum(counts)[:-1])[:nb]


def _margin(lo: np.ndarray, hi: np.ndarray) -> float:
    """1e-9 of a box's largest coordinate, at least 1e-9 m: far above the rounding of a distance near it."""
    return 1e-9 * max(1.0, float(np.abs(lo).max()), float(np.abs(hi).max()))


def _near_box(q: np.ndarray, lo: np.ndarray, hi: np.ndarray, r: float) -> tuple[np.ndarray, np.ndarray]:
    """``(near, low)``: the points of ``q`` (n, 3) not farther than ``r`` plus :func:`_margin` outside the box ``lo``,
    ``hi`` along any axis, and their distance to the box (Chebyshev, negative inside; a lower bound on the distance to
    any point in it): the others are farther than ``r`` from every point in the box, so a k-d tree query bounded by
    ``r`` finds none for them, by more than its rounding."""
    low = np.max(np.maximum(lo - q, q - hi), axis=1)
    keep = low <= r + _margin(lo, hi)
    return q[keep], low[keep]


def _nearest(tree, q: np.ndarray, low: np.ndarray, r: float, margin: float) -> float:
    """The least Chebyshev distance from the points ``q`` (n, 3) to ``tree``'s points, found within ``r`` (inf where
    none): the points asked in batches (64, then doubling) in order of ``low``, their lower bounds, until the next
    bound exceeds the least found by more than ``margin`` (those left are farther: the same least distance as asking
    them all, by fewer queries)."""
    order = np.argsort(low, kind="stable")
    best, start, step = np.inf, 0, 64
    while start < len(order) and low[order[start]] <= best + margin:
        d, _ = tree.query(q[order[start:start + step]], k=1, p=np.inf, distance_upper_bound=r)
        d = d[np.isfinite(d)]
        if len(d):
            best = min(best, float(d.min()))
        start, step = start + step, 2 * step
    return best


def colour(n: int, edges, vol, vel, prev=None) -> tuple[np.ndarray, list[tuple[int, int]]]:
    """``(in_a, shared)``: a 2-colouring of the graph of ``n`` bodies and ``edges`` (shape (n,), bool, True in field
    A) and the edges left within one colour (odd cycles). ``vol`` (n,) the bodies' volumes, ``vel`` (n, 3) their mean
    velocities choose each component's orientation (module notes); ``prev`` (n,) bool, the last frame's fields, where
    given: the orientation that keeps more of the component's bodies in their field, the rule above on a tie."""
    adj = [[] for _ in range(n)]
    tree = [[] for _ in range(n)]   # a spanning forest of the closest pairs (edges closest first): an odd cycle's
    root_of = list(range(n))        # pair left in one field is then its farthest, not a touching one
    for i, j in edges:
        adj[i].append(j)
        adj[j].append(i)
        ri, rj = _find(root_of, i), _find(root_of, j)
        if ri != rj:
            root_of[ri] = rj
            tree[i].append(j)
            tree[j].append(i)
    col = np.full(n, -1)
    in_a = np.zeros(n, bool)
    for root in np.argsort(-np.asarray(vol, float), kind="stable"):
        if col[root] >= 0:
            continue
        comp, q = [int(root)], deque([int(root)])
        col[root] = 0
        while q:
            u = q.popleft()
            for w in tree[u]:
                if col[w] < 0:
                    col[w] = 1 - col[u]
                    comp.append(w)
                    q.append(w)
        # orientation: colour 0 in B (the root, the largest body) unless the flip orients more sliding speed
        score = 0.0
        for u in comp:
            for w in adj[u]:
                if u < w and col[u] != col[w]:
                    big = u if vol[u] >= vol[w] else w
                    s = float(np.linalg.norm(np.asarray(vel[u]) - np.asarray(vel[w])))
                    score += s if col[big] == 0 else -s
        flip = score < -SPEED_TIE
        if prev is not None:   # per frame: keep the bodies where they were (a flip on noise would swap them all)
            keep = sum(1 if bool(prev[u]) == (col[u] == 1) else -1 for u in comp)
            flip = keep < 0 or (keep == 0 and flip)
        for u in comp:
            in_a[u] = (col[u] == 1) != flip
    shared = [(i, j) for i, j in edges if in_a[i] == in_a[j]]
    return in_a, shared


def _find(root_of: list, a: int) -> int:
    """Union-find's root of ``a`` (path halving)."""
    while root_of[a] != a:
        root_of[a] = root_of[root_of[a]]
        a = root_of[a]
    return a


_CACHE: list = []


def colour_scene(setup, prev=None):
    """``(in_a, shared, edges)`` of a setup (:func:`contact_graph`, :func:`colour`): ``in_a`` (n_materials,) bool;
    the last two setups' kept (the same object with the same point array: an engine's build and its stats ask
    several times)."""
    for kept, x, out in _CACHE:
        if kept is setup and x is setup.x:
            return out
    x, v, vol, body = _material_view(setup)
    nb = len(setup.materials)
    vols = np.bincount(body, weights=vol, minlength=nb)
    w = np.maximum(np.bincount(body, minlength=nb), 1)
    vel = np.stack([np.bincount(body, weights=v[:, k], minlength=nb) / w for k in range(3)], 1)
    edges = contact_graph(setup)
    in_a, shared = colour(nb, edges, vols, vel, prev)
    _CACHE[:] = [*_CACHE[-1:], (setup, setup.x, (in_a, shared, edges))]   # the last two (a setup, a frame's view)
    return in_a, shared, edges


def recolour(eng) -> np.ndarray | None:
    """Round 61 (:data:`RECOLOUR`): an engine's ``in_a`` (shape (n_materials,), int32) from its last frame's points
    (``eng.positions()``, ``eng.velocities()``, setup order; ``eng.setup``'s volumes and bodies), or None where its
    scene is not :func:`coloured` or before the first frame (the build's colouring holds). The pairs left sharing a
    field are added to ``eng.colour_shared`` (a set, for the stats)."""
    from types import SimpleNamespace
    from gasp_core.mpm.rigid import step_view
    if getattr(eng, "colour_on", None) is None:
        eng.colour_on = bool(RECOLOUR) and coloured(step_view(eng.setup))
        eng.colour_shared = set()
        eng.colour_prev = colour_scene(step_view(eng.setup))[0] if eng.colour_on else None   # the build's
    if not eng.colour_on or eng.frame == 0:
        return None
    st = eng.setup
    view = SimpleNamespace(x=np.asarray(eng.positions(), float), v=np.asarray(eng.velocities(), float),
                           p_vol=st.p_vol, body_id=st.body_id, materials=st.materials, dx=float(st.dx),
                           frame_dt=st.frame_dt, gravity=st.gravity, n_material=getattr(eng, "n_material", None))
    in_a, shared, _ = colour_scene(view, eng.colour_prev)
    eng.colour_prev = in_a
    eng.colour_shared.update(shared)
    return in_a.astype(np.int32)


def colour_state(eng) -> dict[str, np.ndarray]:
    """What a coloured engine's state adds (:meth:`gasp_core.mpm.grid_engine.GridEngineBase.get_state`): the fields of
    its last frame, ``colour_prev`` (shape (n_materials,), int32), which the next frame's :func:`recolour` keeps where
    it can; empty for a scene that is not coloured (or before its first recolouring)."""
    prev = getattr(eng, "colour_prev", None)
    return {} if prev is None else {"colour_prev": np.asarray(prev, np.int32).copy()}


def restore_colour(eng, state: dict) -> None:
    """Restore :func:`colour_state` into a freshly built engine, so a resumed run colours its next frame as the run
    it continues would have (the build's colouring otherwise)."""
    if "colour_prev" not in state:
        return
    from gasp_core.mpm.rigid import step_view
    eng.colour_on = bool(RECOLOUR) and coloured(step_view(eng.setup))
    eng.colour_shared = set()
    eng.colour_prev = np.asarray(state["colour_prev"]).astype(bool) if eng.colour_on else None


def coloured(setup) -> bool:
    """Whether a setup takes round 61's colouring: :data:`COLOUR`, the option ``contact_fields`` on, three or more
    bodies on the particle contact (none flowing), none rigid unless round 62's :data:`RIGID_PAIRS` (rigid bodies
    among three or more: their pairs solved together, :mod:`gasp_core.mpm.rigid_pairs`)."""
    from gasp_core.mpm.contact import contact_model
    from gasp_core.mpm.rigid import rigid_mask
    return (bool(COLOUR) and setup.options.get("contact_fields", True) and len(setup.materials) >= 3
            and contact_model(setup) == "particle"
            and (bool(RIGID_PAIRS) or not np.asarray(rigid_mask(setup.materials)).any()))
