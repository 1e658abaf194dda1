"""Issue 21 repros that need an engine, a renderer or a fake failure (the others are cases of test_bad_inputs.py).

Each asserts what the user sees: the exit status and exactly one ``gasp:`` line on stderr, no traceback.
"""
import errno
import json
import subprocess
import sys
import warnings

import numpy as np
import pytest
from gasp_testing import scene_text, needs_package

from gasp_core.cli import main as cli
from gasp_core.cli.main import main
from gasp_core.errors import GaspError
from gasp_core.fsutil import CLAIM


def lines(err: str) -> list[str]:
    return [ln for ln in err.splitlines() if ln.strip()]


def dead_pid() -> int:
    p = subprocess.Popen([sys.executable, "-c", "pass"])
    p.wait()
    return p.pid


def ball(path, n: int = 600, radius: float = 0.05):
    """The issue's ball: ``n`` flat Gaussians on a sphere of ``radius`` m, normals outward (Fibonacci sphere)."""
    from scipy.spatial.transform import Rotation
    from gasp_core.gs.gaussians import Gaussians
    from gasp_core.gs.io import write_gaussians
    from gasp_core.testing.scenes_passive import fibonacci_sphere
    d = fibonacci_sphere(n)
    q = np.array([Rotation.align_vectors([v], [[1.0, 0.0, 0.0]])[0].as_quat() for v in d])   # x y z w
    g = Gaussians(means=radius * d, scales=np.tile([1e-8, 0.006, 0.006], (n, 1)), rotations=q[:, [3, 0, 1, 2]],
                  opacities=np.full(n, 3.0, np.float32), sh_dc=np.full((n, 3), 0.5, np.float32))
    return write_gaussians(path, g)


def test_n_grid_8_starts_every_point_inside_the_stencil(tmp_path, donut_small, capsys):
    """n_grid 8 with a ground: the default domain used to start three cells below the ground and end one
    cell above the object, so the top points were outside the grid's stencil at frame 0 ("left the domain")."""
    needs_package("gasp_warp_mpm")
    scene = tmp_path / "s.toml"
    scene.write_text(scene_text(donut_small, n_frames=1, n_grid=8, engine="warp_mpm", engine_options="{ }"))
    assert main(["simulate", str(scene), "-o", str(tmp_path / "o"), "-q"]) == 0, capsys.readouterr().err
    run = json.loads((tmp_path / "o" / "run.json").read_text())
    from gasp_core.gs.io import read_gaussians
    top = read_gaussians(tmp_path / "o" / "donut_small" / "frame_0000.ply").means[:, 2].max() + 0.05
    dom = run["domain"]
    assert dom["hi"][2] - top >= 2.9 * dom["dx"]          # three free cells above the points


def test_stale_claim_with_overwrite_is_a_killed_runs(tmp_path, donut_small, capsys):
    """After kill -9 the claim names a dead pid: --overwrite throws the partial away (it used to say
    "being written by another gasp run"); without it the folder is named as a killed run's."""
    needs_package("gasp_warp_mpm")
    scene = tmp_path / "s.toml"
    scene.write_text(scene_text(donut_small, n_frames=1, n_grid=16, engine="warp_mpm", engine_options="{ }"))
    out, pid = tmp_path / "o", dead_pid()
    out.mkdir()
    (out / CLAIM).write_text(f"0123456789abcdef {pid}\n")
    partial = tmp_path / ".o.partial-killed"
    partial.mkdir()
    (partial / ".gasp-pid").write_text(str(pid))
    assert main(["simulate", str(scene), "-o", str(out), "-q"]) == 2
    err = capsys.readouterr().err
    assert lines(err) == [err.strip()] and f"stopped or killed (pid {pid})" in err
    assert main(["simulate", str(scene), "-o", str(out), "-q", "--overwrite"]) == 0, capsys.readouterr().err
    assert (out / "run.json").exists() and not (out / CLAIM).exists() and not partial.exists()


def test_overlapping_objects_on_mujoco_flex_name_the_cause(tmp_path, capsys):
    """Two identical objects in one place: MuJoCo's arena filled at the first substep, and the line blamed the time
    step. Since issue 55 the overlap is refused before any engine is built (``prepare/checks.check_overlap``), on
    every engine, in one line naming both objects; nothing is written."""
    needs_package("gasp_mujoco_flex")
    ply = ball(tmp_path / "ball.ply")
    text = scene_text(ply, n_frames=1, n_grid=40, engine="mujoco_flex", engine_options="{ }")
    obj = text[text.index("[[object]]"):]
    (tmp_path / "s.toml").write_text(text + "\n" + obj)
    code = main(["simulate", str(tmp_path / "s.toml"), "-o", str(tmp_path / "o"), "-q"])
    err = capsys.readouterr().err
    errors = [line for line in lines(err) if line.startswith("gasp: error:")]
    assert code == 2 and len(errors) == 1, err
    assert "objects 'ball' and 'ball' start inside each other" in errors[0] and "Increase arena" not in err
    assert not (tmp_path / "o").exists()


@pytest.fixture(scope="module")
def small_run(tmp_path_factory, donut_small):
    """Three frames of the donut on warp_mpm at n_grid 16 (a run folder to render)."""
    needs_package("gasp_warp_mpm")
    d = tmp_path_factory.mktemp("small_run")
    (d / "s.toml").write_text(scene_text(donut_small, n_frames=3, n_grid=16, engine="warp_mpm", engine_options="{ }"))
    assert main(["simulate", str(d / "s.toml"), "-o", str(d / "run"), "-q"]) == 0
    return d / "run"


def test_a_render_error_starts_its_own_line(tmp_path, small_run, capsys, monkeypatch):
    """A render that fails on a full disk (ENOSPC) mid-way: the progress bar's line ends first."""
    pytest.importorskip("imageio", reason='the render extra (imageio) is not installed: python -m pip install -e ".[render]"')
    import gasp_core.render.video as video
    real = video.write_frames

    def full_disk(frames, output, **kw):
        def failing():
            for i, img in enumerate(frames):
                if i == 2:
                    raise OSError(errno.ENOSPC, "No space left on device", str(output))
                yield img
        return real(failing(), output, **kw)

    monkeypatch.setattr(video, "write_frames", full_disk)
    code = main(["render", str(small_run), "-o", str(tmp_path / "pngs"), "--resolution", "32x24"])
    err = capsys.readouterr().err
    assert code == 2, err
    assert err.splitlines()[-1] == f"gasp: error: No space left on device: {tmp_path / 'pngs'}", err
    assert not (tmp_path / "pngs").exists()


def test_numpy_warnings_are_held_back(monkeypatch, capsys):
    """NumPy's floating-point chatter never precedes the error line; after a run that succeeded it is said once."""
    def cast_then(fail):
        def command(args):
            with warnings.catch_warnings():
                warnings.simplefilter("always")
                np.array([1e300, 1e300]).astype(np.float32)       # "overflow encountered in cast"
                np.array([1e300]).astype(np.float32)
            if fail:
                raise GaspError("something the user can fix")
            return 0
        return command

    for fail in (True, False):
        parser = cli.build_parser()
        args = parser.parse_args(["info", "x.ply"])
        args.func = cast_then(fail)
        monkeypatch.setattr(cli, "build_parser", lambda: type("P", (), {"parse_args": lambda self, a: args})())
        code = main(["info", "x.ply"])
        err = capsys.readouterr().err
        if fail:
            assert code == 2 and err == "gasp: error: something the user can fix\n"
        else:
            assert code == 0 and err == "gasp: warning: numpy: overflow encountered in cast (2 times)\n"


def test_the_work_estimate_notes_large_runs_and_refuses_beyond_the_bound_without_yes():
    from gasp_core.run import budget
    stats = {"n_substeps": 32}
    assert budget.check(stats, 2000, 100, 99, 0.05, yes=False) == ""                      # 5 s: nothing said
    note = budget.check(stats, 2000, 100_000, 99_999, 0.05, yes=False)                     # 83 min: said
    assert "6.4e+09 point-substeps (32 substeps/frame x 2,000 points x 100,000 frames)" in note
    assert "about 83.3 min at the measured 0.05 s/frame" in note
    with pytest.raises(GaspError, match="beyond the bound of 24 h; pass --yes"):
        budget.check(stats, 2000, 10**9, 10**9 - 2, 0.05, yes=False)
    assert "about 579 days" in budget.check(stats, 2000, 10**9, 10**9 - 2, 0.05, yes=True)
