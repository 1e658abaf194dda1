"""Scene keys for colliders, force fields and impulses (``[[collider]]``, ``[[force]]``, ``[[impulse]]``;
``docs/colliders.md``), read with the checked value readers of :mod:`gasp_core.scene.values`."""
from __future__ import annotations

import math
from dataclasses import dataclass, fields
from pathlib import Path
from typing import Any


from gasp_core.colliders.model import Motion
from gasp_core.errors import SceneError
from gasp_core.scene.values import (MAX_COORD, MAX_GRAVITY, MAX_SPEED, MAX_SPIN, SCALE_RANGE, UP_AXES, as_boolean,
                                    as_integer, as_number, as_string, as_tables, as_vec3, bad_value, check_keys,
                                    is_number, read_key, resolve_path)

# --------------------------------------------------------------------------- colliders, forces, impulses
@dataclass
class ColliderSpec:
    """``[[collider]]``: a rigid obstacle (built into a :class:`gasp_core.colliders.model.Collider` by the core).

    Exactly one source: ``mesh`` (a closed triangle mesh file, .obj/.ply/.stl, read by trimesh),
    ``gaussians`` (a Gaussian Splatting file whose footprints' enclosed space is the obstacle) or
    ``object`` (index from 1, or file stem, of a static ``[[object]]``). ``mesh`` and ``gaussians``
    are placed like objects (``up_axis``, ``scale``, ``recentre``, ``position``) and then turned by
    ``rotation`` (degrees about x, then y, then z, about ``position``). ``friction`` is Coulomb's
    coefficient. Motion: ``velocity`` (m/s) and ``angular_velocity`` (rad/s, about ``position``), or
    ``path = [[t, x, y, z], ...]`` keyframes of the position (linear in between); not for
    ``gaussians`` / ``object`` colliders, which are static.
    """

    where: str
    mesh: Path | None = None
    gaussians: Path | None = None
    object: int | str | None = None
    up_axis: str = "+z"
    scale: float = 1.0
    recentre: bool = True
    position: tuple[float, float, float] = (0.0, 0.0, 0.0)
    rotation: tuple[float, float, float] = (0.0, 0.0, 0.0)
    friction: float = 0.5
    velocity: tuple[float, float, float] = (0.0, 0.0, 0.0)
    angular_velocity: tuple[float, float, float] = (0.0, 0.0, 0.0)
    path: list | None = None
    min_opacity: float = 0.1
    by_default: bool = False    # a selection's rest, added by gasp_core.prepare.around (not a scene key)

    @property
    def moving(self) -> bool:
        """True with a prescribed motion (the rule of :attr:`gasp_core.colliders.model.Motion.moving`)."""
        return Motion(velocity=self.velocity, angular_velocity=self.angular_velocity, path=self.path).moving


_COLLIDER_KEYS = {f.name for f in fields(ColliderSpec)} - {"where", "by_default"}
_PLACED = {"up_axis", "scale", "recentre", "position", "rotation"}
_MOVING = {"velocity", "angular_velocity", "path"}   # refused below, with its own words, on all but a mesh
#: The keys each collider source uses (an ``object`` collider sits where its object is; only Gaussians have opacity).
_COLLIDER_SOURCE_KEYS = {"mesh": {"mesh", "friction"} | _PLACED | _MOVING,
                         "gaussians": {"gaussians", "friction", "min_opacity"} | _PLACED | _MOVING,
                         "object": {"object", "friction", "min_opacity", "position", "rotation"} | _MOVING}
_FORCE_KIND_KEYS = {"wind": {"kind", "direction", "speed", "air_density", "drag_coefficient", "turbulence",
                             "turbulence_scale", "turbulence_time", "seed"},
                    "attractor": {"kind", "point", "strength", "radius", "falloff"}}
_IMPULSE_SHAPE_KEYS = {"box": {"lo", "hi"}, "sphere": {"centre", "radius"}}
_IMPULSE_KEYS = {"shape", "velocity_change", "t0", "t1", "mode", "ramp", "constrain"}
#: Largest acceleration of a force field, m/s^2 (as gravity).
MAX_ACCEL = MAX_GRAVITY


def _input_file(value, key: str, src: Path, suffixes=None) -> Path:
    name = as_string(value, key, src)
    f = resolve_path(src, name, key)
    if not f.is_file():
        raise SceneError(f"{src}: {key} '{name}' does not exist or is not a file (looked for {f})")
    if suffixes and f.suffix.lower() not in suffixes:
        raise SceneError(f"{src}: {key} '{name}' has suffix {f.suffix!r}; expected one of {list(suffixes)}")
    return f


def _collider(c: dict, where: str, src: Path, n_objects: int) -> ColliderSpec:
    check_keys(c, _COLLIDER_KEYS, where, src)
    sources = [k for k in ("mesh", "gaussians", "object") if k in c]
    if len(sources) != 1:
        raise SceneError(f"{src}: {where} needs exactly one of 'mesh', 'gaussians' or 'object', got {sources or 'none'}")
    check_keys(c, _COLLIDER_SOURCE_KEYS[sources[0]], f"{where} (a {sources[0]!r} collider)", src)
    kw: dict[str, Any] = {"where": where}
    if "mesh" in c:
        kw["mesh"] = _input_file(c["mesh"], f"{where}.mesh", src, (".obj", ".ply", ".stl", ".off", ".glb", ".gltf"))
    elif "gaussians" in c:
        kw["gaussians"] = _input_file(c["gaussians"], f"{where}.gaussians", src)
    else:
        o = c["object"]
        if isinstance(o, int) and not isinstance(o, bool):
            kw["object"] = as_integer(o, f"{where}.object", src, 1, max(n_objects, 1))
        else:
            kw["object"] = as_string(o, f"{where}.object", src)

    def get(key, read, *args, **kw):   # c[key] checked by read, or ColliderSpec's default
        return read_key(c, key, read, *args, default_from=ColliderSpec, where=where, src=src, **kw)
    kw.update(up_axis=get("up_axis", as_string, UP_AXES), scale=get("scale", as_number, *SCALE_RANGE),
              recentre=get("recentre", as_boolean), position=get("position", as_vec3, max_abs=MAX_COORD, unit=" m"),
              rotation=get("rotation", as_vec3, max_abs=360.0, unit=" degrees"),
              friction=get("friction", as_number, 0.0), min_opacity=get("min_opacity", as_number, 0.0, 1.0),
              velocity=get("velocity", as_vec3, max_norm=MAX_SPEED, unit=" m/s"),
              angular_velocity=get("angular_velocity", as_vec3, max_norm=MAX_SPIN, unit=" rad/s"))
    if "path" in c:
        if "velocity" in c:
            raise SceneError(f"{src}: {where}: give 'velocity' or 'path', not both")
        p = c["path"]
        if not isinstance(p, list) or len(p) < 2 or not all(
                isinstance(r, list) and len(r) == 4 and all(is_number(a) and math.isfinite(a) for a in r) for r in p):
            bad_value(src, f"{where}.path", p, "a list of at least 2 keyframes [t, x, y, z] of finite numbers")
        ts = [float(r[0]) for r in p]
        if any(b <= a for a, b in zip(ts, ts[1:])) or ts[0] < 0:
            bad_value(src, f"{where}.path", p, "keyframe times >= 0 and strictly increasing")
        if max(abs(a) for r in p for a in r[1:]) > MAX_COORD:
            bad_value(src, f"{where}.path", p, f"positions within +-{MAX_COORD:g} m")
        kw["path"] = [[float(a) for a in r] for r in p]
    moving = "path" in kw or any(kw["velocity"]) or any(kw["angular_velocity"])
    if moving and "mesh" not in kw:
        raise SceneError(f"{src}: {where}: only a 'mesh' collider can move (velocity, angular_velocity, path); "
                         f"a collider from Gaussians is static")
    return ColliderSpec(**kw)


def _force(f: dict, where: str, src: Path):
    from gasp_core.colliders.model import FALLOFFS, ForceField
    kind = as_string(f.get("kind"), f"{where}.kind", src, tuple(_FORCE_KIND_KEYS))

    def get(key, read, *args, **kw):   # f[key] checked by read, or ForceField's default
        return read_key(f, key, read, *args, default_from=ForceField, where=where, src=src, **kw)
    if kind == "wind":
        from gasp_core.colliders.model import WIND_ACCELERATION_REMOVED
        if "strength" in f:                  # the wind of before issue 17: an acceleration
            raise SceneError(f"{src}: {where} (kind = 'wind'): {WIND_ACCELERATION_REMOVED}")
        check_keys(f, _FORCE_KIND_KEYS[kind], f"{where} (kind = {kind!r})", src)
        if "speed" not in f:
            raise SceneError(f"{src}: {where} (kind = 'wind') needs 'speed' (m/s)")
        d = get("direction", as_vec3)
        n = math.sqrt(sum(a * a for a in d))
        if n == 0.0:
            bad_value(src, f"{where}.direction", f["direction"], "a non-zero vector")
        return ForceField("wind", direction=tuple(a / n for a in d),
                          speed=as_number(f["speed"], f"{where}.speed", src, 0.0, MAX_SPEED),
                          air_density=get("air_density", as_number, 0.0, 1e5),
                          drag_coefficient=get("drag_coefficient", as_number, 0.0, 100.0),
                          turbulence=get("turbulence", as_number, 0.0, MAX_SPEED),
                          turbulence_scale=get("turbulence_scale", as_number, 0.0, MAX_COORD, lo_open=True),
                          turbulence_time=get("turbulence_time", as_number, 0.0, lo_open=True),
                          seed=get("seed", as_integer, 0, 2 ** 32 - 1))
    check_keys(f, _FORCE_KIND_KEYS[kind], f"{where} (kind = {kind!r})", src)
    if "strength" not in f:
        raise SceneError(f"{src}: {where} (kind = {kind!r}) needs 'strength' (m/s^2)")
    strength = as_number(f["strength"], f"{where}.strength", src, -MAX_ACCEL, MAX_ACCEL)
    if "point" not in f:
        raise SceneError(f"{src}: {where} (kind = 'attractor') needs 'point'")
    return ForceField("attractor", strength=strength,
                      point=as_vec3(f["point"], f"{where}.point", src, max_abs=MAX_COORD, unit=" m"),
                      radius=get("radius", as_number, 0.0, MAX_COORD, lo_open=True),
                      falloff=get("falloff", as_string, FALLOFFS))


def _impulse(i: dict, where: str, src: Path):
    from gasp_core.colliders.model import Impulse
    shape = as_string(i.get("shape"), f"{where}.shape", src, tuple(_IMPULSE_SHAPE_KEYS))
    check_keys(i, _IMPULSE_KEYS | _IMPULSE_SHAPE_KEYS[shape], f"{where} (shape = {shape!r})", src)
    for k in sorted(_IMPULSE_SHAPE_KEYS[shape]) + ["velocity_change"]:
        if k not in i:
            raise SceneError(f"{src}: {where} (shape = {shape!r}) needs '{k}'")
    kw: dict[str, Any] = {"shape": shape}
    if shape == "box":
        kw["lo"] = as_vec3(i["lo"], f"{where}.lo", src, max_abs=MAX_COORD, unit=" m")
        kw["hi"] = as_vec3(i["hi"], f"{where}.hi", src, max_abs=MAX_COORD, unit=" m")
        if not all(h > l for l, h in zip(kw["lo"], kw["hi"])):
            raise SceneError(f"{src}: {where} 'hi' must exceed 'lo' on every axis, got lo={list(kw['lo'])} "
                             f"hi={list(kw['hi'])}")
    else:
        kw["centre"] = as_vec3(i["centre"], f"{where}.centre", src, max_abs=MAX_COORD, unit=" m")
        kw["radius"] = as_number(i["radius"], f"{where}.radius", src, 0.0, MAX_COORD, lo_open=True)
    kw["velocity_change"] = as_vec3(i["velocity_change"], f"{where}.velocity_change", src, max_norm=MAX_SPEED,
                                    unit=" m/s")
    kw["mode"] = read_key(i, "mode", as_string, ("add", "set"), default_from=Impulse, where=where, src=src)
    kw["t0"] = read_key(i, "t0", as_number, 0.0, default_from=Impulse, where=where, src=src)
    kw["t1"] = as_number(i.get("t1", kw["t0"]), f"{where}.t1", src, 0.0)
    if kw["t1"] < kw["t0"]:
        raise SceneError(f"{src}: {where}: t1 = {kw['t1']:g} s is before t0 = {kw['t0']:g} s")
    if kw["mode"] == "set" and kw["t1"] <= kw["t0"]:
        raise SceneError(f"{src}: {where}: mode = 'set' needs t1 > t0 (the window the velocity is imposed)")
    if "ramp" in i:
        if kw["mode"] != "set":
            raise SceneError(f"{src}: {where}.ramp: only mode = 'set' takes a ramp (an 'add' impulse spreads its "
                             f"change evenly over [t0, t1] already), got mode = {kw['mode']!r}")
        kw["ramp"] = as_number(i["ramp"], f"{where}.ramp", src, 0.0)
        if kw["ramp"] > kw["t1"] - kw["t0"]:
            bad_value(src, f"{where}.ramp", i["ramp"], f"seconds within the window, at most t1 - t0 = "
                      f"{kw['t1'] - kw['t0']:g}")
    if "constrain" in i:
        kw["constrain"] = as_string(i["constrain"], f"{where}.constrain", src, ("all", "along"))
        if kw["constrain"] == "along" and kw["mode"] != "set":
            raise SceneError(f"{src}: {where}.constrain: only mode = 'set' takes 'along' (an 'add' impulse adds "
                             f"every component), got mode = {kw['mode']!r}")
        if kw["constrain"] == "along" and not any(c != 0.0 for c in kw["velocity_change"]):
            raise SceneError(f"{src}: {where}.constrain = 'along' needs a nonzero velocity_change (its direction is "
                             f"the one imposed; to hold the region at rest in every component use 'all'), got "
                             f"{list(kw['velocity_change'])}")
    return Impulse(**kw)


def read_extras(data: dict, src: Path, objects: list) -> dict:
    """``[[collider]]``, ``[[force]]`` and ``[[impulse]]`` of a scene, checked (see :class:`ColliderSpec`).

    Returns
    -------
    dict
        ``colliders`` (list of ColliderSpec), ``forces`` (list of ForceField), ``impulses`` (list of Impulse).
    """
    return {
        "colliders": [_collider(c, f"[[collider]] #{i + 1}", src, len(objects))
                      for i, c in enumerate(as_tables(data.get("collider", []), "collider", src))],
        "forces": [_force(f, f"[[force]] #{i + 1}", src)
                   for i, f in enumerate(as_tables(data.get("force", []), "force", src))],
        "impulses": [_impulse(m, f"[[impulse]] #{i + 1}", src)
                     for i, m in enumerate(as_tables(data.get("impulse", []), "impulse", src))],
    }
