"""``gasp studio`` without a browser: selection by rays, the form through the scene checker, a run streamed from its
own process, and the saved scene reproducing it bit for bit with ``gasp simulate``."""
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("viser", reason='the view extra is not installed: python -m pip install -e ".[view]"')
pytest.importorskip("tomli_w", reason='the view extra is not installed: python -m pip install -e ".[view]"')

from gasp_core.errors import SceneError  # noqa: E402

DONUT = Path(__file__).resolve().parents[1] / "examples" / "data" / "donut_v3dg.ply"


@pytest.fixture
def studio(tmp_path):
    from gasp_core.studio.app import Studio
    st = Studio(DONUT, tmp_path / "studio", port=0, warm=False)   # the warm-up: tests/test_studio_warm.py
    t0 = time.time()
    while st.labels[0] is None and time.time() - t0 < 60:
        time.sleep(0.05)
    yield st
    st.stop()


def _down_onto(st, dx=0.0):
    """A ray straight down onto the donut's ring (``dx`` = 0) or through its hole (``dx`` = None)."""
    p = st.scene.pieces[0]
    c = np.median(p.means, axis=0)
    r = np.percentile(np.hypot(*(p.means[:, :2] - c[:2]).T), 50)
    x = c[0] + (0.0 if dx is None else r + dx)
    return (x, c[1], 1.0), (0.0, 0.0, -1.0)


def test_click_selects_the_piece_removes_it_and_background_selects_nothing(studio):
    p = studio.scene.pieces[0]
    said = studio.click(*_down_onto(studio))
    n = int(p.selected.sum())
    # the donut's opaque piece and the faint splats inside its splats: all but the 149 strays
    assert said.startswith(f"selected {n:,} Gaussians") and p.n - 200 < n < p.n
    # the selection's text (count, size in metres) is shown once: in the Select panel, not again in the message
    panel = studio.form.selection.content
    assert panel == studio.selection_text() and panel.endswith("m)") and panel not in said and "m)" not in said
    said = studio.click(*_down_onto(studio))                     # the same piece again: removed
    assert said.startswith("removed") and not p.selected.any()
    studio.click(*_down_onto(studio))
    said = studio.click(*_down_onto(studio, dx=None))            # through the hole: background
    assert said.startswith("Nothing selected: the click hit no splat") and not p.selected.any()
    studio.click(*_down_onto(studio))
    said = studio.click((0.0, 0.0, 1.0), (0.0, 1.0, 0.0), add=True)   # shift-click on nothing keeps the selection
    assert said.startswith("Nothing selected") and p.selected.sum() == n


def test_a_bad_value_is_refused_with_the_scene_checkers_line(studio, tmp_path):
    import tomli_w
    studio.click(*_down_onto(studio))
    studio.form.material.value = "jelly"
    studio.form.values["nu"].value = 0.7
    with pytest.raises(SceneError) as e:
        studio.form.apply()
    line = str(e.value)
    assert "material.nu" in line and "0.7" in line and "\n" not in line
    assert studio.run().startswith(line[:60])                   # the page says it, no run starts
    assert studio.stream is None
    # the same document given to gasp simulate: the same line
    doc = studio.form.document()
    doc["object"][0]["select"] = {"indices": [0, 1]}
    studio.scene.scene_file.write_text(tomli_w.dumps(doc))
    r = subprocess.run([sys.executable, "-m", "gasp_core", "simulate", str(studio.scene.scene_file), "-o",
                        str(tmp_path / "never")], capture_output=True, text=True)
    assert r.returncode == 2 and r.stderr.strip() == f"gasp: error: {line}"


def _wait(stream, timeout=300.0):
    t0 = time.time()
    while stream.job.running and time.time() - t0 < timeout:
        time.sleep(0.2)
    stream.refresh()
    return stream.job.outcome()


def test_saved_scene_reproduces_the_run_bit_for_bit_and_an_open_selection_warns(studio, tmp_path):
    """The top 15 % of the donut's height (a cap of icing, a sheet that encloses nothing) on warp_mpm, 2 frames: the
    studio's run warns as gasp simulate does, and the saved scene's run writes the same bytes."""
    p = studio.scene.pieces[0]
    p.selected[:] = p.means[:, 2] > np.percentile(p.means[:, 2], 85)
    studio.form.frames.value = 2
    studio.form.material.value = "jelly"
    studio.form.engine.value = "warp_mpm"
    studio.run()
    assert _wait(studio.stream) == "finished", studio.stream.job.stderr[-3:]
    assert studio.stream.n_ready == 3
    warned = [m for m in studio.message_log if "enclose no volume" in m]
    saved = studio.scene.write(tmp_path / "keep" / "icing.toml")
    assert (tmp_path / "keep" / "icing.select0.npy").is_file()
    r = subprocess.run([sys.executable, "-m", "gasp_core", "simulate", str(saved), "-o", str(tmp_path / "again"),
                        "-q"], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    # the warning the page showed is the one gasp simulate prints
    assert warned and any(w.split("warning: ", 1)[-1] in r.stderr for w in warned), (r.stderr, studio.message_log)
    a, b = studio.stream.outdir, tmp_path / "again"
    files = sorted(f.relative_to(a) for f in a.rglob("frame_*.ply"))
    assert len(files) == 3
    for f in files:
        assert (a / f).read_bytes() == (b / f).read_bytes(), f
    # and the saved file is refused nothing: it names its mask relative to itself
    assert 'mask = "icing.select0.npy"' in saved.read_text()


def test_stop_resume_run_again_and_export(studio, tmp_path):
    """Stop keeps the finished frames, Resume continues them to the end, Run again starts run2, Export writes the
    page; a failed run's one line reaches the page."""
    studio.click(*_down_onto(studio))
    studio.form.frames.value = 4
    studio.form.material.value = "jelly"
    studio.form.engine.value = "warp_mpm"
    studio.run()
    stream = studio.stream
    t0 = time.time()
    while stream.n_ready < 3 and time.time() - t0 < 300:   # frames 0, 1, 2 readable
        time.sleep(0.2)
        stream.refresh()
    assert stream.job.running
    assert studio.stop_run() == "run1: stopped"
    assert studio.run().startswith("a run is in progress") is False
    assert studio.stream.outdir.name == "run2"                # Run while stopped: a new run, run1 kept
    studio.stop_run()
    studio.stream = stream                                    # back to run1, as the page's Resume after its Stop
    said = studio.run(resume=True)
    assert said.startswith("running run1"), said
    assert _wait(studio.stream) == "finished", studio.stream.job.stderr[-3:]
    assert studio.stream.n_ready == 5 and studio.stream.live.status == "finished"
    studio.form.export_path.value = "run1.html"                # a name inside the studio's folder
    page = studio.save_dir / "run1.html"
    assert studio.form.export().startswith(f"wrote {page}")
    assert page.stat().st_size > 1e5
    assert "exists" in studio.form.export()                   # an existing page is not replaced


def test_gasp_studio_refuses_bad_input_in_one_line(tmp_path):
    for argv, expected in ((["studio", str(tmp_path / "nothing.ply")], "nothing.ply: no such file"),
                           (["studio", str(DONUT), "--port", "70000"], "--port 70000: expected a TCP port")):
        r = subprocess.run([sys.executable, "-m", "gasp_core", *argv], capture_output=True, text=True)
        assert r.returncode == 2 and r.stderr.startswith("gasp: error: ") and expected in r.stderr
        assert len(r.stderr.strip().splitlines()) == 1
    bad = tmp_path / "bad.toml"
    bad.write_text('[[object]]\nfile = "missing.ply"\n')
    r = subprocess.run([sys.executable, "-m", "gasp_core", "studio", str(bad)], capture_output=True, text=True)
    assert r.returncode == 2 and "missing.ply" in r.stderr and len(r.stderr.strip().splitlines()) == 1


def test_box_selects_the_centres_inside_it_seen_from_above(studio):
    """ctrl-drag: a camera straight above the donut's centre, looking down (image x along world +x): the left half of
    the screen holds exactly the Gaussians west of the centre, at any depth."""
    from types import SimpleNamespace

    from gasp_core.gs.gaussians import rotmat_to_quat
    p = studio.scene.pieces[0]
    c = np.median(p.means, axis=0)
    R = np.array([[1.0, 0, 0], [0, -1, 0], [0, 0, -1]])        # OpenCV camera axes in the world: x, -y, -z
    cam = SimpleNamespace(position=(c[0], c[1], 2.0), wxyz=rotmat_to_quat(R), fov=np.radians(30.0), aspect=1.5)
    event = SimpleNamespace(client=SimpleNamespace(camera=cam), screen_min=(0.0, 0.0), screen_max=(0.5, 1.0))
    said = studio.box(event)
    west = p.means[:, 0] < c[0]
    assert np.array_equal(p.selected, west) and said.startswith(f"box: {int(west.sum()):,} Gaussians")
    # ctrl-shift adds the east half: everything; a box off the donut selects nothing and says so
    studio.box(SimpleNamespace(client=event.client, screen_min=(0.5, 0.0), screen_max=(1.0, 1.0)), add=True)
    assert p.selected.all()
    said = studio.box(SimpleNamespace(client=event.client, screen_min=(0.0, 0.0), screen_max=(0.01, 0.01)))
    assert said.startswith("Nothing selected") and not p.selected.any()
