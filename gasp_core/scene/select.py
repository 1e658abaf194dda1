"""``select`` and ``static`` of a scene object: which part of a file moves (:mod:`gasp_core.prepare.selection`)."""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any


from gasp_core.errors import SceneError
from gasp_core.scene.values import (MAX_COORD, as_boolean, as_number, as_string, as_table, as_vec3, bad_value,
                                    check_keys, read_key, resolve_path)


#: Object keys that only matter when the object is simulated: refused beside ``static = true``.
_SIMULATION_KEYS = ("material", "select", "velocity", "angular_velocity", "fill", "alpha", "rebuild", "thickness",
                    "core_fraction", "if_open", "surface_points", "rest_collider")

#: Kinds of ``select`` region, one per ``select`` table.
SELECT_KINDS = ("box", "sphere", "indices", "mask", "file")
#: What an editor's PLY (``select = { file = ... }``) stands for: the splats it kept, or those deleted from it.
SELECT_TAKE = ("kept", "deleted")
#: The longest ``select.offset``, metres: a selection lifted or moved within a room, not out of the world.
MAX_OFFSET = 100.0
#: Frames a ``select`` box or sphere may be given in.
SELECT_FRAMES = ("file", "world")


@dataclass(frozen=True)
class SelectSpec:
    """``select = {...}`` on an object: the part of its file that moves (the rest is static).

    Exactly one kind: ``box = {lo = [x, y, z], hi = [x, y, z]}``, ``sphere = {centre = [x, y, z],
    radius = r}`` (a Gaussian is in when its centre is; bounds inclusive), ``indices = [i, ...]``
    (rows of the file, 0-based) or ``mask = "file.npy"`` (a boolean array of one entry per
    Gaussian, or an integer array of indices; path relative to the scene file). Optional
    ``frame = "file"`` (default: the file's own coordinates and units, as a viewer shows the
    input file; for a dynamic model, its positions at ``dynamic_time``) or ``"world"`` (metres,
    z up, after ``up_axis``, ``scale``, ``position``, ``recentre``; placement is always computed
    from the whole file). Optional ``grow = true`` grows the selection to the whole connected
    pieces it touches (:func:`gasp_core.prepare.selection.grow_selection`). Optional ``offset = [dx, dy, dz]``
    (metres, world frame, z up; default none) moves the selection before the run, the rest staying where it is: lift
    a part of a capture to drop it (the kitchen's spinach into its pan, ``examples/kitchen_spinach.toml``).

    ``file = "cut.ply"``: a copy of the object's file edited in a splat editor (SuperSplat: delete
    splats, export PLY or compressed PLY), matched to the file by position
    (:func:`gasp_core.prepare.editor_cut.match_cut`). ``take = "kept"`` (default) simulates the splats
    the edit kept, ``"deleted"`` those it removed; ``tolerance`` is the largest distance of a match,
    file units (default 1e-3 of the file's bounding-box diagonal).

    Attributes
    ----------
    kind : str
        One of :data:`SELECT_KINDS`.
    lo, hi : (3,) float or None
        Box corners (``kind == "box"``).
    centre : (3,) float or None
    radius : float or None
        Sphere (``kind == "sphere"``).
    indices : tuple of int or None
        ``kind == "indices"``.
    mask : Path or None
        ``kind == "mask"``, resolved against the scene file's folder.
    frame : str
        ``"file"`` or ``"world"`` (box and sphere only).
    grow : bool
    file : Path or None
        ``kind == "file"``: the edited PLY, resolved against the scene file's folder.
    take : str
        ``"kept"`` or ``"deleted"`` (``kind == "file"``).
    tolerance : float or None
        Match distance, file units (``None``: 1e-3 of the bounding-box diagonal).
    offset : (3,) float or None
        World-frame shift of the selected Gaussians before the run, metres.
    """

    kind: str
    lo: tuple[float, float, float] | None = None
    hi: tuple[float, float, float] | None = None
    centre: tuple[float, float, float] | None = None
    radius: float | None = None
    indices: tuple[int, ...] | None = None
    mask: Path | None = None
    frame: str = "file"
    grow: bool = False
    file: Path | None = None
    take: str = "kept"
    tolerance: float | None = None
    offset: tuple[float, float, float] | None = None

    def describe(self) -> dict:
        """A JSON-ready summary (``run.json``)."""
        out: dict[str, Any] = {"kind": self.kind, "frame": self.frame, "grow": self.grow}
        if self.offset is not None:
            out["offset_m"] = list(self.offset)
        if self.kind == "box":
            out.update(lo=list(self.lo), hi=list(self.hi))
        elif self.kind == "sphere":
            out.update(centre=list(self.centre), radius=self.radius)
        elif self.kind == "indices":
            out.update(n_indices=len(self.indices))
        elif self.kind == "mask":
            out.update(mask=str(self.mask))
        else:
            out.update(file=str(self.file), take=self.take, tolerance=self.tolerance)
        return out


def read_static(o: dict, where: str, src: Path) -> bool:
    """An object's ``static`` (default false); with ``static = true`` (never simulated) keys that only a
    simulation reads are a :class:`SceneError`."""
    static = as_boolean(o.get("static", False), f"{where}.static", src)
    if static:
        extra = [k for k in _SIMULATION_KEYS if k in o]
        if extra:
            raise SceneError(f"{src}: {where} is static = true (never simulated) but also sets {extra}; "
                             f"remove them, or set static = false to simulate it")
    return static


def read_rest_collider(o: dict, where: str, src: Path) -> bool:
    """An object's ``rest_collider`` (default true): its unselected rest is a collider
    (:mod:`gasp_core.prepare.around`); a :class:`SceneError` on an object without ``select``."""
    if "rest_collider" not in o:
        return True
    if "select" not in o:
        raise SceneError(f"{src}: {where}.rest_collider applies to an object with 'select' (its unselected rest)")
    return as_boolean(o["rest_collider"], f"{where}.rest_collider", src)


def read_select(value, where: str, src: Path) -> SelectSpec:
    """An object's ``select = { box | sphere | indices | mask, frame, grow, offset }``, checked (see
    :class:`SelectSpec`)."""
    t = as_table(value, where, src)
    check_keys(t, set(SELECT_KINDS) | {"frame", "grow", "take", "tolerance", "offset"}, where, src)
    kinds = [k for k in SELECT_KINDS if k in t]
    if len(kinds) != 1:
        raise SceneError(f"{src}: {where} needs exactly one of {list(SELECT_KINDS)}, got {kinds or 'none'}")
    kind = kinds[0]
    frame = read_key(t, "frame", as_string, SELECT_FRAMES, default_from=SelectSpec, where=where, src=src)
    if "frame" in t and kind in ("indices", "mask", "file"):
        raise SceneError(f"{src}: {where}.frame applies to a box or sphere, not to {kind}")
    extra = [k for k in ("take", "tolerance") if k in t]
    if extra and kind != "file":
        raise SceneError(f"{src}: {where}.{extra[0]} applies to select = {{ file = ... }}, not to {kind}")
    kw: dict[str, Any] = {"kind": kind, "frame": frame,
                          "grow": read_key(t, "grow", as_boolean, default_from=SelectSpec, where=where, src=src)}
    if "offset" in t:
        kw["offset"] = as_vec3(t["offset"], f"{where}.offset", src, max_norm=MAX_OFFSET, unit=" m")
    key = f"{where}.{kind}"
    if kind == "box":
        b = as_table(t["box"], key, src)
        check_keys(b, {"lo", "hi"}, key, src)
        if "lo" not in b or "hi" not in b:
            raise SceneError(f"{src}: {key} needs 'lo' and 'hi'")
        kw["lo"] = as_vec3(b["lo"], f"{key}.lo", src, max_abs=MAX_COORD)
        kw["hi"] = as_vec3(b["hi"], f"{key}.hi", src, max_abs=MAX_COORD)
        if not all(h > l for l, h in zip(kw["lo"], kw["hi"])):
            raise SceneError(f"{src}: {key} 'hi' must exceed 'lo' on every axis, got lo={list(kw['lo'])} "
                             f"hi={list(kw['hi'])}")
    elif kind == "sphere":
        b = as_table(t["sphere"], key, src)
        check_keys(b, {"centre", "radius"}, key, src)
        if "centre" not in b or "radius" not in b:
            raise SceneError(f"{src}: {key} needs 'centre' and 'radius'")
        kw["centre"] = as_vec3(b["centre"], f"{key}.centre", src, max_abs=MAX_COORD)
        kw["radius"] = as_number(b["radius"], f"{key}.radius", src, 0.0, MAX_COORD, lo_open=True)
    elif kind == "indices":
        idx = t["indices"]
        if not isinstance(idx, list) or not idx or \
                not all(isinstance(i, int) and not isinstance(i, bool) and i >= 0 for i in idx):
            bad_value(src, key, idx, "a non-empty list of row indices (integers >= 0)")
        kw["indices"] = tuple(idx)
    elif kind == "mask":
        name = as_string(t["mask"], key, src)
        m = resolve_path(src, name, key)
        if not m.is_file():
            raise SceneError(f"{src}: {key} '{name}' is not a file (looked for {m}); expected a .npy array")
        kw["mask"] = m
    else:
        name = as_string(t["file"], key, src)
        m = resolve_path(src, name, key)
        if not m.is_file():
            raise SceneError(f"{src}: {key} '{name}' is not a file (looked for {m}); expected a PLY edited "
                             f"in a splat editor")
        kw["file"] = m
        kw["take"] = read_key(t, "take", as_string, SELECT_TAKE, default_from=SelectSpec, where=where, src=src)
        if "tolerance" in t:
            kw["tolerance"] = as_number(t["tolerance"], f"{where}.tolerance", src, 0.0, MAX_COORD, lo_open=True)
    return SelectSpec(**kw)


