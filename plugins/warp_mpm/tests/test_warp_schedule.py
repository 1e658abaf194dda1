"""The engine option ``schedule`` (issue 65; ``gasp_warp_mpm.schedule``): the gpu schedule, run here on CPU, agrees
with the cpu schedule, repeats bit for bit, launches nothing with ``dim=1`` over points or nodes, and its launches and
host syncs per substep are what the design says.

Small scenes (n_grid 16, about 1-2 thousand points, 2 frames), so the file runs in well under a minute on two cores
once the kernels are compiled.
"""
import numpy as np
import pytest

wp = pytest.importorskip("warp")

from gasp_core.seam import Boundary, build_engine, Material, SceneError, SimSetup  # noqa: E402
from gasp_core.seam.plugins import engines  # noqa: E402
from gasp_core.testing.helpers import box_points  # noqa: E402

from gasp_warp_mpm.schedule import BLOCK, resolve  # noqa: E402
from gasp_warp_mpm.schedule import gpu as G  # noqa: E402
from gasp_warp_mpm.schedule.ordered import CpuViscosity, build_ordered_viscosity  # noqa: E402

N_GRID = 16
DX = 1.0 / N_GRID
FRAMES = 2
#: Agreement asked of the two schedules after FRAMES frames, in cells (dx): they differ in the order of the dot
#: products' and the balance's sums only (measured: see the report of test_schedules_agree).
TOL_DX = 1e-3

#: Kernels a gpu-schedule substep may launch with dim=1: scalar bookkeeping (the CG's step lengths and
#: condition, the last fold of at most BLOCK block partials, the time table's tick) and per-body or per-support work
#: (launched over bodies or supports: one thread in a one-body scene).
DIM1_ALLOWED = {"step_alpha", "cg_begin", "cg_beta", "fold_final", "tick", "rigid_update", "rigid_lift",
                "contact_shift", "fix_supports", "fix_clear",
                "islands",   # round 81: the rigid pairs' islands, integer work over the listed pairs (rigid_pairs.py)
                "box_reset", "held_box"}   # round 64/65's box: 12 int32 (grid_box.py), in viscous scenes since round 65


def viscous_scene(schedule):
    """The README donut's configuration, small: a viscous jelly (viscosity 4 Pa s) dropped on a ground with friction
    (the particle contact and its balance)."""
    x, p_vol = box_points((0.35, 0.35, 0.22), (0.65, 0.65, 0.45), 1.0 / 40)
    return SimSetup(x=x, v=np.zeros_like(x), p_vol=p_vol, body_id=0,
                    materials=[Material("jelly", E=2e4, nu=0.3, rho=300.0, viscosity=4.0)],
                    gravity=np.array([0.0, 0.0, -9.81]), domain_lo=np.zeros(3), domain_hi=np.ones(3), n_grid=N_GRID,
                    boundaries=[Boundary("ground", height=0.2, friction=0.5)], frame_dt=1.0 / 30,
                    options={"schedule": schedule})


def contact_scene(schedule):
    """Two jelly bodies (no viscosity) sliding and falling onto a ground with friction inside walls: two bodies, the
    grounds and the walls' faces as supports (several balance rows)."""
    xa, p_vol = box_points((0.25, 0.3, 0.21), (0.45, 0.5, 0.36), 1.0 / 40)
    xb, _ = box_points((0.55, 0.45, 0.22), (0.75, 0.65, 0.37), 1.0 / 40)
    x = np.concatenate([xa, xb])
    v = np.concatenate([np.tile([1.0, 0.0, -0.5], (len(xa), 1)), np.tile([0.8, -0.3, 0.0], (len(xb), 1))])
    body = np.concatenate([np.zeros(len(xa), int), np.ones(len(xb), int)])
    return SimSetup(x=x, v=v, p_vol=p_vol, body_id=body,
                    materials=[Material("jelly", E=3e4, nu=0.3, rho=500.0), Material("jelly", E=5e4, nu=0.3, rho=800.0)],
                    gravity=np.array([0.0, 0.0, -9.81]), domain_lo=np.zeros(3), domain_hi=np.ones(3), n_grid=N_GRID,
                    boundaries=[Boundary("ground", height=0.2, friction=0.6), Boundary("walls", friction=0.3)],
                    frame_dt=1.0 / 30, options={"schedule": schedule})


SCENES = {"viscous": viscous_scene, "contact": contact_scene}


def build(setup):
    return build_engine(engines()["warp_mpm"], setup)


def frames(scene, schedule, n=FRAMES):
    e = build(SCENES[scene](schedule))
    try:
        out = []
        for _ in range(n):
            e.step_frame()
            out.append(e.positions().copy())
        return out
    finally:
        e.close()


@pytest.fixture(scope="module")
def runs():
    """Frames of each scene on each schedule, the gpu schedule twice."""
    return {(scene, run): frames(scene, run.rstrip("2")) for scene in SCENES for run in ("cpu", "gpu", "gpu2")}


def test_option_resolves_and_is_checked():
    assert resolve("auto", True) == "gpu" and resolve("auto", False) == "cpu"
    assert resolve("gpu", False) == "gpu" and resolve("cpu", True) == "cpu"
    e = build(viscous_scene("auto"))
    try:
        assert e.schedule == "cpu" and type(e.visc) is CpuViscosity   # auto on CPU: today's path
    finally:
        e.close()
    with pytest.raises(SceneError, match="schedule"):
        build(viscous_scene("fast"))


@pytest.mark.parametrize("scene", list(SCENES))
def test_schedules_agree(runs, scene):
    cpu, gpu = runs[(scene, "cpu")], runs[(scene, "gpu")]
    diff = max(float(np.abs(a.astype(np.float64) - b).max()) for a, b in zip(cpu, gpu)) / DX
    print(f"{scene}: max |x_gpu - x_cpu| over {FRAMES} frames = {diff:.3g} dx")
    assert diff < TOL_DX


@pytest.mark.parametrize("scene", list(SCENES))
def test_gpu_schedule_repeats_bit_for_bit(runs, scene):
    for a, b in zip(runs[(scene, "gpu")], runs[(scene, "gpu2")]):
        assert a.tobytes() == b.tobytes()


class Recorder:
    """Every kernel launch (``wp.launch``, a recorded ``wp.Launch``'s ``launch()``), scan and ``.numpy()`` while
    active: ``launches`` as (kernel key, dim) in order, ``syncs`` the ``.numpy()`` calls."""

    def __init__(self, monkeypatch):
        self.launches, self.syncs, self._inside = [], 0, False
        launch, cmd_launch, numpy, scan = wp.launch, wp.Launch.launch, wp.array.numpy, wp.utils.array_scan
        rec = self

        def launch_(kernel, dim=None, *a, **kw):
            if not kw.get("record_cmd"):
                d = dim if isinstance(dim, int) else int(np.prod(dim))
                rec.launches.append((kernel.key, d))
            rec._inside = True
            try:
                return launch(kernel, dim, *a, **kw)
            finally:
                rec._inside = False

        def cmd_launch_(self_, *a, **kw):
            if not rec._inside:
                rec.launches.append((self_.kernel.key, int(self_.bounds.size)))
            return cmd_launch(self_, *a, **kw)

        def numpy_(self_):
            rec.syncs += 1
            return numpy(self_)

        def scan_(a, b, inclusive=True):
            rec.launches.append(("array_scan", a.shape[0]))
            return scan(a, b, inclusive)

        monkeypatch.setattr(wp, "launch", launch_)
        monkeypatch.setattr(wp.Launch, "launch", cmd_launch_)
        monkeypatch.setattr(wp.array, "numpy", numpy_)
        monkeypatch.setattr(wp.utils, "array_scan", scan_)


def one_substep(engine, monkeypatch):
    """The launches and syncs of the engine's second substep (the first warms the state), as a Recorder."""
    engine.flags.zero_()
    with monkeypatch.context() as m:
        m.setattr(engine, "n_substeps", 1)
        engine._substeps()
        rec = Recorder(m)
        engine._substeps()
    return rec


def dim1_outside_allow_list(rec) -> list:
    return sorted({name(k) for k, d in rec.launches if d == 1 and name(k) not in DIM1_ALLOWED})


def name(key: str) -> str:
    """A kernel's name from its key (``build_lists__locals__list_flags`` -> ``list_flags``)."""
    return key.rpartition("__")[2]


@pytest.fixture
def gpu_engine():
    e = build(viscous_scene("gpu"))
    yield e
    e.close()


def test_no_dim1_launch_over_points_or_nodes(gpu_engine, monkeypatch):
    rec = one_substep(gpu_engine, monkeypatch)
    assert rec.launches and dim1_outside_allow_list(rec) == []
    # the big launches are over nodes or points, or blocks of them, never one thread
    assert {name(k) for k, _ in rec.launches} >= {"list_flags", "array_scan", "list_scatter", "dot_blocks", "moment_blocks",
                                             "friction_blocks", "fix_nodes", "p2g", "grid_update", "g2p"}


def test_the_check_catches_todays_lists_and_dot(gpu_engine, monkeypatch):
    """The gpu schedule patched to build its lists with today's one-thread ``lists`` kernel, or to sum with today's
    one-thread ``dot``: the check names them."""
    e, visc = gpu_engine, gpu_engine.visc
    k = build_ordered_viscosity(visc.Ft)   # the cpu schedule's one-thread lists and dot (schedule/ordered.py)

    with monkeypatch.context() as m:
        orig_solve = G.GpuViscosity.solve

        def broken_solve(self, capturing):
            wp.launch(k.lists, dim=1, device=self.e.device, inputs=[self.e.grid_mv, self.u, self.valid, self.nodes,
                                                                     self.cells, self.counts, self.e.n_grid,
                                                                     self.label, int(self.same_label), self.box])
            return orig_solve(self, capturing)
        m.setattr(G.GpuViscosity, "solve", broken_solve)
        rec = one_substep(e, monkeypatch)
    assert dim1_outside_allow_list(rec) == ["lists"]

    with monkeypatch.context() as m:
        def broken_dot(self, a, b, slot):
            wp.launch(k.dot, dim=1, device=self.e.device, inputs=[a, b, self.nodes, self.counts, self.scal, slot])
        m.setattr(G.GpuViscosity, "_dot", broken_dot)
        rec = one_substep(e, monkeypatch)
    assert dim1_outside_allow_list(rec) == ["dot"]

    with monkeypatch.context() as m:   # the whole of today's viscous step
        m.setattr(G.GpuViscosity, "solve", CpuViscosity.solve)
        m.setattr(visc, "o", k, raising=False)
        rec = one_substep(e, monkeypatch)
    assert dim1_outside_allow_list(rec) == ["begin", "dot", "lists", "mom_sum", "step_beta"]


def counts(scene, schedule, monkeypatch):
    e = build(SCENES[scene](schedule))
    try:
        rec = one_substep(e, monkeypatch)
        iters = None
        if e.visc is not None and schedule == "gpu":
            iters = int(e.visc.it.numpy()[0])
        return rec, iters
    finally:
        e.close()


def test_launches_and_syncs_per_substep(monkeypatch):
    """The viscous scene (the donut's configuration): per substep, the cpu schedule launches 14 kernels plus 8 per CG
    iteration and syncs 2 plus one per iteration; the gpu schedule launches 24 plus 10 per iteration run (the
    iterations run in fours, the condition read once per four: the syncs) and, at n_grid 16, each dot product is
    two launches (16 blocks of 256 nodes, then their fold), and so is round 49's momentum sum (``mom_blocks``,
    ``fold_final``; on the cpu schedule one-thread ``mom_sum``; one pass a body, one body here: round 50's node
    labels are all 0, nothing launched for them). Round 65: both 4 more, the grid update's box and the viscous step's
    (each ``box_reset`` on one thread and ``field_box`` over the points; ``grid_box.py``: a viscous scene's grid update
    over the box; ``viscosity.ImplicitViscosity.box``: its lists and labels over the box). Round 97: both 1 more,
    the ground's hold on the particle contact's points (``box_hold`` over the points, ``gasp_core.mpm.box_hold``)."""
    rec, _ = counts("viscous", "cpu", monkeypatch)
    n_it = sum(1 for k, _ in rec.launches if name(k) == "step_alpha")
    print(f"cpu schedule: {len(rec.launches)} launches, {rec.syncs} syncs, {n_it} CG iterations;",
          dict(zip(*np.unique([name(k) for k, _ in rec.launches], return_counts=True))))
    assert n_it >= 1
    assert len(rec.launches) == 19 + 8 * n_it
    assert rec.syncs == 2 + n_it
    # shift, lists, 1 + 2 n dots, begin, 2 n steps, mom_sum, fix, two box_reset
    assert sum(1 for _, d in rec.launches if d == 1) == 8 + 4 * n_it
    # of which over nodes or list entries: lists, dot, mom_sum, contact_fix (begin and step_beta: scalars)
    assert dim1_outside_allow_list(rec) == ["begin", "contact_fix", "dot", "lists", "mom_sum", "step_beta"]
    rec, eff = counts("viscous", "gpu", monkeypatch)
    n_run = sum(1 for k, _ in rec.launches if name(k) == "step_alpha")
    print(f"gpu schedule: {len(rec.launches)} launches, {rec.syncs} syncs, {n_run} CG iterations run ({eff} "
          "effective);", dict(zip(*np.unique([name(k) for k, _ in rec.launches], return_counts=True))))
    assert n_run % G.CHECK_EVERY == 0 and n_run - G.CHECK_EVERY < eff <= n_run
    assert len(rec.launches) == 29 + 10 * n_run
    assert rec.syncs == n_run // G.CHECK_EVERY + 1
    # one thread: per body or support (contact_shift, fix_supports, fix_clear: one body, one support here), cg_begin,
    # fold_final, the momentum sum's fold_final, two box_reset; per iteration two fold_final, step_alpha, cg_beta
    assert sum(1 for _, d in rec.launches if d == 1) == 8 + 4 * n_run
    assert dim1_outside_allow_list(rec) == []


def test_fold_chain_sizes():
    assert G.fold_chain(16 ** 3) == [16]
    assert G.fold_chain(64 ** 3) == [1024, 4]
    assert G.fold_chain(1) == [1] and BLOCK == 256
