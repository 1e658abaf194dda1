"""``gasp compare`` and ``gasp bench`` (gasp_studies) on a tiny cut of the real donut (every 32nd Gaussian)."""
import csv
import dataclasses
import importlib.util
import re
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("distributed", reason="the studies extra is not installed (pip install -e '.[studies]')")

from gasp_testing import scene_text  # noqa: E402
from gasp_core.cli.main import main  # noqa: E402
from gasp_core.errors import SceneError  # noqa: E402
from gasp_core.gs.io import write_gaussians  # noqa: E402
from gasp_core.run.frames import iter_frames
from gasp_core.prepare.scene import prepare_scene
from gasp_core.seam.plugins import engines  # noqa: E402
from gasp_core.scene.spec import load_scene  # noqa: E402
from gasp_studies import report  # noqa: E402
from gasp_studies.bench import apply_setting, bench_scene, plan_sweeps, setting_label  # noqa: E402
from gasp_studies.compare import compare_scene, select_engines, subsample_scene  # noqa: E402
from gasp_studies.measure import frame_distances, pareto_front  # noqa: E402
from gasp_studies.run import Runner, RunSpec  # noqa: E402

INSTALLED = engines()
needs_taichi = pytest.mark.skipif("taichi_mpm" not in INSTALLED, reason="taichi_mpm not installed")
needs_warp = pytest.mark.skipif("warp_mpm" not in INSTALLED, reason="warp_mpm not installed")
needs_flex = pytest.mark.skipif("mujoco_flex" not in INSTALLED, reason="mujoco_flex not installed")


def deterministic(name: str) -> dict:
    """The options that make ``name`` repeat bit for bit on CPU (its ``deterministic_options``).

    Local fallback until every plugin declares them: one thread where the engine has a ``threads`` option.
    """
    info = INSTALLED[name]
    if info.deterministic_options:
        return dict(info.deterministic_options)
    return {"threads": 1} if "threads" in {o.name for o in info.options} else {}


@pytest.fixture(scope="module")
def donut_tiny(tmp_path_factory, donut):
    """Every 32nd Gaussian of the real donut (1,426 Gaussians)."""
    path = tmp_path_factory.mktemp("tiny") / "donut_tiny.ply"
    write_gaussians(path, donut.subset(np.arange(0, donut.n, 32)))
    return path


def _read_csv(path: Path) -> tuple[list[str], list[dict]]:
    with open(path, newline="") as f:
        r = csv.DictReader(f)
        return list(r.fieldnames), list(r)


@needs_warp
@needs_flex
def test_compare_writes_report_self_divergence_zero_and_refuses_an_unknown_engine(donut_tiny, write_scene, tmp_path):
    scene = write_scene(scene_text(donut_tiny, n_frames=3, n_grid=16, engine="warp_mpm", engine_options="{}"))
    out = tmp_path / "cmp"
    with pytest.raises(SceneError, match="'no_such_engine' is not an installed engine"):   # issue 21: refused
        compare_scene(scene, ["warp_mpm", "no_such_engine"], out, progress=False)
    assert not out.exists()
    res = compare_scene(scene, ["warp_mpm", "warp_mpm", "mujoco_flex"], out, progress=False,
                        options={"warp_mpm": deterministic("warp_mpm")})
    for name in ("table.csv", "table.md", "divergence.csv", "divergence.png", "timing.png", "report.md"):
        assert (out / name).stat().st_size > 0, name
    cols, table = _read_csv(out / "table.csv")
    assert cols == report.TABLE_COLUMNS
    assert [r["engine"] for r in table] == ["warp_mpm", "warp_mpm#2", "mujoco_flex"]
    # a point for each of the 1,426 Gaussians (their centres since the quality levels' surface_points; vertices, 3
    # each, before) and the fill's
    assert all(r["status"] == "ok" and int(r["simulated_points"]) > 1426 for r in table)
    assert all(float(r["s_per_frame"]) > 0 and float(r["peak_rss_mb"]) >= float(r["worker_base_rss_mb"]) > 50
               for r in table)
    # every run in its own fresh worker process
    pids = [o.record["pid"] for o in res.outputs]
    assert len(set(pids)) == 3 and all(o.record["isolated"] for o in res.outputs)
    cols, div = _read_csv(out / "divergence.csv")
    assert cols == report.DIVERGENCE_COLUMNS
    assert {r["reference"] for r in div} == {"warp_mpm"}
    again = [r for r in div if r["engine"] == "warp_mpm#2"]
    assert [int(r["frame"]) for r in again] == [0, 1, 2, 3]
    # the same deterministic engine twice: exactly zero, on every metric and frame
    assert all(float(r[k]) == 0.0 for r in again for k in ("mean_dist_m", "max_dist_m", "chamfer_m"))
    flex = [r for r in div if r["engine"] == "mujoco_flex"]
    assert float(flex[0]["max_dist_m"]) == 0.0                       # frame 0 is the input for both
    assert float(flex[-1]["mean_dist_m"]) > 0.0                      # different solvers differ later
    assert float(flex[-1]["chamfer_m"]) <= float(flex[-1]["mean_dist_m"]) + 1e-12  # NN <= same-index
    text = (out / "report.md").read_text()
    assert "fresh worker process" in text
    assert {p.name for p in (out / "runs").glob("*.npz")} == {"warp_mpm.npz", "warp_mpm_2.npz", "mujoco_flex.npz"}
    assert not list(tmp_path.glob(".cmp.partial-*"))                 # temp folder moved into place


@needs_taichi
@needs_warp
@needs_flex
@pytest.mark.slow  # several fresh worker processes, about a minute each on a loaded 2-core machine
def test_compare_runs_agree_bit_for_bit_with_in_process_runs(donut_tiny, write_scene, tmp_path):
    """A Dask worker run is the same computation as a run in this process (same scene, deterministic options)."""
    names = ["taichi_mpm", "warp_mpm", "mujoco_flex"]
    scene_path = write_scene(scene_text(donut_tiny, n_frames=3, n_grid=16, engine_options="{}"))
    opts = {n: deterministic(n) for n in names}
    res = compare_scene(scene_path, names, tmp_path / "cmp", progress=False, options=opts, max_gaussians=700)
    assert [o.record["status"] for o in res.outputs] == ["ok"] * 3
    scene, strides = subsample_scene(load_scene(scene_path), 700, tmp_path)
    assert strides == [3]
    for name, out in zip(names, res.outputs):
        prep = prepare_scene(scene, name, opts[name])
        means = np.stack([np.concatenate([g.means for g in gs]).astype(np.float32)
                          for _, gs, _ in iter_frames(prep, 3)])
        saved = np.load(tmp_path / "cmp" / "runs" / f"{name}.npz")["means"]
        assert saved.shape == means.shape == (4, 476, 3)
        assert np.array_equal(saved, means), name
        assert np.array_equal(out.means, means), name
        assert not np.array_equal(means[3], means[0])                 # it did move


def test_compare_refuses_existing_folder(donut_tiny, write_scene, tmp_path, capsys):
    scene = write_scene(scene_text(donut_tiny, n_frames=2, n_grid=16))
    out = tmp_path / "exists"
    out.mkdir()
    (out / "keep.txt").write_text("x")
    with pytest.raises(FileExistsError, match="--overwrite"):
        compare_scene(scene, ["taichi_mpm"], out, progress=False)
    assert main(["compare", str(scene), "-o", str(out), "--engines", "taichi_mpm"]) == 2
    assert "exists" in capsys.readouterr().err
    assert main(["bench", str(scene), "-o", str(out)]) == 2
    assert (out / "keep.txt").read_text() == "x"


def test_cli_without_the_studies_extra_names_the_install(donut_tiny, write_scene, tmp_path, capsys, monkeypatch):
    scene = write_scene(scene_text(donut_tiny, n_frames=2, n_grid=16))
    real = importlib.util.find_spec
    monkeypatch.setattr(importlib.util, "find_spec", lambda name, *a: None if name == "distributed" else real(name, *a))
    for cmd in ("compare", "bench"):
        assert main([cmd, str(scene), "-o", str(tmp_path / cmd)]) == 2
        err = capsys.readouterr().err.strip()
        assert len(err.splitlines()) == 1 and 'pip install -e ".[studies]"' in err and "distributed" in err
        assert not (tmp_path / cmd).exists()


@needs_flex
def test_missing_capability_is_listed_with_reason(donut_tiny, write_scene):
    scene = load_scene(write_scene(scene_text(donut_tiny, material='name = "sand"\nE = 1e5\nnu = 0.3\nrho = 1500.0')))
    runnable, skipped = select_engines(scene, ["mujoco_flex", "not_here"])
    assert runnable == []
    assert "material 'sand'" in skipped["mujoco_flex"]
    assert "not installed" in skipped["not_here"]


@needs_warp
@needs_taichi
def test_compare_reports_a_diverging_engine_and_runs_the_others(donut_tiny, write_scene, tmp_path):
    scene = write_scene(scene_text(donut_tiny, n_frames=3, n_grid=16, engine="taichi_mpm",
                                   engine_options="{}",
                                   material='name = "jelly"\nE = 2.0e6\nnu = 0.3\nrho = 300.0\nmodel = "elastic"'))
    # one substep per frame: ~300x above the elastic-wave limit at n_grid 16 (on the grid contact: the particle
    # contact takes its own stable step whatever n_substeps says); the other engine at its own step (mujoco_flex,
    # the engine here before, now refuses this stiffness on its lattice: singular inertia at frame 1)
    res = compare_scene(scene, ["warp_mpm", "taichi_mpm"], tmp_path / "cmp", progress=False,
                        options={"warp_mpm": {"n_substeps": 1, "contact": "grid"}, "taichi_mpm": {"threads": 1}})
    assert "warp_mpm" in res.failed and "diverged at frame" in res.failed["warp_mpm"]
    assert res.reference == "taichi_mpm"
    row = next(r for r in res.table if r["engine"] == "warp_mpm")
    assert row["status"].startswith("diverged at frame")
    assert next(r for r in res.table if r["engine"] == "taichi_mpm")["status"] == "ok"
    assert "diverged at frame" in (tmp_path / "cmp" / "report.md").read_text()


@needs_taichi
@needs_flex
@pytest.mark.slow  # several fresh worker processes, about a minute each on a loaded 2-core machine
def test_a_run_past_its_timeout_is_killed_and_the_next_run_gets_a_fresh_worker(donut_tiny, write_scene):
    scene = load_scene(write_scene(scene_text(donut_tiny, n_frames=2, n_grid=16)))
    # 2,000 frames of taichi_mpm take minutes; 15 s is far too short, and ample for 2 frames of mujoco_flex
    slow = RunSpec(scene, "taichi_mpm", {"threads": 1}, 2000, "slow")
    quick = RunSpec(scene, "mujoco_flex", {}, 2, "quick")
    with Runner(timeout_s=15.0) as runner:
        out = runner.run([slow, quick])
        assert runner.startup_s > 0
    assert out[0].record["status"] == "timeout" and "15 s" in out[0].record["message"]
    assert 15.0 <= out[0].record["run_wall_s"] < 60
    assert out[0].means is None
    assert out[1].record["status"] == "ok" and out[1].means.shape == (3, 1426, 3)


def test_frame_distances_units_and_chamfer():
    rng = np.random.default_rng(0)
    a = rng.normal(size=(200, 3))
    b = a + np.array([0.0, 0.0, 0.5])
    d = frame_distances(a, b, np.full(200, 2.0), np.array([0, 200]))
    assert d["mean_dist_m"] == pytest.approx(1.0) and d["max_dist_m"] == pytest.approx(1.0)
    assert 0 < d["chamfer_m"] <= 1.0
    perm = rng.permutation(200)                                   # same cloud, other order
    d2 = frame_distances(a, a[perm], np.ones(200), np.array([0, 200]))
    assert d2["chamfer_m"] == 0.0 and d2["mean_dist_m"] > 0


def test_pareto_front_on_synthetic_points():
    cost = [1.0, 2.0, 3.0, 4.0, 2.0, 5.0, 1.0, np.nan]
    err = [0.5, 0.2, 0.3, 0.0, 0.2, 0.0, 0.6, 0.0]
    # 0: cheapest with least error among cost 1; 1 and 4 tie (both kept); 2 dominated by 1;
    # 3: zero error; 5 dominated by 3; 6 dominated by 0; 7 NaN never on the front
    assert pareto_front(cost, err).tolist() == [True, True, False, True, True, False, False, False]
    with pytest.raises(ValueError, match="same length"):
        pareto_front([1.0], [1.0, 2.0])


def test_settings_split_into_scene_keys_and_engine_options(donut_tiny, write_scene):
    scene = load_scene(write_scene(scene_text(donut_tiny, n_grid=24)))
    s = {"n_grid": 48, "particles_per_cell": 1, "fill": False, "core_fraction": 0.5, "cfl": 0.8,
         "precision": "f64", "threads": 1, "surface": "passive"}
    sc, opts = apply_setting(scene, s, {"device": "cpu", "cfl": 0.4})
    assert (sc.domain.n_grid, sc.domain.particles_per_cell) == (48, 1)
    assert [(o.fill, o.core_fraction, o.surface) for o in sc.objects] == [(False, 0.5, "passive")]
    with pytest.raises(SceneError, match="surface: expected 'material' or 'passive'"):
        apply_setting(scene, {"surface": "hollow"}, {})
    assert opts == {"device": "cpu", "cfl": 0.8, "precision": "f64", "threads": 1}
    assert (scene.domain.n_grid, scene.objects[0].fill) == (24, True)          # the input is untouched
    assert setting_label(s) == "g48 cfl0.8 threads1 ppc1 nofill f64 core0.5 passive"
    assert setting_label({"n_grid": 96, "cfl": 0.2, "particles_per_cell": 8, "fill": True,
                          "precision": "f64", "core_fraction": 1.0}) == "g96 cfl0.2 ppc8 fill f64"


def test_plan_takes_each_engines_own_sweep_and_notes_those_without():
    base = next(iter(INSTALLED.values()))
    ref = {"n_grid": 32, "cfl": 0.2}
    swept = dataclasses.replace(base, name="a", sweep=lambda quick: ([{"n_grid": 16, "cfl": 0.4}, dict(ref)]
                                                                     if quick else [], dict(ref)))
    found = {"a": swept, "b": dataclasses.replace(base, name="b", sweep=None)}
    plan, skipped = plan_sweeps(found, ["a", "b"], True, None, None)
    assert plan == {"a": [ref, {"n_grid": 16, "cfl": 0.4}]}                    # reference first, no duplicate
    assert "no sweep" in skipped["b"]
    plan, skipped = plan_sweeps(found, ["a"], False, None, 64)
    assert plan == {} and "no settings in full mode" in skipped["a"]
    plan, _ = plan_sweeps(found, ["a", "b"], True, {"b": [{"cfl": 0.1}, {"cfl": 0.5}]}, 64)
    # a finer reference grid: the sweep's own reference setting becomes an ordinary run
    assert plan == {"a": [{"n_grid": 64, "cfl": 0.2}, {"n_grid": 16, "cfl": 0.4}, {"n_grid": 32, "cfl": 0.2}],
                    "b": [{"cfl": 0.1}, {"cfl": 0.5}]}


@needs_warp
def test_bench_rows_reference_zero_and_error_grows_as_grid_coarsens(donut_tiny, write_scene, tmp_path, capsys):
    scene = write_scene(scene_text(donut_tiny, n_frames=4, n_grid=24, engine="warp_mpm", engine_options="{}"))
    out = tmp_path / "bench"
    # reference: the finest grid in f64; then f32 on three grids
    sweep = [{"n_grid": 24, "cfl": 0.4, "precision": "f64"}] + \
            [{"n_grid": g, "cfl": 0.4, "precision": "f32"} for g in (14, 18, 24)]
    # progress on, as gasp bench runs it (round 100: its strips line raised NameError, an exit-1 bug, after every run)
    res = bench_scene(scene, out, engines=["warp_mpm"], n_frames=4, progress=True,
                      settings={"warp_mpm": sweep}, options={"warp_mpm": deterministic("warp_mpm")})
    assert "gasp bench: strips: " in capsys.readouterr().err
    cols, rows = _read_csv(out / "bench.csv")
    assert cols == report.bench_columns(["cfl", "precision"]) == res.columns
    assert len(rows) == 4 and len({r["setting"] for r in rows}) == 4
    assert rows[0]["is_reference"] == "True" and float(rows[0]["err_mean"]) == 0.0
    assert all(r["status"] == "ok" for r in rows), [r["message"] for r in rows]
    f32 = {int(r["n_grid"]): float(r["err_max"]) for r in rows if r["precision"] == "f32"}
    # same grid as the reference, f32 instead of f64: rounding only; coarser grids: discretisation
    assert f32[24] < 1e-4 < f32[18] < f32[14]
    assert all(float(r["wall_s"]) > 0 for r in rows)
    for r in rows:   # end to end: read, fill, build, frame 1 and the T^-1 rebuilds on top of frames 2..n
        steady = 3 * float(r["s_per_frame"])
        assert float(r["end_to_end_s"]) > steady + float(r["build_s"]) + float(r["prepare_s"])
    for name in ("summary.md", "pareto_warp_mpm.png", "pareto.png"):
        assert (out / name).stat().st_size > 0
    assert rows[0]["pareto"] == "True"                               # error 0: nothing beats it
    assert float(rows[0]["ke_vs_ref"]) == 1.0 and all(0.0 <= float(r["ke_left"]) <= 1.0 for r in rows)  # energy
    assert "warp_mpm" in res.summary and "within 1 %" in (out / "summary.md").read_text()
    assert len(list((out / "runs").glob("*.json"))) == 4
    # the converged reference: the reference's model on the three grids (f64 at 24, f32 at 14 and 18)
    assert {r["ref_method"] for r in rows} in ({"richardson [14, 18, 24]"}, {"finest [18, 24]"})
    bound = float(rows[0]["ref_bound"])
    if rows[0]["ref_method"].startswith("richardson"):    # the reference's own distance to the extrapolation
        assert bound > 0 and float(rows[0]["err_conv_max"]) == pytest.approx(bound)
    else:   # no order of convergence: the finest run is the converged reference, uncertain by its distance to 18
        assert bound > 0 and float(rows[0]["err_conv_max"]) == 0.0
    if bound >= 0.01:   # a coarse sequence: the 1 % tolerance is finer than the reference knows
        assert "not ranked" in (out / "summary.md").read_text()
    # the accuracy report's ranking: U from the twin (g18 f32, the reference's model one grid coarser)
    text = (out / "summary.md").read_text()
    assert "## Ranking" in text and "twin `g18" in text
    assert "U = shape" in text and "PSNR" in text
    by = {int(r["n_grid"]): r for r in rows if r["precision"] == "f32"}
    assert float(by[18]["shape_u"]) == pytest.approx(1.0)          # the twin is 1 U by definition
    assert float(by[24]["shape_u"]) < 0.1 < float(by[14]["shape_u"])  # rounding only; a coarser grid
    assert float(by[24]["psnr_db"]) > float(by[18]["psnr_db"]) > float(by[14]["psnr_db"])


def test_reports_without_matplotlib_say_so(tmp_path, monkeypatch):
    monkeypatch.setattr(report, "_pyplot", lambda: None)
    rows = [{"engine": "e", "setting": "g8", "status": "ok", "is_reference": True, "wall_s": 1.0,
             "err_mean": 0.0, "err_max": 0.0, "err_final": 0.0, "pareto": True}]
    assert report.bench_plots(tmp_path, rows, ["e"]) is False
    report.bench_summary(tmp_path / "summary.md", scene_name="s", scene_path="s.toml", n_frames=2, frame_dt=0.1,
                         rows=rows, engines=["e"], skipped={}, strides=[1], total_s=1.0, runner_line="",
                         plots=False)
    assert report.NO_PLOTS in (tmp_path / "summary.md").read_text()
    assert not list(tmp_path.glob("*.png"))


def test_no_engine_is_named_in_gasp_studies():
    import gasp_studies
    pattern = re.compile(r"taichi|warp|mujoco|genesis|blender", re.I)
    for path in Path(gasp_studies.__file__).parent.glob("*.py"):
        hits = [line for line in path.read_text().splitlines() if pattern.search(line)]
        assert not hits, (path.name, hits)


def test_compare_with_an_unreachable_scheduler_is_one_line(tmp_path, monkeypatch, capsys, donut_small):
    # issue 41: the plan line ("gasp compare: 1 run(s) of 1 frames: ...") came before the one-line error
    import gasp_studies.run
    monkeypatch.setattr(gasp_studies.run, "CONNECT_TIMEOUT", "1s")
    scene = tmp_path / "s.toml"
    scene.write_text(scene_text(donut_small, n_frames=1))
    code = main(["compare", str(scene), "--engines", "taichi_mpm", "--scheduler", "tcp://127.0.0.1:1",
                 "-o", str(tmp_path / "cmp"), "--strip-frames", "0"])
    err = [line for line in capsys.readouterr().err.splitlines() if line.strip()]
    assert code == 2 and len(err) == 1 and err[0].startswith("gasp: error: --scheduler tcp://127.0.0.1:1"), err
    assert not (tmp_path / "cmp").exists()
