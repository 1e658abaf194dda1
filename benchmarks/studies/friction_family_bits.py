"""The field-friction families bit for bit across a code change (issue 67 item 4, round 44, ``docs/contact.md``
"Round 44"): sha1 (first 12 hex digits) of the whole trajectories (``x``, ``v``, frames 0-3 of ``run_trace``) of the
scenes of ``tests/test_field_a_frictions.py`` and ``tests/test_field_b_frictions.py`` (their ``FAMILY``, both speeds of
``RATIO_SPEEDS``), one line per engine and scene.

Run it on two trees and compare the lines: ``PYTHONPATH=<tree>:<tree>/plugins/taichi_mpm:<tree>/plugins/warp_mpm
python benchmarks/studies/friction_family_bits.py [warp_mpm|taichi_mpm] [--fast]`` (``--fast``: n_grid 32 only).
"""
import hashlib
import sys
import warnings
from pathlib import Path

import numpy as np

import gasp_core

ROOT = Path(gasp_core.__file__).resolve().parents[1]   # the tree on PYTHONPATH: its own test modules
sys.path.insert(0, str(ROOT / "tests"))


def family_scenes(fast: bool):
    """``(name, n_grid, builder)`` for each scene: ``builder(v0)`` gives the setup."""
    import test_field_a_frictions as TA
    import test_field_b_frictions as TB
    from gasp_core.testing import sand_ball as S
    out = []
    for n_grid, angles, mu, model in TA.FAMILY:
        out.append((f"A-n{n_grid}-{angles[0]:g}-{angles[1]:g}-{mu}{model}", n_grid,
                    lambda v0, a=angles, m=mu, md=model: TA.two_sand_setup(v0, a, m, {"threads": 1}, model=md)))
    for n_grid, mus, model in TB.FAMILY:
        out.append((f"B-n{n_grid}-{mus[0]}-{mus[1]}{model}", n_grid,
                    lambda v0, m=mus, md=model: S.two_slab_setup(v0, m, {"threads": 1}, model=md)))
    return [s for s in out if not fast or s[1] == 32]


def main(engine: str, fast: bool) -> None:
    from gasp_core.seam.plugins import get_engine
    from gasp_core.testing import sand_ball as S
    from gasp_core.testing.kit import run_trace
    from gasp_core.testing.scenes_flow_pairs import RATIO_FRAMES, RATIO_SPEEDS
    warnings.filterwarnings("ignore", message="engine .* share one grid velocity field")
    info = get_engine(engine)
    for name, n_grid, build in family_scenes(fast):
        S.N_GRID = n_grid
        for v0 in RATIO_SPEEDS:
            tr = run_trace(info, build(v0), RATIO_FRAMES)
            h = hashlib.sha1(np.ascontiguousarray(tr.x).tobytes() + np.ascontiguousarray(tr.v).tobytes())
            print(f"{engine} {name} {v0:g}: {h.hexdigest()[:12]}", flush=True)


if __name__ == "__main__":
    args = [a for a in sys.argv[1:] if not a.startswith("--")]
    main(args[0] if args else "warp_mpm", "--fast" in sys.argv)
