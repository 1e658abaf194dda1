"""The GPU schedule of taichi_mpm (issue 65, :mod:`gasp_taichi_mpm.schedule`), tested on ``ti.cpu``:

- its primitives: the compaction gives the lists of a serial walk in node order, entry for entry; the slice sums
  repeat bit for bit and equal a float64 sum;
- no ``ti.loop_config(serialize=True)`` and no ``block_dim=1`` is compiled into a substep of the GPU schedule, shown
  catching each of the two put back;
- its frames agree with the CPU schedule's on a family of scenes (viscous, contact with the balance, two bodies and
  walls, a sand column), and repeat bit for bit on one thread.
"""
import numpy as np
import pytest

from gasp_core.seam import Boundary, Material

ti = pytest.importorskip("taichi")

from test_taichi_mpm import block_setup, build  # noqa: E402

pytestmark = pytest.mark.filterwarnings("ignore:.*non-taichi function")   # the loop_config spy below


# ---------------------------------------------------------------- primitives
@ti.data_oriented
class _Flags:
    def __init__(self, flags):
        ng = flags.shape[0]
        self.f = ti.field(ti.i32, shape=flags.shape)
        self.f.from_numpy(flags.astype(np.int32))
        self.a = ti.Vector.field(3, ti.i32, shape=ng ** 3)
        self.b = ti.Vector.field(3, ti.i32, shape=7)   # a small capacity: entries past it are left out
        self.dropped = ti.field(ti.i32, shape=())
        from gasp_taichi_mpm.schedule.primitives import BoxCompaction
        self.comp = BoxCompaction(self, ng, (self.a, self.b))

    @ti.func
    def listed(self, I, q: ti.template()):
        return (self.f[I] >> q) & 1 == 1

    @ti.func
    def overflow(self, I, q: ti.template()):
        ti.atomic_add(self.dropped[None], 1)

    @ti.kernel
    def run(self, lo: ti.types.vector(3, ti.i32), ext: ti.types.vector(3, ti.i32)):
        self.comp.run(lo, ext)


def test_compaction_gives_the_serial_walk_in_node_order():
    ti.init(arch=ti.cpu, cpu_max_num_threads=2, offline_cache=False)
    rng = np.random.default_rng(7)
    flags = rng.integers(0, 4, size=(12, 12, 12))
    k = _Flags(flags)
    for lo, ext in (((0, 0, 0), (12, 12, 12)), ((2, 3, 1), (7, 5, 9)), ((4, 4, 4), (0, 3, 3))):
        k.dropped[None] = 0
        k.run(ti.Vector(lo), ti.Vector(ext))
        sub = flags[lo[0]:lo[0] + ext[0], lo[1]:lo[1] + ext[1], lo[2]:lo[2] + ext[2]]
        for q, out, cap in ((0, k.a, 12 ** 3), (1, k.b, 7)):
            want = np.argwhere((sub >> q) & 1 == 1) + np.array(lo)   # x-major: the order of a serial (i, j, k) walk
            assert k.comp.count[q] == len(want)
            got = out.to_numpy()[:min(len(want), cap)]
            np.testing.assert_array_equal(got, want[:cap])
        assert k.dropped[None] == max(0, len(np.argwhere((sub >> 1) & 1 == 1)) - 7)


@ti.data_oriented
class _Sums:
    def __init__(self, n, r):
        from gasp_taichi_mpm.schedule.primitives import SliceSums
        self.s = SliceSums(n, r)

    @ti.kernel
    def reduce(self, n: ti.i32):
        self.s.reduce(n)


@pytest.mark.parametrize("n", [1, 31, 32, 33, 1025, 40000])
def test_slice_sums_repeat_bit_for_bit_and_equal_the_sum(n):
    ti.init(arch=ti.cpu, cpu_max_num_threads=2, offline_cache=False)
    rng = np.random.default_rng(n)
    part = rng.normal(size=(40000, 3)) * 10.0 ** rng.integers(-6, 6, size=(40000, 1))
    k = _Sums(40000, 3)
    k.s.part.from_numpy(part)
    outs = []
    for _ in range(3):
        k.reduce(n)
        outs.append(k.s.out.to_numpy().copy())
    assert all(np.array_equal(outs[0], o) for o in outs[1:])   # bit for bit
    np.testing.assert_allclose(outs[0], part[:n].sum(0), rtol=1e-12, atol=1e-12 * np.abs(part[:n]).sum())


# ---------------------------------------------------------------- nothing serial in a GPU-schedule substep
def _dt(setup, frame_dt=0.01):
    import dataclasses
    return dataclasses.replace(setup, frame_dt=frame_dt)


def _viscous_contact_scene(schedule):
    return _dt(block_setup(n_grid=16, material=Material("jelly", E=1e4, nu=0.3, rho=1000.0, viscosity=2.0),
                           boundaries=[Boundary("ground", height=0.38, friction=0.5)], v=(0.3, 0.0, -0.5),
                           schedule=schedule, threads=1))


def _serial_loops_compiled(monkeypatch, break_it=None, scene=None, rigid=False):
    """The loop configs compiled while one frame of the GPU schedule runs: [(kernel, what)], what "serialize" or
    "block_dim=1". ``break_it(solver)`` puts a serial loop back before the first substep compiles."""
    seen = []
    real = ti.loop_config

    def spy(**kw):
        import taichi.lang.impl as impl
        name = getattr(impl.get_runtime().current_kernel, "func", None)
        name = getattr(name, "__name__", "?")
        if kw.get("serialize"):
            seen.append((name, "serialize"))
        if kw.get("block_dim") == 1:
            seen.append((name, "block_dim=1"))
        return real(**kw)

    monkeypatch.setattr(ti, "loop_config", spy)
    e = build(scene or _viscous_contact_scene("gpu"))
    assert e.stats()["schedule"] == "gpu"
    assert e.solver.any_rigid if rigid else (e.solver.n_spin and e.solver.visc is not None)
    if break_it:
        break_it(e.solver)
    e.step_frame()
    return seen


def test_no_serial_loop_is_compiled_into_a_gpu_schedule_substep(monkeypatch):
    assert _serial_loops_compiled(monkeypatch) == []


def test_no_serial_loop_in_a_rigid_gpu_substep(monkeypatch):
    assert _serial_loops_compiled(monkeypatch, scene=FAMILY["rigid_on_ground"]("gpu"), rigid=True) == []


def test_the_check_catches_serial_rigid_sums(monkeypatch):
    def cpu_rigid(solver):
        solver.rigid_reduce_gpu = solver.rigid_reduce
    seen = _serial_loops_compiled(monkeypatch, cpu_rigid, scene=FAMILY["rigid_on_ground"]("gpu"), rigid=True)
    assert ("rigid_reduce", "serialize") in seen


def test_the_check_catches_a_serialize_put_back(monkeypatch):
    def cpu_dots(solver):   # the viscous dots of the CPU schedule: chunk sums added by one thread
        solver.visc.gpu = False
    seen = _serial_loops_compiled(monkeypatch, cpu_dots)
    assert ("_start", "serialize") in seen and ("_iterate", "serialize") in seen


def test_the_check_catches_a_block_dim_1_put_back(monkeypatch):
    def cpu_moments(solver):   # the CPU schedule's moments: 64 slices, one thread each
        solver.contact_moments_gpu = lambda: (solver.contact_moments(), solver.contact_shift())
    seen = _serial_loops_compiled(monkeypatch, cpu_moments)
    assert ("contact_moments", "block_dim=1") in seen


# ---------------------------------------------------------------- the two schedules agree
FAMILY = {
    "viscous_on_ground": lambda s: _viscous_contact_scene(s),
    "two_bodies_walls": lambda s: _two_bodies(s),
    "rigid_on_ground": lambda s: _dt(block_setup(lo=(0.4, 0.4, 0.43), size=(0.2, 0.15, 0.1), n_grid=16,
                                                 material=Material("jelly", E=1e9, nu=0.3, rho=700.0, model="rigid"),
                                                 boundaries=[Boundary("ground", height=0.4, friction=0.4)],
                                                 v=(0.4, 0.0, -0.3), schedule=s, threads=1)),
    "sand_column": lambda s: _dt(block_setup(lo=(0.45, 0.45, 0.3), size=(0.1, 0.1, 0.3), n_grid=24,
                                             material=Material("sand", E=1e5, nu=0.3, rho=1500.0,
                                                               friction_angle=30.0),
                                             boundaries=[Boundary("ground", height=0.25, friction=0.4)],
                                             schedule=s, threads=1)),
}


def _two_bodies(schedule):
    a = block_setup(lo=(0.3, 0.4, 0.42), size=(0.15, 0.15, 0.1), n_grid=16, v=(0.5, 0.0, 0.0))
    b = block_setup(lo=(0.55, 0.4, 0.42), size=(0.1, 0.15, 0.15), n_grid=16, v=(-0.5, 0.0, 0.0))
    from gasp_core.seam import SimSetup
    return SimSetup(x=np.vstack([a.x, b.x]), v=np.vstack([a.v, b.v]),
                    p_vol=np.concatenate([a.p_vol, b.p_vol]),
                    body_id=np.r_[np.zeros(len(a.x), int), np.ones(len(b.x), int)],
                    materials=[Material("jelly", E=2e4, nu=0.3, rho=1000.0), Material("jelly", E=1e4, nu=0.3, rho=800.0)],
                    gravity=a.gravity, domain_lo=a.domain_lo, domain_hi=a.domain_hi, n_grid=16,
                    boundaries=[Boundary("ground", height=0.4, friction=0.5), Boundary("walls", friction=0.3)],
                    frame_dt=0.01, options={"schedule": schedule, "threads": 1})


def _agreement(name):
    """Five frames of FAMILY[name] on the CPU schedule and twice on the GPU schedule: (largest distance between the
    schedules in dx, whether the GPU runs are alike bit for bit, largest motion in dx)."""
    runs = {}
    for sched in ("cpu", "gpu", "gpu"):
        setup = FAMILY[name](sched)
        e = build(setup)
        for _ in range(5):
            e.step_frame()
        runs.setdefault(sched, []).append(e.positions())
        dx = setup.dx
        x0 = setup.x
    return (np.abs(runs["gpu"][0] - runs["cpu"][0]).max() / dx, np.array_equal(runs["gpu"][0], runs["gpu"][1]),
            np.abs(runs["cpu"][0] - x0).max() / dx)


@pytest.mark.parametrize("name", sorted(FAMILY))
def test_gpu_schedule_agrees_with_the_cpu_schedule_and_repeats(name):
    """Five frames: the GPU schedule's positions within 1e-3 dx of the CPU schedule's (they sum in another order:
    f32 rounding), two of its runs bit for bit alike (one thread: its atomics in one order), and the scene moved
    (a run that did nothing would agree trivially)."""
    apart, alike, moved = _agreement(name)
    assert moved > 0.2
    assert apart < 1e-3
    assert alike


def test_the_agreement_catches_sums_that_drop_slices(monkeypatch):
    """A broken GPU schedule whose sums keep only the first slice (the viscous dots, the balance's sums)
    is caught by the agreement check above."""
    from gasp_taichi_mpm.schedule import primitives as pr

    @ti.func
    def first_slice_only(self, n):
        for r in range(self.n_cols):
            s = ti.cast(0, self.dtype)
            for t in range(ti.min(n, 1)):
                s += self.part[t, r]
            self.out[r] = s
    monkeypatch.setattr(pr.SliceSums, "reduce", first_slice_only)
    apart, _alike, _moved = _agreement("viscous_on_ground")
    assert apart >= 1e-3
