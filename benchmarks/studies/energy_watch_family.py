"""The energy watchdog's ratio ``(E - E0) / S`` on a family of scenes (round 60, ``gasp_core.seam.energy_watch``).

Each case runs through the runner (:func:`gasp_core.testing.kit.run_trace`, the watchdog on) and prints the largest
gain seen, a fraction of the scene's energy scale (the allowance is ``ALLOWANCE``), or where it stopped.
Usage: ``python benchmarks/studies/energy_watch_family.py ENGINE CASE[,CASE...] [FRAMES] [--no-watch]`` (``--no-watch``:
the allowance infinite, the runs as before round 60; each frame's fastest point's speed, m/s, is printed); cases: the conformance
scenes by name (their own frames, at most FRAMES), ``snow`` (``gasp_core.testing.snow.ball_setup``), ``brittle_ball``
(``benchmarks/brittle_drop_family.py``'s ball R 3 cm at 4.43 m/s, f_t ratio 0.25), ``donut`` (``examples/
donut_jelly.toml`` as prepared), ``rigid_throw`` (a rigid-route block thrown at (1, 0, 2) m/s onto a ground),
``finestep[_old][:SUBSTEPS[:BALL[:SPEED[:RIGID]]]]`` (``benchmarks/studies/finestep_pair.py``'s ball,
default snow at 5 m/s, onto a box, default rigid (1; 0: jelly), at SUBSTEPS (default 400) a frame, 12 frames,
``FIELD_OLD_VELOCITY`` True / False (``_old``: round 59's defect)), ``scaled`` (the bounce with every frame's velocity times 1.2: a
broken engine, ``tests/test_energy_watch.py``).
"""
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "benchmarks"))
sys.path.insert(0, str(ROOT / "benchmarks" / "studies"))


def rigid_throw():
    """A 10 cm rigid-route jelly block 5 cm above a ground (friction 0.5), thrown at (1, 0, 2) m/s, n_grid 32 (12 frames: it lands and slides inside the domain)."""
    from gasp_core.seam.setup import Boundary, Material, SimSetup
    from gasp_core.testing.helpers import box_points
    dx = 0.6 / 32
    x, vol = box_points((-0.25, -0.05, 0.05), (-0.15, 0.05, 0.15), dx / 2)
    return SimSetup(x=x, v=np.tile([1.0, 0.0, 2.0], (len(x), 1)), p_vol=np.full(len(x), vol), body_id=np.zeros(len(x), int),
                    materials=[Material("jelly", E=1e8, rho=700.0, model="rigid")], gravity=np.array([0, 0, -9.81]),
                    domain_lo=np.array([-0.3, -0.3, -0.02]), domain_hi=np.array([0.3, 0.3, 0.58]), n_grid=32,
                    boundaries=[Boundary("ground", height=0.0, friction=0.5)], frame_dt=1 / 30)


def build(engine: str, case: str):
    """``(setup, n_frames)`` of a case (module notes); the frames are the case's own."""
    if case == "snow":
        from gasp_core.testing.snow import ball_setup
        return ball_setup(), 20
    if case == "brittle_ball":
        from brittle_drop_family import BODIES
        return BODIES["ball R 3 cm"](0.25), 6
    if case == "donut":
        from gasp_core.prepare.scene import prepare_scene
        from gasp_core.scene.spec import load_scene
        return prepare_scene(load_scene(ROOT / "examples" / "donut_jelly.toml"), engine).setup, 8
    if case == "rigid_throw":
        return rigid_throw(), 12
    if case.startswith("finestep"):   # finestep[_old][:substeps[:ball[:speed[:rigid]]]]
        from finestep_pair import scene
        _, n_sub, ball, speed, rigid = (case.split(":") + ["400", "snow", "5", "1"][len(case.split(":")) - 1:])[:5]
        return scene(ball=ball, speed=float(speed), opts={"n_substeps": int(n_sub)}, rigid=rigid == "1")[0], 12
    from gasp_core.testing.scenes import scene_by_name
    from gasp_core.seam.plugins import engines
    sc = scene_by_name("bounce" if case == "scaled" else case)
    return sc.build(engines()[engine]), sc.n_frames


def scaled(info, factor: float):
    """``info`` whose engine multiplies every point's velocity by ``factor`` after each frame (set_state-free: the
    engine's own ``set_velocities`` where it has one, else its state's ``v``): a broken engine that gains energy."""
    import dataclasses

    def factory(setup):
        eng = info.factory(setup)
        step = eng.step_frame

        def step_frame():
            step()
            st = eng.get_state()
            st["v"] = np.asarray(st["v"]) * factor
            eng.set_state(st)
        eng.step_frame = step_frame
        return eng
    return dataclasses.replace(info, factory=factory)


def run(engine: str, case: str, cap: int) -> dict:
    """Run one case: ``{frames, largest, stop}`` (the watchdog's largest ratio, the divergence's frame and cause)."""
    from gasp_core.errors import EngineDivergence
    from gasp_core.mpm import fields
    from gasp_core.seam.plugins import engines
    from gasp_core.seam.runner import RunStats, run_engine
    setup, n = build(engine, case)
    n = min(n, cap)
    info = engines()[engine]
    if case == "scaled":
        info = scaled(info, 1.2)
    fields.FIELD_OLD_VELOCITY = not case.startswith("finestep_old")
    stats, stop, done, speed = RunStats(), None, 0, []
    x_prev = setup.x
    try:
        for rec in run_engine(info, setup, n, stats):
            done = rec.frame
            speed.append(round(float(np.linalg.norm(rec.x - x_prev, axis=1).max() / setup.frame_dt), 2))
            x_prev = rec.x
    except EngineDivergence as e:
        stop = str(e)[:300]
    finally:
        fields.FIELD_OLD_VELOCITY = True
    energy = stats.energy or {}
    return {"max_speed": speed if "--no-watch" in sys.argv else max(speed, default=None), "points": len(setup.x), "n_grid": setup.n_grid, "substeps": stats.engine.get("n_substeps"), "frames": done,
            "largest": energy.get("largest_gain"), "skipped": energy.get("skipped"), "stop": stop}


if __name__ == "__main__":
    if "--no-watch" in sys.argv:   # the runs as before round 60: the watchdog never stops them
        from gasp_core.seam import energy_watch
        energy_watch.ALLOWANCE = float("inf")
    args = [a for a in sys.argv[1:] if a != "--no-watch"]
    eng, cases = args[0], args[1].split(",")
    cap = int(args[2]) if len(args) > 2 else 10 ** 6
    for c in cases:
        t0 = time.perf_counter()
        try:
            r = run(eng, c, cap)
        except TypeError as ex:   # a conformance scene with its own run (no build)
            r = f"not run: {ex}"
        print(eng, c, r, f"{time.perf_counter() - t0:.0f} s", flush=True)
