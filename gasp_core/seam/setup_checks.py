"""Checks of a :class:`~gasp_core.seam.setup.SimSetup`'s fields that an engine would otherwise meet first (and fail on
as if it were the engine's bug): shapes, signs and finiteness of the arrays and of each :class:`Boundary`."""
from __future__ import annotations

import numpy as np

from gasp_core.errors import SceneError


def broadcast(name: str, value, shape: tuple[int, ...], dtype) -> np.ndarray:
    """``value`` broadcast to ``shape`` as a contiguous array of ``dtype``.

    Raises
    ------
    SceneError
        ``value`` does not broadcast to ``shape``; the message names ``SimSetup.<name>`` and both shapes.
    """
    try:
        return np.ascontiguousarray(np.broadcast_to(value, shape), dtype=dtype)
    except (ValueError, TypeError):
        got = np.shape(value) if not isinstance(value, (str, bytes)) else type(value).__name__
        raise SceneError(f"SimSetup.{name}: got shape {got}; expected {shape} or a shape that broadcasts to it") \
            from None


def vector(name: str, value) -> np.ndarray:
    """``value`` as a finite (3,) float64 vector.

    Raises
    ------
    SceneError
        Not three numbers, or one of them not finite; the message names ``SimSetup.<name>``.
    """
    try:
        v = np.asarray(value, dtype=np.float64).reshape(3)
    except (ValueError, TypeError):
        raise SceneError(f"SimSetup.{name} = {value!r}; expected 3 numbers") from None
    if not np.isfinite(v).all():
        raise SceneError(f"SimSetup.{name} = {v.tolist()}; expected 3 finite numbers")
    return v


def check_rows(body_id: np.ndarray, n: int, n_render: int, boundaries=()) -> None:
    """Refuse a negative ``body_id`` and an ``n_render`` outside ``[0, n]`` (``SimSetup`` reads -1 or one past the
    points as every point first), then :func:`check_boundaries`.

    Raises
    ------
    SceneError
        Naming the field, the value and (for ``body_id``) the first point.
    """
    neg = np.flatnonzero(body_id < 0)
    if len(neg):
        raise SceneError(f"SimSetup.body_id: {int(body_id[neg[0]])} at point {int(neg[0])}; expected an index "
                         "into SimSetup.materials (>= 0)")
    if not 0 <= n_render <= n:
        raise SceneError(f"SimSetup.n_render = {n_render} with {n} points; expected 0..{n} (or -1: every point)")
    check_boundaries(boundaries)


def check_boundaries(boundaries) -> None:
    """Every boundary's numbers finite: a ground's height, a friction >= 0, a restitution in [0, 1], a fixed box's
    corners (``lo <= hi``).

    Raises
    ------
    SceneError
        Naming ``SimSetup.boundaries[i]``, its kind, the field and the value.
    """
    for i, b in enumerate(boundaries):
        where = f"SimSetup.boundaries[{i}] ({getattr(b, 'kind', b)!r})"
        checks = [("friction", b.friction, 0.0, np.inf), ("restitution", b.restitution, 0.0, 1.0)]
        if b.kind == "ground" and not isinstance(b.height, str):
            checks.append(("height", b.height, -np.inf, np.inf))
        for key, val, lo, hi in checks:
            try:
                ok = bool(np.isfinite(float(val)) and lo <= float(val) <= hi)
            except (TypeError, ValueError):
                ok = False
            if not ok:
                raise SceneError(f"{where}.{key} = {val!r}; expected a finite number"
                                 + ("" if (lo, hi) == (-np.inf, np.inf) else f" in [{lo:g}, {hi:g}]"))
        if b.kind == "fixed_region":
            lo_hi = [vector(f"boundaries[{i}].{key}", getattr(b, key)) for key in ("lo", "hi")]
            if not np.all(lo_hi[0] <= lo_hi[1]):
                raise SceneError(f"{where}: lo = {lo_hi[0].tolist()} exceeds hi = {lo_hi[1].tolist()} on an axis")


def check_passive(passive, p_vol: np.ndarray, body_id: np.ndarray, n_render: int, n_bodies: int) -> None:
    """Refuse passive rows (``SimSetup.passive``, (n,) bool or None) with a volume, past ``n_render``, all rows
    passive, or a body of passive rows alone.

    Raises
    ------
    SceneError
        Naming ``SimSetup.passive`` or ``SimSetup.p_vol`` and the rule broken (the body for the last).
    """
    if passive is None:
        return
    if np.any(p_vol[passive] != 0):
        raise SceneError("SimSetup.p_vol: passive rows (SimSetup.passive) must have volume 0")
    if passive[n_render:].any():
        raise SceneError("SimSetup.passive: only rendered rows [:n_render] may be passive")
    if passive.all():
        raise SceneError("SimSetup.passive: every point is passive; the material needs points with volume")
    has = np.bincount(body_id[~passive], minlength=n_bodies) > 0
    used = np.bincount(body_id, minlength=n_bodies) > 0
    if np.any(used & ~has):
        b = int(np.flatnonzero(used & ~has)[0])
        raise SceneError(f"SimSetup.passive: body {b} has only passive points; it needs material points")


def check_cells(cells, n: int, passive) -> np.ndarray | None:
    """``SimSetup.cells`` (``gasp_core.run.grady_cells``) as (n,) int32, or None where no point is in a cell.

    Raises
    ------
    SceneError
        Not (n,) integers, or a cell id at or past 256 (the engines' node key), naming ``SimSetup.cells``.
    """
    c = np.asarray(cells)
    if c.shape != (n,) or not np.issubdtype(c.dtype, np.integer):
        raise SceneError(f"SimSetup.cells: got shape {c.shape} of {c.dtype}; expected ({n},) integers")
    cell = np.where(c <= -2, -2 - c, c)
    if cell.max(initial=-1) >= 256:
        raise SceneError(f"SimSetup.cells: cell {int(cell.max())}; expected at most 255")
    if not (c != -1).any():
        return None
    return c.astype(np.int32)
