"""Conformance scenes of the error contract (:mod:`gasp_core.errors`), for every engine.

=========================  =========================================================================
scene                      what must happen
=========================  =========================================================================
contract_declarations      the engine's declarations are consistent: option defaults valid for their
                           own declaration, ``deterministic_options`` and ``known_failures`` name
                           declared options and existing scenes
contract_refusals          a material, boundary or feature the engine lacks, an unknown option and a
                           wrongly typed option are refused by :func:`~gasp_core.seam.build.build_engine`
                           with ``SceneError`` naming them, before the factory runs
contract_declared_accepted every declared material (one body each) and boundary in one scene is
                           built and run for 2 frames without any error
contract_blowup            a stiff body (E = 1e10 Pa, random velocities of 0.1 m/s) with the time
                           step forced to one substep per frame (the engine's ``n_substeps`` or ``dt`` option) ends in
                           ``EngineDivergence``, never NaN output or another exception
contract_outside_domain    points 3 cells outside the domain: ``SceneError`` at build or
                           ``EngineDivergence``, never a crash and never a run that accepts them
=========================  =========================================================================
"""
from __future__ import annotations

import dataclasses
import functools
from typing import Callable

import numpy as np

from gasp_core.seam.build import build_engine
from gasp_core.seam.engine import EngineInfo, FEATURES
from gasp_core.seam.options import Option
from gasp_core.errors import EngineBug, EngineDivergence, GaspError, SceneError
from gasp_core.seam.setup import BOUNDARIES, MATERIALS, Boundary, Material, SimSetup
from gasp_core.testing.helpers import GRAVITY, Check, box_points
from gasp_core.testing.kit import Requires, Scene, run_trace

DX = 1.0 / 16
GROUND_H = 3 * DX
#: A name no engine declares as an option.
UNKNOWN_OPTION = "gasp_conformance_no_such_option"


class _FactoryCalled(Exception):
    """Raised by the spy factory: the core let a setup through that it should have refused."""


def _spy(info: EngineInfo) -> EngineInfo:
    def factory(setup):
        raise _FactoryCalled()
    return dataclasses.replace(info, factory=factory)


def _material(info: EngineInfo, **kw) -> Material:
    name = "jelly" if "jelly" in info.capabilities.materials else sorted(info.capabilities.materials)[0]
    return Material(name, **kw)


def _base(info: EngineInfo, material: Material | None = None, options=None, n_frames_fall: float = 0.2) -> SimSetup:
    """A 0.125 m cube (64 points) one cell above the ground (where the engine has a ground)."""
    x, p_vol = box_points((0.4375, 0.4375, GROUND_H + DX), (0.5625, 0.5625, GROUND_H + DX + 0.125), DX / 2)
    bounds = [Boundary("ground", height=GROUND_H, friction=0.5)] if "ground" in info.capabilities.boundaries else []
    return SimSetup(x=x, v=0.0, p_vol=p_vol, body_id=0, materials=[material or _material(info)],
                    gravity=np.array([0.0, 0.0, -GRAVITY]), domain_lo=np.zeros(3), domain_hi=np.ones(3), n_grid=16,
                    boundaries=bounds, frame_dt=0.01, options=dict(options or {}))


def _refused(info: EngineInfo, setup: SimSetup, name: str, what: str) -> Check:
    """Check that building ``setup`` raises SceneError naming ``name`` before the factory runs."""
    try:
        build_engine(_spy(info), setup)
    except SceneError as e:
        ok = name in str(e)
        return Check(f"refuses_{what}", ok, f"{what} {name!r}: SceneError{'' if ok else ' NOT naming it'}: {e}")
    except _FactoryCalled:
        return Check(f"refuses_{what}", False, f"{what} {name!r} reached the engine's factory unrefused")
    except Exception as e:  # noqa: BLE001 (any other outcome is the failure being reported)
        return Check(f"refuses_{what}", False, f"{what} {name!r}: {type(e).__name__} instead of SceneError: {e}")
    return Check(f"refuses_{what}", False, f"{what} {name!r} was accepted")


def _wrong_value(o: Option):
    """A value of the wrong type for option ``o``."""
    return {"bool": "yes", "str": 12345, "int": "three"}.get(o.kind, "fast")


def _run_declarations(info: EngineInfo, scene_names: Callable[[], set[str]]) -> list[Check]:
    declared = {o.name: o for o in info.options}
    bad_defaults = [f"{o.name}={o.default!r} (expected {o.expected()})" for o in info.options
                    if o.kind not in ("int", "number", "str", "bool") or not o.valid(o.default)]
    bad_det = [f"{k}={v!r}" + ("" if k in declared else " (not a declared option)")
               for k, v in info.deterministic_options.items() if k not in declared or not declared[k].valid(v)]
    names = scene_names()
    bad_kf = sorted(k for k in info.known_failures if k not in names)
    empty_kf = sorted(k for k, v in info.known_failures.items() if not str(v).strip())
    return [
        Check("option_defaults_valid", not bad_defaults,
              f"{len(info.options)} declared option(s); invalid defaults: {bad_defaults or 'none'}"),
        Check("deterministic_options_declared", not bad_det,
              f"deterministic_options {dict(info.deterministic_options)}; invalid: {bad_det or 'none'}"),
        Check("known_failures_name_scenes", not bad_kf and not empty_kf,
              f"known_failures {sorted(info.known_failures)}; unknown scenes: {bad_kf or 'none'}; "
              f"without a reason: {empty_kf or 'none'}"),
    ]


def _run_refusals(info: EngineInfo) -> list[Check]:
    caps = info.capabilities
    checks = []
    lacking = sorted(MATERIALS - caps.materials)
    if lacking:
        checks.append(_refused(info, _base(info, Material(lacking[0])), lacking[0], "material"))
    lacking = sorted(BOUNDARIES - caps.boundaries)
    if lacking:
        s = _base(info)
        s.boundaries = s.boundaries + [Boundary(lacking[0], lo=(0.0, 0.0, 0.0), hi=(0.1, 0.1, 0.1))]
        checks.append(_refused(info, s, lacking[0], "boundary"))
    # SimSetup.C is a hint ("initial_C" engines start from it, others may ignore it), so it is not
    # refused; the features a setup does require (colliders, forces) are checked when the core has them.
    checks += _refused_extras(info)
    checks.append(_refused(info, _base(info, options={UNKNOWN_OPTION: 1}), UNKNOWN_OPTION, "unknown_option"))
    for o in info.options:
        checks.append(_refused(info, _base(info, options={o.name: _wrong_value(o)}), o.name, f"mistyped_option_{o.name}"))
    if len(checks) < 2:
        checks.append(Check("refuses_unsupported", True, "the engine declares every material, boundary "
                            f"and setup feature ({sorted(FEATURES)}): nothing else to refuse"))
    return checks


def _refused_extras(info: EngineInfo) -> list[Check]:
    """Colliders, forces and impulses the engine lacks are refused before the factory (gasp_core.colliders.model)."""
    from gasp_core.colliders.model import ForceField, Impulse, Motion
    from gasp_core.colliders.sdf import box_collider
    far = np.array([0.5, 0.5, 0.9])
    extras = {
        "static_colliders": {"colliders": [box_collider((0.05, 0.05, 0.05), DX, position=far)]},
        "moving_colliders": {"colliders": [box_collider((0.05, 0.05, 0.05), DX, position=far,
                                                        motion=Motion(velocity=(0.1, 0.0, 0.0)))]},
        "impulse": {"impulses": [Impulse("box", (0.1, 0.0, 0.0), lo=(0, 0, 0), hi=(1, 1, 1))]},
        "wind": {"forces": [ForceField("wind", speed=1.0)]},
        "attractors": {"forces": [ForceField("attractor", strength=1.0, point=(0.5, 0.5, 0.5))]},
    }
    out = []
    for feature, fields in extras.items():
        if feature not in info.capabilities.features:
            s = _base(info)
            for k, v in fields.items():
                setattr(s, k, v)
            out.append(_refused(info, s, feature, f"feature_{feature}"))
    return out


def _outcome(info: EngineInfo, setup: SimSetup, n_frames: int):
    """``(kind, error)``: kind is 'ok', 'divergence', 'scene' (SceneError/EngineError at build), 'bug'
    (EngineBug) or 'other' (an exception outside the contract reached the kit)."""
    try:
        run_trace(info, setup, n_frames)
    except EngineDivergence as e:
        return "divergence", e
    except EngineBug as e:
        return "bug", e
    except GaspError as e:
        return "scene", e
    except Exception as e:  # noqa: BLE001 (reported as the failure)
        return "other", e
    return "ok", None


def _run_declared_accepted(info: EngineInfo) -> list[Check]:
    caps = info.capabilities
    mats = sorted(caps.materials)
    xs, vols, ids = [], [], []
    # one block (1 x 1.6 x 1 cells) per material on a grid of columns x rows inside [0.25, 0.75]^2, so
    # every point is 4 cells or more from the domain's faces: an engine may keep a boundary band of a
    # few cells (an MPM box may be the domain less 3 dx on each side)
    cols = int(np.ceil(np.sqrt(len(mats))))
    rows = int(np.ceil(len(mats) / cols))
    size = np.array([DX, 0.1, DX])
    for k, m in enumerate(mats):
        x0 = 0.25 + (k % cols) * (0.5 - size[0]) / max(cols - 1, 1)
        y0 = 0.25 + (k // cols) * (0.5 - size[1]) / max(rows - 1, 1)
        lo = np.array([x0, y0, GROUND_H + DX])
        x, p_vol = box_points(tuple(lo), tuple(lo + size), DX / 2)
        xs.append(x), vols.append(np.full(len(x), p_vol)), ids.append(np.full(len(x), k))
    x = np.concatenate(xs)
    bounds = []
    for b in sorted(caps.boundaries):
        if b == "ground":
            bounds.append(Boundary("ground", height=GROUND_H, friction=0.5))
        elif b == "fixed_region":  # holds the bottom layer of the first cube
            lo = xs[0].min(axis=0) - DX / 8
            bounds.append(Boundary("fixed_region", lo=tuple(lo), hi=tuple(lo + np.array([0.07, 0.11, DX / 2]))))
        else:
            bounds.append(Boundary(b))
    setup = SimSetup(x=x, v=0.0, p_vol=np.concatenate(vols), body_id=np.concatenate(ids).astype(np.int32),
                     materials=[Material(m) for m in mats], gravity=np.array([0.0, 0.0, -GRAVITY]),
                     domain_lo=np.zeros(3), domain_hi=np.ones(3), n_grid=16, boundaries=bounds, frame_dt=0.01)
    kind, e = _outcome(info, setup, 2)
    what = f"materials {mats}, boundaries {sorted(caps.boundaries)}, {len(x)} points, 2 frames"
    return [Check("declared_capabilities_run", kind == "ok",
                  f"{what}: " + ("ran" if kind == "ok" else f"{type(e).__name__}: {e}"))]


def _run_blowup(info: EngineInfo) -> list[Check]:
    declared = {o.name for o in info.options}
    setup = _base(info, _material(info, E=1e10))
    # a uniform fall strains nothing (F stays I, springs at rest): random velocities load the material
    setup.v = np.random.default_rng(11).uniform(-0.1, 0.1, size=setup.x.shape)
    if "n_substeps" in declared:
        setup.options, forced = {"n_substeps": 1}, "n_substeps=1"
    elif "dt" in declared:
        setup.options, forced = {"dt": setup.frame_dt}, f"dt={setup.frame_dt}"
    else:
        forced = "no time-step option declared: the engine's own step"
    if "contact" in declared:
        # a grid engine's particle contact shortens a hand-set step to its own stable one (issue 38): keep the step
        setup.options = {**setup.options, "contact": "grid"}
    kind, e = _outcome(info, setup, 5)
    text = f"E = 1e10 Pa, {forced}, frame_dt {setup.frame_dt} s: "
    if kind == "divergence":
        return [Check("blowup_is_divergence", True, text + f"EngineDivergence ({e})")]
    if kind == "ok":  # a stable (implicit) engine may survive; NaN would have been a divergence
        return [Check("blowup_is_divergence", True, text + "no blow-up: finite and inside the domain for 5 frames")]
    return [Check("blowup_is_divergence", False, text + f"{type(e).__name__} instead of EngineDivergence: {e}")]


def _run_outside(info: EngineInfo) -> list[Check]:
    setup = _base(info)
    x = setup.x.copy()
    x[:5, 0] = 1.0 + 3 * DX  # five points 3 cells beyond the domain's +x face
    kind, e = _outcome(info, setup.replace(x=x), 2)
    ok = kind == "divergence" or (kind == "scene" and isinstance(e, SceneError))
    msg = "accepted and not reported" if kind == "ok" else f"{type(e).__name__}: {e}"
    return [Check("outside_domain_reported", ok, f"5 points 3 dx beyond the +x face: {msg}")]


def contract_scenes(scene_names: Callable[[], set[str]]) -> list[Scene]:
    """The error-contract scenes; ``scene_names()`` gives every conformance scene's name (for the check
    that an engine's ``known_failures`` name real scenes)."""
    return [
    Scene("contract_declarations", "option defaults, deterministic_options and known_failures are consistent",
          Requires(), run=functools.partial(_run_declarations, scene_names=scene_names)),
    Scene("contract_refusals", "a material, boundary or feature the engine lacks, an unknown option and a "
          "wrongly typed option: SceneError naming it, before the factory runs", Requires(), run=_run_refusals),
    Scene("contract_declared_accepted", "every declared material and boundary together: built and run "
          "2 frames without error", Requires(), run=_run_declared_accepted),
    Scene("contract_blowup", "E = 1e10 Pa at one substep per frame: EngineDivergence, never NaN or "
          "another exception", Requires(), run=_run_blowup),
    Scene("contract_outside_domain", "points outside the domain: SceneError or EngineDivergence, never a "
          "crash or silent acceptance", Requires(), run=_run_outside),
    ]
