"""Crack faces in a run's output: ``<object>/crack_faces_NNNN.ply`` beside each frame of a brittle object.

Each file is a graphdeco 3DGS PLY in the object's file frame (the frame file's), one Gaussian per fill point of the
object (:mod:`gasp_core.maps.crack_faces`): opacity 0.99 (logit 4.6) where the face is exposed at that frame, a logit
of -30 (opacity 1e-13: not drawn) where the material around it is whole or the point is in a crumb (a part under
the pieces' debris share, whose surface Gaussians are drawn on its piece: :func:`gasp_core.run.apart.hold_to_pieces`);
SH degree 0, the colour of its nearest surface Gaussians; an int32 property ``piece``, the face's piece numbered as
the object's ``pieces_NNNN.npy`` (:func:`gasp_core.run.pieces.piece_ranks`; -1 for a piece that holds no surface
Gaussian). Frame 0 has every face hidden. A shown face is kept on its piece's side of every crack where the
pieces are apart, as the object's Gaussians are (:func:`gasp_core.run.sides.keep_faces_to_side`: its in-plane scales
trimmed, or hidden; where they touch it is left whole, :class:`gasp_core.run.sides.PieceTree`), and the frame's
``run.json`` row counts ``faces_spanning`` (shown faces whose 2-sigma ellipse reaches across a gap onto another
piece's side, as :func:`gasp_core.run.apart.apart_masks` counts the Gaussians) and ``faces_trimmed`` (trimmed or
hidden). ``gasp render`` draws them with their object (and any 3DGS viewer that is given both files); the object's
own frame files are unchanged (one row per input Gaussian).
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from gasp_core.gs.gaussians import Gaussians, rotmat_to_quat
from gasp_core.gs.io import write_gaussians
from gasp_core.maps.crack_faces import CrackFaces, build_crack_faces, crack_face_gaussians
from gasp_core.gs.unseen import unseen_rows
from gasp_core.run.apart import REACH, TIPS
from gasp_core.run.pieces import piece_ranks
from gasp_core.run.sides import keep_faces_to_side

#: A frame's crack-face file in an object's folder.
CRACK_FILE = "crack_faces_{:04d}.ply"
#: Opacity logits of a shown and of a hidden face.
SHOWN, HIDDEN = 4.6, -30.0


class CrackOutput:
    """The crack faces of a prepared scene's brittle objects, written frame after frame.

    Parameters
    ----------
    prep : PreparedScene
    pairs : ndarray, shape (k, 2), int
        Rest neighbour links of the material points (:attr:`gasp_core.run.pieces.PieceTracker.pairs`).
    """

    def __init__(self, prep, pairs: np.ndarray):
        s = prep.setup
        self.mass = np.asarray(s.p_mass, np.float64)
        self.reach = REACH * float(s.dx)
        self.trim = True    # False: the faces not kept to their side (the rule before, kept to show what it drew)
        self.vol, self.dx = np.asarray(s.p_vol, np.float64), float(s.dx)
        self.gap = True     # False: kept to their side wherever another piece's side is, touching or not (round 32, the pull rule)
        self.counts: dict = {}   # the last frame's faces_spanning and faces_trimmed, all objects
        self.objects: list[tuple[str, object, CrackFaces]] = []
        for o, name in zip(prep.objects, prep.names):
            rows = np.arange(len(s.x))[o.fill_slice]
            if o.spec.static or o.spec.material.name != "brittle" or len(rows) == 0:
                continue
            dc = o.gaussians.sh_dc if o.moving is None else o.gaussians.sh_dc[o.moving]
            means = o.surface.tri_rest[:, 0]
            hidden = unseen_rows(o)   # the capture's inside gives no colour (gasp_core.gs.unseen)
            if hidden is not None:
                seen = ~(hidden if o.moving is None else hidden[np.asarray(o.moving)])
                dc, means = (dc[seen], means[seen]) if seen.any() else (dc, means)
            h = float(np.max(s.p_vol[rows])) ** (1 / 3)
            self.objects.append((name, o, build_crack_faces(s.x[rows], rows, pairs, means, dc, h, x_rest=s.x)))

    def write(self, folder, frame: int, x: np.ndarray, labels: np.ndarray, damage: np.ndarray | None,
              piece: np.ndarray | None = None) -> list[str]:
        """Write every brittle object's ``crack_faces_NNNN.ply`` at positions ``x`` (n, 3, world), point ``labels``
        (n,), ``damage`` (n,) or None (nothing broken) and ``piece`` (per label, bool, or None:
        :func:`gasp_core.run.pieces.piece_ranks`), atomically; the files, relative to ``folder``."""
        d = np.zeros(len(x)) if damage is None else np.asarray(damage, np.float64)
        rels, self.counts = [], {"faces_spanning": 0, "faces_trimmed": 0}
        for name, o, faces in self.objects:
            means, rot, scales, visible = crack_face_gaussians(faces, x, labels, d)
            if piece is not None:     # a crumb's faces are hidden: its Gaussians go with its piece (run.apart)
                visible &= np.asarray(piece, bool)[np.asarray(labels)[faces.rows]]
            visible = self._keep_to_side(faces, x, labels, piece, means, rot, scales, visible)
            pl = o.placement
            rank = piece_ranks(o, labels, self.mass, piece)[np.asarray(labels)[faces.rows]]
            g = Gaussians(means=pl.to_file(means), scales=scales / pl.scale,
                          rotations=rotmat_to_quat(pl.R.T @ rot), opacities=np.where(visible, SHOWN, HIDDEN),
                          sh_dc=faces.sh_dc, sh_rest=np.zeros((len(means), 0, 3)), extra={"piece": rank},
                          source=f"{name} crack faces")
            rel = f"{name}/{CRACK_FILE.format(frame)}"
            write_gaussians(Path(folder) / rel, g, overwrite=True)
            rels.append(rel)
        return rels


    def _keep_to_side(self, faces: CrackFaces, x, labels, piece, means, rot, scales, visible) -> np.ndarray:
        """The shown faces kept on their piece's side (module notes; ``scales`` changed in place; not with
        :attr:`trim` False) and counted into :attr:`counts`; returns the faces shown now, (m,) bool."""
        from gasp_core.run.apart import apart_masks
        from gasp_core.run.sides import PieceTree, opening
        lab, rows = np.asarray(labels), np.asarray(faces.rows)
        pts = rows[self.mass[rows] > 0]
        if piece is not None:
            pts = pts[np.asarray(piece, bool)[lab[pts]]]
        if not visible.any() or len(pts) == 0:
            return visible
        tree = PieceTree(x[pts], lab[pts], opening(self.vol[pts], self.dx) if self.gap else None)
        if self.trim:
            visible, k = keep_faces_to_side(means, rot, scales, visible, lab[rows], tree, lab[pts], self.reach, TIPS)
            self.counts["faces_trimmed"] += k
        v = np.flatnonzero(visible)
        span = apart_masks(means[v], rot[v], scales[v], x[pts], lab[pts], self.reach, lab[rows][v], tree)[0]
        self.counts["faces_spanning"] += int(span.sum())
        return visible


def crack_output_for(prep, tracker) -> CrackOutput | None:
    """A :class:`CrackOutput` of ``prep`` when it has a brittle object with fill points (and a piece tracker), else
    None."""
    if tracker is None:
        return None
    out = CrackOutput(prep, tracker.pairs)
    return out if out.objects else None


def read_crack_faces(run, name: str, frame: int):
    """Object ``name``'s crack faces at ``frame`` in the run folder ``run`` (:class:`Gaussians`, file frame), or None
    when the run has no such file."""
    path = Path(run) / name / CRACK_FILE.format(frame)
    if not path.is_file():
        return None
    from gasp_core.gs.io import read_gaussians
    return read_gaussians(path)


def shown_crack_faces(run, name: str, frame: int):
    """Object ``name``'s crack faces shown at ``frame`` (:func:`read_crack_faces`, the rows of positive opacity;
    file frame, SH degree 0, the ``piece`` property kept), or None when the run has no such file (no brittle body)."""
    g = read_crack_faces(run, name, frame)
    return None if g is None else g.subset(np.flatnonzero(g.opacities > 0))


def with_crack_faces(g: Gaussians, faces: Gaussians) -> Gaussians:
    """``g``'s rows, unchanged and in order, then the crack faces ``faces`` (one file of a single-cloud format, as
    ``gasp export`` writes a brittle object's frame): the faces in ``g``'s SH degree (higher coefficients 0) and
    with ``g``'s extra properties (0 for the faces; their ``piece`` is not carried over)."""
    k = g.sh_rest.shape[1]
    extra = {key: np.concatenate([v, np.zeros(faces.n, v.dtype)]) for key, v in g.extra.items()}
    return Gaussians(means=np.concatenate([g.means, faces.means]), scales=np.concatenate([g.scales, faces.scales]),
                     rotations=np.concatenate([g.rotations, faces.rotations]),
                     opacities=np.concatenate([g.opacities, faces.opacities]),
                     sh_dc=np.concatenate([g.sh_dc, faces.sh_dc]),
                     sh_rest=np.concatenate([g.sh_rest, np.zeros((faces.n, k, 3), np.float32)]), extra=extra,
                     source=g.source, layout=g.layout, meta=dict(g.meta))
