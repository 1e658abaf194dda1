"""Several sands of field A, each with its own ``friction_angle`` (issue 67 item 4, "the pair's friction";
docs/contact.md "Round 43: several sands' angles in field A").

In a ``"mixed"`` scene field A is the flowing bodies. Round 42 made field B's friction per node but left A one
coefficient, ``tan`` of its sands' largest angle, so a 20 deg sand beside a 40 deg one slid at the 40 deg sand's pair.
Now both grid engines build A's coefficient per node too (``gasp_core.mpm.fields.a_node_friction``): A's points
scatter ``w_ip m_p tan(phi_p)`` to one more node channel, and a contact node's Coulomb limit is
``combine_friction(tan_A(node), mu_B)``, ``tan_A`` the mass-weighted mean there, ``mu_B`` B's per node (round 42),
or its one coefficient, or ``tan_A`` itself where B's bodies name none (round 41's rule: the pair is the sand's own).
A scene whose field A brings one angle keeps round 42's path, bit-identical (sha1 of the trajectories,
docs/contact.md).

The engine check: :func:`two_sand_setup`, ``sand_ball.two_slab_setup``'s two 4.5 cm slabs side by side with the same
``friction`` (or none), a sand block of its own angle thrown along each at 1.2 and 1.6 m/s; each block's Coulomb
ratio (``sand_ball.coulomb_ratio``, throw to frame 3) within ``RATIO_TOL`` 2.5 % of its own pair. Family: both
engines, n_grid 32 and 48, angles (20, 40) on slabs of 0.6 and (35, 25) on slabs that name none, jelly and rigid
slabs; warp_mpm at n_grid 32, (20, 40), 1.2 m/s in the default tier, the rest slow. **Catches:** the old rule (one
``tan``, the largest angle: ``a_node_friction`` None) reads the 20 deg block about +50 % high; a per-node pair 5 %
off (A's ``tan(phi)`` scaled by 1.05^2 or 0.95^2, slabs of 0.6) fails both blocks the right way.

The hold check (rigid slabs, round 43's pair table ``hold_pairs``): one point of each block 5 mm inside its slab's top
moving at (1, 0, -0.1) m/s leaves each engine's hold at ``v_x = 1 - 0.1 pair`` for its own sand's pair (warp_mpm's
kernel, :func:`hold_slips`; taichi_mpm's ``hold_rigid_point`` in a kernel of its own, :func:`taichi_hold_slips`);
**catch:** the old per-body table (each slab's row's coefficient, the largest angle's) holds the 20 deg point at the
40 deg sand's pair.
"""
from __future__ import annotations

import dataclasses
import math

import pytest

from gasp_core.mpm import fields as F
from gasp_core.testing import sand_ball as S
from gasp_core.testing.scenes_flow_pairs import RATIO_FRAMES, RATIO_SPEEDS, RATIO_TOL

pytestmark = pytest.mark.filterwarnings("ignore:engine .* share one grid velocity field")


def two_sand_setup(v0: float, angles, slab_mu: float | None, options: dict | None = None, model: str = ""):
    """``sand_ball.two_slab_setup`` with both slabs' ``friction`` ``slab_mu`` (None: unnamed) and the blocks (bodies
    0 and 2) of friction angles ``angles`` (deg)."""
    setup = S.two_slab_setup(v0, (0.5, 0.5), options, model=model)
    mats = list(setup.materials)
    for b, phi in zip((0, 2), angles):
        mats[b] = dataclasses.replace(mats[b], friction_angle=float(phi))
    for b in (1, 3):
        mats[b] = dataclasses.replace(mats[b], friction=slab_mu)
    setup.materials = mats
    return setup


def own_pair(phi: float, slab_mu: float | None) -> float:
    """A block's pair: ``sqrt(tan(phi) mu)``, or ``tan(phi)`` on a slab that names none."""
    t = math.tan(math.radians(phi))
    return t if slab_mu is None else math.sqrt(t * slab_mu)


def test_a_node_friction_only_where_field_a_brings_several_angles():
    one = S.two_slab_setup(1.2)
    assert F.a_node_friction(one) is None and F.hold_pairs(one) is None   # one angle: round 42's path
    two = two_sand_setup(1.2, (20.0, 40.0), 0.6)
    mu_a, lo, hi, mu_b = F.a_node_friction(two)
    t20, t40 = (math.tan(math.radians(a)) for a in (20.0, 40.0))
    assert list(mu_a) == pytest.approx([t20, 0.0, t40, 0.0], rel=1e-15) and (lo, hi, mu_b) == (t20, t40, 0.6)
    assert F.node_friction(two) is None                                    # B brings one: its scalar
    unnamed = two_sand_setup(1.2, (35.0, 25.0), None)
    assert F.a_node_friction(unnamed)[3] == -1.0                           # B names none: the pair is A's own
    pairs = F.hold_pairs(unnamed)
    assert pairs[0, 1] == pytest.approx(math.tan(math.radians(35.0))) and pairs[2, 3] == pairs[2, 1]
    assert F.hold_pairs(two)[0, 1] == pytest.approx(math.sqrt(t20 * 0.6), rel=1e-15)
    same = two_sand_setup(1.2, (30.0, 30.0), 0.6)
    assert F.a_node_friction(same) is None
    one_field = two_sand_setup(1.2, (20.0, 40.0), 0.6, {"contact_fields": False})
    assert F.a_node_friction(one_field) is None


def run_two_sands(engine: str, n_grid: int, angles, slab_mu, monkeypatch, speeds=RATIO_SPEEDS,
                  model: str = "") -> dict:
    """Per speed, each block's ratio error against its own pair: ``{v0: (e0, e2)}``."""
    from gasp_core.seam.plugins import get_engine
    from gasp_core.testing.kit import run_trace
    pytest.importorskip({"warp_mpm": "gasp_warp_mpm", "taichi_mpm": "gasp_taichi_mpm"}[engine])
    info = get_engine(engine)
    monkeypatch.setattr(S, "N_GRID", n_grid)
    out = {}
    for v0 in speeds:
        setup = two_sand_setup(v0, angles, slab_mu, {"threads": 1}, model=model)
        tr = run_trace(info, setup, RATIO_FRAMES)
        out[v0] = tuple(S.coulomb_ratio(tr.v, setup, 0, RATIO_FRAMES, body=b) / own_pair(phi, slab_mu) - 1.0
                        for b, phi in ((0, angles[0]), (2, angles[1])))
    print(f"two sands {engine} n_grid {n_grid} {angles} slabs {slab_mu} {model or 'jelly'}: {out}")   # with -s
    return out


FAMILY = [(32, (20.0, 40.0), 0.6, ""), (48, (20.0, 40.0), 0.6, ""), (32, (35.0, 25.0), None, ""),
          (48, (35.0, 25.0), None, ""), (32, (20.0, 40.0), 0.6, "rigid"), (32, (35.0, 25.0), None, "rigid")]


def _fast(engine, n_grid, angles, model) -> bool:
    return engine == "warp_mpm" and n_grid == 32 and angles == (20.0, 40.0) and not model


def _family_params():
    for engine in ("warp_mpm", "taichi_mpm"):
        for n_grid, angles, mu, model in FAMILY:
            yield pytest.param(engine, n_grid, angles, mu, model,
                               id=f"{engine}-n{n_grid}-{angles[0]:g}-{angles[1]:g}-{mu}{model}",
                               marks=() if _fast(engine, n_grid, angles, model) else pytest.mark.slow)


@pytest.mark.parametrize("engine, n_grid, angles, slab_mu, model", list(_family_params()))
def test_each_sand_slides_with_its_own_angles_pair(engine, n_grid, angles, slab_mu, model, monkeypatch):
    fast = _fast(engine, n_grid, angles, model)
    out = run_two_sands(engine, n_grid, angles, slab_mu, monkeypatch,
                        speeds=RATIO_SPEEDS[:1] if fast else RATIO_SPEEDS, model=model)
    assert all(abs(e) <= RATIO_TOL for pair in out.values() for e in pair), out


def _patch(monkeypatch, fn) -> None:
    import gasp_warp_mpm.fields as wf
    monkeypatch.setattr(F, "a_node_friction", fn)
    monkeypatch.setattr(wf, "a_node_friction", fn)


def largest_rule(monkeypatch) -> None:
    """Round 42's rule: field A one ``tan``, its sands' largest angle (``a_node_friction`` None everywhere)."""
    _patch(monkeypatch, lambda setup: None)


def bias_a_friction(monkeypatch, factor: float) -> None:
    """A's per-node ``tan(phi)`` ``factor^2`` times the right one (on a named slab the pair ``factor`` times)."""
    real = F.a_node_friction

    def biased(setup):
        got = real(setup)
        if got is None:
            return None
        mu_a, lo, hi, mu_b = got
        return mu_a * factor ** 2, lo * factor ** 2, hi * factor ** 2, mu_b
    _patch(monkeypatch, biased)


@pytest.mark.parametrize("engine", ["warp_mpm", pytest.param("taichi_mpm", marks=pytest.mark.slow)])
def test_the_check_catches_the_largest_angle_rule(engine, monkeypatch):
    pytest.importorskip("gasp_warp_mpm")
    largest_rule(monkeypatch)
    out = run_two_sands(engine, 32, (20.0, 40.0), 0.6, monkeypatch, speeds=RATIO_SPEEDS[:1])
    assert all(e0 > RATIO_TOL and abs(e2) <= RATIO_TOL for e0, e2 in out.values()), out


@pytest.mark.slow
@pytest.mark.parametrize("factor", [0.95, 1.05])
@pytest.mark.parametrize("engine", ["warp_mpm", "taichi_mpm"])
def test_the_check_catches_a_per_node_friction_5pct_off(engine, factor, monkeypatch):
    pytest.importorskip("gasp_warp_mpm")
    bias_a_friction(monkeypatch, factor)
    out = run_two_sands(engine, 32, (20.0, 40.0), 0.6, monkeypatch)
    assert all((e < -RATIO_TOL) if factor < 1 else (e > RATIO_TOL) for pair in out.values() for e in pair), out


def hold_slips(pairs_on: bool = True) -> list[float]:
    """warp_mpm's rigid hold (``rigid_hold.build_rigid_hold``, CPU, float64) on one point of each sand block put
    5 mm inside its rigid slab's top face, moving at (1, 0, -0.1) m/s, the slabs at rest: each point's ``v_x`` after
    the hold. The top face's normal is +z, so Coulomb leaves ``v_x = 1 - 0.1 mu`` with ``mu`` the point's pair
    (``hold_pairs``; ``pairs_on`` False: each slab's row's, ``pair_frictions``, the largest angle's)."""
    import numpy as np
    import warp as wp
    from gasp_core.mpm.contact import flowing_bodies
    from gasp_core.mpm.rigid import body_frames, rigid_mask
    from gasp_core.mpm.rigid_hold import hold_setup
    from gasp_warp_mpm.rigid import mat33d, vec3d
    from gasp_warp_mpm.rigid_hold import build_rigid_hold
    setup = two_sand_setup(1.2, (20.0, 40.0), 0.6, model="rigid")
    flows = flowing_bodies(setup, "mixed")
    (row, sdf, grad, meta), pairs = hold_setup(setup, S.DX, flows)
    rigid = rigid_mask(setup.materials)
    centre = body_frames(setup.x, setup.p_mass, np.asarray(setup.body_id), rigid)[0]
    h = S.COULOMB_SLAB_H
    x = np.array([[0.1, -0.08, h - 0.005], [0.1, 0.08, h - 0.005]])
    v = np.array([[1.0, 0.0, -0.1]] * 2)
    d, f8, nb = "cpu", wp.float64, len(setup.materials)
    arr = lambda a, t: wp.array(np.asarray(a), dtype=t, device=d)   # noqa: E731
    xs, vs = arr(x, wp.vec3d), arr(v, wp.vec3d)
    wp.launch(build_rigid_hold(f8), dim=2, device=d, inputs=[
        xs, vs, arr([1e-3, 1e-3], f8), arr([0, 2], wp.int32), arr(flows.astype(np.int32), wp.int32),
        arr(row.astype(np.int32), wp.int32), arr(meta, f8), arr(sdf, f8), arr(grad, f8), arr(centre, vec3d),
        arr(np.tile(np.eye(3), (nb, 1, 1)), mat33d), arr(np.zeros((nb, 3)), vec3d), arr(np.zeros((nb, 3)), vec3d),
        arr(np.zeros((nb, 3)), vec3d), arr(np.zeros((nb, 3)), vec3d), nb,
        arr(pairs.ravel() if pairs_on else np.zeros(1), f8)])
    return [float(a) for a in vs.numpy()[:, 0]]


def taichi_hold_slips(pairs_on: bool = True) -> list[float]:
    """:func:`hold_slips`' two points through taichi_mpm's hold (``RigidHold.hold_rigid_point``, CPU, float64) of an
    engine built on the same scene, the slabs at rest at their start pose: each point's ``v_x`` after the hold
    (``pairs_on`` False: ``rh_pairs_on`` off before the kernel compiles, each slab's row's coefficient)."""
    import numpy as np
    import taichi as ti
    from gasp_taichi_mpm.engine import TaichiMPMEngine
    setup = two_sand_setup(1.2, (20.0, 40.0), 0.6, {"threads": 1, "precision": "float64"}, model="rigid")
    s = TaichiMPMEngine(setup).solver
    assert s.rh_pairs_on
    s.rh_pairs_on = pairs_on
    body = s.body.to_numpy()[:s.n_points[None]]   # the solver's own point order
    p0, p2 = int(np.flatnonzero(body == 0)[0]), int(np.flatnonzero(body == 2)[0])
    x, v = s.x.to_numpy(), s.v.to_numpy()
    h = S.COULOMB_SLAB_H
    x[p0], x[p2] = [0.1, -0.08, h - 0.005], [0.1, 0.08, h - 0.005]
    v[p0] = v[p2] = [1.0, 0.0, -0.1]
    s.x.from_numpy(x)
    s.v.from_numpy(v)

    @ti.kernel
    def hold():   # no arguments: the module's ``from __future__ import annotations`` hides taichi's types
        for k in range(2):
            s.hold_rigid_point(p0 if k == 0 else p2)

    hold()
    out = s.v.to_numpy()
    return [float(out[p0, 0]), float(out[p2, 0])]


#: Each engine's hold check: the two points' ``v_x`` after its rigid hold (``pairs_on`` False: the per-body table).
HOLD_SLIPS = {"warp_mpm": hold_slips, "taichi_mpm": taichi_hold_slips}


@pytest.mark.parametrize("engine", list(HOLD_SLIPS))
def test_a_rigid_slab_holds_each_sand_with_its_own_pair(engine):
    pytest.importorskip(f"gasp_{engine}")
    got = HOLD_SLIPS[engine]()
    want = [1.0 - 0.1 * own_pair(phi, 0.6) for phi in (20.0, 40.0)]
    assert got == pytest.approx(want, abs=2e-4), (got, want)


@pytest.mark.parametrize("engine", list(HOLD_SLIPS))
def test_the_hold_check_catches_the_largest_angle(engine):
    pytest.importorskip(f"gasp_{engine}")
    got = HOLD_SLIPS[engine](pairs_on=False)
    assert got[0] < 1.0 - 0.1 * own_pair(20.0, 0.6) - 2e-3, got   # held at the 40 deg sand's pair
