"""The GPU schedule of taichi_mpm (issue 65, :mod:`gasp_taichi_mpm.schedule`), tested on ``ti.cpu``:

- its primitives: the compaction gives the lists of a serial walk in node order, entry for entry; the slice sums
  repeat bit for bit and equal a float64 sum;
- no ``ti.loop_config(serialize=True)`` and no ``block_dim=1`` is compiled into a substep of the GPU schedule, shown
  catching each of the two put back; none is written outside the CPU-only module ``schedule/ordered.py``;
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


# ---------------------------------------------------------------- ordered loops only in the CPU-only module
#: The CPU-only modules: the only ones of taichi_mpm that may hold an ordered one-thread loop (schedule/__init__.py).
CPU_ONLY = ("schedule/ordered.py",)
#: One-iteration loops kept elsewhere, each O(1) work on one thread by nature on both schedules (not an ordered
#: variant of a parallel loop): kernel name -> why.
ONE_ITEM = {"rigid_pair": "the contact of one pair of rigid bodies: a dozen float64 operations, once a substep",
            "rigid_pairs": "round 62: the touching pairs of rigid bodies among three or more, SWEEPS (8) x n_on pair "
                           "updates, once a substep; round 63: only the n_on touching slots the node kernel listed "
                           "(their insertion sort and clears), none of the n_bodies^2 table",
            "rigid_pairs_gpu": "round 81: the GPU schedule's islands of touching rigid bodies, integer work over the "
                               "n_on listed pairs (union-find, the islands' lists); the sweeps run one thread an "
                               "island",
            "collider_body": "round 63: the rigid body's V* from its field's sums, one body, once a substep (round 64: "
                             "a parallel loop over the slots, the scene's rigid bodies)",
            "collider_solve": "round 63: the body's 6 x 6 solve with its layer, one body, twice a substep (round 64: "
                              "one a slot)",
            "collider_coulomb": "round 63: Coulomb's scale of the layer's tangential impulse, one body (round 64: "
                                "one a slot; round 65: collider_pair.py, a parallel loop over the contact pairs)"}


def _serial_constructs(root):
    """[(path relative to root, line, what)] of every ``serialize=...``, ``block_dim=1`` keyword and one-iteration
    ``for _ in range(1)`` in the .py files under ``root`` (by the syntax tree: docstrings and comments do not
    count), the one-iteration loops of :data:`ONE_ITEM`'s functions left out."""
    import ast
    from pathlib import Path
    found = []
    for path in sorted(Path(root).rglob("*.py")):
        rel = path.relative_to(root).as_posix()
        tree = ast.parse(path.read_text())
        allowed = set()
        for fn in ast.walk(tree):
            if isinstance(fn, ast.FunctionDef) and fn.name in ONE_ITEM:
                allowed |= {id(n) for n in ast.walk(fn)}
        for node in ast.walk(tree):
            if isinstance(node, ast.keyword) and node.arg == "serialize":
                found.append((rel, node.value.lineno, "serialize"))
            if isinstance(node, ast.keyword) and node.arg == "block_dim" and \
                    isinstance(node.value, ast.Constant) and node.value.value == 1:
                found.append((rel, node.value.lineno, "block_dim=1"))
            if isinstance(node, ast.For) and id(node) not in allowed and isinstance(node.iter, ast.Call) and \
                    getattr(node.iter.func, "id", "") == "range" and \
                    [getattr(a, "value", None) for a in node.iter.args] in ([1], [0, 1]):
                found.append((rel, node.lineno, "range(1)"))
    return sorted(found)


def test_ordered_loops_only_in_the_cpu_only_module():
    """Issue 65's layout: every ``serialize``, ``block_dim=1`` and one-iteration loop of taichi_mpm is in
    :data:`CPU_ONLY` (the modules both schedules compile hold none), and that module holds some."""
    from pathlib import Path
    import gasp_taichi_mpm
    found = _serial_constructs(Path(gasp_taichi_mpm.__file__).parent)
    assert [f for f in found if f[0] not in CPU_ONLY] == []
    assert {f[2] for f in found if f[0] in CPU_ONLY} == {"serialize", "block_dim=1"}


def test_the_layout_check_catches_each_kind_outside(tmp_path):
    """The check above sees each kind put back in a shared module, not in a docstring or comment, and skips
    :data:`ONE_ITEM`'s kernels."""
    (tmp_path / "schedule").mkdir()
    (tmp_path / "schedule" / "ordered.py").write_text("ti.loop_config(serialize=True)\n")
    (tmp_path / "balance.py").write_text(
        '"""ti.loop_config(serialize=True)"""\n# ti.loop_config(block_dim=1)\n'
        "def k():\n    ti.loop_config(serialize=not gpu)\n    ti.loop_config(block_dim=1)\n"
        "    for _ in range(1):\n        pass\n"
        "def rigid_pair():\n    for _ in range(1):\n        pass\n")
    found = _serial_constructs(tmp_path)
    want = [("balance.py", 4, "serialize"), ("balance.py", 5, "block_dim=1"), ("balance.py", 6, "range(1)")]
    assert [f for f in found if f[0] not in CPU_ONLY] == want


BUNDLED = ("donut_shatter", "cup_drop", "donut_wood", "guitar_sand", "donut_on_guitar", "donut_wind")


@pytest.mark.slow
@pytest.mark.parametrize("example", BUNDLED)
def test_no_serial_loop_in_a_bundled_examples_gpu_substep(monkeypatch, example):
    """Every bundled example a user runs (brittle with passive skins and the grid contact, the stiff cup's rigid
    fragments, a rigid body, sand on a guitar, two bodies, wind): one frame of the GPU schedule compiles no serial
    loop (round 39; 23-58 s each on 2 cores). The catches above show the spy sees each kind put back."""
    import warnings
    from pathlib import Path
    from gasp_core.prepare.scene import prepare_scene
    from gasp_core.scene.spec import load_scene
    from gasp_core.seam.runner import run_engine
    seen = []
    real = ti.loop_config

    def spy(**kw):
        import taichi.lang.impl as impl
        name = getattr(getattr(impl.get_runtime().current_kernel, "func", None), "__name__", "?")
        seen.extend((name, w) for w, on in (("serialize", kw.get("serialize")),
                                            ("block_dim=1", kw.get("block_dim") == 1)) if on)
        return real(**kw)
    monkeypatch.setattr(ti, "loop_config", spy)
    scene = load_scene(Path(__file__).resolve().parents[3] / "examples" / f"{example}.toml")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        prep = prepare_scene(scene, "taichi_mpm", options={**scene.engine.options, "schedule": "gpu"})
        records = list(run_engine(prep.info, prep.setup, 1))
    assert len(records) == 1 and seen == []


# ---------------------------------------------------------------- the two schedules agree
FAMILY = {
    "viscous_on_ground": lambda s: _viscous_contact_scene(s),
    "two_bodies_walls": lambda s: _two_bodies(s),
    "rigid_on_ground": lambda s: _dt(block_setup(lo=(0.4, 0.4, 0.43), size=(0.2, 0.15, 0.1), n_grid=16,
                                                 material=Material("jelly", E=1e9, nu=0.3, rho=700.0, model="rigid"),
                                                 boundaries=[Boundary("ground", height=0.4, friction=0.4)],
                                                 v=(0.4, 0.0, -0.3), schedule=s, threads=1)),
    "passive_skin": lambda s: _passive_skin(s),
    "sand_column": lambda s: _dt(block_setup(lo=(0.45, 0.45, 0.3), size=(0.1, 0.1, 0.3), n_grid=24,
                                             material=Material("sand", E=1e5, nu=0.3, rho=1500.0,
                                                               friction_angle=30.0),
                                             boundaries=[Boundary("ground", height=0.25, friction=0.4)],
                                             schedule=s, threads=1)),
}


def _passive_skin(schedule, threads=1):
    """A jelly block thrown onto a ground, with passive points over its top face (the skin a scan's Gaussians give)."""
    b = _viscous_contact_scene(schedule)
    top = b.x[b.x[:, 2] > b.x[:, 2].max() - 1e-9][::3] + np.array([0.0, 0.0, 0.3 * b.dx])
    from gasp_core.seam import SimSetup
    passive = np.r_[np.ones(len(top), bool), np.zeros(len(b.x), bool)]
    return SimSetup(x=np.vstack([top, b.x]), v=np.array([0.3, 0.0, -0.5]), p_vol=np.where(passive, 0.0, b.p_vol[0]),
                    body_id=0, materials=[Material("jelly", E=1e4, nu=0.3, rho=1000.0)], gravity=b.gravity,
                    domain_lo=b.domain_lo, domain_hi=b.domain_hi, n_grid=b.n_grid, boundaries=b.boundaries,
                    frame_dt=b.frame_dt, n_render=len(top), passive=passive, options={**b.options, "threads": threads})


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


# ---------------------------------------------------------------- the CPU schedule's passive points
def _passive_box_after(frames=3):
    """(the passive points' node box the CPU schedule holds, the box of their stencils from their positions)."""
    setup = _passive_skin("cpu", threads=2)
    e = build(setup)
    for _ in range(frames):
        e.step_frame()
    sv = e.solver
    assert sv.coloured and sv.has_passive
    x = sv.x.to_numpy()[sv.n_material:sv.n]
    base = np.floor((x - setup.domain_lo) / setup.dx - 0.5).astype(int)
    return sv.pbox.to_numpy()[0], np.stack([base.min(0), base.max(0) + 2])


def test_cpu_schedule_passive_box_is_their_stencils():
    """Round 39: the CPU schedule's passive G2P runs one thread a point (it ran on one thread for all of them: 61 %
    of donut_shatter's frame), its node box (where the next grid update starts) by integer atomic min and max on
    2 threads: the box of the points' stencils exactly, whatever order the threads arrive in."""
    held, want = _passive_box_after()
    np.testing.assert_array_equal(held, want)


def test_the_passive_box_check_catches_a_box_of_one_point(monkeypatch):
    from gasp_taichi_mpm.transfers import Transfers

    @ti.func
    def first_point_only(self):
        for t in range(self.n_chunks):
            base, _fx, _ok = self.base_fx(self.x[self.n_points[None]])
            self.pbox[t, 0] = base
            self.pbox[t, 1] = base + 2
    monkeypatch.setattr(Transfers, "_passive_box", first_point_only)
    held, want = _passive_box_after()
    assert not np.array_equal(held, want)
