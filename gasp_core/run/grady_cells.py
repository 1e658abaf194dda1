"""Grady's cells on a soft brittle body at its landing (issue 66 item 4, "the pieces of 5 % never decrease with
speed"; ``docs/fracture.md`` "Round 102: Grady's cells in the engines").

A soft ``brittle`` body (one the grid simulates, not the rigid route of :mod:`gasp_core.run.fragment_run`) that
a ground will meet within the coming frame in free fall (:func:`gasp_core.run.fragments.ground_hit`) at a speed
that breaks it (:func:`gasp_core.run.fragments.break_check`: the plane-wave stress against ``f_t``, Grady's
fragment size against the energy) is laid out in the stiff route's fragments, here called cells
(:func:`gasp_core.run.fragments.split_body`: Voronoi cells of Grady's size, seeded around the impact point). The
body stays one soft body; what changes is where it may crack:

* a point with a rest neighbour in another cell (:func:`gasp_core.run.fragments.cut_damage`) is a *band* point and
  damages as before (the crack band of ``docs/fracture.md``); every other point is a cell's *inside* and never
  damages (Grady's fragments do not break again);
* the engines part the cells at their faces: at each grid node the cell of the point of largest weight is the
  node's reference cell, its points one velocity field there, every other cell's points the other; the two fields
  move as one unless each has a broken point (damage 1) at the node, and then meet in Coulomb contact when they
  approach and part freely when they do not (the engines' feature ``fracture_cells``);
* the pieces (:class:`gasp_core.run.pieces.PieceTracker`) cut a link between two cells once it opens past its gap,
  whatever its points' damage (:meth:`~gasp_core.run.pieces.PieceTracker.split_cells`).

The study that chose this class is ``benchmarks/studies/cells101.py`` (a NumPy MLS-MPM apart from the engines).

Limits: a scene of one body only (two-field contact between bodies and the cells' fields would need a third field
where they meet: not modelled, the cells are not laid); a ground below the body along -z gravity; the body is laid
out once. Cells are laid no narrower than :data:`MIN_CELL_DX` grid cells (narrower ones hardly part): where
Grady's are, fewer and larger cells are laid, with a warning.
"""
from __future__ import annotations

import warnings

import numpy as np

from gasp_core.run.fragments import break_check, cut_damage, decode, encode, ground_hit, split_body  # noqa: F401
from gasp_core.run.pieces import SPACING_PERCENTILE
from gasp_core.run.stress_cells import probe, union

#: ``SimSetup.cells`` of a point not laid out in cells.
NO_CELL = -1
#: The most cells the engines tell apart (their node key packs a cell id in 8 bits).
MAX_CELLS = 256
#: Cells are laid no narrower than this many grid cells (round 101's study: under it they hardly part; a ball of R 0.07
#: m at 7 m/s, 2.0 cells, stayed whole). Round 102: at 2.6 the 7 m/s ball's 5 cells stayed one piece on n_grid 28.
MIN_CELL_DX = 2.3
#: The cells are laid where Grady's fragments fit the body at least this many times (``V / s^3``): under it (the
#: guitar dropped 0.3 m: one fragment of 1 m for a body of 0.01 m^3) fragmentation does not set where it breaks, its
#: structure's stress does, and ``break_check``'s two fragments would be two arbitrary cells that never crack inside.
MIN_FRAGMENTS = 2.0
#: Engine feature: reads ``SimSetup.cells`` (module notes).
FEATURE = "fracture_cells"


def body_spacing(p_vol: np.ndarray) -> float:
    """The body's fill spacing, m, from its material points' volumes ``p_vol`` (m^3): the
    :data:`~gasp_core.run.pieces.SPACING_PERCENTILE` percentile of ``p_vol^(1/3)``, as the pieces' links take it (a
    few points of outsized volume do not widen the cells' links, nor the memory their pairs take)."""
    return float(np.percentile(np.cbrt(np.asarray(p_vol, np.float64)), SPACING_PERCENTILE))


def soft_brittle(setup) -> bool:
    """Whether ``setup`` is one soft ``brittle`` body (not on the rigid route) under gravity along -z with a ground:
    the scenes the cells are laid in (module notes)."""
    if len(setup.materials) != 1:
        return False
    m = setup.materials[0]
    g = np.asarray(setup.gravity, np.float64)
    return (m.name == "brittle" and m.model != "rigid" and g[2] < 0 and np.allclose(g[:2], 0.0)
            and any(b.kind == "ground" for b in setup.boundaries))


def landing(setup, x: np.ndarray, v: np.ndarray) -> dict | None:
    """The body's landing within the coming frame, as its free fall from ``x``, ``v`` (n, 3) predicts it
    (:func:`gasp_core.run.fragments.ground_hit` from its lowest material point over the highest ground below
    it, its mean vertical speed): ``{"speed": m/s, "impact_point": (3,)}``, or None."""
    mat = setup.material_mask
    xm, m = np.asarray(x, np.float64)[mat], setup.p_mass[mat]
    z0 = float(xm[:, 2].min())
    grounds = [b.height for b in setup.boundaries if b.kind == "ground" and b.height <= z0]
    if not grounds:
        return None
    vz = float((m * np.asarray(v, np.float64)[mat, 2]).sum() / m.sum())
    speed = ground_hit(z0 - max(grounds), vz, -float(setup.gravity[2]), float(setup.frame_dt))
    if speed is None:
        return None
    spacing = body_spacing(setup.p_vol[mat])
    foot = xm[:, 2] <= z0 + spacing
    return {"speed": speed, "impact_point": np.array([*xm[foot, :2].mean(0), z0])}


def lay(setup, x: np.ndarray, v: np.ndarray, seed: int = 0, info=None,
        frame: int = 0) -> tuple[np.ndarray, dict] | None:
    """The cells of ``setup``'s body at positions ``x`` and velocities ``v`` (n, 3), when :func:`soft_brittle` and
    its :func:`landing` within the coming frame breaks it (:func:`break_check`): ``(cells, record)``, ``cells`` the
    ``SimSetup.cells`` (:func:`encode`) and ``record`` the split's figures (JSON-ready); None otherwise.

    With ``info`` (an engine's :class:`~gasp_core.seam.plugins.EngineInfo`; a run passes it) the landing is probed
    on it too (:mod:`gasp_core.run.stress_cells`): where its stress breaks the body into parts, the cells are Grady's
    cut by those parts (``record["seeded"]`` "impact and stress"), else Grady's ("impact"); ``frame``, the run's
    frame ``x`` stands at, numbers the probe's blow-up (:func:`gasp_core.run.stress_cells.probe`).

    Warns (UserWarning) when Grady's fragments are under :data:`MIN_CELL_DX` grid cells across: the cells are laid
    at that size instead, fewer and larger than Grady's (the pieces fall short of his count)."""
    if not soft_brittle(setup):
        return None
    hit = landing(setup, x, v)
    if hit is None:
        return None
    mat = setup.material_mask
    xm = np.asarray(x, np.float64)
    m = setup.materials[0]
    chk = break_check(m, float(setup.p_mass.sum()), float(setup.p_vol[mat].sum()), float(np.ptp(xm[mat, 2])),
                      hit["speed"])
    if not chk["breaks"] or float(setup.p_vol[mat].sum()) < MIN_FRAGMENTS * chk["size"] ** 3:
        return None   # Grady's fragments do not fit the body twice: where it breaks is its structure's stress
    spacing = body_spacing(setup.p_vol[mat])
    size = max(chk["size"], MIN_CELL_DX * setup.dx)   # no cell under the grid's resolution (module notes)
    count = int(min(chk["count"], max(2, round(float(setup.p_vol[mat].sum()) / size ** 3))))
    cell = split_body(xm, mat, spacing, hit["impact_point"], count, size, seed)
    seeded = {"seeded": "impact"}
    if info is not None:
        parts, rec = probe(info, setup.replace(x=np.array(xm), v=np.array(v, np.float64), C=None), spacing, frame)
        seeded = {"seeded": "impact" if parts is None else "impact and stress", **rec}
        if parts is not None:
            cell = union(xm, mat, spacing, cell, parts)
    cell = cell % MAX_CELLS   # split_body's parts past the engines' 8-bit key share an id (they seldom touch)
    band = cut_damage(xm, cell, mat, spacing) > 0
    size_dx = chk["size"] / setup.dx
    if size_dx < MIN_CELL_DX:
        warnings.warn(f"brittle body: Grady's fragments at {hit['speed']:.3g} m/s are {size_dx:.2f} grid cells "
                      f"across, under the {MIN_CELL_DX} the grid parts: laid as {count} cells of {MIN_CELL_DX} "
                      f"instead of {chk['count']}, fewer and larger than Grady's; raise n_grid to resolve them",
                      UserWarning, stacklevel=2)
    record = {"speed": round(hit["speed"], 4), **seeded,
              "impact_point": [round(float(c), 5) for c in hit["impact_point"]], "cells": int(cell.max() + 1),
              "size": chk["size"], "size_dx": round(size_dx, 3), "band": round(float(band[mat].mean()), 4)}
    return encode(cell, band), record


def laid(setup, seed: int = 0, info=None):
    """``setup`` with its cells laid at its start (:func:`lay` on ``setup.x``, ``setup.v``, probed on engine ``info``
    where given, as a run does), and the record (None where not laid): what a run does at frame 0, and the pieces
    family's scenes."""
    out = lay(setup, setup.x, setup.v, seed, info)
    if out is None:
        return setup, None
    return setup.replace(cells=out[0]), out[1]


def applies(info, setup) -> bool:
    """Whether a run lays cells on ``setup`` with engine ``info``: :func:`soft_brittle`, the engine has the features
    :data:`FEATURE` and ``damage`` (the landing's probe reads it; the others run the body as before) and its option
    ``fracture_cells`` is not false."""
    features = info.capabilities.features
    return (soft_brittle(setup) and FEATURE in features and "damage" in features
            and setup.options.get("fracture_cells", True) is not False)


def frames(info, setup, stats, n_frames: int, start_frame: int = 0, state: dict | None = None, sleep: bool = False,
           before=None, tracker=None, settle: bool = False):
    """The run's checked frames (:meth:`gasp_core.seam.runner.EngineRun.frames`) of a scene that :func:`applies`, its
    body laid out in cells at the frame its landing is predicted in (module notes): at the start, the scene's engine
    is built with them; later, after the frame before the landing, a new engine is built at that frame's positions
    and velocities with them (as the stiff route's fragments are; the body's ``F`` and ``C`` start again from the
    identity and zero, which a body in free fall nearly has). A body already damaged then is not laid out. The
    landing is probed on ``info`` first (:func:`lay`'s ``info``; the run's own engine closed before).
    ``stats.fragments`` gains the record (``route`` "cells", ``frame`` the last frame before it, :func:`lay`'s
    figures); ``tracker`` (:class:`gasp_core.run.pieces.PieceTracker`) is told the cells. After a rebuild the frames
    carry no engine state (no checkpoint: the engine is not the scene's; a resumed run starts before the landing and
    lays them again), while cells laid at the start are laid again on resuming. Errors as
    :class:`~gasp_core.seam.runner.EngineRun`."""
    from gasp_core.errors import EngineDivergence, shifted
    from gasp_core.seam.engine import call_engine
    from gasp_core.seam.runner import EngineRun, FrameRecord

    def laid_at(frame, s, out):
        stats.fragments = [*stats.fragments, {"route": "cells", "frame": frame, **out[1]}]
        if tracker is not None:
            tracker.split_cells(out[0])
        return s.replace(cells=out[0])

    out = lay(setup, setup.x, setup.v, info=info)   # a resumed run lays them again: a function of the setup alone
    if out is not None:
        setup = laid_at(0, setup, out)
    with EngineRun(info, setup, stats, start_frame=start_frame, state=state, sleep=sleep, settle=settle) as run:
        if before is not None:
            before()
        if setup.cells is not None:
            yield from run.frames(n_frames)
            return
        for rec in run.frames(n_frames):
            yield rec
            if rec.frame >= n_frames:
                return
            if "damage" in info.capabilities.features and float(np.max(np.asarray(
                    call_engine(info, "damage", run.engine.damage), np.float64), initial=0.0)) > 0.0:
                continue   # a body already damaged is not laid out
            v = np.asarray(call_engine(info, "velocities", run.engine.velocities), np.float64)
            if lay(setup, rec.x, v) is not None:   # Grady's check; the probe once this engine is closed
                break
        else:
            return
    k0 = rec.frame
    out = lay(setup, rec.x, v, info=info, frame=k0)
    new = laid_at(k0, setup.replace(x=np.array(rec.x), v=v, C=None), out)
    try:
        with EngineRun(info, new, stats, sleep=sleep) as run:
            for r in run.frames(n_frames - k0):
                yield FrameRecord(r.frame + k0, r.x, r.wall_s, None)
    except EngineDivergence as err:   # the rebuilt engine counts its frames from the landing
        raise shifted(err, k0, f"the body laid out in cells after frame {k0}") from err
