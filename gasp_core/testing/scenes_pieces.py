"""Brittle balls landing on the ground, their pieces counted frame by frame two ways (issue 66, item 4): by the
run's :class:`~gasp_core.run.pieces.PieceTracker` (geometry and damage, cut links kept) and from the frames alone
(:class:`~gasp_core.testing.pieces_count.FramePieces`, no damage read). Used by ``tests/test_pieces_family.py`` and
``benchmarks/pieces_family.py``."""
from __future__ import annotations

import numpy as np

from gasp_core.run.pieces import LINK_RADIUS, PieceTracker, tracker_for
from gasp_core.seam.build import build_engine
from gasp_core.seam.plugins import engines
from gasp_core.seam.setup import Boundary, Material, SimSetup
from gasp_core.testing.helpers import box_points, make_setup, sphere_points
from gasp_core.testing.pieces_count import FramePieces, tracker_count

#: The ball family's landing speeds, m/s (issue 66: 1, 2, 4, 7 and 10).
SPEEDS = (1.0, 2.0, 4.0, 7.0, 10.0)
#: The ball's brittle material: E 200 kPa, nu 0.25, rho 300 kg/m^3, f_t 10 kPa, G_f 10 J/m^2 (15 before round 31's crack band ``dx``: the same softening stress) (tests/test_brittle.py's
#: ball that breaks from 1 m).
BALL = {"E": 2e5, "nu": 0.25, "rho": 300.0, "tensile_strength": 1e4, "fracture_energy": 10.0}


#: ``examples/donut_shatter.toml``'s biscuit: E 1 MPa, nu 0.25, rho 300 kg/m^3, f_t 27 kPa, G_f 6.14 J/m^2 (a ring of it
#: landing on its edge at 4.43 m/s breaks in bending into its quarters).
BISCUIT = {"E": 1e6, "nu": 0.25, "rho": 300.0, "tensile_strength": 2.7e4, "fracture_energy": 6.1351179}


def ball_setup(speed: float, n_grid: int = 32, radius: float = 0.1) -> SimSetup:
    """A brittle ball (:data:`BALL`, radius ``radius`` m, a lattice of spacing ``dx / 2``, frames of 0.01 s) that
    reaches the ground (friction 0.5, walls) at ``speed`` m/s: it starts 5 mm above it with that speed; one thread,
    single precision."""
    dx = 1 / n_grid
    ground = 3 * dx + 0.004
    x, pv = sphere_points((0.5, 0.5, ground + radius + 0.005), radius, dx / 2)
    return make_setup(x, pv, Material("brittle", **BALL), v=np.array([0.0, 0.0, -speed]), n_grid=n_grid,
                      frame_dt=0.01, boundaries=[Boundary("ground", height=ground, friction=0.5), Boundary("walls")],
                      options={"precision": "f32", "threads": 1})


def cube_setup(speed: float, n_grid: int = 32, side: float = 0.16) -> SimSetup:
    """:func:`ball_setup`'s scene (its material, points at ``dx / 2``, ground, walls, frames) with a cube of ``side`` m
    (0.16 m: the 0.1 m ball's volume within 2 %) landing flat on a face at ``speed`` m/s: the ball's neighbour shape
    (round 101's study, ``benchmarks/studies/cells101.py``)."""
    dx = 1 / n_grid
    ground = 3 * dx + 0.004
    lo = np.array([0.5 - side / 2, 0.5 - side / 2, ground + 0.005])
    x, pv = box_points(lo, lo + side, dx / 2)
    return make_setup(x, pv, Material("brittle", **BALL), v=np.array([0.0, 0.0, -speed]), n_grid=n_grid,
                      frame_dt=0.01, boundaries=[Boundary("ground", height=ground, friction=0.5), Boundary("walls")],
                      options={"precision": "f32", "threads": 1})


def ring_setup(speed: float, n_grid: int = 32, radius: float = 0.1, tube: float = 0.03,
               material: Material | None = None) -> SimSetup:
    """:func:`ball_setup`'s scene with a ring (a torus of centre-line radius ``radius`` m and tube radius ``tube`` m,
    its axis along y) standing on its edge and landing at ``speed`` m/s: a body whose structure decides where it
    breaks (thin-ring theory: bending at the contact and the sides; ``examples/donut_shatter.toml``). ``material``:
    default :data:`BISCUIT`."""
    dx = 1 / n_grid
    ground = 3 * dx + 0.004
    c = np.array([0.5, 0.5, ground + radius + tube + 0.005])
    x, _ = box_points(c - (radius + tube, tube, radius + tube), c + (radius + tube, tube, radius + tube), dx / 2)
    rho_xz = np.hypot(x[:, 0] - c[0], x[:, 2] - c[2])
    x = x[np.hypot(rho_xz - radius, x[:, 1] - c[1]) <= tube]
    pv = 2 * np.pi ** 2 * radius * tube ** 2 / len(x)
    return make_setup(x, pv, material or Material("brittle", **BISCUIT), v=np.array([0.0, 0.0, -speed]),
                      n_grid=n_grid, frame_dt=0.01, options={"precision": "f32", "threads": 1},
                      boundaries=[Boundary("ground", height=ground, friction=0.5), Boundary("walls")])


def shape_setup(shape: str, speed: float, n_grid: int) -> SimSetup:
    """The family's specimen named ``shape``: ``"ball"`` (R 0.1 m), ``"ball:R"`` (radius R, m), ``"cube:A"`` (side
    A, m) or ``"ring:R:r"`` (:func:`ring_setup`; r defaults to 0.3 R), landing at ``speed`` m/s on ``n_grid``.
    Raises ``ValueError`` on another name or a size outside (0.02, 0.3) m."""
    kind, _, size = shape.partition(":")
    if kind == "ring":
        r, _, t = (size or "0.1:0.03").partition(":")
        return ring_setup(speed, n_grid, float(r), float(t or 0.3 * float(r)))
    if kind not in ("ball", "cube"):
        raise ValueError(f"shape {shape!r}: expected 'ball', 'ball:R', 'cube:A' or 'ring:R:r' (sizes in m)")
    a = float(size) if size else (0.1 if kind == "ball" else 0.16)
    if not 0.02 < a < 0.3:
        raise ValueError(f"shape {shape!r}: size {a} m outside (0.02, 0.3)")
    return ball_setup(speed, n_grid, a) if kind == "ball" else cube_setup(speed, n_grid, a)


def rejoined_share(t: PieceTracker, cut: np.ndarray, x: np.ndarray, x_rest: np.ndarray, gap: float) -> float:
    """Of the links ``cut`` (shape (n_links,), bool) of tracker ``t``, the share whose points at ``x`` (n, 3), m, are
    within their rest distance (at ``x_rest``) plus ``gap`` (m), as :class:`FramePieces` holds a link; 0 where none is
    cut."""
    if not cut.any():
        return 0.0
    a, b = t.pairs[cut, 0], t.pairs[cut, 1]
    x, x_rest = np.asarray(x, np.float64), np.asarray(x_rest, np.float64)
    rest = np.linalg.norm(x_rest[a] - x_rest[b], axis=1)
    return float(np.mean(np.linalg.norm(x[a] - x[b], axis=1) <= rest + gap))


def counted_run(name: str, setup: SimSetup, n_frames: int, tracker: PieceTracker | None = None) -> dict:
    """Run ``setup`` on engine ``name`` for ``n_frames`` frames; per frame (0 .. n_frames) lists ``tracker`` (the
    run's pieces, crumbs apart), ``tracker_1`` and ``tracker_5`` (its pieces of at least 1 and 5 % of the mass),
    ``frames_1`` (:class:`FramePieces`'s count, 1 %), ``frames_kept_1`` (the same with ``remember``: a link opened on
    a frame stays open), ``debris`` and ``rejoined`` (round 77, :func:`rejoined_share`:
    the share of the links the tracker had cut by the frame before that hold again in the frames-only reference: the
    pieces meeting again). ``tracker``: the tracker to count with (a broken variant in the tests); default
    :func:`gasp_core.run.pieces.tracker_for`."""
    t = tracker_for(setup) if tracker is None else tracker
    spacing = float(np.cbrt(np.max(setup.p_vol)))
    ref = FramePieces(setup.x, setup.p_mass, LINK_RADIUS * spacing, setup.dx)
    kept = FramePieces(setup.x, setup.p_mass, LINK_RADIUS * spacing, setup.dx, remember=True)
    total = float(np.sum(setup.p_mass))
    out = {k: [] for k in ("tracker", "tracker_1", "tracker_5", "frames_1", "frames_kept_1", "debris", "rejoined")}

    def count(x, d):
        out["rejoined"].append(rejoined_share(t, t.cut, x, setup.x, setup.dx))   # before row() cuts this frame's
        row = t.row(x, d)[0]
        out["tracker"].append(row["pieces"])
        out["debris"].append(row["debris"])
        out["tracker_1"].append(tracker_count(row, total, 0.01))
        out["tracker_5"].append(tracker_count(row, total, 0.05))
        out["frames_1"].append(ref.count(x))
        out["frames_kept_1"].append(kept.count(x))

    count(setup.x, None)
    e = build_engine(engines()[name], setup)
    try:
        for _ in range(n_frames):
            e.step_frame()
            count(np.asarray(e.positions(), np.float64), np.asarray(e.damage(), np.float64))
    finally:
        e.close()
    return out
