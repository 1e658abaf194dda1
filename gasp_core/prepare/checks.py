"""Checks of an object's Gaussians against its placement, before any work, and of the grid against the
object (the values in the scene file itself are checked by :mod:`gasp_core.scene`)."""
from __future__ import annotations

import math
import warnings

import numpy as np

from gasp_core.errors import SceneError
from gasp_core.scene.spec import ObjectSpec
from gasp_core.scene.values import MAX_COORD


#: A Gaussian under this opacity (one step of an 8-bit channel) leaves no mark on a rendered frame.
INVISIBLE = 1.0 / 255.0


def warn_invisible(f, g) -> None:
    """Warn (naming the file ``f``) when every one of ``g``'s Gaussians is under :data:`INVISIBLE` opacity
    (``sigmoid`` of its logit): it simulates, but every frame renders empty (round 101: such a file ran without a
    word). Not an error: an object may be a collider or a hidden proxy on purpose."""
    from scipy.special import expit
    alpha = float(expit(np.asarray(g.opacities, np.float64)).max())
    if alpha < INVISIBLE:
        warnings.warn(f"{f}: every one of its {g.n} Gaussians is invisible (opacity at most {alpha:.3g}, under 1/255):"
                      " the frames will render nothing; is this the trained scene's file?", stacklevel=3)


def warn_one_point(f, g) -> None:
    """Warn (naming the file ``f``, the count and the point) when two or more of ``g``'s Gaussians, and every one,
    share one centre: a degenerate object with no extent, simulated as one blob (round 102: up to
    :data:`gasp_core.gs.io.MAX_AT_ONE_POINT` of them ran without a word; more are refused). Not an error: a few
    Gaussians at one point are a legal, tiny object; one Gaussian alone is not warned about."""
    x = np.asarray(g.means, np.float64)
    if g.n >= 2 and np.isfinite(x).all() and not (np.ptp(x, axis=0) > 0).any():
        at = ", ".join(f"{float(v) + 0.0:.6g}" for v in x[0])   # + 0.0: no "-0"
        warnings.warn(f"{f}: all {g.n} Gaussians lie at one point ({at}): the object has no extent and simulates "
                      "as one blob; expected Gaussians spread over a surface; is this the trained scene's file?",
                      stacklevel=3)


def check_object(spec: ObjectSpec, g) -> None:
    """Check an object's Gaussians against its placement before any work.

    Parameters
    ----------
    spec : ObjectSpec
    g : Gaussians
        As read from ``spec.file`` (file units).

    Raises
    ------
    SceneError
        If there are no Gaussians, more than :data:`gasp_core.gs.io.MAX_AT_ONE_POINT` all at one point
        (:func:`gasp_core.gs.io.refuse_one_point`), or if placed with ``spec.scale`` and ``spec.position`` a
        Gaussian's centre would lie beyond :data:`MAX_COORD` metres from the origin on some axis,
        or a Gaussian's largest scale would exceed :data:`MAX_COORD` metres; the message names the
        file, the value and the limit. Warns (:func:`warn_one_point`, :func:`warn_invisible`) for fewer Gaussians all
        at one point and for Gaussians all invisible.
    """
    f = spec.file
    if g.n == 0:
        raise SceneError(f"{f}: the file has 0 Gaussians; nothing to simulate")
    from gasp_core.gs.io import refuse_one_point
    refuse_one_point(f, g)
    warn_one_point(f, g)
    warn_invisible(f, g)
    x = g.means
    lo, hi = x.min(axis=0), x.max(axis=0)
    pos = max(abs(p) for p in spec.position)
    if spec.recentre:  # centred on position horizontally, bottom at position: within one extent of it
        reach = spec.scale * float(np.max(hi - lo)) + pos
    else:
        reach = spec.scale * float(np.max(np.maximum(np.abs(lo), np.abs(hi)))) + pos
    if not reach <= MAX_COORD:
        raise SceneError(f"{f}: placed with scale = {spec.scale:g} at position = {list(spec.position)}, the "
                         f"Gaussians reach {reach:.3g} m from the origin; expected at most {MAX_COORD:g} m "
                         "(engines compute in float32; check 'scale' and the file's units)")
    s_max = spec.scale * float(g.scales.max())
    if not s_max <= MAX_COORD:
        k = int(np.argmax(g.scales.max(axis=1)))
        raise SceneError(f"{f}: Gaussian {k} has a scale of {s_max:.3g} m after scale = {spec.scale:g}; "
                         f"expected at most {MAX_COORD:g} m")


#: Fewest grid cells across an object's smallest axis before a warning (below it contact and bending are
#: resolved by a handful of cells).
MIN_CELLS = 8
#: Share of an object's occupancy solid left unfilled (thinner than two fill cells) before a warning.
THIN_WARN_SHARE = 0.05


def check_resolution(name: str, extent: np.ndarray, dx: float, n_grid: int, report) -> list[str]:
    """Warnings about how well the grid resolves one simulated object; an error when it cannot.

    Parameters
    ----------
    name : str
        Object name.
    extent : ndarray, shape (3,)
        The object's simulated footprint extent, metres.
    dx : float
        Grid spacing, metres.
    n_grid : int
        Cells along the domain's longest side.
    report : FillReport or None
        Its fill (a shell is measured on its second largest axis: a sheet's width).

    Returns
    -------
    list of str
        Warnings (empty when fine): a shell (no closed fill) with fewer than :data:`MIN_CELLS` cells across its
        width, naming the ``n_grid`` that gives that many; thin parts of a solid that stay shells, naming the
        ``n_grid`` that fills them. A solid's resolution is judged by its local thickness, not its bounding box
        (:func:`gasp_core.prepare.thickness.thin_part_warnings`, issue 54: a donut 6 cells across its tube is
        resolved, a guitar 12 cells across its box is not at its neck).

    Raises
    ------
    SceneError
        A grid cell larger than the object's largest extent.
    """
    ext = np.sort(np.asarray(extent, dtype=np.float64))
    if not dx < ext[2]:
        raise SceneError(f"object '{name}': grid cells of {dx:.3g} m are larger than the object ({ext[2]:.3g} m "
                         f"across); raise [domain] n_grid to at least {math.ceil(n_grid * MIN_CELLS * dx / ext[2])} "
                         f"or lower padding")
    out = []
    solid = report is not None and report.closed and report.n_fill > 0
    if not solid and ext[1] < MIN_CELLS * dx:   # a solid is judged by its thinnest part (prepare/thickness.py)
        out.append(f"object '{name}': {ext[1] / dx:.1f} grid cells across its width ({ext[1]:.3g} m, dx = "
                   f"{dx:.3g} m); n_grid = {math.ceil(n_grid * MIN_CELLS * dx / ext[1])} gives {MIN_CELLS}")
    if solid and report.thin_share > THIN_WARN_SHARE and report.thin_h > 0:
        lo, hi = (np.round(b, 3).tolist() for b in report.thin_box)
        out.append(f"object '{name}': thin parts ({report.thin_share:.0%} of its solid, up to "
                   f"{2 * report.thin_h:.3g} m thick, within {lo} to {hi} m) span under two fill cells of "
                   f"{report.h:.3g} m and stay shells; n_grid = {math.ceil(n_grid * report.h / report.thin_h)} "
                   f"fills them")
    return out


#: Kept floaters (``keep_floaters = true``) may widen an object up to this many times before the default
#: domain is refused: beyond it they size the grid, whose cells on the object are that many times coarser.
FAR_FLOATERS = 4.0


def check_kept_floaters(path, objects) -> None:
    """Refuse floaters kept by ``keep_floaters = true`` that would size the default domain (no ``[domain]``
    ``lo``/``hi``): a Gaussian 100 m from a 20 cm donut made cells of 12.5 m and the donut a 980 m^3 shell;
    the bundled ``spinach_4.splatv`` whole reached 2 km.

    Parameters
    ----------
    path : str or Path
        The scene file, for the message.
    objects : list of PreparedObject
        The simulated objects; whole objects (no ``select``, ``mesh`` or floaters dropped) with
        ``keep_floaters`` are judged by :func:`gasp_core.maps.floaters.find_floaters` in the world frame.

    Raises
    ------
    SceneError
        Their floaters widen the object more than :data:`FAR_FLOATERS` times: names the count, the distance,
        both extents and the keys that fix it.
    """
    from gasp_core.maps.floaters import find_floaters
    for o in objects:
        if not o.spec.keep_floaters or o.spec.select is not None or o.spec.mesh is not None or o.moving is not None:
            continue
        floating = find_floaters(o.tri_rest[:, 0], o.scales_rest.max(axis=1))
        if not floating.any():
            continue
        body = o.tri_rest[~floating].reshape(-1, 3)
        lo, hi = body.min(axis=0), body.max(axis=0)
        whole = float(np.ptp(o.tri_rest.reshape(-1, 3), axis=0).max())
        size = float(np.ptp(body, axis=0).max())
        if whole > FAR_FLOATERS * size:
            c = o.tri_rest[floating].reshape(-1, 3)     # their splats' footprints too
            far = float(np.linalg.norm(np.maximum(lo - c, 0.0) + np.maximum(c - hi, 0.0), axis=1).max())
            raise SceneError(f"{path}: object '{o.name}': keep_floaters = true keeps {int(floating.sum())} floater(s) "
                             f"(Gaussians detached from the object) up to {far:.3g} m from it, so the default domain "
                             f"spans {whole:.3g} m for an object {size:.3g} m across (its grid cells "
                             f"{whole / size:.0f}x coarser); set keep_floaters = false to leave them static, select "
                             f"the part that moves (select), or give [domain] lo/hi")


#: Share of the smaller body's grid cells that another body's points may share at the start. Bodies touching
#: share one layer of cells (a sixth of a body six cells thick); two copies of an object at the same place share
#: all of them, and the engine, which adds their masses on one grid, moves them as one body of double density.
OVERLAP_SHARE = 0.5


def check_overlap(path, x: np.ndarray, body_id: np.ndarray, names: list[str], lo: np.ndarray, dx: float) -> None:
    """Refuse two bodies that start inside each other, as a body inside a collider is refused.

    Parameters
    ----------
    path : str or Path
        The scene file, for the message.
    x : ndarray, shape (n, 3), float64
        The simulated points (metres, world frame).
    body_id : ndarray, shape (n,), int
        Each point's body, an index into ``names``.
    names : list of str
        The bodies' object names.
    lo : ndarray, shape (3,)
        The domain's low corner, metres.
    dx : float
        Grid spacing, metres: the cells compared are the engine's.

    Raises
    ------
    SceneError
        Two bodies whose points share more than :data:`OVERLAP_SHARE` of the smaller one's cells: names both
        objects, the share and the fix.
    """
    cells = [np.unique(np.floor((x[body_id == b] - lo) / dx).astype(np.int64) @ np.array([1, 1 << 21, 1 << 42]))
             for b in range(len(names))]
    boxes = [(x[body_id == b].min(axis=0), x[body_id == b].max(axis=0)) for b in range(len(names))]
    for i in range(len(names)):
        for j in range(i + 1, len(names)):
            if (boxes[i][1] < boxes[j][0]).any() or (boxes[j][1] < boxes[i][0]).any():
                continue   # boxes apart: nothing shared
            share = np.isin(cells[i], cells[j], assume_unique=True).sum() / max(min(len(cells[i]), len(cells[j])), 1)
            if share > OVERLAP_SHARE:
                raise SceneError(f"{path}: objects '{names[i]}' and '{names[j]}' start inside each other ({share:.0%} "
                                 f"of the smaller one's grid cells hold both): the engine would move them as one body "
                                 f"of double density; move them apart (position) or make them one object")
