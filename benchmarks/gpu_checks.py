"""Correctness on a lent GPU (issue 65), in one short device call: what the CPU cannot show of taichi_mpm's CUDA path.

1. The GPU schedule's primitives on CUDA: a fixed-tree slice sum repeats bit for bit over three runs and equals a
   float64 sum; the compaction gives the lists of a serial walk in node order.
2. A rigid block on a slope (tests/test_rigid_slope.py's scene) on CUDA: its acceleration against Coulomb's closed form
   where it slides, its travel where it sticks (the rigid bodies' GPU-schedule sums and the slide brake on CUDA).
3. The rigid ball and cylinder of tests/test_rolling.py on CUDA: rolling at (5/7) or (2/3) g sin theta with
   omega R = v, slipping at g (sin - mu cos) (issue 67 item 2).
4. The README donut with ``device = "auto"`` twice, 3 frames each: the device ``auto`` chose, and how far two runs'
   positions differ (the atomic P2G: CUDA runs are not bit-repeatable; ``deterministic`` stays ``{"cpu"}``), and the
   second run's seconds a frame (compiled).
5. Rounds 48-51's contact on CUDA (issue 67, round 52): the slide shapes' jelly hexagonal prism and slab and the rigid
   cube (``gasp_core.testing.slide_shapes``; the rigid body routed to the particle contact under ``"grid"``), the
   landed and released jelly blocks of ``tests/test_landed_slide.py`` (the touch bound), the block thrown down onto
   the slab and the block landing on the slope (its landing's friction over ``mu`` times its normal impulse; round
   52's ``"body"`` bound, its pool summed by rows): each figure and its check.

6. Round 59, a regression look after rounds 53-58 (no GPU lent since round 52): the walls' floor under a ground
   (``tests/test_walls_floor.py``'s slab, round 58), snow's state clock (``benchmarks/energy_ledger_plastic.py``'s
   snow block and slab: each frame's substeps and the ledger's untraced end, round 57), the tension family's bar
   L0.7 at n_grid 24 and 48 (``benchmarks/tension_family.py``: peak, place, work; issue 66) and the porcelain cup
   of ``tests/test_cup_drop.py`` at 4.43 and 20 m/s (its fragments; the 20 m/s cup diverges on the CPU since round
   55); the state's clock beside colliders and impulses (``snow_extras``, round 59). Each routed to ``device`` by
   :func:`taichi_on`.

Writes ``gpu_checks.json`` to ``--out``. (No ``from __future__ import annotations`` here: Taichi reads the kernels'
annotations as types.) Usage on the device (``../shared/device``)::

    bash .device/setup.sh && PYTHONPATH=/tmp/site python3 benchmarks/gpu_checks.py --out $OUT
"""
import argparse
import json
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]


def primitives(device: str) -> dict:
    import taichi as ti
    ti.init(arch=ti.cuda if device == "cuda" else ti.cpu, offline_cache=False)
    from gasp_taichi_mpm.schedule.primitives import BoxCompaction, SliceSums

    @ti.data_oriented
    class Sums:
        def __init__(self, n, r):
            self.s = SliceSums(n, r)

        @ti.kernel
        def reduce(self, n: ti.i32):
            self.s.reduce(n)

    rng = np.random.default_rng(65)
    n = 400_000
    part = rng.normal(size=(n, 19)) * 10.0 ** rng.integers(-6, 6, size=(n, 1))
    k = Sums(n, 19)
    k.s.part.from_numpy(part)
    outs = []
    for _ in range(3):
        k.reduce(n)
        outs.append(k.s.out.to_numpy().copy())
    rel = float(np.max(np.abs(outs[0] - part.sum(0)) / np.abs(part).sum(0)))

    @ti.data_oriented
    class Flags:
        def __init__(self, flags):
            ng = flags.shape[0]
            self.f = ti.field(ti.i32, shape=flags.shape)
            self.f.from_numpy(flags.astype(np.int32))
            self.a = ti.Vector.field(3, ti.i32, shape=ng ** 3)
            self.comp = BoxCompaction(self, ng, (self.a,))

        @ti.func
        def listed(self, I, q: ti.template()):
            return self.f[I] == 1

        @ti.func
        def overflow(self, I, q: ti.template()):
            pass

        @ti.kernel
        def run(self, lo: ti.types.vector(3, ti.i32), ext: ti.types.vector(3, ti.i32)):
            self.comp.run(lo, ext)

    flags = rng.integers(0, 2, size=(64, 64, 64))
    c = Flags(flags)
    c.run(ti.Vector([3, 5, 7]), ti.Vector([50, 40, 45]))
    want = np.argwhere(flags[3:53, 5:45, 7:52] == 1) + np.array([3, 5, 7])
    got = c.a.to_numpy()[:len(want)]
    return {"slice_sums_alike_3_runs": all(np.array_equal(outs[0], o) for o in outs[1:]),
            "slice_sums_rel_error": rel, "compaction_is_the_serial_walk": bool(np.array_equal(got, want)
                                                                              and c.comp.count[0] == len(want))}


def slope(device: str) -> dict:
    sys.path.insert(0, str(ROOT / "tests"))
    import test_rigid_slope as rs
    out = {}
    make = rs.block_setup

    def on_cuda(theta, mu):
        s = make(theta, mu)
        s.options = {**(s.options or {}), "device": device}
        return s
    rs.block_setup = on_cuda
    for theta, mu in ((30, 0.3), (30, 0.2), (15, 0.4)):
        fig = rs.measure("taichi_mpm", theta, mu)
        out[f"{theta}deg_mu{mu}"] = {"figure": fig, "closed_form": rs.closed_form(theta, mu),
                                     "problem": rs.check(theta, mu, fig)}
    return out


def rolling(device: str) -> dict:
    """tests/test_rolling.py's ball and cylinder on the 20 degree slope on ``device`` (issue 67 item 2: the contact
    patch's flatness and the rolling damping on the GPU schedule): each case's figures and its check."""
    sys.path.insert(0, str(ROOT / "tests"))
    import test_rolling as rl
    out = {}
    make = rl.body_setup

    def on_device(shape, mu, theta=rl.THETA):
        s = make(shape, mu, theta)
        s.options = {**(s.options or {}), "device": device}
        return s
    rl.body_setup = on_device
    try:
        for shape, mu in (("ball", rl.ROLL_MU), ("ball", rl.SLIP_MU), ("cylinder", 0.3)):
            fig = rl.measure("taichi_mpm", shape, mu)
            out[f"{shape}_mu{mu}"] = {**fig, "closed_form": rl.closed_form(shape, mu),
                                      "problem": rl.check(shape, mu, fig)}
    finally:
        rl.body_setup = make
    return out


def donut_twice(device: str) -> dict:
    from gasp_core.prepare.scene import prepare_scene
    from gasp_core.scene.spec import load_scene
    from gasp_core.seam.runner import RunStats, run_engine
    src = ROOT / "examples" / "donut_jelly.toml"
    text = src.read_text().replace('file = "data/', f'file = "{src.parent}/data/') + \
        f'\n[engine.options]\ndevice = "{"auto" if device == "cuda" else device}"\n'
    xs, device, ticks = [], None, []
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "donut_auto.toml"
        path.write_text(text)
        for _ in range(2):
            prep = prepare_scene(load_scene(path), "taichi_mpm")
            stats = RunStats()
            ticks = [time.perf_counter()]
            for rec in run_engine(prep.info, prep.setup, 3, stats):
                last = rec.x
                ticks.append(time.perf_counter())
            xs.append(last)
            device = stats.engine.get("device")
    d = np.linalg.norm(xs[0] - xs[1], axis=1)
    return {"device_auto_chose": device, "two_runs_max_dx": float(d.max() / prep.setup.dx),
            "two_runs_alike": bool(np.array_equal(xs[0], xs[1])),
            "s_per_frame_frames_2_3": round((ticks[-1] - ticks[-3]) / 2.0, 4)}


def contact(device: str) -> dict:
    """Item 5 of the module docstring on ``device``: each case's figure, its check's verdict (None: met) and the
    figure the same case gives on the CPU where the tests pin it."""
    import gasp_core.seam.build as build
    from gasp_core.seam.plugins import get_engine
    from gasp_core.testing import grid_hold as gh
    from gasp_core.testing import sand_ball as S
    from gasp_core.testing import slide_shapes as ss
    from gasp_core.testing.kit import run_trace
    make = build.build_engine

    def on_device(info, s, *a, **k):
        s.options = {**(s.options or {}), "device": device}
        return make(info, s, *a, **k)
    build.build_engine = on_device
    out = {}
    try:
        for shape, mat, con, theta, mu in (("hex", "jelly", "grid", 30, 0.3), ("hex", "jelly", "grid", 30, 0.7),
                                           ("slab", "jelly", "particle", 30, 0.3), ("cube", "rigid", "grid", 30, 0.7),
                                           ("cube", "rigid", "grid", 30, 0.3)):
            fig = ss.measure("taichi_mpm", shape, 1.0, mat, con, 32, theta, mu)
            out[f"{shape}_{mat}_{con}_n32_{theta}_{mu}"] = {"figure": fig, "problem": ss.problem(theta, mu, fig, 0.025)}
        for case in ((32, 45, 0.95, 1.0), (48, 45, 0.95, 0.0)):
            err = gh.landed_slide_error("taichi_mpm", *case)
            out["landed_n{}_{}deg_mu{}_v{}".format(*case)] = {"error": err, "met_2.5pc": abs(err) < 0.025}
        s = S.slide_setup(1.6, {"contact": "grid", "device": device}, ground=True, solid=True)
        s.v = np.asarray(s.v, float) + np.array([0.0, 0.0, -1.0])
        tr = run_trace(get_engine("taichi_mpm"), s, 1)
        err = S.coulomb_ratio(tr.v, s, 0, 1) / float(s.boundaries[0].friction) - 1.0
        out["thrown_vz1"] = {"excess": err, "met_2.5pc": abs(err) < 0.025}   # round 51's debt: +18.40 %
        err = gh.landing_error("taichi_mpm", 32, 45, 0.95, 1.0)   # round 52's slope landing ("body": +1.07 %)
        out["slope_landing_n32_45deg_v1"] = {"error": err, "met_2.5pc": abs(err) < 0.025}
    finally:
        build.build_engine = make
    return out


class taichi_on:
    """Within the block every taichi_mpm engine built runs on ``device`` (its setup's ``options["device"]``)."""

    def __init__(self, device: str):
        self.device = device

    def __enter__(self):
        import dataclasses
        from gasp_taichi_mpm.engine import TaichiMPMEngine
        self.cls, self.init, device = TaichiMPMEngine, TaichiMPMEngine.__init__, self.device
        init = self.init

        def on_device(eng, setup):
            init(eng, dataclasses.replace(setup, options={**(setup.options or {}), "device": device}))
        TaichiMPMEngine.__init__ = on_device
        return self

    def __exit__(self, *exc):
        self.cls.__init__ = self.init


def walls_floor(device: str) -> dict:
    """tests/test_walls_floor.py's slab (frictionless walls, ground mu 0.3) at the ground's three offsets: its slide
    against Coulomb's, less 1 (the CPU: -0.30 % at each; tolerance 4 %)."""
    sys.path.insert(0, str(ROOT / "tests"))
    import test_walls_floor as wf
    with taichi_on(device):
        return {f"offset_{o:+g}": {"error": (err := wf.slide_error("taichi_mpm", o)), "met_4pc": abs(err) < 0.04}
                for o in wf.OFFSETS}


def snow(device: str) -> dict:
    """Snow's state clock (round 57) on ``device``: the snow block and slab of benchmarks/energy_ledger_plastic.py at
    n_grid 32, each frame's substeps (the CPU: 194, 202, 202 and 242, 241, 241) and the ledger's untraced end (the
    CPU: +1.99 % and +3.62 % of E0) and gain (0)."""
    sys.path.insert(0, str(ROOT / "benchmarks"))
    import energy_ledger_plastic as elp
    out = {}
    with taichi_on(device):
        for body in ("snow_block", "snow_slab"):
            r = elp.run(body, "taichi_mpm", 32)
            out[body] = {"substeps": r["frames"], "untraced_end_pc": 100 * r["untraced_end"] / r["E0"],
                         "untraced_worst_pc": 100 * r["untraced_worst"] / r["E0"], "gain": r["gain"],
                         "seconds": round(r["seconds"], 1)}
    return out


def tension(device: str) -> dict:
    """The tension family's bar L0.7 (the default tier's case) at n_grid 24 and 48 on ``device``: the peak nominal
    stress over f_t, where it breaks, the work to separate over G_f (the must-show: 5 %, the gauge, 20 %)."""
    sys.path.insert(0, str(ROOT / "benchmarks"))
    import tension_family as tf
    sp, out = tf.FAMILY[1], {}
    with taichi_on(device):
        for n in (24, 48):
            r = tf.run_case(sp, n, "taichi_mpm")
            out[f"{sp.name}_n{n}"] = {"peak_vs_ft": r["peak"] / tf.FT - 1, "where": r["where"],
                                      "work_vs_gf": r["work"] / tf.GF - 1}
    return out


def cup(device: str) -> dict:
    """tests/test_cup_drop.py's porcelain cup (n_grid 80, 6 frames) at 4.43 and 20 m/s on ``device``: its fragments,
    lowest point (mm) and whether the energy stays under the start's; or the error that stopped it."""
    sys.path.insert(0, str(ROOT / "tests"))
    import test_cup_drop as cd
    out = {}
    with taichi_on(device), tempfile.TemporaryDirectory() as tmp:
        for speed in (4.43, 20.0):
            try:
                setup, xs, stats = cd.run_frames(cd.cup_scene(Path(tmp), "taichi_mpm", speed), "taichi_mpm")
                e = cd.energies(setup, xs)
                out[f"v{speed:g}"] = {"frames": len(xs) - 1, "fragments": stats.fragments[0]["fragments"]
                                      if stats.fragments else 0, "lowest_mm": 1e3 * min(float(x[:, 2].min()) for x in xs),
                                      "energy_over_start": float(e[1:].max() / e[0] - 1)}
            except Exception as err:
                out[f"v{speed:g}"] = {"error": f"{type(err).__name__}: {str(err)[:300]}"}
    return out


def snow_extras(device: str) -> dict:
    """Round 59's clock beside colliders and impulses on ``device`` (tests/test_state_step_extras.py): the compacted
    snow block's substeps beside a static collider (the CPU's count), and the impulse's x-momentum after frames 1
    and 2 over its own (0 and 1 within 1e-5)."""
    sys.path.insert(0, str(ROOT / "tests"))
    import test_state_step_extras as tx
    out = {}
    with taichi_on(device):
        e = tx.compacted("taichi_mpm", tx.with_extras(tx.block(), "static collider"))
        try:
            e.step_frame()
            out["substeps_beside_collider"] = e.stats()["n_substeps"]
        finally:
            e.close()
        out["impulse_frames_1_2"] = tx.impulse_momentum("taichi_mpm")
    f1, f2 = out["impulse_frames_1_2"]
    out["met"] = abs(f1) < 1e-5 and abs(f2 - 1.0) < 1e-5 and out["substeps_beside_collider"] >= tx.expected_substeps(
        tx.block(), 0.7)
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, default=ROOT / "benchmarks" / "results")
    ap.add_argument("--device", default="cuda", choices=("cuda", "cpu"), help="cpu: a smoke run of the script")
    ap.add_argument("--only", nargs="*", default=None, help="run only these sections, in this order (names as in the JSON)")
    a = ap.parse_args(argv)
    a.out.mkdir(parents=True, exist_ok=True)
    doc = {}
    sections = {"primitives": primitives, "slope": slope, "rolling": rolling, "donut_auto": donut_twice,
                "contact": contact, "walls_floor": walls_floor, "snow": snow, "tension": tension, "cup": cup,
                "snow_extras": snow_extras}
    for name in sections if a.only is None else a.only:   # --only: in its order (a timeout keeps the first ones)
        fn = sections[name]
        t0 = time.perf_counter()
        try:
            doc[name] = fn(a.device)
        except Exception as e:   # one failed check is reported, the others still run
            doc[name] = {"error": f"{type(e).__name__}: {e}"}
        doc[name]["wall_s"] = round(time.perf_counter() - t0, 1)
        print(name, json.dumps(doc[name]), flush=True)
        (a.out / "gpu_checks.json").write_text(json.dumps(doc, indent=1))   # after each: a timeout keeps the rest
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
