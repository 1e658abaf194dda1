"""The studio runs what its user is about to ask for while they choose (issue 39 item 4): a held run
(:mod:`gasp_core.studio.warm`, ``gasp simulate --hold``) starts when a file opens, the page says so while it
prepares; Run on that choice takes it over, Run on another stops and removes it. The layout's points (no material
preselected, Run asks for one).

The process is replaced by a stand-in here (no compile time); the real one, and the time it saves, are in
tests/test_hold.py, tests/test_studio_browser.py and docs/studio.md ("Time to the first frame")."""
import threading
import time
import tomllib
from pathlib import Path

import numpy as np
import pytest

from gasp_core.fsmarker import CLAIM

pytest.importorskip("viser", reason='the view extra is not installed: python -m pip install -e ".[view]"')
pytest.importorskip("tomli_w", reason='the view extra is not installed: python -m pip install -e ".[view]"')

DONUT = Path(__file__).resolve().parents[1] / "examples" / "data" / "donut_v3dg.ply"


class FakeJob:
    """Stands for ``gasp simulate [--hold FILE]``: running until stopped; :attr:`frame` is the last frame done."""

    made: list = []

    def __init__(self, scene, outdir, resume=False, hold=None):
        self.scene, self.outdir, self.hold = Path(scene), Path(outdir), hold
        self.started = time.monotonic()
        self.outdir.mkdir(parents=True, exist_ok=True)
        (self.outdir / CLAIM).write_text("token pid\n")     # what a real run leaves when stopped before frame 1
        self.frame = 0
        self.done = threading.Event()
        self.stopped = False
        FakeJob.made.append(self)

    @property
    def running(self):
        return not self.done.is_set()

    def frames_done(self):
        return self.frame

    def snapshot(self):
        return []

    def outcome(self):
        return "running" if self.running else ("stopped" if self.stopped else "finished")

    def stop(self, timeout=60.0):
        self.stopped = True
        self.done.set()
        return self.outcome()


def _until(cond, timeout=60.0):
    t0 = time.time()
    while not cond() and time.time() - t0 < timeout:
        time.sleep(0.05)
    return cond()


@pytest.fixture
def studio(tmp_path, monkeypatch):
    import gasp_core.studio.stream as stream
    import gasp_core.studio.warm as warm
    from gasp_core.studio.app import Studio
    FakeJob.made = []
    monkeypatch.setattr(warm, "Job", FakeJob)
    monkeypatch.setattr(stream, "Job", FakeJob)
    st = Studio(DONUT, tmp_path / "studio", port=0)
    yield st
    st.stop()


def test_a_held_run_starts_when_the_file_opens_and_the_page_says_so_until_frame_1(studio):
    from gasp_core.studio.form import CHOOSE
    form = studio.form
    assert _until(lambda: len(FakeJob.made) == 1), "no held run started on opening the file"
    job = FakeJob.made[0]
    # the run the user is about to start, into the next run folder: the engine on the page, its quality level,
    # the default model (nothing chosen yet), the page's frame count, and the piece a click selects (the donut's
    # opaque piece); held while its hold file exists
    assert job.outdir == studio.scene.workdir / "run1" and job.hold.exists()
    doc = tomllib.loads(job.scene.read_text())
    assert doc["engine"]["name"] == form.engine.value and doc["quality"] == form.quality.value == "draft"
    assert doc["n_frames"] == 30 and doc["object"][0]["material"]["name"] == "jelly"
    mask = np.load(job.scene.parent / doc["object"][0]["select"]["mask"])
    assert 45000 < mask.sum() < studio.scene.pieces[0].n
    engine = form.engine.value
    assert _until(lambda: form.run_status.content.startswith(f"compiling {engine} kernels"))
    assert form.material.value == CHOOSE                      # the held run chose nothing for the user
    job.frame = 1
    assert _until(lambda: form.run_status.content == "no run yet"), form.run_status.content
    assert studio.message_log[0].startswith(f"{engine} kernels ready, frame 1 simulated")
    # another model: the held run is stopped and its files removed (its folder is free again), the new choice held
    form.material.value = "sand"
    assert _until(lambda: len(FakeJob.made) == 2)
    assert job.stopped and FakeJob.made[1].outdir == job.outdir
    assert tomllib.loads(FakeJob.made[1].scene.read_text())["object"][0]["material"]["name"] == "sand"
    # a change of model while it prepares stops it at once; a change that keeps its kernels (the frame count)
    # waits for its frame 1 (they land in the engine's cache)
    form.material.value = "jelly"
    assert _until(lambda: len(FakeJob.made) == 3) and FakeJob.made[1].stopped
    form.frames.value = 12
    assert _until(lambda: studio.warmer.pending is not None)
    time.sleep(1.0)
    assert len(FakeJob.made) == 3 and FakeJob.made[2].running
    FakeJob.made[2].frame = 1
    assert _until(lambda: len(FakeJob.made) == 4) and FakeJob.made[2].stopped
    # the studio closes: the held run is stopped and what it wrote removed
    studio.warmer.stop()
    work = studio.scene.workdir
    assert FakeJob.made[3].stopped and not list(work.glob("run1*")) and not list((work / ".warm").iterdir())


def test_run_takes_over_the_held_run_of_its_choice_and_stops_any_other(studio):
    form = studio.form
    assert _until(lambda: len(FakeJob.made) == 1)
    held = FakeJob.made[0]
    held.frame = 1
    p = studio.scene.pieces[0]
    p.selected[:] = np.load(held.scene.parent / tomllib.loads(held.scene.read_text())["object"][0]["select"]["mask"])
    form.material.value = "jelly"                             # the default model's typical values: the same run
    studio.run()
    assert studio.stream.job is held and not held.hold.exists() and held.running
    assert len(FakeJob.made) == 1                             # no second process: frame 1 is there already
    held.done.set()
    # the page's choice changes (12 frames), a held run of it starts; Run on yet another (more frames) stops it
    form.frames.value = 12
    form.material.value = "sand"
    assert _until(lambda: len(FakeJob.made) == 2)
    second = FakeJob.made[1]
    form.frames.value = 20
    studio.run()
    assert second.stopped
    assert studio.stream.job is FakeJob.made[2] and FakeJob.made[2].hold is None
    assert studio.stream.outdir == second.outdir          # the folder it held is free again


def test_no_material_is_preselected_and_run_asks_for_one(studio):
    from gasp_core.studio.form import CHOOSE
    form = studio.form
    assert form.material.value == CHOOSE and not form.values
    p = studio.scene.pieces[0]
    p.selected[:] = True
    said = studio.run()
    assert said.startswith("choose a material first") and studio.stream is None
    form.material.value = "jelly"
    assert CHOOSE in form.material.options and form.values["E"].value == 2.0e4
