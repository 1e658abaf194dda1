"""The cup of ``examples/cup_drop.toml`` at a given speed and grid on one engine, checked as
``tests/test_cup_drop.py`` checks it (round 59, ``docs/fracture.md`` "Round 59: the cup at 20 m/s"): its fragments,
the lowest point (mm), the largest frame energy over the start's, and the wall time; or the error.

``python benchmarks/studies/cup_extremes.py ENGINE SPEED N_GRID`` (speed in m/s, downwards; 6 frames).
"""
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "tests"))


def main(eng: str, speed: float, ng: int) -> str:
    import test_cup_drop as T
    from gasp_core.scene.spec import load_scene
    text = T.EXAMPLE.read_text().replace('name = "taichi_mpm"', f'name = "{eng}"').replace("n_grid = 96", f"n_grid = {ng}")
    text = text.replace("velocity = [0.0, 0.0, -4.43]", f"velocity = [0.0, 0.0, {-speed}]")
    text = text.replace('"data/cup_mesh.ply"', f'"{(T.EXAMPLE.parent / "data" / "cup_mesh.ply").as_posix()}"')
    p = Path(tempfile.mkdtemp()) / "cup.toml"
    p.write_text(text)
    t = time.time()
    try:
        setup, xs, stats = T.run_frames(load_scene(p), eng)
        f = T.check_cup(setup, xs, stats)
        return (f"OK {eng} {speed:g} m/s n_grid {ng}: {f['fragments']} fragments, {len(xs) - 1} frames, lowest "
                f"{f['lowest_mm']:.2f} mm, energy max/start {max(f['energy'][1:]) / f['energy'][0]:.4f}, "
                f"{time.time() - t:.0f} s")
    except Exception as e:   # noqa: BLE001 (the report names it)
        return f"FAIL {eng} {speed:g} m/s n_grid {ng}: {type(e).__name__}: {str(e)[:160]} ({time.time() - t:.0f} s)"


if __name__ == "__main__":
    print(main(sys.argv[1], float(sys.argv[2]), int(sys.argv[3])))
