"""Round 102's hostile inputs, each taken without a word, refused for the wrong cause or treated two ways:

1. ``gasp simulate -o LINK --overwrite`` where ``LINK`` is a symbolic link to an earlier run: the link was replaced
   by a new folder and the old run left at its target with the new run's claim file in it; an output folder that
   is a symbolic link is now refused (with or without ``--overwrite``), naming the link and its target, and nothing
   is touched;
2. an object whose Gaussians all lie at one point (fewer than ``MAX_AT_ONE_POINT``, which are refused) simulated
   as one blob without a word; it is warned about, naming the file, the count and the point (a single Gaussian,
   and Gaussians spread apart, stay quiet; an object of invisible Gaussians was already warned about, round 101);
3. ``gasp compare`` and ``gasp bench`` took ``--timeout inf`` (no limit), ``nan`` and negative numbers (refused
   later by the runner as ``timeout_s``, not naming the flag), and ``--strip-frames 100000000``; both are argparse
   errors now, naming the flag and what is expected (``--strip-frames`` from 0 to 100);
4. a text file given as ``select = { mask = ... }`` was refused with numpy's "This file contains pickled (object)
   data ... allow_pickle" and an empty one with "No data left in file"; one line now names the file and the format
   expected;
5. a ``.spz`` of no splats (``gasp`` writes one) was refused as "0 splats" by every reader while a PLY of 0
   vertices reads as no Gaussians: both now read as no Gaussians (``gasp info`` says ``count: 0``), and a scene
   refuses either with the same line ("the file has 0 Gaussians; nothing to simulate").

Each case takes a second or two at most (no engine is built).
"""
from __future__ import annotations

import importlib.util
import warnings
from pathlib import Path

import numpy as np
import pytest
from gasp_testing import scene_text

from gasp_core.cli.main import main
from gasp_core.errors import GaspError, SceneError
from gasp_core.fsmarker import CLAIM
from gasp_core.fsutil import OutputClaim, atomic_json
from gasp_core.gs.gaussians import Gaussians
from gasp_core.gs.io import read_gaussians


def one_error(err: str, code: int, expected: int = 2) -> str:
    lines = [ln for ln in err.splitlines() if ln.strip() and not ln.startswith("gasp: warning:")]
    assert code == expected and len(lines) == 1 and lines[0].startswith("gasp: error:"), (code, err)
    assert "Traceback" not in err
    return lines[0]


def gaussians(n: int = 3, **fields) -> Gaussians:
    d = dict(means=np.arange(3 * n, dtype=float).reshape(n, 3) * 0.1, scales=np.full((n, 3), 0.01),
             rotations=np.tile([1.0, 0, 0, 0], (n, 1)), opacities=np.zeros(n), sh_dc=np.zeros((n, 3)))
    d.update(fields)
    return Gaussians(**d)


def tree(folder: Path) -> dict:
    """Every file under ``folder`` and its bytes (what a refusal must leave as it was)."""
    return {str(p.relative_to(folder)): p.read_bytes() for p in sorted(folder.rglob("*")) if p.is_file()}


# 1. ------------------------------------------------------------------------------------------------------------
def finished_run(out: Path) -> Path:
    """A gasp output folder as a finished run leaves it (claimed, written, committed)."""
    claim = OutputClaim(out)
    tmp = claim.partial_dir()
    (tmp / "obj").mkdir()
    (tmp / "obj" / "frame_0000.ply").write_bytes(b"ply")
    atomic_json(tmp / "frames.json", {"objects": [{"name": "obj"}]})
    atomic_json(tmp / "run.json", {"objects": [{"name": "obj"}]})
    claim.commit(tmp)
    return out


@pytest.mark.parametrize("overwrite", [True, False])
def test_an_output_folder_that_is_a_symlink_is_refused_naming_its_target(tmp_path, overwrite):
    """Before: with ``overwrite`` the claim went through the link (its claim file written into the old run), and the
    commit put the new folder in the link's place; without it, "exists; pass --overwrite" led there."""
    old = finished_run(tmp_path / "old")
    before = tree(old)
    link = tmp_path / "out"
    link.symlink_to(old, target_is_directory=True)
    with pytest.raises(GaspError, match=rf"output folder '{link}' is a symbolic link \(to '{old}'\)"):
        OutputClaim(link, overwrite=overwrite)
    assert link.is_symlink() and tree(old) == before and not (old / CLAIM).exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["old", "out"]


def test_a_dangling_symlink_as_output_is_refused(tmp_path):
    link = tmp_path / "out"
    link.symlink_to(tmp_path / "gone")
    with pytest.raises(GaspError, match="is a symbolic link"):
        OutputClaim(link, overwrite=True)
    assert link.is_symlink() and not (tmp_path / "gone").exists()


def test_simulate_into_a_symlink_is_one_line_and_leaves_the_old_run(tmp_path, donut_small, capsys):
    old = finished_run(tmp_path / "old")
    before = tree(old)
    link = tmp_path / "out"
    link.symlink_to(old, target_is_directory=True)
    scene = tmp_path / "s.toml"
    scene.write_text(scene_text(donut_small, n_frames=1, n_grid=16))
    code = main(["simulate", str(scene), "-o", str(link), "--overwrite", "-q"])
    line = one_error(capsys.readouterr().err, code)
    assert f"'{link}' is a symbolic link (to '{old}')" in line, line
    assert link.is_symlink() and tree(old) == before


def test_a_real_output_folder_is_still_replaced_under_overwrite(tmp_path):
    out = finished_run(tmp_path / "out")
    claim = OutputClaim(out, overwrite=True)
    tmp = claim.partial_dir()
    atomic_json(tmp / "run.json", {"objects": []})
    atomic_json(tmp / "frames.json", {"objects": []})
    claim.commit(tmp)
    assert not (out / "obj").exists() and (out / "run.json").is_file()


# 2. ------------------------------------------------------------------------------------------------------------
def one_point_warnings(tmp_path, g) -> list[str]:
    from gasp_core.prepare.checks import check_object
    from gasp_core.scene.spec import ObjectSpec
    with warnings.catch_warnings(record=True) as got:
        warnings.simplefilter("always")
        check_object(ObjectSpec(file=tmp_path / "dot.ply"), g)
    return [str(w.message) for w in got if "one point" in str(w.message)]


@pytest.mark.parametrize("n", [2, 5, 1000])
def test_an_object_of_gaussians_all_at_one_point_is_warned_about(tmp_path, n):
    """Before: up to 1000 Gaussians at one point simulated as one blob without a word (more are refused)."""
    said = one_point_warnings(tmp_path, gaussians(n, means=np.tile([0.1, -0.0, 0.3], (n, 1))))
    assert len(said) == 1, said
    assert "dot.ply" in said[0] and f"all {n} Gaussians lie at one point (0.1, 0, 0.3)" in said[0], said


@pytest.mark.parametrize("case", ["one_gaussian", "spread", "spread_on_one_axis"])
def test_a_single_gaussian_or_a_spread_object_is_quiet(tmp_path, case):
    means = {"one_gaussian": np.zeros((1, 3)), "spread": np.arange(9.0).reshape(3, 3),
             "spread_on_one_axis": np.array([[0.0, 0, 0], [0, 0, 1e-6], [0, 0, 0]])}[case]
    assert one_point_warnings(tmp_path, gaussians(len(means), means=means)) == []


def test_more_than_the_bound_at_one_point_is_still_refused(tmp_path):
    from gasp_core.gs.io import MAX_AT_ONE_POINT
    n = MAX_AT_ONE_POINT + 1
    with pytest.raises(SceneError, match=f"all {n:,} Gaussians lie at one point"):
        one_point_warnings(tmp_path, gaussians(n, means=np.zeros((n, 3))))


# 3. ------------------------------------------------------------------------------------------------------------
@pytest.mark.parametrize("command", ["compare", "bench"])
@pytest.mark.parametrize("value", ["inf", "nan", "-1", "0", "-inf", "1e400"])
def test_a_study_timeout_not_finite_and_positive_is_refused_naming_the_flag(tmp_path, capsys, command, value):
    """Before: ``inf`` ran with no limit; ``nan``, ``0`` and ``-1`` were refused by the runner as ``timeout_s``
    (after the scene was read), not naming ``--timeout``. The scene here does not exist: argparse answers first."""
    with pytest.raises(SystemExit) as done:
        main([command, str(tmp_path / "none.toml"), "-o", str(tmp_path / "out"), f"--timeout={value}"])
    line = one_error(capsys.readouterr().err, done.value.code)
    assert "argument --timeout" in line and "positive finite number" in line and repr(value) in line, line
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize("command", ["compare", "bench"])
@pytest.mark.parametrize("value", ["101", "100000000", "-1", "1e8", "six"])
def test_strip_frames_outside_0_to_100_is_refused_naming_the_flag(tmp_path, capsys, command, value):
    """Before: ``100000000`` (and ``-1``, later, by the studies) was taken; now the flag's range is said."""
    with pytest.raises(SystemExit) as done:
        main([command, str(tmp_path / "none.toml"), "-o", str(tmp_path / "out"), f"--strip-frames={value}"])
    line = one_error(capsys.readouterr().err, done.value.code)
    assert "argument --strip-frames" in line and "[0, 100]" in line and repr(value) in line, line


def test_good_study_flags_still_parse():
    from gasp_core.cli.main import build_parser
    for command in ("compare", "bench"):
        a = build_parser().parse_args([command, "s.toml", "-o", "out", "--timeout", "0.5", "--strip-frames", "100"])
        assert a.timeout == 0.5 and a.strip_frames == 100
        a = build_parser().parse_args([command, "s.toml", "-o", "out", "--strip-frames", "0"])
        assert a.timeout is None and a.strip_frames == 0


# 4. ------------------------------------------------------------------------------------------------------------
MASKS = {"text": b"1 2 3\n", "empty": b"", "csv": b"true,false,true\n", "pickle_like": b"\x80\x04K\x01."}


@pytest.mark.parametrize("content", sorted(MASKS))
def test_a_select_mask_that_is_not_npy_names_the_file_and_the_format(tmp_path, content):
    """Before: "This file contains pickled (object) data. If you trust the file you can load it unsafely using the
    `allow_pickle=` keyword argument or `pickle.load()`." (text), "No data left in file" (empty)."""
    from gasp_core.prepare.selection import region_rows
    from gasp_core.scene.select import SelectSpec
    from gasp_core.scene.spec import ObjectSpec
    mask = tmp_path / "picked.npy"
    mask.write_bytes(MASKS[content])
    spec = ObjectSpec(file=tmp_path / "obj.ply", select=SelectSpec(kind="mask", mask=mask))
    with pytest.raises(SceneError) as e:
        region_rows(spec, gaussians(3), None)
    msg = str(e.value)
    assert f"'{mask}' is not a .npy file" in msg and "numpy.save" in msg and "(3)" in msg, msg
    assert "pickle" not in msg and "\n" not in msg


def test_a_text_mask_through_simulate_is_one_line(tmp_path, donut_small, capsys):
    (tmp_path / "m.txt").write_text("0\n1\n2\n")
    scene = tmp_path / "s.toml"
    scene.write_text(scene_text(donut_small, n_frames=1, n_grid=16, extra_object='select = { mask = "m.txt" }'))
    code = main(["simulate", str(scene), "-o", str(tmp_path / "out"), "-q"])
    line = one_error(capsys.readouterr().err, code)
    assert "m.txt' is not a .npy file" in line and "pickle" not in line, line
    assert not (tmp_path / "out").exists()


def test_a_good_mask_still_selects(tmp_path):
    from gasp_core.prepare.selection import region_rows
    from gasp_core.scene.select import SelectSpec
    from gasp_core.scene.spec import ObjectSpec
    for a in (np.array([True, False, True]), np.array([2, 0])):
        np.save(tmp_path / "m.npy", a)
        spec = ObjectSpec(file=tmp_path / "obj.ply", select=SelectSpec(kind="mask", mask=tmp_path / "m.npy"))
        assert region_rows(spec, gaussians(3), None).tolist() == [0, 2]


# 5. ------------------------------------------------------------------------------------------------------------
EMPTY = [pytest.param("ply", id="ply"),
         pytest.param("spz", id="spz", marks=pytest.mark.skipif(importlib.util.find_spec("gsply") is None,
                                                                reason="gsply is not installed"))]


@pytest.mark.parametrize("fmt", EMPTY)
def test_a_file_of_no_gaussians_reads_alike_in_ply_and_spz(tmp_path, fmt, capsys):
    """Before: the ``.spz`` gasp wrote was refused on reading ("0 splats; expected at least one Gaussian") while the
    PLY read as no Gaussians; ``gasp info`` said ``count: 0`` of one and refused the other."""
    from gasp_core.gs import registry
    path = registry.write(tmp_path / f"none{registry.get(fmt).suffix}", gaussians(0), fmt)
    assert read_gaussians(path).n == 0
    assert main(["info", str(path)]) == 0
    assert "count: 0" in capsys.readouterr().out


@pytest.mark.parametrize("fmt", EMPTY)
def test_a_scene_of_no_gaussians_is_refused_alike_in_ply_and_spz(tmp_path, donut_small, capsys, fmt):
    from gasp_core.gs import registry
    path = registry.write(tmp_path / f"none{registry.get(fmt).suffix}", gaussians(0), fmt)
    scene = tmp_path / "s.toml"
    scene.write_text(scene_text(path, n_frames=1, n_grid=16))
    code = main(["simulate", str(scene), "-o", str(tmp_path / "out"), "-q"])
    line = one_error(capsys.readouterr().err, code)
    assert f"{path}: the file has 0 Gaussians; nothing to simulate" in line, line
    assert not (tmp_path / "out").exists()
