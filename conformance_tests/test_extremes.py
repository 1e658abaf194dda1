"""Stability at the extremes, per engine: a plausible result or a clear error, never NaN or a crash.

Base case: an elastic cube (0.2 m, 216 points) one cell above the ground in [0, 1]^3,
``n_grid`` 16, ``frame_dt`` 0.01 s, 2 frames. Each case changes one thing. Allowed outcomes:

- ``ok``: :func:`gasp_core.seam.runner.run_engine` returned finite positions and the result is plausible
  (no point moved farther than free fall plus the initial speed allows, plus 2 dx; no point more
  than dx below the ground);
- a clear error: :class:`SceneError` / :class:`EngineError` at build, or
  :class:`EngineDivergence` at the frame where it goes wrong.

Any other exception is a failure (an unclear error from inside the engine). For the cases within
an engine's declared range (nominal material, nu = 0, ``dt`` at 0.5x and 1x the limit, 1e4
points) only ``ok`` is accepted; for a precision the engine lists, ``ok`` or a refusal at build
(SceneError/EngineError, e.g. one precision per process), never a divergence. Outcomes are recorded in the session's result table.
"""
from __future__ import annotations

import numpy as np
import pytest

from gasp_core.seam.plugins import engines as installed_engines
from gasp_core.testing import GRAVITY, box_points, record
from gasp_core.testing.scenes_basic import GROUND_H
from gasp_core.errors import EngineDivergence, EngineError, SceneError
from gasp_core.seam.setup import Boundary, Material, SimSetup
from gasp_core.toolkit.substeps import mpm_stable_dt
from gasp_core.seam.runner import simulate

N_FRAMES = 2
FRAME_DT = 0.01
DX = 1.0 / 16


def _base(material: Material | None = None, x=None, p_vol=None, n_grid=16, options=None) -> SimSetup:
    if x is None:
        x, p_vol = box_points((0.4, 0.4, GROUND_H + DX), (0.6, 0.6, GROUND_H + DX + 0.2), DX / 2)
    return SimSetup(x=x, v=0.0, p_vol=p_vol, body_id=0, materials=[material or Material("jelly")],
                    gravity=np.array([0.0, 0.0, -GRAVITY]), domain_lo=np.zeros(3), domain_hi=np.ones(3),
                    n_grid=n_grid, boundaries=[Boundary("ground", height=GROUND_H, friction=0.5)],
                    frame_dt=FRAME_DT, options=dict(options or {}))


def _dt_case(factor):
    def build(info):
        s = _base()
        dt = mpm_stable_dt(s.materials, s.dx, s.gravity, height=1.0)
        return s.replace(options={"dt": factor * dt})
    return build


def _coincident(info):
    x, p_vol = box_points((0.4, 0.4, GROUND_H + DX), (0.6, 0.6, GROUND_H + DX + 0.2), DX / 2)
    return _base(x=np.concatenate([x, x[:20]]), p_vol=p_vol)


def _outside(info):
    s = _base()
    x = s.x.copy()
    x[:5, 0] = 1.0 + 3 * DX  # five points 3 cells beyond the domain's +x face
    return s.replace(x=x)


def _thin(info):  # a sheet one point thick
    x, _ = box_points((0.3, 0.3, 0.5), (0.7, 0.7, 0.5 + DX / 2), DX / 2)
    return _base(x=x, p_vol=(DX / 2) ** 3)


def _points(n_side, n_grid=16):
    def build(info):
        x, p_vol = box_points((0.35, 0.35, GROUND_H + DX), (0.65, 0.65, GROUND_H + DX + 0.3),
                              0.3 / n_side)
        return _base(x=x, p_vol=p_vol, n_grid=n_grid)
    return build


def _precision(p):
    return lambda info: _base(options={"precision": p})


#: case -> (build(info) -> SimSetup, must_be_ok(info) -> bool, slow)
CASES = {
    "nominal": (lambda info: _base(), lambda info: True, False),
    "E_1e2": (lambda info: _base(Material("jelly", E=1e2)), lambda info: False, False),
    "E_1e10": (lambda info: _base(Material("jelly", E=1e10)), lambda info: False, False),
    "nu_0": (lambda info: _base(Material("jelly", nu=0.0)), lambda info: True, False),
    "nu_0.499": (lambda info: _base(Material("jelly", nu=0.499)), lambda info: False, False),
    "rho_1": (lambda info: _base(Material("jelly", rho=1.0)), lambda info: False, False),
    "rho_20000": (lambda info: _base(Material("jelly", rho=20000.0)), lambda info: False, False),
    "dt_0.5x": (_dt_case(0.5), lambda info: True, False),
    "dt_1x": (_dt_case(1.0), lambda info: True, False),
    "dt_2x": (_dt_case(2.0), lambda info: False, False),
    "one_point": (lambda info: _base(x=np.array([[0.5, 0.5, 0.5]]), p_vol=(DX / 2) ** 3),
                  lambda info: False, False),
    "points_1e4": (_points(22), lambda info: True, False),
    "points_1e6": (_points(100, n_grid=64), lambda info: True, True),
    "coincident": (_coincident, lambda info: False, False),
    "outside_domain": (_outside, lambda info: False, False),
    "thin_sheet": (_thin, lambda info: False, False),
    "f32": (_precision("f32"), lambda info: "f32" in info.capabilities.precisions, False),
    "f64": (_precision("f64"), lambda info: "f64" in info.capabilities.precisions, False),
}


def _cases():
    found = installed_engines()
    if not found:
        yield pytest.param(None, None, id="no-engine",
                           marks=pytest.mark.skip(reason="no engine plugin installed"))
        return
    for name, info in found.items():
        reason = info.unavailable_reason()
        needs = "jelly" in info.capabilities.materials and "ground" in info.capabilities.boundaries
        for case, (_, _, slow) in CASES.items():
            marks = [pytest.mark.slow] if slow else []
            if reason:
                marks.append(pytest.mark.skip(reason=f"engine unavailable: {reason}"))
            elif not needs:
                marks.append(pytest.mark.skip(reason="missing capability: material 'jelly' or boundary 'ground'"))
            elif case.startswith("dt_") and "dt" not in {o.name for o in info.options}:
                marks.append(pytest.mark.skip(reason="the engine declares no option 'dt'"))
            yield pytest.param(name, case, id=f"{name}-{case}", marks=marks)


def _plausible(setup: SimSetup, xs: np.ndarray) -> str | None:
    t = FRAME_DT * (len(xs) - 1)
    reach = 0.5 * GRAVITY * t ** 2 + float(np.abs(setup.v).max(initial=0.0)) * t + 2 * setup.dx
    moved = float(np.linalg.norm(xs[-1] - xs[0], axis=1).max())
    if moved > reach:
        return f"a point moved {moved:.3g} m in {t:.2f} s; free fall allows {reach:.3g} m"
    below = float(GROUND_H - xs[:, :, 2].min())
    if below > setup.dx:
        return f"a point went {below:.3g} m below the ground"
    return None


@pytest.mark.parametrize("engine_name,case", list(_cases()))
def test_extreme(engine_name, case, request):
    info = installed_engines()[engine_name]
    build, must_be_ok, _ = CASES[case]
    setup = None
    try:
        setup = build(info)
        xs, stats = simulate(info, setup, N_FRAMES)
    except (SceneError, EngineError, EngineDivergence) as e:
        outcome = f"clear error {type(e).__name__}: {e}"
        record(request.node, outcome)
        refusal = isinstance(e, (SceneError, EngineError)) and case in ("f32", "f64")
        assert refusal or not must_be_ok(info), \
            f"{case} is within {engine_name}'s declared range, but: {outcome}"
        if case == "outside_domain":
            assert isinstance(e, (SceneError, EngineDivergence))
        return
    problem = _plausible(setup, xs)
    n_sub = stats.engine.get("n_substeps", "?")
    record(request.node, f"ok: {len(setup.x)} points, {N_FRAMES} frames, n_substeps {n_sub}, "
                         f"build {stats.build_s:.2f} s, frames {sum(stats.frame_s):.2f} s"
                         + (f"; IMPLAUSIBLE: {problem}" if problem else ""))
    assert problem is None, problem
    assert case != "outside_domain", "points outside the domain were accepted and not reported"
