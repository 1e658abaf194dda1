"""The pieces of a body counted from its frames alone, with no damage read: the check of
:class:`gasp_core.run.pieces.PieceTracker` (issue 66, item 4).

Two points of a body are linked when they were closer than ``radius`` (m) at rest
(:meth:`scipy.spatial.cKDTree.query_pairs`, every such pair, no cap); a link holds while its points are no
further apart than their rest distance plus ``gap`` (m; the grid cell ``dx``: separated by a gap of at least
1 dx). The parts are the connected components over the links that hold (``scipy.sparse.csgraph``); those of at
least ``share`` of the body's mass (1 %) are counted. Nothing here reads the damage or remembers an earlier frame.

Round 77, ``remember=True``: a link that has opened past its reach on any frame counted stays open (the parts a user
saw come apart stay apart when they land in a heap; issue 66: the count "never decreases"). Without it, pieces that
met again after coming apart are one part again: at n_grid 48-64 the ball at 10 m/s sprays to the walls by frame 7-9
and its fragments meet again from frame 8-10, where the run's tracker, which never rejoins, counts them apart
(``docs/fracture.md`` "Round 77"). Still no damage read.
"""
from __future__ import annotations

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components
from scipy.spatial import cKDTree

#: Parts of at least this share of the body's mass are counted (issue 66: 1 %).
SHARE = 0.01


class FramePieces:
    """Counts a body's parts frame by frame from its positions (module notes).

    Parameters
    ----------
    x_rest : ndarray, shape (n, 3), float64
        Rest positions, m (one body's material points).
    mass : ndarray, shape (n,), float64
        Point masses, kg.
    radius : float
        Rest neighbours are closer than this, m (the fill's face and edge neighbours: 1.5 fill spacings).
    gap : float
        A link whose points have moved apart by more than this over their rest distance no longer holds, m.
    remember : bool, optional
        A link that has opened on a frame counted stays open (module notes; default False: each frame alone).
    """

    def __init__(self, x_rest: np.ndarray, mass: np.ndarray, radius: float, gap: float, remember: bool = False):
        x_rest = np.asarray(x_rest, np.float64)
        self.mass = np.asarray(mass, np.float64)
        self.pairs = cKDTree(x_rest).query_pairs(radius, output_type="ndarray")
        self.reach = np.linalg.norm(x_rest[self.pairs[:, 0]] - x_rest[self.pairs[:, 1]], axis=1) + gap
        #: Per link, opened on an earlier frame (``remember``), else None.
        self.opened = np.zeros(len(self.pairs), bool) if remember else None

    def masses(self, x: np.ndarray) -> np.ndarray:
        """Each part's mass at positions ``x`` (n, 3), m, kg, largest first, shape (parts,). With ``remember``, the
        links opened here stay open for the later calls (call it once a frame, in order)."""
        x = np.asarray(x, np.float64)
        a, b = self.pairs[:, 0], self.pairs[:, 1]
        hold = np.linalg.norm(x[a] - x[b], axis=1) <= self.reach
        if self.opened is not None:
            self.opened |= ~hold
            hold = ~self.opened
        n = len(self.mass)
        graph = coo_matrix((np.ones(int(hold.sum())), (a[hold], b[hold])), shape=(n, n))
        lab = connected_components(graph, directed=False)[1]
        return np.sort(np.bincount(lab, weights=self.mass))[::-1]

    def count(self, x: np.ndarray, share: float = SHARE) -> int:
        """Parts of at least ``share`` of the body's mass at positions ``x`` (n, 3), m."""
        return int((self.masses(x) >= share * self.mass.sum()).sum())


def tracker_count(row: dict, total: float, share: float = SHARE) -> int:
    """A :meth:`~gasp_core.run.pieces.PieceTracker.row`'s pieces of at least ``share`` of ``total`` (kg)."""
    return sum(m >= share * total for m in row["piece_mass"])
