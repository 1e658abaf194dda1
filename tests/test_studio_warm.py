"""The studio compiles while the user chooses (issue 39 item 4): a warm-up starts when a file opens, the page says
so while it runs and clears it when it ends; the layout's points (no material preselected, Run asks for one).

The warm-up process is replaced by a stand-in here (no compile time); the real one, and the time it saves, are in
tests/test_studio_browser.py and docs/studio.md ("Time to the first frame")."""
import threading
import time
import tomllib
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("viser", reason='the view extra is not installed: python -m pip install -e ".[view]"')
pytest.importorskip("tomli_w", reason='the view extra is not installed: python -m pip install -e ".[view]"')

DONUT = Path(__file__).resolve().parents[1] / "examples" / "data" / "donut_v3dg.ply"


class FakeJob:
    """Stands for ``gasp simulate`` on the warm-up scene: running until :attr:`done` is set."""

    made: list = []

    def __init__(self, scene, outdir):
        self.scene, self.outdir = Path(scene), Path(outdir)
        self.started = time.monotonic()
        self.done = threading.Event()
        self.stopped = False
        FakeJob.made.append(self)

    @property
    def running(self):
        return not self.done.is_set()

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
    import gasp_core.studio.warm as warm
    from gasp_core.studio.app import Studio
    FakeJob.made = []
    monkeypatch.setattr(warm, "Job", FakeJob)
    st = Studio(DONUT, tmp_path / "studio", port=0)
    yield st
    st.stop()


def test_a_warm_up_starts_when_the_file_opens_and_the_page_says_so_until_it_ends(studio):
    from gasp_core.studio.form import CHOOSE
    form = studio.form
    assert _until(lambda: len(FakeJob.made) == 1), "no warm-up started on opening the file"
    job = FakeJob.made[0]
    doc = tomllib.loads(job.scene.read_text())
    # the run the user is about to start: the engine on the page, its quality level, the default model (nothing
    # chosen yet), one frame, and the piece a click selects (the donut's opaque piece)
    assert doc["engine"]["name"] == form.engine.value and doc["quality"] == form.quality.value == "draft"
    assert doc["n_frames"] == 1 and doc["object"][0]["material"]["name"] == "jelly"
    mask = np.load(doc["object"][0]["select"]["mask"])
    assert 45000 < mask.sum() < studio.scene.pieces[0].n
    engine = form.engine.value
    assert _until(lambda: form.run_status.content.startswith(f"compiling {engine} kernels"))
    assert form.material.value == CHOOSE                      # the warm-up chose nothing for the user
    job.done.set()
    assert _until(lambda: form.run_status.content == "no run yet"), form.run_status.content
    assert studio.message_log[0].startswith(f"{engine} kernels ready")
    # another model: built again; back to the one built: nothing to do
    form.material.value = "sand"
    assert _until(lambda: len(FakeJob.made) == 2)
    assert tomllib.loads(FakeJob.made[1].scene.read_text())["object"][0]["material"]["name"] == "sand"
    FakeJob.made[1].done.set()
    assert _until(lambda: "compiling" not in form.run_status.content)
    form.material.value = "jelly"
    time.sleep(1.0)
    assert len(FakeJob.made) == 2


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
