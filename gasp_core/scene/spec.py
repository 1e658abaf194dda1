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

``engine = "NAME"`` at the top level is shorthand for ``[engine] name = "NAME"``.

Every table accepts only the keys listed in this module and :mod:`gasp_core.scene.tables` (``[engine]``,
``[domain]``, ``[[boundary]]``, ``material``); a mistyped key is a :class:`SceneError`
that names it and the allowed ones. A ``material`` takes only the keys its ``name`` uses
(:data:`gasp_core.seam.schema.MATERIAL_KINDS`, listed in ``docs/scene_keys.md``): ``name = "jelly"`` with
``yield_stress`` is an error naming the keys jelly takes. A key left out takes the default its dataclass
(:class:`ObjectSpec`, :class:`Scene`, :class:`~gasp_core.seam.setup.Material`) declares. Every value is
type-checked before use (a wrong type is a :class:`SceneError` naming the key, the value, its TOML type
and what was expected: integers are integers, ``n_grid = 24.9`` is not 24) and range-checked
(:data:`MAX_COORD`, :data:`MAX_SPEED`, :data:`MAX_GRAVITY`, :data:`SCALE_RANGE`). Units are SI: metres, seconds,
Pa, kg/m^3, degrees.
"""
from __future__ import annotations

import math
import tomllib
from dataclasses import dataclass, field, fields
from pathlib import Path

from gasp_core.errors import SceneError
from gasp_core.maps.centres import SURFACE_POINTS
from gasp_core.maps.games import REBUILDS
from gasp_core.gs.registry import is_dynamic
from gasp_core.scene.extras import read_extras
from gasp_core.scene.mesh import MESH_KEYS, MeshSpec, read_mesh
from gasp_core.scene.quality import DEFAULT_QUALITY, apply_quality, read_quality
from gasp_core.scene.select import SelectSpec, read_rest_collider, read_select, read_static
from gasp_core.scene.tables import DomainSpec, EngineSpec, read_boundaries, read_domain, read_engine, read_material
from gasp_core.scene.values import (ALPHA_MIN, MAX_COORD, MAX_GRAVITY, MAX_SPEED, MAX_SPIN, SCALE_RANGE, UP_AXES,
                                    as_boolean, as_integer, as_number, as_string, as_table, as_tables, as_vec3,
                                    bad_value, check_keys, is_number, read_key, resolve_path)
from gasp_core.seam.setup import FRAME_DT_RANGE, Boundary, Material

#: ``[[object]] surface``: the triangle vertices are material points, or passive (massless, carried), or
#: chosen by the rule of :mod:`gasp_core.prepare.surface` ("auto", what the quality levels set).
SURFACES = ("material", "passive", "auto")


@dataclass
class ObjectSpec:
    """One scene object: a Gaussian Splatting file placed in the world (z up, metres).

    Attributes
    ----------
    file : Path
        Gaussian Splatting file (graphdeco / GaMeS / 2DGS / compressed PLY), relative to the scene file.
    up_axis : str
        The file's up axis, one of ``+x -x +y -y +z -z``; it is turned to world +z.
    up_axis_stated : bool
        False where the file states neither ``up_axis`` nor ``up``: :func:`gasp_core.prepare.up.resolve_up_axis`.
    up : None, "auto" or (3,) float
        Replaces ``up_axis``: the file's up as a vector in the file frame, any direction, or ``"auto"`` (the
        support plane of the scan, :mod:`gasp_core.gs.support`; a :class:`SceneError` where it is unsure). It
        is turned to world +z by the shortest turn (:func:`gasp_core.prepare.up.up_rotation`).
    scale : float
        Metres per file unit.
    recentre : bool
        Place the object's bounding-box bottom centre (in the world orientation) at ``position``;
        if false, ``position`` is added to the rotated, scaled file coordinates.
    position : (3,) float
        Metres.
    rotation : (3,) float
        Degrees about world x, then y, then z, applied after ``up_axis`` and before ``recentre``
        (:func:`gasp_core.prepare.placed.euler_matrix`); a static object and the ``[[collider]]``
        made from it share this placement.
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
    rebuild : str
        How ``T^-1`` rebuilds each Gaussian from its moved triangle (:data:`gasp_core.maps.games.REBUILDS`):
        ``"games"`` (the paper: Gram-Schmidt, ``s2 = |v2 - v1|``, ``s3`` the triangle's height) or
        ``"covariance"`` (PhysGaussian's ``F Sigma F^T`` with the triangle's own ``F``; keeps in-plane
        shear). The alpha rule applies to either (``docs/rebuild.md``).
    thickness : str
        Output thin-axis scale: ``"keep"`` the input's own thinnest scale (frame 0 renders as the
        input), or ``"eps"`` the GaMeS ``1e-8``.
    min_opacity : float
        Gaussians below this activated opacity are carried but do not mark occupied space for
        the interior fill.
    if_open : str
        What a filled object whose Gaussians enclose no volume does (:mod:`gasp_core.maps.fill`):
        ``"warn"`` (simulate a hollow shell, warn and record it in run.json) or ``"error"``
        (refuse before the run starts).
    core_fraction : float
        Share of Gaussians simulated, in (0, 1]: below 1, that many Core Gaussians are built by a linear-time
        grid clustering (in place of the paper's BIRCH, which costs 108 s and 4.9 GB on the donut) and the rest
        follow them (paper Sec. 3, hierarchy; :mod:`gasp_core.maps.hierarchy`).
    surface : str
        ``"material"``: the triangle vertices are material points sharing the solid's volume
        with the fill. ``"passive"``: they carry no mass and follow the material (the fill alone
        is the solid; :mod:`gasp_core.seam.passive`, ``SimSetup.passive``).
    surface_points : str
        Which points of a Gaussian the engine moves (:data:`gasp_core.maps.centres.SURFACE_POINTS`): the GaMeS
        triangle's three ``"vertices"`` (the paper's), or its ``"centres"`` alone (PhysGaussian's layout, a
        third of the points; ``F`` from the neighbours' motion, :mod:`gasp_core.maps.centres`), or ``"auto"``
        (what the levels ``draft`` and ``default`` set: centres on elastic bodies, their surface material or
        passive, else vertices; :func:`gasp_core.prepare.surface.choose_surface_points`). Centres not with
        ``core_fraction < 1`` or ``mesh``.
    dynamic_time : float or None
        For a dynamic model (``.splatv``): the model time ``s`` at which physics takes over,
        ``G_t = T^-1(phi(psi(V, s), t))`` (paper Sec. 3, dynamic scenes); default 0.
    velocity_from_model : bool
        A dynamic model whose scene sets neither ``velocity`` nor ``angular_velocity``: the simulated
        part starts with the velocity the model gives it at ``s`` (finite difference of ``psi`` over one
        frame, :mod:`gasp_core.prepare.dynamic`).
    background : str
        A dynamic model's rows that are not simulated (unselected, floaters, a static object): ``"model"``
        (default) they keep playing, frame ``k`` writes ``psi(V, s + k frame_dt)``; ``"frozen"`` they stay at
        ``psi(V, s)``, written once by the split layout.
    select : SelectSpec or None
        The part of the file that moves (``select = { box = {...} }``, see :class:`SelectSpec`);
        the rest is static background, written unchanged in every frame. None: all of it moves.
    rest_collider : bool
        With ``select``: the unselected rest is a collider by default (:mod:`gasp_core.prepare.around`); false: not.
    keep_floaters : bool
        False (default): Gaussians detached from a whole object (:mod:`gasp_core.maps.floaters`; not in a
        ``select``ion) are left out of the domain and the physics and written unchanged in every frame,
        with a warning giving their count. True: they are simulated with the rest.
    mesh : MeshSpec or None
        Mesh mode (``mesh = "shape.obj"``, :mod:`gasp_core.scene.mesh`): the engine moves the mesh's
        vertices and the Gaussians follow their faces. Without ``file`` the Gaussians are laid on the
        faces and ``file`` is the mesh.
    static : bool
        The whole object is static: never simulated, written unchanged in every frame (scenery,
        and a collider where a ``[[collider]]`` names it). A static object takes no ``material``,
        ``select`` or other key only a simulation reads (a :class:`SceneError` names them), and
        a scene needs at least one object that is not static.
    """

    file: Path
    up_axis: str = "+z"
    up: str | tuple[float, float, float] | None = None
    up_axis_stated: bool = True
    scale: float = 1.0
    recentre: bool = True
    position: tuple[float, float, float] = (0.0, 0.0, 0.0)
    velocity: tuple[float, float, float] = (0.0, 0.0, 0.0)
    angular_velocity: tuple[float, float, float] = (0.0, 0.0, 0.0)
    material: Material = field(default_factory=Material)
    rotation: tuple[float, float, float] = (0.0, 0.0, 0.0)
    fill: bool = True
    alpha: float | None = 1.5
    rebuild: str = "games"
    thickness: str = "keep"
    min_opacity: float = 0.1
    core_fraction: float = 1.0
    if_open: str = "warn"
    dynamic_time: float | None = None
    surface: str = "material"
    surface_points: str = "vertices"
    select: SelectSpec | None = None
    rest_collider: bool = True
    static: bool = False
    keep_floaters: bool = False
    mesh: MeshSpec | None = None
    velocity_from_model: bool = False
    background: str = "model"


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
    colliders: list = field(default_factory=list)
    forces: list = field(default_factory=list)
    impulses: list = field(default_factory=list)
    quality: str = DEFAULT_QUALITY
    sleep: bool = True
    settle: bool = False   # round 84: start from the bodies at rest in their weight (gasp_core.seam.settle)


_TOP_KEYS = {"name", "frame_dt", "n_frames", "gravity", "output", "engine", "domain", "boundary", "object",
             "collider", "force", "impulse", "quality", "sleep", "settle"}
_OBJECT_KEYS = ({f.name for f in fields(ObjectSpec)} | set(MESH_KEYS)) - {"velocity_from_model", "up_axis_stated"}


def _dynamic_time(o: dict, f: Path, where: str, src: Path) -> float | None:
    t = o.get("dynamic_time")
    if not is_dynamic(f):
        if t is not None:
            raise SceneError(f"{src}: {where}.dynamic_time is only for dynamic models (.splatv), not {f.name}")
        return None
    if t is None:
        return 0.0
    return as_number(t, f"{where}.dynamic_time", src)


def _background(o: dict, f: Path, where: str, src: Path) -> str:
    if "background" in o and not is_dynamic(f):
        raise SceneError(f"{src}: {where}.background is only for dynamic models (.splatv), not {f.name}")
    return read_key(o, "background", as_string, ("model", "frozen"), default_from=ObjectSpec, where=where, src=src)


def _surface_points(o: dict, mesh, where: str, src: Path) -> str:
    v = read_key(o, "surface_points", as_string, SURFACE_POINTS, default_from=ObjectSpec, where=where, src=src)
    if v == "centres" and (mesh is not None or o.get("core_fraction", 1.0) != 1.0):   # "auto": vertices there
        raise SceneError(f"{src}: {where}.surface_points = \"centres\" moves every Gaussian's own centre; it does "
                         "not combine with core_fraction < 1 (Core Gaussians) or mesh (the mesh's vertices)")
    return v


def _up(o: dict, where: str, src: Path):
    if "up" not in o:
        return None
    if "up_axis" in o:
        raise SceneError(f"{src}: {where} states both 'up' and 'up_axis'; keep one ('up' replaces 'up_axis')")
    if o["up"] == "auto":
        return "auto"
    expected = '"auto" or a vector [x, y, z] in the file frame, not [0, 0, 0]'
    u = as_vec3(o["up"], f"{where}.up", src) if not isinstance(o["up"], str) else None
    if u is None or not any(u):
        bad_value(src, f"{where}.up", o["up"], expected)
    return u


def _object(o: dict, where: str, src: Path) -> ObjectSpec:
    check_keys(o, _OBJECT_KEYS, where, src)
    mesh = read_mesh(o, where, src)
    if "file" not in o and mesh is None:
        raise SceneError(f"{src}: {where} needs 'file' (a Gaussian Splatting file) or 'mesh'")
    name = as_string(o["file"], f"{where}.file", src) if mesh is None or not mesh.laid else o["mesh"]
    f = resolve_path(src, name, f"{where}.file")
    if f.is_dir():
        raise SceneError(f"{src}: {where}.file '{name}' is a directory (looked at {f}); expected a Gaussian "
                         "Splatting file")
    if not f.exists():
        raise SceneError(f"{src}: {where}.file '{name}' does not exist (looked for {f})")
    alpha = o.get("alpha", ObjectSpec.alpha)
    if alpha is False or alpha is None:
        alpha = None
    elif not is_number(alpha) or not math.isfinite(alpha) or alpha < ALPHA_MIN:
        bad_value(src, f"{where}.alpha", alpha, f"a stretch bound of at least {ALPHA_MIN:g} (the paper ablates 1 to "
                  "5; below 1 the rule shrinks every Gaussian at rest), or false to disable the control rule")
    else:
        alpha = float(alpha)

    def get(key, read, *args, **kw):   # o[key] checked by read, or ObjectSpec's default
        return read_key(o, key, read, *args, default_from=ObjectSpec, where=where, src=src, **kw)
    return ObjectSpec(
        file=f, alpha=alpha, mesh=mesh,
        up_axis=get("up_axis", as_string, UP_AXES), up=_up(o, where, src),
        up_axis_stated="up_axis" in o or "up" in o,
        scale=get("scale", as_number, *SCALE_RANGE),
        recentre=get("recentre", as_boolean),
        position=get("position", as_vec3, max_abs=MAX_COORD, unit=" m"),
        velocity=get("velocity", as_vec3, max_norm=MAX_SPEED, unit=" m/s"),
        angular_velocity=get("angular_velocity", as_vec3, max_norm=MAX_SPIN, unit=" rad/s"),
        rotation=get("rotation", as_vec3, max_abs=360.0, unit=" degrees"),
        material=read_material(o.get("material", {}), f"{where}.material", src),
        fill=get("fill", as_boolean),
        rebuild=get("rebuild", as_string, REBUILDS),
        thickness=get("thickness", as_string, ("keep", "eps")),
        min_opacity=get("min_opacity", as_number, 0.0, 1.0),
        core_fraction=get("core_fraction", as_number, 0.0, 1.0, lo_open=True),
        if_open=get("if_open", as_string, ("warn", "error")),
        surface=get("surface", as_string, SURFACES),
        surface_points=_surface_points(o, mesh, where, src),
        dynamic_time=_dynamic_time(o, f, where, src),
        select=read_select(o["select"], f"{where}.select", src) if "select" in o else None,
        rest_collider=read_rest_collider(o, where, src),
        static=read_static(o, where, src),
        keep_floaters=get("keep_floaters", as_boolean),
        velocity_from_model=is_dynamic(f) and not {"velocity", "angular_velocity"} & set(o),
        background=_background(o, f, where, src))


def load_scene(path: str | Path, quality: str | None = None) -> Scene:
    """Read and validate a scene file.

    Parameters
    ----------
    path : str or Path
        TOML file (UTF-8). Relative object paths are resolved against its folder.
    quality : str, optional
        A level of :mod:`gasp_core.scene.quality` replacing the file's ``quality`` key.

    Returns
    -------
    Scene

    Raises
    ------
    SceneError
        One line naming the file, the key, the value and what was expected: the file is missing,
        a directory or not a regular file, unreadable, not UTF-8 or not TOML; a key is unknown (the message lists the
        allowed keys); a value has the wrong type (every key is type-checked: an integer where a
        table is expected, ``24.9`` for an integer, a string for a boolean) or is out of range
        (see the module constants :data:`MAX_COORD`, :data:`MAX_SPEED`, :data:`MAX_GRAVITY`,
        :data:`SCALE_RANGE`); a fixed region or domain whose ``hi`` does not exceed ``lo``; an
        object file does not exist or is a directory.
    """
    src = Path(path)
    if src.is_dir():
        raise SceneError(f"{src}: is a directory; expected a scene file (TOML)")
    if src.exists() and not src.is_file():   # a FIFO or a device (/dev/zero): reading could hang or never end
        raise SceneError(f"{src}: is not a regular file (a pipe, device or socket); expected a scene file (TOML)")
    try:
        data = tomllib.loads(src.read_bytes().decode("utf-8-sig"))   # a BOM (Notepad) is no TOML error
    except FileNotFoundError:
        raise SceneError(f"{src}: scene file not found") from None
    except UnicodeDecodeError as e:
        raise SceneError(f"{src}: not a UTF-8 text file (byte 0x{e.object[e.start]:02x} at offset {e.start}); "
                         "expected a TOML scene file") from None
    except OSError as e:
        raise SceneError(f"{src}: cannot read the scene file: {e.strerror or e}") from None
    except tomllib.TOMLDecodeError as e:
        raise SceneError(f"{src}: not valid TOML: {e}") from None
    except RecursionError:
        raise SceneError(f"{src}: tables or arrays nested too deep to read (hundreds of levels); "
                         "expected a scene file (TOML)") from None
    return parse_scene(data, src, quality)


def parse_scene(data: dict, src: Path, quality: str | None = None) -> Scene:
    """Validate an already-parsed TOML document (see :func:`load_scene`).

    Raises
    ------
    SceneError
        As :func:`load_scene`; never another exception type for any ``data`` a TOML parser returns.
    """
    src = Path(src)
    data = as_table(data, "the scene", src)
    check_keys(data, _TOP_KEYS, "the top level", src)
    level = read_quality(data, src, quality)
    data = apply_quality(data, level)
    base = src.parent
    engine = read_engine(data.get("engine", {}), src)
    domain = read_domain(data.get("domain", {}), src)
    boundaries = read_boundaries(data, src)
    obj_list = as_tables(data.get("object", []), "object", src)
    if not obj_list:
        raise SceneError(f"{src}: the scene has no [[object]]")
    objects = [_object(o, f"[[object]] #{i + 1}", src) for i, o in enumerate(obj_list)]
    if all(o.static for o in objects):
        raise SceneError(f"{src}: every [[object]] is static = true; nothing to simulate")
    n_frames = read_key(data, "n_frames", as_integer, 1, default_from=Scene, where="", src=src)
    output = data.get("output")
    if output is not None:
        output = base / as_string(output, "output", src)
    extras = read_extras(data, src, objects)
    return Scene(
        **extras, path=src, objects=objects, engine=engine, domain=domain, boundaries=boundaries,
        gravity=read_key(data, "gravity", as_vec3, default_from=Scene, where="", src=src, max_norm=MAX_GRAVITY,
                         unit=" m/s^2"),
        frame_dt=read_key(data, "frame_dt", as_number, *FRAME_DT_RANGE, default_from=Scene, where="", src=src),
        n_frames=n_frames, output=output, name=as_string(data.get("name", src.stem), "name", src), quality=level,
        **{k: read_key(data, k, as_boolean, default_from=Scene, where="", src=src) for k in ("sleep", "settle")})
