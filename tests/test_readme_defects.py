"""The README-line defects of issue 55, each on its own, fast (the README run itself: tests/test_readme.py).

Each test failed on the issue's base (3ad98bd): the relative path ``gasp info --rho`` read twice, ``--resume`` of a
finished run called a blow-up, a library's warning shown as GASP's own, Dask's dashboard on the taken port 8787,
``velocity`` missing from the scene reference's key block, and "dropped 5 cm" for a 10 cm drop.
"""
import json
import re
import socket
import warnings
from pathlib import Path

import pytest

from gasp_core.errors import GaspError
from gasp_core.fsutil import PARTIAL_INFIX
from gasp_core.run import resume

ROOT = Path(__file__).resolve().parents[1]


def test_info_with_rho_reads_a_relative_path_once(monkeypatch):
    """``gasp info examples/data/donut_v3dg.ply --rho 300`` from the clone's root: the stand estimate's scene
    took the path relative to the file's own folder (examples/data/examples/data/...)."""
    from gasp_core.cli.info import info
    monkeypatch.chdir(ROOT)
    d = info(Path("examples/data/donut_v3dg.ply"), rho=300.0)
    assert d["mass_kg"] > 0 and d["stand_E_crit_Pa"] > 0
    whole = info(ROOT / "examples/data/donut_v3dg.ply", rho=300.0)
    assert d["stand_E_crit_Pa"] == whole["stand_E_crit_Pa"] and d["mass_kg"] == whole["mass_kg"]


def _run_folder(tmp_path, record):
    out = tmp_path / "donut"
    out.mkdir()
    (out / "run.json").write_text(json.dumps(record))
    return out


def test_resume_of_a_finished_run_says_it_is_finished(tmp_path):
    out = _run_folder(tmp_path, {"n_frames": 36, "engine": "x"})
    with pytest.raises(GaspError) as e:
        resume.refuse_unresumable(out)
    msg = str(e.value)
    assert "finished (36 frames" in msg and "--overwrite" in msg and "frame 0" in msg, msg
    assert "diverged" not in msg and "blow-up" not in msg, msg


def test_resume_of_a_killed_run_beside_a_finished_one_goes_on(tmp_path):
    """A finished run re-run with --overwrite and killed: its partial folder with a checkpoint is resumed."""
    out = _run_folder(tmp_path, {"n_frames": 36})
    partial = tmp_path / f".donut{PARTIAL_INFIX}1"
    partial.mkdir()
    (partial / resume.CHECKPOINT).write_bytes(b"")
    resume.refuse_unresumable(out)       # no error: find_resumable takes it from here


def test_resume_of_a_diverged_run_still_names_the_blow_up(tmp_path):
    out = _run_folder(tmp_path, {"n_frames": 36, "status": "diverged", "diverged": {"frame": 7}})
    with pytest.raises(GaspError, match="diverged at frame 7"):
        resume.refuse_unresumable(out)
    resume.refuse_unresumable(tmp_path / "none")     # no run.json: nothing refused here


def test_a_library_warning_is_shown_as_the_library_s():
    """One line, naming the package it came from; GASP's own warnings stay as they were."""
    from gasp_core.cli.main import _show_warning
    seen = []

    class R:
        def warning(self, text):
            seen.append(text)
    site = "/venv/lib/python3.11/site-packages/distributed/node.py"
    _show_warning(R(), UserWarning("Port 8787 is already in use.\nPerhaps you already have a cluster running?"),
                  UserWarning, site, 195)
    _show_warning(R(), UserWarning("the fill left 3 pieces"), UserWarning, str(ROOT / "gasp_core/maps/fill.py"), 1)
    _show_warning(R(), UserWarning("x"), UserWarning, "/venv/lib/python3.11/site-packages/gasp_warp_mpm/e.py", 1)
    assert seen[0] == ("from distributed (a library GASP uses, not GASP itself): Port 8787 is already in use. "
                       "Perhaps you already have a cluster running?")
    assert seen[1:] == ["the fill left 3 pieces", "x"]
    # a library's deprecation is its developers' business: taichi 1.7's locale one made one error two lines
    # (tests/test_hostile_68.py run alone); GASP's own deprecations are still said
    _show_warning(R(), DeprecationWarning("'locale.getdefaultlocale' is deprecated"), DeprecationWarning,
                  "/venv/lib/python3.12/site-packages/taichi/_lib/utils.py", 1)
    _show_warning(R(), DeprecationWarning("option x is renamed y"), DeprecationWarning,
                  str(ROOT / "gasp_core/seam/config.py"), 1)
    assert seen[3:] == ["option x is renamed y"], seen


def test_the_studies_cluster_says_nothing_when_port_8787_is_taken():
    """``gasp compare`` started Dask's dashboard on 8787 and printed its "Port 8787 is already in use"."""
    pytest.importorskip("distributed", reason="the studies extra: python -m pip install -e '.[studies]'")
    from gasp_studies.run import Runner
    held = socket.socket()
    try:
        held.bind(("", 8787))
        held.listen()
    except OSError:
        pass                      # already taken by someone else: the case itself
    try:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            with Runner(workers=1):
                pass
        said = [str(w.message) for w in caught if "8787" in str(w.message)]
        assert not said, said
    finally:
        held.close()


def test_velocity_is_in_the_scene_reference_key_block():
    text = (ROOT / "docs/scene_reference.md").read_text(encoding="utf-8")
    block = re.search(r"## Scene files\n.*?^```toml\n(.*?)^```", text, re.S | re.M).group(1)
    assert re.search(r"^velocity = \[", block, re.M), "velocity, the object's initial velocity, in the key block"


def test_the_contact_benchmark_says_the_drop_it_makes():
    """contact_mustshow places the ball's bottom (``position`` is the bottom centre) at RADIUS + DROP: 10 cm."""
    src = (ROOT / "benchmarks/contact_mustshow.py").read_text(encoding="utf-8")
    radius, drop = (float(x) for x in re.search(r"N, RADIUS, DROP, JITTER = \d+, ([\d.]+), ([\d.]+)", src).groups())
    assert "position = [0.0, 0.0, {RADIUS + DROP}]" in src
    said = f"{round((radius + drop) * 100)} cm"
    assert "dropped 5 cm" not in src and said in src
    doc = (ROOT / "docs/contact.md").read_text(encoding="utf-8")
    line = next(ln for ln in doc.splitlines() if "friction 0.5" in ln and "contact_mustshow.py" in ln)
    assert f"dropped {said}" in line, line
