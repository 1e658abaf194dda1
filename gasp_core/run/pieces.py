"""Pieces: the connected parts of a broken body, labelled each frame from the engine's per-point damage.

A body of the ``brittle`` material breaks where its points' damage ``d`` (the engine feature ``damage``,
``docs/fracture.md``) reaches 1. Two material points are *linked* when they were neighbours at rest (each point's
at most :data:`MAX_LINKS` nearest within :data:`LINK_RADIUS` times the body's fill spacing, the 90th percentile of
its ``p_vol^(1/3)``: the work and memory are bounded by the points, whatever one point's volume), both have
``d < BROKEN`` and the two are no further apart than a spacing plus ``gap`` (``SimSetup.dx``: a crack a grid cell
wide parts the pieces, whatever the damage says; issue 66); a piece is a connected component of the undamaged points over those
links (``scipy.sparse.csgraph.connected_components``).
A broken point (``d >= BROKEN``, the crack band) or one without a rest neighbour joins the piece of the nearest
undamaged linked point at its current position, and a passive point the piece of the nearest material point at
rest, so every point, and each piece's mass, is counted once. Points of different bodies never link.

``run.json`` holds, per frame, ``pieces`` (the count) and ``piece_mass`` (kg, each piece's, largest first);
``gasp simulate --json`` emits a ``pieces`` event when the count changes (``frame``, ``pieces``,
``piece_mass``).

Each Gaussian's piece: ``<run>/<object>/pieces_NNNN.npy`` beside the frame's file (:func:`write_frame_pieces`,
:func:`read_pieces`), int32 of shape (n_gaussians,) in the file's row order: the piece of the point that anchors the
Gaussian (:meth:`gasp_core.maps.surface.SurfaceMap.anchors`: its triangle's ``v1``, so a triangle whose vertices fall
in different pieces goes whole to ``v1``'s), numbered within the object from 0, the heaviest first; -1 for rows that
are not simulated (``select``, ``static``). ``gasp export --split-pieces`` reads them.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
from scipy.sparse import csr_matrix
from scipy.sparse.csgraph import connected_components
from scipy.spatial import cKDTree

from gasp_core.errors import SceneError
from gasp_core.fsutil import atomic_write

#: A point at or above this damage no longer links its neighbours: it carries at most 10 % of its tensile stress.
BROKEN = 0.9
#: Rest neighbours are closer than this times the fill spacing ``max(p_vol)^(1/3)`` (the fill's lattice,
#: docs/fill.md): a lattice's face and edge neighbours (1 and sqrt 2 spacings) but no pair across one broken layer
#: (2 spacings).
LINK_RADIUS = 1.5
#: A point links at most this many rest neighbours (a lattice's 6 face and 12 edge neighbours).
MAX_LINKS = 18
#: The body's fill spacing is this percentile of its points' ``p_vol^(1/3)`` (the fill's lattice; a few points of
#: outsized volume, an open shell's, do not widen the links).
SPACING_PERCENTILE = 90.0


class PieceTracker:
    """The pieces of a run's points, frame after frame.

    Parameters
    ----------
    x_rest : ndarray, shape (n, 3), float64
        Rest positions, m (``SimSetup.x``).
    body_id : ndarray, shape (n,), int
    p_mass : ndarray, shape (n,), float64
        Point masses, kg; 0 marks a passive point (rendered, not simulated).
    p_vol : ndarray, shape (n,), float64
        Point volumes, m^3 (the link radius, :data:`LINK_RADIUS`).
    gap : float, optional
        A link whose points are further apart than the body's spacing plus this (m; ``SimSetup.dx``) is cut: their
        cells have opened by more than ``gap``. Default: the body's spacing.
    """

    def __init__(self, x_rest: np.ndarray, body_id: np.ndarray, p_mass: np.ndarray, p_vol: np.ndarray,
                 gap: float | None = None):
        x_rest = np.asarray(x_rest, np.float64)
        self.body = np.asarray(body_id)
        self.mass = np.asarray(p_mass, np.float64)
        self.material = np.flatnonzero(self.mass > 0)
        pairs, reach = [], []
        for b in np.unique(self.body[self.material]):
            idx = np.intersect1d(self.material, np.flatnonzero(self.body == b))
            spacing = float(np.percentile(np.cbrt(np.asarray(p_vol, np.float64)[idx]), SPACING_PERCENTILE))
            pairs.append(self._rest_pairs(x_rest, idx, LINK_RADIUS * spacing))
            reach.append(np.full(len(pairs[-1]), spacing + (spacing if gap is None else float(gap))))
        self.pairs = np.concatenate(pairs) if pairs else np.zeros((0, 2), np.int64)
        # a link is cut when its two points are further apart than a spacing plus the gap: their cells are then apart
        # by more than the gap (a face link opened by the gap, an edge link by less); never below a quarter over its
        # rest length (a fill coarser than the grid keeps its rest links)
        rest = np.linalg.norm(x_rest[self.pairs[:, 0]] - x_rest[self.pairs[:, 1]], axis=1)
        self._open = np.maximum(np.concatenate(reach) if reach else np.zeros(0), 1.25 * rest)
        self.linked = np.zeros(len(self.mass), bool)
        self.linked[self.pairs.ravel()] = True
        # the links both ways, sorted by their first point (a CSR graph's order): each labelling only masks them
        rows = np.concatenate([self.pairs[:, 0], self.pairs[:, 1]])
        cols = np.concatenate([self.pairs[:, 1], self.pairs[:, 0]])
        order = np.lexsort((cols, rows))
        self._pair_of = np.concatenate([np.arange(len(self.pairs))] * 2)[order]
        self._cols = cols[order].astype(np.int32)
        self._degree = np.bincount(rows, minlength=len(self.mass))
        self._indptr = np.concatenate([[0], np.cumsum(self._degree)])
        passive = np.flatnonzero(self.mass <= 0)
        near = cKDTree(x_rest[self.material]).query(x_rest[passive])[1] if len(passive) else np.zeros(0, np.int64)
        self.passive, self.passive_host = passive, self.material[near]
        self.count: int | None = None
        #: The labels of the last :meth:`row`, shape (n,), int64 (what :func:`write_frame_pieces` writes).
        self.last_labels: np.ndarray | None = None
        self._last: tuple[np.ndarray, np.ndarray] | None = None   # (intact mask, labels) of the last labelling

    def split_bodies(self, body_id: np.ndarray) -> None:
        """Cut for good the links between points now of different bodies (``body_id``, shape (n,): a stiff brittle
        body broken into rigid fragments, each its own body, ``gasp_core.run.fragment_run``): the pieces are then at
        least the bodies, without damage."""
        b = np.asarray(body_id)
        self._open[b[self.pairs[:, 0]] != b[self.pairs[:, 1]]] = -1.0
        self._last = None

    @staticmethod
    def _rest_pairs(x: np.ndarray, idx: np.ndarray, radius: float) -> np.ndarray:
        """Index pairs (k, 2), each once, of the points ``idx``: each point with its at most :data:`MAX_LINKS` nearest
        closer than ``radius`` (m) at rest (at most ``MAX_LINKS len(idx)`` pairs: bounded by the input)."""
        if len(idx) < 2:
            return np.zeros((0, 2), np.int64)
        k = min(MAX_LINKS + 1, len(idx))
        dist, near = cKDTree(x[idx]).query(x[idx], k=k, distance_upper_bound=radius)
        me = np.broadcast_to(np.arange(len(idx))[:, None], near.shape)
        ok = np.isfinite(dist) & (near != me)
        a, b = me[ok], near[ok]
        ab = np.unique(np.stack([np.minimum(a, b), np.maximum(a, b)], 1), axis=0)
        return idx[ab]

    def labels(self, x: np.ndarray, damage: np.ndarray | None) -> np.ndarray:
        """Piece label of every point, shape (n,), int64, 0 .. count - 1 (pieces numbered by first point).

        ``x`` (n, 3): current positions, m; ``damage`` (n,) in [0, 1] or None (nothing broken). Labelled again only
        when the set of intact points changed since the last call (damage never heals: a frame where nothing broke
        costs one comparison); the broken points keep the piece they joined then."""
        n = len(self.mass)
        d = np.zeros(n) if damage is None else np.asarray(damage, np.float64)
        whole = (d < BROKEN) & self.linked
        x = np.asarray(x, np.float64)
        held = np.linalg.norm(x[self.pairs[:, 0]] - x[self.pairs[:, 1]], axis=1) <= self._open
        state = np.concatenate([whole, held])
        if self._last is not None and np.array_equal(state, self._last[0]):
            return self._last[1]   # nothing broke or opened since: the same pieces
        comp = self._components(whole, held)
        lab = np.full(n, -1, np.int64)
        intact = self.material[whole[self.material]]
        lab[intact] = comp[intact]
        broken = self.material[~whole[self.material]]
        if len(broken):
            if len(intact):
                lab[broken] = lab[intact[cKDTree(x[intact]).query(x[broken])[1]]]
            else:   # nothing intact: each broken point a piece of its own
                lab[broken] = broken
        lab[self.passive] = lab[self.passive_host]
        _, first, dense = np.unique(lab, return_index=True, return_inverse=True)
        lab = np.argsort(np.argsort(first))[dense]
        self._last = (state, lab)
        return lab

    def _components(self, whole: np.ndarray, held: np.ndarray) -> np.ndarray:
        """Connected components over the ``held`` links (per pair) between ``whole`` points, shape (n,): a CSR graph
        cut from the sorted two-way links without a sort or a transpose (the cost of a frame where something broke;
        on a symmetric graph the strong components are the connected ones)."""
        n = len(self.mass)
        keep = np.repeat(whole, self._degree) & whole[self._cols] & held[self._pair_of]
        indptr = np.concatenate([[0], np.cumsum(keep)])[self._indptr]
        graph = csr_matrix((np.ones(int(indptr[-1]), np.int8), self._cols[keep], indptr), shape=(n, n))
        graph.has_sorted_indices = True
        return connected_components(graph, directed=True, connection="strong")[1]

    def row(self, x: np.ndarray, damage: np.ndarray | None) -> tuple[dict, bool]:
        """``({"pieces": count, "piece_mass": [kg, largest first]}, changed)`` of the frame at positions ``x``;
        ``changed``: the count differs from the last call's (always True on the first)."""
        lab = self.labels(x, damage)
        self.last_labels = lab
        masses = np.bincount(lab, weights=self.mass)
        count = int(len(masses))
        changed, self.count = count != self.count, count
        return {"pieces": count, "piece_mass": sorted((float(m) for m in masses), reverse=True)}, changed


def tracker_for(setup) -> PieceTracker | None:
    """A :class:`PieceTracker` of ``setup`` (a :class:`~gasp_core.seam.setup.SimSetup`) when one of its bodies is
    ``brittle``, else None (nothing can break)."""
    if not any(m.name == "brittle" for m in setup.materials):
        return None
    return PieceTracker(setup.x, setup.body_id, setup.p_mass, setup.p_vol, gap=setup.dx)


def frame_row(tracker: PieceTracker, reporter, frame: int, x: np.ndarray, damage: np.ndarray | None) -> dict:
    """The frame's ``run.json`` figures (:meth:`PieceTracker.row`); on a change of the count (and at frame 0), the
    event ``{"event": "pieces", "frame", "pieces", "piece_mass"}`` through ``reporter``
    (:class:`gasp_core.run.report.Reporter`)."""
    row, changed = tracker.row(x, damage)
    if changed:
        reporter.emit({"event": "pieces", "frame": frame, **row})
    return row


#: A frame's piece file in an object's folder (module notes).
PIECES_FILE = "pieces_{:04d}.npy"


def gaussian_pieces(o, labels: np.ndarray, mass: np.ndarray) -> np.ndarray:
    """Each Gaussian's piece in object ``o`` (a :class:`~gasp_core.prepare.placed.PreparedObject`), shape
    (o.gaussians.n,), int32, file row order (module notes): ``labels`` (n_points,) the setup's point labels
    (:meth:`PieceTracker.labels`), ``mass`` (n_points,) kg, to number the object's pieces heaviest first."""
    out = np.full(o.gaussians.n, -1, np.int32)
    if o.spec.static or o.surface is None:
        return out
    lab = np.asarray(labels)[o.vertex_slice][o.surface.anchors()]
    out[np.arange(o.gaussians.n) if o.moving is None else o.moving] = piece_ranks(o, labels, mass)[lab]
    return out


def piece_ranks(o, labels: np.ndarray, mass: np.ndarray) -> np.ndarray:
    """The object's number of each point label (``labels`` (n_points,) from :meth:`PieceTracker.labels`), shape
    (max label + 1,), int32: the pieces that hold a Gaussian of ``o`` numbered 0.. heaviest first (``mass``
    (n_points,) kg), -1 for the others (:func:`gaussian_pieces`, the crack faces' ``piece``)."""
    labels = np.asarray(labels)
    present = np.unique(labels[o.vertex_slice][o.surface.anchors()])
    masses = np.bincount(labels, weights=mass)
    rank = np.full(len(masses), -1, np.int32)
    rank[present] = np.argsort(np.argsort(-masses[present], kind="stable"), kind="stable")
    return rank


def write_frame_pieces(folder, prep, frame: int, labels: np.ndarray, mass: np.ndarray) -> list[str]:
    """Write ``<object>/pieces_NNNN.npy`` of every simulated object of ``prep`` (a
    :class:`~gasp_core.prepare.scene.PreparedScene`) into the run folder ``folder``, atomically (a resumed run
    rewrites its frame); the files written, relative to ``folder``."""
    rels = []
    for o, name in zip(prep.objects, prep.names):
        if o.spec.static:
            continue
        rel = f"{name}/{PIECES_FILE.format(frame)}"
        a = gaussian_pieces(o, labels, mass)
        atomic_write(Path(folder) / rel, lambda f, a=a: np.save(f, a), overwrite=True)
        rels.append(rel)
    return rels


def read_pieces(run, name: str, frame: int) -> np.ndarray | None:
    """Object ``name``'s Gaussians' pieces at ``frame`` in the run folder ``run`` (module notes), shape
    (n_gaussians,), int32; None when the run has no such file (no brittle body, or a run before pieces were
    written)."""
    path = Path(run) / name / PIECES_FILE.format(frame)
    if not path.is_file():
        return None
    try:      # memory-mapped: a header that claims more than the file holds reads nothing (issue 68)
        a = np.load(path, mmap_mode="r", allow_pickle=False)
    except (OSError, ValueError, EOFError) as e:     # random bytes, a pickle, an empty or cut file
        raise SceneError(f"{path}: not a pieces file written by gasp simulate ({type(e).__name__}: "
                         f"{str(e)[:120] or 'empty'}); expected one int32 piece per Gaussian (.npy)") from None
    if not isinstance(a, np.ndarray):                # an .npz archive under the name
        raise SceneError(f"{path}: not a pieces file written by gasp simulate (an archive); expected one int32 "
                         "piece per Gaussian (.npy)")
    return a      # memory-mapped until its shape is checked (gasp_core.run.split_pieces.frame_labels)
