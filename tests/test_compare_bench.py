"""``gasp compare`` and ``gasp bench`` on a tiny cut of the real donut (every 32nd Gaussian)."""
import csv
from pathlib import Path

import numpy as np
import pytest

from gasp_testing import scene_text
from gasp_core.bench import BENCH_COLUMNS, bench_scene, mpm_sweep, pareto_front
from gasp_core.cli import main
from gasp_core.compare import DIVERGENCE_COLUMNS, TABLE_COLUMNS, compare_scene, frame_distances, select_engines
from gasp_core.io import write_gaussians
from gasp_core.plugins import engines
from gasp_core.scene import load_scene

INSTALLED = engines()
needs_warp = pytest.mark.skipif("warp_mpm" not in INSTALLED, reason="warp_mpm not installed")
needs_flex = pytest.mark.skipif("mujoco_flex" not in INSTALLED, reason="mujoco_flex not installed")


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
def test_compare_writes_report_self_divergence_zero_and_lists_missing(donut_tiny, write_scene, tmp_path):
    scene = write_scene(scene_text(donut_tiny, n_frames=3, n_grid=16, engine="warp_mpm",
                                   engine_options="{ threads = 1 }"))
    out = tmp_path / "cmp"
    res = compare_scene(scene, ["warp_mpm", "warp_mpm", "mujoco_flex", "no_such_engine"], out, progress=False)
    for name in ("table.csv", "table.md", "divergence.csv", "divergence.png", "timing.png", "report.md"):
        assert (out / name).stat().st_size > 0, name
    cols, table = _read_csv(out / "table.csv")
    assert cols == TABLE_COLUMNS
    assert [r["engine"] for r in table] == ["warp_mpm", "warp_mpm#2", "mujoco_flex"]
    assert all(r["status"] == "ok" and int(r["simulated_points"]) > 3 * 1426 for r in table)
    assert all(float(r["s_per_frame"]) > 0 and float(r["peak_rss_mb"]) > 50 for r in table)
    cols, div = _read_csv(out / "divergence.csv")
    assert cols == DIVERGENCE_COLUMNS
    assert {r["reference"] for r in div} == {"warp_mpm"}
    again = [r for r in div if r["engine"] == "warp_mpm#2"]
    assert [int(r["frame"]) for r in again] == [0, 1, 2, 3]
    # the same deterministic engine twice: exactly zero, on every metric and frame
    assert all(float(r[k]) == 0.0 for r in again for k in ("mean_dist_m", "max_dist_m", "chamfer_m"))
    flex = [r for r in div if r["engine"] == "mujoco_flex"]
    assert float(flex[0]["max_dist_m"]) == 0.0                       # frame 0 is the input for both
    assert float(flex[-1]["mean_dist_m"]) > 0.0                      # different solvers differ later
    assert float(flex[-1]["chamfer_m"]) <= float(flex[-1]["mean_dist_m"]) + 1e-12  # NN <= same-index
    assert "no_such_engine" in res.skipped and "not installed" in res.skipped["no_such_engine"]
    report = (out / "report.md").read_text()
    assert "no_such_engine" in report and "not installed" in report
    assert not list(tmp_path.glob(".cmp.partial-*"))                 # temp folder moved into place


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


@needs_flex
def test_missing_capability_is_listed_with_reason(donut_tiny, write_scene):
    scene = load_scene(write_scene(scene_text(donut_tiny, material='name = "sand"\nE = 1e5\nnu = 0.3\nrho = 1500.0')))
    runnable, skipped = select_engines(scene, ["mujoco_flex", "not_here"])
    assert runnable == []
    assert "material 'sand'" in skipped["mujoco_flex"]
    assert "not installed" in skipped["not_here"]


@needs_warp
@needs_flex
def test_compare_reports_a_diverging_engine_and_runs_the_others(donut_tiny, write_scene, tmp_path):
    scene = write_scene(scene_text(donut_tiny, n_frames=3, n_grid=16, engine="mujoco_flex",
                                   engine_options="{}", material='name = "jelly"\nE = 2.0e6\nnu = 0.3\nrho = 300.0'))
    # one substep per frame: ~300x above the elastic-wave limit at n_grid 16
    res = compare_scene(scene, ["warp_mpm", "mujoco_flex"], tmp_path / "cmp", progress=False,
                        options={"warp_mpm": {"n_substeps": 1}})
    assert "warp_mpm" in res.failed and "diverged at frame" in res.failed["warp_mpm"]
    assert res.reference == "mujoco_flex"
    row = next(r for r in res.table if r["engine"] == "warp_mpm")
    assert row["status"].startswith("diverged at frame")
    assert next(r for r in res.table if r["engine"] == "mujoco_flex")["status"] == "ok"
    assert "diverged at frame" in (tmp_path / "cmp" / "report.md").read_text()


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


def test_mpm_sweep_reference_is_finest_and_unique():
    s = mpm_sweep((32, 48, 64), (0.2, 0.4, 0.8), (1, 8), (True, False), ("f32", "f64"), (1.0, 0.5))
    assert s[0] == {"n_grid": 64, "cfl": 0.2, "particles_per_cell": 8, "fill": True,
                    "precision": "f64", "core_fraction": 1.0}
    keys = [tuple(sorted(x.items())) for x in s]
    assert len(keys) == len(set(keys))
    assert {(x["n_grid"], x["cfl"]) for x in s if x["precision"] == "f32"} >= \
        {(g, c) for g in (32, 48, 64) for c in (0.2, 0.4, 0.8)}


@needs_warp
def test_bench_rows_reference_zero_and_error_grows_as_grid_coarsens(donut_tiny, write_scene, tmp_path):
    scene = write_scene(scene_text(donut_tiny, n_frames=4, n_grid=24, engine="warp_mpm",
                                   engine_options="{ threads = 1 }"))
    out = tmp_path / "bench"
    kw = dict(n_grid=(14, 18, 24), cfl=(0.4,), particles_per_cell=(8,), fill=(True,),
              precision=("f32", "f64"), core_fraction=(1.0,))
    res = bench_scene(scene, out, engines=["warp_mpm"], n_frames=4, progress=False, **kw)
    cols, rows = _read_csv(out / "bench.csv")
    assert cols == BENCH_COLUMNS
    expected = mpm_sweep(kw["n_grid"], kw["cfl"], kw["particles_per_cell"], kw["fill"], kw["precision"],
                         kw["core_fraction"])
    assert len(rows) == len(expected)
    assert len({r["setting"] for r in rows}) == len(rows)
    assert rows[0]["is_reference"] == "True" and float(rows[0]["err_mean"]) == 0.0
    assert all(r["status"] == "ok" for r in rows), [r["message"] for r in rows]
    f32 = {int(r["n_grid"]): float(r["err_max"]) for r in rows if r["precision"] == "f32"}
    # same grid as the reference, f32 instead of f64: rounding only; coarser grids: discretisation
    assert f32[24] < 1e-4 < f32[18] < f32[14]
    assert all(float(r["wall_s"]) > 0 for r in rows)
    for name in ("summary.md", "pareto_warp_mpm.png", "pareto.png"):
        assert (out / name).stat().st_size > 0
    assert rows[0]["pareto"] == "True"                               # error 0: nothing beats it
    worst = max(rows, key=lambda r: float(r["err_max"]))
    assert worst["pareto"] == ("True" if float(worst["wall_s"]) == min(float(r["wall_s"]) for r in rows) else "False")
    assert "warp_mpm" in res.summary and "within 1 %" in (out / "summary.md").read_text()
