"""Output folders: claimed at start, committed only if still ours, never replacing what the run did not make."""
import json
import os
import stat

import pytest

from gasp_core.errors import GaspError
from gasp_core.fsutil import CLAIM, OutputClaim, OutputConflict, atomic_json, atomic_write, leftover_partials


def finished_run(claim: OutputClaim, objects=("obj",)) -> None:
    """Write what a finished run writes into a partial folder, then commit it."""
    tmp = claim.partial_dir()
    for name in objects:
        (tmp / name).mkdir()
        (tmp / name / "frame_0000.ply").write_bytes(b"ply")
    atomic_json(tmp / "run.json", {"objects": [{"name": n} for n in objects]})
    claim.commit(tmp)


def test_two_runs_to_one_folder_exactly_one_gets_it(tmp_path):
    out = tmp_path / "res"
    first = OutputClaim(out)
    with pytest.raises(FileExistsError, match="res"):
        OutputClaim(out)
    with pytest.raises(FileExistsError, match="another gasp run"):
        OutputClaim(out, overwrite=True)  # even --overwrite does not take a folder in use
    finished_run(first)
    assert (out / "run.json").exists() and not (out / CLAIM).exists()


def test_a_file_added_during_the_run_is_never_deleted(tmp_path):
    out = tmp_path / "res"
    claim = OutputClaim(out)
    (out / "precious.txt").write_text("x")
    with pytest.raises(OutputConflict, match="gained entries") as e:
        finished_run(claim)
    assert (out / "precious.txt").read_text() == "x"
    kept = [p for p in tmp_path.iterdir() if p.name.startswith(".res.partial-")]
    assert len(kept) == 1 and str(kept[0]) in str(e.value)     # the results are kept and named


def test_overwrite_replaces_only_a_gasp_output(tmp_path):
    out = tmp_path / "res"
    finished_run(OutputClaim(out), objects=("old",))
    finished_run(OutputClaim(out, overwrite=True), objects=("new",))
    assert sorted(p.name for p in out.iterdir()) == [".gasp-output", "new", "run.json"]
    mine = tmp_path / "mine"
    mine.mkdir()
    (mine / "thesis.tex").write_text("x")
    with pytest.raises(GaspError, match="not a gasp output"):
        OutputClaim(mine, overwrite=True)
    assert (mine / "thesis.tex").exists() and not (mine / CLAIM).exists()
    assert not [p for p in tmp_path.iterdir() if ".old-" in p.name]


def test_overwrite_refuses_inputs_the_scene_and_the_working_directory(tmp_path, monkeypatch):
    data = tmp_path / "data"
    data.mkdir()
    ply = data / "in.ply"
    ply.write_bytes(b"ply")
    monkeypatch.chdir(tmp_path)
    for target in (tmp_path, data, ply, tmp_path / "."):
        with pytest.raises(GaspError, match="is, contains or lies above"):
            OutputClaim(target, overwrite=True, protected=[ply])
    assert ply.read_bytes() == b"ply"
    other = tmp_path / "other.ply"
    other.write_bytes(b"ply")
    with pytest.raises(GaspError, match="not a folder"):
        OutputClaim(other, overwrite=True)
    assert other.read_bytes() == b"ply"


def test_failed_run_gives_the_folder_back(tmp_path):
    out = tmp_path / "res"
    claim = OutputClaim(out)
    claim.release()
    assert not out.exists()


@pytest.mark.skipif(os.geteuid() == 0, reason="root ignores permission bits")
def test_read_only_parent_is_one_clear_error(tmp_path):
    ro = tmp_path / "ro"
    ro.mkdir()
    ro.chmod(0o555)
    try:
        with pytest.raises(GaspError, match="permission denied"):
            OutputClaim(ro / "res")
    finally:
        ro.chmod(0o755)


def test_files_follow_the_umask_not_mkstemp(tmp_path):
    old = os.umask(0o022)
    try:
        p = atomic_write(tmp_path / "a.bin", lambda f: f.write(b"x"))
        d = OutputClaim(tmp_path / "res").partial_dir()
    finally:
        os.umask(old)
    assert stat.S_IMODE(p.stat().st_mode) == 0o644
    assert stat.S_IMODE(d.stat().st_mode) == 0o755


def test_leftover_partial_of_a_killed_run_is_found(tmp_path):
    out = tmp_path / "res"
    dead = tmp_path / ".res.partial-abc"
    dead.mkdir()
    (dead / ".gasp-pid").write_text("999999999")
    live = OutputClaim(out).partial_dir()          # this process: alive, not a leftover
    assert leftover_partials(out) == [dead]
    assert live.exists()
    json.dumps([str(p) for p in leftover_partials(out)])
