"""Issue 53 item 2: a rigid body rests on its lowest points, not in the ground (``gasp_core.mpm.rigid``:
``lift_setup``, ``settle_projection``, ``support_scale``; ``docs/rigid.md`` "Resting on its lowest points").

Known answers:

* the conformance scene's hardwood slab (``rigid_rest``, 6 x 6 x 2 cells of fill, n_grid 24) put with the bottom of
  its points' volumes ``depth`` cells inside the ground rests with them within 0.1 dx of it (the issue's limit) and
  gains no upward speed beyond ``MAX_RISE`` (a body lifted out is not thrown). Before issue 53's fix the slab put
  0.2 dx in stayed 0.2 dx in (the particle contact's start clearance became its skin: 0.05 dx), and put 0.6 dx in
  it was thrown up at 2.6 m/s in its first frame (both engines);
* a wider slab (12 x 12 x 2 cells, 576 points on its face) standing on three single points that hang 0.5 dx under
  its bottom (surface rows: no skin) rests on them within 0.1 dx of the ground. Before the fix its stiffness was set
  for its face (``k = M / (N dt^2)``): three points held its weight ``g dt^2 N / 3`` deep (-0.252 dx on both
  engines). It must rest still on them and be held by its contact, less than half the projection's slop deep:
  with ``support_scale`` left out (``RIGID_LEVER`` infinite) the projection holds it at the slop, 0.05 dx; with the
  approach removed at the contact centre rather than through the mass centre it rocked 0.14-0.39 deg.
"""
import numpy as np
import pytest

from gasp_core.seam import build_engine, engines, get_engine
from gasp_core.testing import scenes_pairs as sp

INSTALLED = engines()
ENGINES = [pytest.param(e, marks=pytest.mark.skipif(e not in INSTALLED or INSTALLED[e].unavailable_reason() is not None,
                                                    reason=f"{e} not installed")) for e in ("taichi_mpm", "warp_mpm")]
#: The largest upward speed of the centroid a body set down at rest may show, m/s: a fall of 1/300 s (the frame)
#: under gravity is 0.033 m/s; the slab thrown out of 0.6 dx rose at 2.6 m/s, out of 0.05 dx of its whole face at
#: 0.36 m/s.
MAX_RISE = 0.05
GAP_TOL = 0.1
#: The turn (degrees) a body at rest may show over its last 0.5 s (the slab on three points: 3e-5 deg on warp_mpm).
STILL_DEG = 0.01


def run(engine: str, s, frames: int):
    """Per frame (frame 0 the start) the points' positions and the centroid's vertical speed (m/s)."""
    e = build_engine(get_engine(engine), s)
    xs, vz = [np.asarray(s.x, np.float64)], [0.0]
    for _ in range(frames):
        e.step_frame()
        xs.append(e.positions().astype(np.float64))
        vz.append(float(e.velocities()[:, 2].mean()))
    return xs, np.array(vz)


@pytest.mark.parametrize("engine", ENGINES)
@pytest.mark.parametrize("depth", [0.2, 0.6])
def test_rigid_slab_put_in_the_ground_is_lifted_out(engine, depth):
    s = sp._build_rest(None)
    s.x = np.asarray(s.x, np.float64) - [0.0, 0.0, (sp.REST_DROP + depth) * sp.DX]
    s.frame_dt = 1.0 / 300.0
    h = float(np.cbrt(np.median(s.p_vol)))
    xs, vz = run(engine, s, 6)
    low = [(np.sort(x[:, 2])[:len(x) // 100].mean() - 0.5 * h - sp.GROUND) / sp.DX for x in xs[1:]]
    assert vz.max() < MAX_RISE, f"{engine}: put {depth} dx in, it rises at {vz.max():.3f} m/s"
    assert max(abs(v) for v in low) < GAP_TOL, f"{engine}: put {depth} dx in, its bottom at {np.round(low, 3)} dx"


def _slab_on_three_points():
    """The wide hardwood slab (12 x 12 x 2 cells of fill) on three single points hanging 0.5 dx under its bottom,
    just over the ground (the rendered rows: the body's own surface), and their height."""
    from gasp_core.testing.helpers import box_points, make_setup
    from gasp_core.seam.setup import Boundary, Material
    side = (12 * sp.DX, 12 * sp.DX, 2 * sp.DX)
    lo = np.array([sp.SIDE / 2 - side[0] / 2 + 0.3 * sp.DX, sp.SIDE / 2 - side[1] / 2 + 0.2 * sp.DX, 0.0])
    x, p_vol = box_points(lo, lo + np.array(side), sp.DX / 2)
    bottom = x[:, 2].min()
    # three points 0.5 dx under the bottom row (a capture's hanging Gaussians), around the centre
    hang = np.array([[lo[0] + 2 * sp.DX, lo[1] + 2 * sp.DX, 0.0], [lo[0] + 10 * sp.DX, lo[1] + 3 * sp.DX, 0.0],
                     [lo[0] + 5 * sp.DX, lo[1] + 10 * sp.DX, 0.0]]) + [0.0, 0.0, bottom - 0.5 * sp.DX]
    x = np.concatenate([hang, x])
    p_vol = np.concatenate([np.full(3, np.atleast_1d(p_vol)[0]), np.broadcast_to(p_vol, len(x) - 3)])
    x[:, 2] += sp.GROUND + 0.02 * sp.DX - hang[0, 2]   # the hanging points just over the ground
    s = make_setup(x, p_vol, Material("jelly", model="rigid", **sp.SUBSTANCES["wood"]), lo=np.zeros(3),
                   hi=np.full(3, sp.SIDE), n_grid=sp.N_GRID, frame_dt=1.0 / 30.0,
                   boundaries=[Boundary("ground", height=sp.GROUND, friction=0.5)])
    s.n_render = 3   # the hanging points are the body's own surface (no skin), the rest its fill
    return s, hang[0, 2]


@pytest.mark.parametrize("engine", ENGINES)
def test_rigid_slab_rests_on_three_hanging_points(engine):
    s, _ = _slab_on_three_points()
    xs, vz = run(engine, s, 30)
    low = np.array([x[:3, 2].min() - sp.GROUND for x in xs[1:]]) / sp.DX
    assert abs(low[-1]) < GAP_TOL, f"{engine}: its lowest points rest {low[-1]:+.3f} dx from the ground"
    assert np.ptp(low[-15:]) < 0.01, f"{engine}: its lowest points move {np.ptp(low[-15:]):.4f} dx in the last 0.5 s"
    # still on them over the last 0.5 s (the approach removed at the contact centre, not through the mass centre,
    # rocked it 0.14-0.39 deg)
    turn = sp._turn_deg(xs[15], xs[-1])
    assert turn < STILL_DEG, f"{engine}: it turns {turn:.4f} deg over the last 0.5 s on its three points"
    # its contact, not the projection, carries its weight (and gives the friction its budget): it rests less than half
    # the slop deep (support_scale left out, RIGID_LEVER infinite: at the slop, 0.05 dx, held by the projection; the
    # donut so held rocked 1-2 deg for 1.3 s)
    from gasp_core.mpm.rigid import RIGID_SLOP
    assert low[-1] > -0.5 * RIGID_SLOP, f"{engine}: it rests {low[-1]:+.4f} dx deep, held by the projection"


def test_settle_projection_reference():
    """The NumPy reference (``gasp_core.mpm.rigid_friction.settle_projection``): moved out by ``depth - slop`` along the
    normal, its approach removed and no upward speed gained, its slip braked by at most ``mu`` times that impulse;
    nothing within the slop or when it recedes."""
    from gasp_core.mpm.rigid_friction import settle_projection
    n, c, I = np.array([0.0, 0.0, 1.0]), np.zeros(3), np.eye(3) * 0.1
    shift, V, w = settle_projection(0.003, n, [0.01, 0.0, -0.05], c, [0.2, 0.0, -0.5], np.zeros(3), I, 2.0, 0.5, 0.001)
    assert np.allclose(shift, [0.0, 0.0, 0.002])
    assert V[2] == pytest.approx(0.0) and 0.0 <= V[0] < 0.2    # the approach gone, no rise; the slip braked
    assert abs(0.2 - V[0]) <= 0.5 * 0.5 + 1e-12               # at most mu P / M of it (P = 0.5 m/s x 2 kg)
    shift, V2, _ = settle_projection(0.0005, n, [0.01, 0.0, -0.05], c, [0.2, 0.0, -0.5], np.zeros(3), I, 2.0, 0.5,
                                     0.001)
    assert not shift.any() and np.allclose(V2, [0.2, 0.0, -0.5])
    shift, V3, _ = settle_projection(0.003, n, [0.01, 0.0, -0.05], c, [0.2, 0.0, 0.3], np.zeros(3), I, 2.0, 0.5, 0.001)
    assert np.allclose(shift, [0.0, 0.0, 0.002]) and np.allclose(V3, [0.2, 0.0, 0.3])


@pytest.mark.parametrize("engine", ENGINES)
def test_rigid_slab_does_not_rest_on_three_faint_points(engine):
    """The same slab whose three hanging points only faint Gaussians move (``SimSetup.faint``: a capture's floaters,
    as the wooden donut's three of opacity 0.002-0.004 hanging 9 mm under it, which tipped it 1.46 deg): it falls the
    0.25 dx onto its face and rests flat there within 0.1 dx, the faint points under the ground. Taking them as
    support (``faint`` left out: the test above) rests it on them, its face 0.25 dx up, and fails here."""
    s, hang_z = _slab_on_three_points()
    s.faint = np.r_[np.ones(3, bool), np.zeros(len(s.x) - 3, bool)]
    h = float(np.cbrt(np.median(s.p_vol[3:])))
    xs, _ = run(engine, s, 30)
    face = np.array([(np.sort(x[3:, 2])[:len(x) // 20].mean() - 0.5 * h - sp.GROUND) for x in xs[1:]]) / sp.DX
    assert abs(face[-1]) < GAP_TOL, f"{engine}: its face rests {face[-1]:+.3f} dx from the ground"
    # they hang 0.5 dx under the bottom row of points, 0.25 dx under the face (the points' volumes' bottom)
    assert xs[-1][:3, 2].max() < sp.GROUND - 0.15 * sp.DX, "the faint points must hang under the ground"
    assert sp._turn_deg(xs[0][3:], xs[-1][3:]) < 0.1, f"{engine}: it tips onto its faint points"


def test_the_wooden_donuts_floaters_are_faint_rows():
    """``SimSetup.faint`` of ``examples/donut_wood.toml`` marks the rows of its Gaussians under ``min_opacity`` (0.1),
    its three lowest among them (opacity 0.002-0.004, up to 9 mm under the bottom of the opaque ones, 1.4 cells),
    and no row of an opaque Gaussian."""
    from pathlib import Path
    from scipy.special import expit
    from gasp_core.prepare.scene import prepare_scene
    from gasp_core.scene.spec import load_scene
    prep = prepare_scene(load_scene(Path(__file__).resolve().parents[1] / "examples" / "donut_wood.toml"))
    s, o = prep.setup, prep.objects[0]
    opaque = expit(o.simulated_rows(o.gaussians.opacities).astype(np.float64)) >= o.spec.min_opacity
    assert s.faint is not None and not s.faint[s.n_render:].any()
    per = s.n_render // len(opaque)   # one point a Gaussian (its centre) or three (its triangle)
    assert per in (1, 3) and np.array_equal(s.faint[:s.n_render], np.repeat(~opaque, per))
    z = s.x[:s.n_render, 2]
    assert s.faint[np.argsort(z)[:3]].all(), "the three lowest points are the floaters'"
    assert (z[~s.faint[:s.n_render]].min() - z.min()) / s.dx > 1.0, "the floaters hang over a cell under the body"
