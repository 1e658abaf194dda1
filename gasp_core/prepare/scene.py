"""A scene made ready to run: the engine chosen and checked, every object placed, the points assembled.

:func:`prepare_scene` is the first half of the pipeline (:mod:`gasp_core.run.pipeline`): it reads
nothing before the engine is known to support what the scene asks for (:func:`scene_needs`).
"""
from __future__ import annotations

import dataclasses
import time
import warnings
from dataclasses import dataclass
from pathlib import Path

from gasp_core.errors import SceneError
from gasp_core.prepare.around import (reach_line, uses_reach, whole_selections, with_rest_colliders,
                                      with_support_ground)
from gasp_core.prepare.assembly import build_setup
from gasp_core.prepare.dynamic import beyond_model_lines
from gasp_core.prepare.ground import has_auto_ground, resolve_ground
from gasp_core.prepare.placed import PreparedObject
from gasp_core.prepare.placement import prepare_object
from gasp_core.prepare.route import declared_cfl, resolve_models
from gasp_core.prepare.stand import stand_warnings
from gasp_core.scene.quality import engine_options as quality_options
from gasp_core.scene.spec import Scene
from gasp_core.seam.build import check_supported, needs
from gasp_core.seam.engine import EngineInfo
from gasp_core.seam.options import check_options
from gasp_core.seam.plugins import engines as all_engines, get_engine
from gasp_core.seam.setup import SimSetup


@dataclass
class PreparedScene:
    """A scene ready to run: engine chosen and checked, objects placed, points assembled.

    Attributes
    ----------
    prepare_s : float
        Wall time of reading, placing, flattening, the hierarchy and point assembly, seconds.
    around : list of str
        The lines saying what the scene around a selection supplied (:mod:`gasp_core.prepare.around`): the rest
        as a collider, a ground, the domain (``run.json`` ``around_selection``).
    """

    scene: Scene
    info: EngineInfo
    objects: list[PreparedObject]
    names: list[str]
    setup: SimSetup
    prepare_s: float = 0.0
    around: list = dataclasses.field(default_factory=list)


#: Files a run folder holds beside its object folders (``gasp render``'s default output too).
RUN_FILES = frozenset({"run.json", "frames.json", "render.mp4"})


def scene_needs(scene: Scene) -> dict[str, list[str]]:
    """What a scene asks of an engine, before any file is read: :func:`gasp_core.seam.build.needs` of its
    simulated objects' materials, boundaries, colliders, forces and impulses (the rule
    :func:`~gasp_core.seam.build.setup_needs` applies to the setup built from it)."""
    return needs([o.material for o in scene.objects if not o.static], scene.boundaries, scene.colliders,
                 scene.forces, scene.impulses)


def prepare_scene(scene: Scene, engine: str | None = None, options: dict | None = None) -> PreparedScene:
    """Choose and check the engine, read and place every object, build the point set.

    Parameters
    ----------
    scene : Scene
    engine : str, optional
        Override ``scene.engine.name``.
    options : dict, optional
        Engine options replacing ``scene.engine.options`` (e.g. from a settings sweep).

    Raises
    ------
    EngineError
        Unknown engine, or an engine that cannot run here.
    SceneError
        A material, boundary or feature the engine lacks (before any file is read), an
        unreadable object file, an object outside an explicit domain, an explicit domain floored too close
        under a ground for the engine's contact (the engine's own ``check_scene``, :class:`EngineInfo`).
    """
    # The capability check runs here, on the scene, so that an engine that lacks something is refused
    # before any file is read; build_engine applies the same rule (needs) again to the setup, because it
    # is also called with setups built in code (conformance kit, studies). Both give the same names.
    t0 = time.perf_counter()
    name = engine or scene.engine.name
    if not name:
        raise SceneError(f"{scene.path}: no engine: set [engine] name = \"...\" or pass --engine "
                         f"(installed: {sorted(all_engines()) or 'none'})")
    info = get_engine(name)
    check_supported(info, **scene_needs(scene), others=all_engines())
    given = dict(scene.engine.options if options is None else options)
    run_options = quality_options(scene.quality, given, info.presets)     # the options the run takes
    with warnings.catch_warnings():      # checked before anything uses them (issue 68: cfl = 0 reached the substep
        warnings.simplefilter("ignore")  # estimate); the threads cap says its line once, when the engine is built
        check_options(run_options, info.options, info.name)
    if info.check_scene is not None and not has_auto_ground(scene):   # the engine's own check, before any file is read
        info.check_scene(scene, run_options, None)
    objects = [prepare_object(spec) for spec in scene.objects]
    scene, objects, whole = whole_selections(scene, objects)     # a select of every row: the whole object
    if has_auto_ground(scene):     # height = "auto": the support in the scan, once the objects are placed
        scene = resolve_ground(scene, objects)
        if info.check_scene is not None:
            info.check_scene(scene, run_options, None)
    scene, around = around_selection(scene, objects, info.capabilities.features)
    around = whole + around
    if around and info.check_scene is not None:
        info.check_scene(scene, run_options, None)
    # object folder names: a stem that is one of a run folder's own files (run.json.ply) or hidden
    # (.gasp-output.ply) gets a leading "_"; equal ones their index
    stems = [f"_{o.name}" if o.name in RUN_FILES or o.name.startswith(".") else o.name for o in objects]
    names = [n if stems.count(n) == 1 else f"{i}_{n}" for i, n in enumerate(stems)]
    setup, objects = build_setup(scene, objects)
    if uses_reach(scene):
        around.append(reach_line(setup, scene))
    for line in around + beyond_model_lines(objects, scene.frame_dt, scene.n_frames):   # a model held past its end
        warnings.warn(line, stacklevel=2)
    moving = [i for i, o in enumerate(objects) if not o.spec.static]   # body k of the setup (build_setup's order)
    setup.options = run_options   # before the routes: their lines give the substeps these options take (issue 53)
    routes = resolve_models(setup, [names[i] for i in moving], info.capabilities.features, declared_cfl(info),
                            info.substeps)
    for i, route in zip(moving, routes):
        objects[i] = dataclasses.replace(objects[i], body_model=route)
    # can each body carry itself, with the model it runs as (a rigid body cannot sag: gasp_core.prepare.stand)
    for msg in stand_warnings(setup.materials, scene.boundaries, scene.gravity, setup.x, setup.p_vol, setup.body_id,
                              [objects[i].name for i in moving], setup.dx):
        warnings.warn(msg, stacklevel=2)
    if info.check_scene is not None:     # again with the bodies' models chosen
        info.check_scene(scene, run_options, setup)
    return PreparedScene(scene, info, objects, names, setup, prepare_s=time.perf_counter() - t0, around=around)


def around_selection(scene: Scene, objects: list[PreparedObject], features=None) -> tuple[Scene, list[str]]:
    """``scene`` with what the scene around a selection supplies where the file states none (the rest as a
    collider, a ground under the selection: :mod:`gasp_core.prepare.around`) and the lines that say so."""
    scene, lines = with_rest_colliders(scene, features)
    scene, ground = with_support_ground(scene, objects)
    return scene, lines + ([ground] if ground else [])


def input_files(scene: Scene) -> list[Path]:
    """The files a run reads: the scene, every object's file and mesh, selection masks, collider meshes and Gaussians.

    The output claim protects them (never overwritten) and the resume fingerprint stands for exactly these
    (:func:`gasp_core.run.resume.fingerprint`).
    """
    return ([Path(scene.path)] + [Path(o.file) for o in scene.objects]
            + [Path(o.select.mask) for o in scene.objects if o.select is not None and o.select.mask is not None]
            + [Path(o.select.file) for o in scene.objects if o.select is not None and o.select.file is not None]
            + [Path(c.mesh or c.gaussians) for c in scene.colliders if (c.mesh or c.gaussians) is not None]
            + [o.mesh.path for o in scene.objects if o.mesh is not None and not o.mesh.laid])
