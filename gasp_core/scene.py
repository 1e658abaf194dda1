"""Scene files (TOML): objects, materials, engine, gravity, domain, boundaries, timing, output.

Example::

    frame_dt = 0.0333
    n_frames = 45
    gravity = [0.0, 0.0, -9.81]

    [engine]
    name = "my_engine"             # an installed engine: see `gasp engines`
    options = { threads = 2 }

    [domain]
    lo = [-0.25, -0.25, 0.0]
    hi = [0.25, 0.25, 0.5]
    n_grid = 64

    [[boundary]]
    kind = "ground"
    friction = 0.5

    [[object]]
    file = "donut_v3dg.ply"
    up_axis = "+z"
    scale = 1.0
    position = [0.0, 0.0, 0.05]
    [object.material]
    name = "jelly"
    E = 2e4
    nu = 0.3
    rho = 200

Every table accepts only the keys listed in this module; a mistyped key is a :class:`SceneError`
that names it and the allowed ones. Units are SI: metres, seconds, Pa, kg/m^3, degrees.
"""
from __future__ import annotations

import math
import tomllib
from dataclasses import dataclass, field, fields
from pathlib import Path
from typing import Any

import numpy as np

from .engine import BOUNDARIES, MATERIALS, Boundary, Material, SceneError

UP_AXES = ("+x", "-x", "+y", "-y", "+z", "-z")


@dataclass
class ObjectSpec:
    """One scene object: a Gaussian Splatting file placed in the world (z up, metres).

    Attributes
    ----------
    file : Path
        Gaussian Splatting file (graphdeco / GaMeS / 2DGS / compressed PLY), relative to the scene file.
    up_axis : str
        The file's up axis, one of ``+x -x +y -y +z -z``; it is turned to world +z.
    scale : float
        Metres per file unit.
    recentre : bool
        Place the object's bounding-box bottom centre (in the world orientation) at ``position``;
        if false, ``position`` is added to the rotated, scaled file coordinates.
    position : (3,) float
        Metres.
    velocity : (3,) float
        Initial velocity, m/s.
    angular_velocity : (3,) float
        Initial angular velocity about the object's centroid (mean of its simulated points),
        rad/s, world frame: ``v = velocity + w x (x - centroid)``; engines with the feature
        ``initial_C`` also start their velocity gradient from it (``SimSetup.C``).
    material : Material
    fill : bool
        Fill the interior with simulated (never rendered) points (solids); false keeps the
        paper's vertices-only mode.
    alpha : float or None
        Control rule factor (paper Eq. alpha_rule); None disables it.
    thickness : str
        Output thin-axis scale: ``"keep"`` the input's own thinnest scale (frame 0 renders as the
        input), or ``"eps"`` the GaMeS ``1e-8``.
    min_opacity : float
        Gaussians below this activated opacity are carried but do not mark occupied space for
        the interior fill.
    if_open : str
        What a filled object whose Gaussians enclose no volume does (:mod:`gasp_core.fill`):
        ``"warn"`` (simulate a hollow shell, warn and record it in run.json) or ``"error"``
        (refuse before the run starts).
    core_fraction : float
        Share of Gaussians simulated, in (0, 1]: below 1, BIRCH clusters build that many Core
        Gaussians and the rest follow them (paper Sec. 3, hierarchy; :mod:`gasp_core.hierarchy`).
    dynamic_time : float or None
        For a dynamic model (``.splatv``): the model time ``s`` at which physics takes over,
        ``G_t = T^-1(phi(psi(V, s), t))`` (paper Sec. 3, dynamic scenes); default 0.
    """

    file: Path
    up_axis: str = "+z"
    scale: float = 1.0
    recentre: bool = True
    position: tuple[float, float, float] = (0.0, 0.0, 0.0)
    velocity: tuple[float, float, float] = (0.0, 0.0, 0.0)
    angular_velocity: tuple[float, float, float] = (0.0, 0.0, 0.0)
    material: Material = field(default_factory=Material)
    fill: bool = True
    alpha: float | None = 1.5
    thickness: str = "keep"
    min_opacity: float = 0.1
    core_fraction: float = 1.0
    if_open: str = "warn"
    dynamic_time: float | None = None


@dataclass
class EngineSpec:
    """``[engine]``: ``name`` (a registered engine; ``gasp engines`` lists them) and its ``options``.

    ``name`` may be left out when the command line names the engine (``--engine``).
    """

    name: str | None = None
    options: dict[str, Any] = field(default_factory=dict)


@dataclass
class DomainSpec:
    """``[domain]``: the simulation box (metres) and grid resolution.

    ``lo``/``hi`` default to the objects' bounds padded by ``padding`` times their largest
    extent (the ground, if any, at the bottom). ``particles_per_cell`` sets the interior fill
    spacing ``dx / ppc^(1/3)``.
    """

    lo: tuple[float, float, float] | None = None
    hi: tuple[float, float, float] | None = None
    n_grid: int = 64
    padding: float = 0.5
    particles_per_cell: int = 8


@dataclass
class Scene:
    """A parsed scene file. See the module docstring for the format."""

    path: Path
    objects: list[ObjectSpec]
    engine: EngineSpec = field(default_factory=EngineSpec)
    domain: DomainSpec = field(default_factory=DomainSpec)
    boundaries: list[Boundary] = field(default_factory=list)
    gravity: tuple[float, float, float] = (0.0, 0.0, -9.81)
    frame_dt: float = 1.0 / 30.0
    n_frames: int = 30
    output: Path | None = None
    name: str = ""


_TOP_KEYS = {"name", "frame_dt", "n_frames", "gravity", "output", "engine", "domain", "boundary", "object"}
_OBJECT_KEYS = {f.name for f in fields(ObjectSpec)}
_MATERIAL_KEYS = {f.name for f in fields(Material)}
_BOUNDARY_KEYS = {f.name for f in fields(Boundary)}
_DOMAIN_KEYS = {f.name for f in fields(DomainSpec)}
_ENGINE_KEYS = {"name", "options"}


def _check_keys(table: dict, allowed: set[str], where: str, src: Path) -> None:
    unknown = sorted(set(table) - allowed)
    if unknown:
        raise SceneError(f"{src}: unknown key(s) {unknown} in {where}; allowed: {sorted(allowed)}")


def _vec3(value, key: str, src: Path) -> tuple[float, float, float]:
    try:
        arr = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError):
        arr = None
    if arr is None or arr.shape != (3,) or not np.all(np.isfinite(arr)):
        raise SceneError(f"{src}: '{key}' must be a list of 3 finite numbers, got {value!r}")
    return tuple(float(a) for a in arr)


def _positive(value, key: str, src: Path, allow_zero: bool = False) -> float:
    ok = isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value) \
        and (value >= 0 if allow_zero else value > 0)
    if not ok:
        raise SceneError(f"{src}: '{key}' must be a {'non-negative' if allow_zero else 'positive'} number, got {value!r}")
    return float(value)


def _dynamic_time(o: dict, f: Path, where: str, src: Path) -> float | None:
    t = o.get("dynamic_time")
    if f.suffix.lower() != ".splatv":
        if t is not None:
            raise SceneError(f"{src}: {where}.dynamic_time is only for dynamic models (.splatv), not {f.name}")
        return None
    if t is None:
        return 0.0
    if not isinstance(t, (int, float)) or isinstance(t, bool) or not math.isfinite(t):
        raise SceneError(f"{src}: {where}.dynamic_time must be a finite number, got {t!r}")
    return float(t)


def _fraction(value, key: str, src: Path) -> float:
    v = _positive(value, key, src)
    if v > 1.0:
        raise SceneError(f"{src}: '{key}' must be in (0, 1], got {value!r}")
    return v


def _material(table: dict, where: str, src: Path) -> Material:
    if not isinstance(table, dict):
        raise SceneError(f"{src}: {where} must be a table")
    _check_keys(table, _MATERIAL_KEYS, where, src)
    name = table.get("name", "jelly")
    if name not in MATERIALS:
        raise SceneError(f"{src}: {where}.name = {name!r} is not a material; known: {sorted(MATERIALS)}")
    kw = {"name": name}
    for k in _MATERIAL_KEYS - {"name"}:
        if k in table:
            kw[k] = _positive(table[k], f"{where}.{k}", src, allow_zero=k in {"softening", "friction_angle", "nu"})
    m = Material(**kw)
    if not 0.0 <= m.nu < 0.5:
        raise SceneError(f"{src}: {where}.nu = {m.nu} must be in [0, 0.5)")
    if not 0.0 <= m.friction_angle < 90.0:
        raise SceneError(f"{src}: {where}.friction_angle = {m.friction_angle} must be in [0, 90) degrees")
    return m


def load_scene(path: str | Path) -> Scene:
    """Read and validate a scene file.

    Parameters
    ----------
    path : str or Path
        TOML file. Relative object paths are resolved against its folder.

    Returns
    -------
    Scene

    Raises
    ------
    SceneError
        If the file is missing or not TOML, a key is unknown (the message lists the allowed
        keys), a value has the wrong type or range, or an object file does not exist.
    """
    src = Path(path)
    try:
        data = tomllib.loads(src.read_text())
    except FileNotFoundError:
        raise SceneError(f"{src}: scene file not found") from None
    except tomllib.TOMLDecodeError as e:
        raise SceneError(f"{src}: not valid TOML: {e}") from None
    return parse_scene(data, src)


def parse_scene(data: dict, src: Path) -> Scene:
    """Validate an already-parsed TOML document (see :func:`load_scene`)."""
    src = Path(src)
    _check_keys(data, _TOP_KEYS, "the top level", src)
    base = src.parent

    engine_t = data.get("engine", {})
    _check_keys(engine_t, _ENGINE_KEYS, "[engine]", src)
    engine = EngineSpec(name=engine_t.get("name"), options=dict(engine_t.get("options", {})))

    dom_t = data.get("domain", {})
    _check_keys(dom_t, _DOMAIN_KEYS, "[domain]", src)
    domain = DomainSpec(
        lo=_vec3(dom_t["lo"], "domain.lo", src) if "lo" in dom_t else None,
        hi=_vec3(dom_t["hi"], "domain.hi", src) if "hi" in dom_t else None,
        n_grid=int(dom_t.get("n_grid", 64)),
        padding=_positive(dom_t.get("padding", 0.5), "domain.padding", src, allow_zero=True),
        particles_per_cell=int(dom_t.get("particles_per_cell", 8)))
    if (domain.lo is None) != (domain.hi is None):
        raise SceneError(f"{src}: [domain] needs both 'lo' and 'hi', or neither")
    if domain.lo is not None and not np.all(np.array(domain.hi) > np.array(domain.lo)):
        raise SceneError(f"{src}: [domain] 'hi' must exceed 'lo' on every axis, got lo={domain.lo} hi={domain.hi}")
    if not 8 <= domain.n_grid <= 1024:
        raise SceneError(f"{src}: domain.n_grid = {domain.n_grid} must be in [8, 1024]")
    if not 1 <= domain.particles_per_cell <= 64:
        raise SceneError(f"{src}: domain.particles_per_cell = {domain.particles_per_cell} must be in [1, 64]")

    boundaries = []
    for i, b in enumerate(data.get("boundary", [])):
        where = f"[[boundary]] #{i + 1}"
        _check_keys(b, _BOUNDARY_KEYS, where, src)
        kind = b.get("kind")
        if kind not in BOUNDARIES:
            raise SceneError(f"{src}: {where}.kind = {kind!r}; expected one of {sorted(BOUNDARIES)}")
        kw: dict[str, Any] = {"kind": kind}
        if "height" in b:
            h = b["height"]
            if not isinstance(h, (int, float)) or not math.isfinite(h):
                raise SceneError(f"{src}: {where}.height must be a finite number, got {h!r}")
            kw["height"] = float(h)
        if "friction" in b:
            kw["friction"] = _positive(b["friction"], f"{where}.friction", src, allow_zero=True)
        if kind == "fixed_region":
            if "lo" not in b or "hi" not in b:
                raise SceneError(f"{src}: {where} (fixed_region) needs 'lo' and 'hi'")
            kw["lo"] = _vec3(b["lo"], f"{where}.lo", src)
            kw["hi"] = _vec3(b["hi"], f"{where}.hi", src)
        boundaries.append(Boundary(**kw))

    objects = []
    obj_list = data.get("object", [])
    if not obj_list:
        raise SceneError(f"{src}: the scene has no [[object]]")
    for i, o in enumerate(obj_list):
        where = f"[[object]] #{i + 1}"
        _check_keys(o, _OBJECT_KEYS, where, src)
        if "file" not in o:
            raise SceneError(f"{src}: {where} needs 'file'")
        f = (base / o["file"]).resolve()
        if not f.exists():
            raise SceneError(f"{src}: {where}.file '{o['file']}' does not exist (looked for {f})")
        up = o.get("up_axis", "+z")
        if up not in UP_AXES:
            raise SceneError(f"{src}: {where}.up_axis = {up!r}; expected one of {list(UP_AXES)}")
        thickness = o.get("thickness", "keep")
        if thickness not in ("keep", "eps"):
            raise SceneError(f"{src}: {where}.thickness = {thickness!r}; expected 'keep' or 'eps'")
        if_open = o.get("if_open", "warn")
        if if_open not in ("warn", "error"):
            raise SceneError(f"{src}: {where}.if_open = {if_open!r}; expected 'warn' or 'error'")
        alpha = o.get("alpha", 1.5)
        if alpha is False:
            alpha = None
        elif alpha is not None:
            alpha = _positive(alpha, f"{where}.alpha", src)
        objects.append(ObjectSpec(
            file=f, up_axis=up,
            scale=_positive(o.get("scale", 1.0), f"{where}.scale", src),
            recentre=bool(o.get("recentre", True)),
            position=_vec3(o.get("position", (0, 0, 0)), f"{where}.position", src),
            velocity=_vec3(o.get("velocity", (0, 0, 0)), f"{where}.velocity", src),
            angular_velocity=_vec3(o.get("angular_velocity", (0, 0, 0)), f"{where}.angular_velocity", src),
            material=_material(o.get("material", {}), f"{where}.material", src),
            fill=bool(o.get("fill", True)), alpha=alpha, thickness=thickness,
            min_opacity=_positive(o.get("min_opacity", 0.1), f"{where}.min_opacity", src, allow_zero=True),
            core_fraction=_fraction(o.get("core_fraction", 1.0), f"{where}.core_fraction", src),
            if_open=if_open,
            dynamic_time=_dynamic_time(o, f, where, src)))

    n_frames = data.get("n_frames", 30)
    if not isinstance(n_frames, int) or isinstance(n_frames, bool) or n_frames < 1:
        raise SceneError(f"{src}: 'n_frames' must be a positive integer, got {n_frames!r}")
    output = data.get("output")
    return Scene(
        path=src, objects=objects, engine=engine, domain=domain, boundaries=boundaries,
        gravity=_vec3(data.get("gravity", (0.0, 0.0, -9.81)), "gravity", src),
        frame_dt=_positive(data.get("frame_dt", 1.0 / 30.0), "frame_dt", src),
        n_frames=n_frames, output=(base / output) if output else None, name=str(data.get("name", src.stem)))
