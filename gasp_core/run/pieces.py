"""Pieces: the parts of a broken body that have come apart, labelled each frame from its points' geometry and damage.

A body of the ``brittle`` material breaks where its points' damage ``d`` (the engine feature ``damage``,
``docs/fracture.md``) reaches 1. Two material points are *linked* when they were neighbours at rest (each point's
at most :data:`MAX_LINKS` nearest within :data:`LINK_RADIUS` times the body's fill spacing, the 90th percentile of
its ``p_vol^(1/3)``: the work and memory are bounded by the points, whatever one point's volume). A link is *cut*
when the geometry and the damage agree (issue 66): its two points are further apart than its rest length plus
``gap`` (``SimSetup.dx``: their cells have opened by a grid cell) while one of them is broken (``d >=``
:data:`BROKEN`). A cut link stays cut (the damage never heals, and the pieces never rejoin), so the count never
decreases. A piece is a connected component of the material points over the links not cut
(``scipy.sparse.csgraph.connected_components``): a body broken through everywhere is as many fragments as its
opened cracks make, and a broken point that has not moved a gap from its neighbours stays with them. A point without
a rest neighbour joins the piece of the nearest linked point at its current position, and a passive point the piece
of the nearest material point at rest, so every point, and each piece's mass, is counted once. Points of different
bodies never link; an elastic body's points (``d = 0``) never part.

*Debris*: a piece lighter than :data:`DEBRIS_SHARE` of its body's mass is a crumb, counted apart. A piece that
crumbles whole leaves its heaviest crumb a piece (the part that has come apart is still there, ground small), so
``pieces`` never decreases either.

``run.json`` holds, per frame, ``pieces`` (the count, crumbs apart), ``piece_mass`` (kg, each piece's, largest
first), ``debris`` (the crumbs' count) and ``debris_mass`` (kg, their total); ``gasp simulate --json`` emits a
``pieces`` event when the count or the crumbs' change (``frame``, ``pieces``, ``piece_mass``, ``debris``,
``debris_mass``). The cut links, the last labels and which of them are pieces go into the run's checkpoint
(:meth:`PieceTracker.state`, :mod:`gasp_core.run.resume`): a resumed run labels as an uninterrupted one.

Each Gaussian's piece: ``<run>/<object>/pieces_NNNN.npy`` beside the frame's file (:func:`write_frame_pieces`,
:func:`read_pieces`), int32 of shape (n_gaussians,) in the file's row order: the piece of the point that anchors the
Gaussian (:meth:`gasp_core.maps.surface.SurfaceMap.anchors`: its triangle's ``v1``, so a triangle whose vertices fall
in different pieces goes whole to ``v1``'s), numbered within the object from 0, the heaviest first, the crumbs all
under the number after the pieces (one debris node in an export, not one a crumb); -1 for rows that are not simulated
(``select``, ``static``). ``gasp export --split-pieces`` reads them.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
from scipy.sparse import csr_matrix
from scipy.sparse.csgraph import connected_components
from scipy.spatial import cKDTree

from gasp_core.errors import GaspError, SceneError
from gasp_core.fsutil import atomic_write

#: A link opened past its gap is cut only when one of its points is at or above this damage (it carries at most
#: 10 % of its tensile stress): the geometry and the damage together.
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
#: A piece lighter than this share of its body's mass is debris, counted apart (issue 66: 0.1 %).
DEBRIS_SHARE = 1e-3


class PieceTracker:
    """The pieces of a run's points, frame after frame (module notes).

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
        A link whose points are further apart than its rest length plus this (m; ``SimSetup.dx``) has opened: their
        cells are apart by more than ``gap``. Default: the body's spacing.
    debris : float, optional
        A piece lighter than this share of its body's mass is debris (:data:`DEBRIS_SHARE`).
    """

    def __init__(self, x_rest: np.ndarray, body_id: np.ndarray, p_mass: np.ndarray, p_vol: np.ndarray,
                 gap: float | None = None, debris: float = DEBRIS_SHARE):
        x_rest = np.asarray(x_rest, np.float64)
        self.body = np.asarray(body_id)
        self.mass = np.asarray(p_mass, np.float64)
        self.material = np.flatnonzero(self.mass > 0)
        pairs, reach = [], []
        self.crumb = np.zeros(len(self.mass))      # per point, its body's debris mass (kg)
        for b in np.unique(self.body[self.material]):
            idx = np.intersect1d(self.material, np.flatnonzero(self.body == b))
            spacing = float(np.percentile(np.cbrt(np.asarray(p_vol, np.float64)[idx]), SPACING_PERCENTILE))
            pairs.append(self._rest_pairs(x_rest, idx, LINK_RADIUS * spacing))
            reach.append(np.full(len(pairs[-1]), spacing if gap is None else float(gap)))
            self.crumb[idx] = debris * self.mass[idx].sum()
        self.pairs = np.concatenate(pairs) if pairs else np.zeros((0, 2), np.int64)
        # a link opens past its rest length plus the gap; never below a quarter over its rest length (a fill coarser
        # than the grid keeps its rest links)
        rest = np.linalg.norm(x_rest[self.pairs[:, 0]] - x_rest[self.pairs[:, 1]], axis=1)
        self._open = np.maximum(rest + (np.concatenate(reach) if reach else 0.0), 1.25 * rest)
        #: Per link, whether it has been cut (never undone), shape (n_links,), bool.
        self.cut = np.zeros(len(self.pairs), bool)
        #: Per link, whether it joins two of Grady's cells (:meth:`split_cells`), shape (n_links,), bool.
        self.cross = np.zeros(len(self.pairs), bool)
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
        self.count: tuple | None = None
        #: The labels of the last :meth:`row`, shape (n,), int64 (what :func:`write_frame_pieces` writes).
        self.last_labels: np.ndarray | None = None
        self._lab: np.ndarray | None = None        # the last labelling, (n,) int64
        self._counted: np.ndarray | None = None    # per label of it, a piece (True) or a crumb

    def split_bodies(self, body_id: np.ndarray) -> None:
        """Cut for good the links between points now of different bodies (``body_id``, shape (n,): a stiff brittle
        body broken into rigid fragments, each its own body, ``gasp_core.run.fragment_run``): the pieces are then at
        least the bodies, without damage."""
        b = np.asarray(body_id)
        self.cut |= b[self.pairs[:, 0]] != b[self.pairs[:, 1]]
        self._lab = None      # labelled again at the next call (kept in the checkpoint with the other cut links)

    def split_cells(self, cells: np.ndarray) -> None:
        """Grady's cells laid on a soft brittle body (``SimSetup.cells``, :mod:`gasp_core.run.grady_cells`): from now
        on a link between two cells is cut once it opens past its gap, whatever its points' damage (the engines part
        the cells at their faces without breaking every band point)."""
        from gasp_core.run.fragments import decode
        cell = decode(cells)[0]
        a, b = cell[self.pairs[:, 0]], cell[self.pairs[:, 1]]
        self.cross = (a >= 0) & (b >= 0) & (a != b)

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

    def cut_links(self, x: np.ndarray, damage: np.ndarray | None) -> int:
        """Cut the links opened past their gap at positions ``x`` (n, 3), m, with a point broken (``damage`` (n,) in
        [0, 1], None: nothing broken); the number newly cut."""
        if (damage is None and not self.cross.any()) or not len(self.pairs):
            return 0
        a, b = self.pairs[:, 0], self.pairs[:, 1]
        broken = self.cross.copy()
        if damage is not None:
            d = np.asarray(damage, np.float64)
            broken |= np.maximum(d[a], d[b]) >= BROKEN
        live = np.flatnonzero(~self.cut & broken)
        x = np.asarray(x, np.float64)
        opened = live[np.linalg.norm(x[a[live]] - x[b[live]], axis=1) > self._open[live]]
        self.cut[opened] = True
        return len(opened)

    def labels(self, x: np.ndarray, damage: np.ndarray | None) -> np.ndarray:
        """Piece label of every point, shape (n,), int64, 0 .. count - 1 (pieces and crumbs, numbered by first point).

        ``x`` (n, 3): current positions, m; ``damage`` (n,) in [0, 1] or None (nothing broken). Labelled again only
        when a link was cut since the last call (a frame where nothing parted costs one pass over the live broken
        links); the points without a rest neighbour keep the piece they joined then."""
        if not self.cut_links(x, damage) and self._lab is not None:
            return self._lab
        n = len(self.mass)
        keep = ~self.cut[self._pair_of]
        indptr = np.concatenate([[0], np.cumsum(keep)])[self._indptr]
        graph = csr_matrix((np.ones(int(indptr[-1]), np.int8), self._cols[keep], indptr), shape=(n, n))
        graph.has_sorted_indices = True   # on a symmetric graph the strong components are the connected ones
        lab = connected_components(graph, directed=True, connection="strong")[1].astype(np.int64)
        linked = self.material[self.linked[self.material]]
        alone = self.material[~self.linked[self.material]]
        if len(alone) and len(linked):
            x = np.asarray(x, np.float64)
            lab[alone] = lab[linked[cKDTree(x[linked]).query(x[alone])[1]]]
        lab[self.passive] = lab[self.passive_host]
        _, first, dense = np.unique(lab, return_index=True, return_inverse=True)
        lab = np.argsort(np.argsort(first))[dense.ravel()]
        self._counted = self._pieces_of(lab)
        self._lab = lab
        return lab

    def _pieces_of(self, lab: np.ndarray) -> np.ndarray:
        """Per label of ``lab``, whether it is a piece (module notes: at least :data:`DEBRIS_SHARE` of its body, or
        the heaviest part of a piece of the last labelling none of whose parts is), shape (max + 1,), bool."""
        masses = np.bincount(lab, weights=self.mass)
        pts = self.material[self.linked[self.material]]
        if not len(pts):
            pts = self.material
        _, at = np.unique(lab[pts], return_index=True)
        rep = np.full(len(masses), -1, np.int64)
        rep[lab[pts[at]]] = pts[at]                       # a linked point of each label (one with material)
        counted = masses >= self.crumb[np.maximum(rep, 0)]
        if self._lab is None or self._counted is None:
            return counted
        has = rep >= 0
        parent = np.full(len(masses), -1, np.int64)
        parent[has] = self._lab[rep[has]]                 # cut links only split: each part lies in one old piece
        kept = np.zeros(len(self._counted), bool)
        kept[parent[counted & has]] = True
        orphan = self._counted & ~kept                    # old pieces left only crumbs
        if orphan.any():
            kids = np.flatnonzero(has & orphan[np.maximum(parent, 0)])
            order = kids[np.lexsort((-masses[kids], parent[kids]))]
            _, first = np.unique(parent[order], return_index=True)
            counted[order[first]] = True                  # each one's heaviest crumb stays a piece
        return counted

    def row(self, x: np.ndarray, damage: np.ndarray | None) -> tuple[dict, bool]:
        """``({"pieces", "piece_mass", "debris", "debris_mass", "broken_mass", "cut_links"}, changed)`` of the frame
        at positions ``x`` (module notes; masses in kg, the pieces' largest first); ``changed``: the pieces or the
        crumbs differ from the last call's in number (always True on the first).

        Round 80: ``broken_mass`` (kg) is the mass of the points at or above :data:`BROKEN` and ``cut_links`` the rest
        links cut so far (opened past their gap with a point broken: the open cracks), so a body that cracks without
        coming apart says so (one piece, ``cut_links`` > 0). With ``damage`` None (frame 0; a stiff body's rigid
        fragments, ``gasp_core.run.fragment_run``, whose pieces are the fragments) ``broken_mass`` is 0, and
        ``cut_links`` counts the links between the fragments (:meth:`split_bodies`)."""
        lab = self.labels(x, damage)
        self.last_labels = lab
        masses = np.bincount(lab, weights=self.mass)
        piece = self._counted
        count = (int(piece.sum()), int((~piece).sum()))
        changed, self.count = count != self.count, count
        broken = 0.0 if damage is None else float(self.mass[np.asarray(damage) >= BROKEN].sum())
        return {"pieces": count[0], "piece_mass": sorted((float(m) for m in masses[piece]), reverse=True),
                "debris": count[1], "debris_mass": float(masses[~piece].sum()), "broken_mass": broken,
                "cut_links": int(self.cut.sum())}, changed

    @property
    def pieces(self) -> np.ndarray | None:
        """Per label of the last labelling, whether it is a piece (False: a crumb), shape (count,), bool; None before
        the first."""
        return self._counted

    def state(self) -> dict[str, np.ndarray]:
        """What a checkpoint keeps (:mod:`gasp_core.run.resume`): ``cut`` (n_links,) bool, ``labels`` (n,) int64 and
        ``counted`` (n_labels,) bool of the last labelling (empty before the first), copies."""
        lab = np.zeros(0, np.int64) if self._lab is None else self._lab
        counted = np.zeros(0, bool) if self._counted is None else self._counted
        return {"cut": self.cut.copy(), "labels": lab.copy(), "counted": counted.copy()}

    def restore(self, state: dict[str, np.ndarray]) -> None:
        """Go on from a :meth:`state` (a resumed run).

        Raises
        ------
        GaspError
            Its arrays are missing or do not fit this tracker's links and points (a damaged checkpoint).
        """
        try:
            cut, lab, counted = (np.asarray(state[k]) for k in ("cut", "labels", "counted"))
            fits = cut.shape == self.cut.shape and lab.size in (0, len(self.mass)) and \
                (not lab.size or (lab.min() >= 0 and counted.shape == (int(lab.max()) + 1,)))
        except (KeyError, ValueError, TypeError):
            fits = False
        if not fits:
            raise GaspError("cannot resume: the checkpoint's pieces (cut links, labels) do not fit the scene's points; "
                            "start again with --discard")
        self.cut = cut.astype(bool)
        self._lab = lab.astype(np.int64) if lab.size else None
        self._counted = counted.astype(bool) if lab.size else None
        if self._lab is not None:
            self.count = (int(self._counted.sum()), int((~self._counted).sum()))


def tracker_for(setup) -> PieceTracker | None:
    """A :class:`PieceTracker` of ``setup`` (a :class:`~gasp_core.seam.setup.SimSetup`) when one of its bodies is
    ``brittle``, else None (nothing can break)."""
    if not any(m.name == "brittle" for m in setup.materials):
        return None
    t = PieceTracker(setup.x, setup.body_id, setup.p_mass, setup.p_vol, gap=setup.dx)
    if getattr(setup, "cells", None) is not None:
        t.split_cells(setup.cells)
    return t


def frame_row(tracker: PieceTracker, reporter, frame: int, x: np.ndarray, damage: np.ndarray | None) -> dict:
    """The frame's ``run.json`` figures (:meth:`PieceTracker.row`); on a change of the pieces' or the crumbs' count
    (and at frame 0), the event ``{"event": "pieces", "frame", **row}`` through ``reporter``
    (:class:`gasp_core.run.report.Reporter`)."""
    row, changed = tracker.row(x, damage)
    if changed:
        reporter.emit({"event": "pieces", "frame": frame, **row})
    return row


def summary_clause(rows: list[dict]) -> str:
    """The console's words on the pieces at a run's last frame (``gasp simulate``'s result line), from its
    ``run.json`` frame rows (each a dict; only rows with ``pieces`` count): ``""`` for a run with no brittle body,
    else e.g. ``"; last frame: 1 piece, cracked (23.6 % of the brittle mass broken), 0 crumbs"``."""
    rows = [r for r in rows if "pieces" in r]
    if not rows:
        return ""
    first, last = rows[0], rows[-1]
    total = sum(first["piece_mass"]) + first["debris_mass"]
    n = last["pieces"]
    broken = last.get("broken_mass", 0.0) / total if total > 0 else 0.0
    state = (f", cracked ({100 * broken:.1f} % of the brittle mass broken)" if n == 1 and last.get("cut_links", 0)
             else f" ({100 * broken:.1f} % of the brittle mass broken)" if broken > 0 else "")
    return (f"; last frame: {n} piece{'s' if n != 1 else ''}{state}, {last['debris']} "
            f"crumb{'s' if last['debris'] != 1 else ''}")


#: A frame's piece file in an object's folder (module notes).
PIECES_FILE = "pieces_{:04d}.npy"


def gaussian_pieces(o, labels: np.ndarray, mass: np.ndarray, piece: np.ndarray | None = None) -> np.ndarray:
    """Each Gaussian's piece in object ``o`` (a :class:`~gasp_core.prepare.placed.PreparedObject`), shape
    (o.gaussians.n,), int32, file row order (module notes): ``labels`` (n_points,) the setup's point labels
    (:meth:`PieceTracker.labels`), ``mass`` (n_points,) kg, to number the object's pieces heaviest first, ``piece``
    (per label, bool: :attr:`PieceTracker.pieces`) the labels that are pieces, the others crumbs (:func:`piece_ranks`);
    None: every label a piece."""
    out = np.full(o.gaussians.n, -1, np.int32)
    if o.spec.static or o.surface is None:
        return out
    lab = np.asarray(labels)[o.vertex_slice][o.surface.anchors()]
    out[np.arange(o.gaussians.n) if o.moving is None else o.moving] = piece_ranks(o, labels, mass, piece)[lab]
    return out


def piece_ranks(o, labels: np.ndarray, mass: np.ndarray, piece: np.ndarray | None = None) -> np.ndarray:
    """The object's number of each point label (``labels`` (n_points,) from :meth:`PieceTracker.labels`), shape
    (max label + 1,), int32: the pieces that hold a Gaussian of ``o`` numbered 0.. heaviest first (``mass``
    (n_points,) kg), then the crumbs that hold one (``piece`` (max label + 1,) bool False, :attr:`PieceTracker.pieces`;
    None: none) all under the one number after them (an export's debris node, not one node a crumb); -1 for the
    others (:func:`gaussian_pieces`, the crack faces' ``piece``)."""
    labels = np.asarray(labels)
    present = np.unique(labels[o.vertex_slice][o.surface.anchors()])
    masses = np.bincount(labels, weights=mass)
    rank = np.full(len(masses), -1, np.int32)
    crumb = np.zeros(len(present), bool) if piece is None else ~np.asarray(piece, bool)[present]
    big = present[~crumb]
    rank[big] = np.argsort(np.argsort(-masses[big], kind="stable"), kind="stable")
    rank[present[crumb]] = len(big)
    return rank


def write_frame_pieces(folder, prep, frame: int, labels: np.ndarray, mass: np.ndarray,
                       piece: np.ndarray | None = None) -> list[str]:
    """Write ``<object>/pieces_NNNN.npy`` of every simulated object of ``prep`` (a
    :class:`~gasp_core.prepare.scene.PreparedScene`) into the run folder ``folder``, atomically (a resumed run
    rewrites its frame); the files written, relative to ``folder`` (:func:`gaussian_pieces`)."""
    rels = []
    for o, name in zip(prep.objects, prep.names):
        if o.spec.static:
            continue
        rel = f"{name}/{PIECES_FILE.format(frame)}"
        a = gaussian_pieces(o, labels, mass, piece)
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
