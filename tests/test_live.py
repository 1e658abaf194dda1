"""Issue 32 item 2: a run in progress can be read and viewed; its frames so far, then the new ones as written.

A real ``gasp simulate`` (warp_mpm, the small donut, 8 frames) runs in a process; the test freezes it with
SIGSTOP once a few frames are on disk (so "in progress" is a state the test holds, not a race), reads it
live, lets it go on with SIGCONT, and follows it to its final folder. The frames read live are the finished
run's, bit for bit. In-process runs check the files on disk at each frame (any layout): the manifest never
lists a frame before its files are complete, and lists each frame by the time the next one is handed on.
"""
import json
import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from gasp_testing import scene_text, needs_package

from gasp_core.cli.main import main
from gasp_core.fsutil import CLAIM
from gasp_core.render import live as live_mod
from gasp_core.render.live import FAILED, FINISHED, RUNNING, STOPPED_STATUS, LiveRun, find_live, follow, locate
from gasp_core.render.run import load_run

needs_package("gasp_warp_mpm")

N_FRAMES = 8
FIELDS = ("means", "scales", "rotations", "opacities", "sh_dc", "sh_rest")
SELECT = "select = { box = { lo = [-1.0, -1.0, -1.0], hi = [0.0, 1.0, 1.0] } }"   # file x <= 0 moves


def write_scene(tmp_path: Path, donut_small: Path, n_frames: int = N_FRAMES, extra: str = "") -> Path:
    # frame_dt 0.1 s at n_grid 16: about a tenth of a second of CPU per frame (as tests/test_stop.py)
    text = scene_text(donut_small, n_frames=n_frames, n_grid=16, engine="warp_mpm", engine_options="{ }")
    scene = tmp_path / "scene.toml"
    scene.write_text(text.replace("frame_dt = 0.0333333", "frame_dt = 0.1") + extra)
    return scene


def wait_for(cond, what: str, timeout_s: float = 300.0, poll_s: float = 0.01):
    """Poll ``cond()`` until it is truthy (returns it); fail naming ``what`` after ``timeout_s``."""
    deadline = time.time() + timeout_s
    while time.time() < deadline:
        got = cond()
        if got:
            return got
        time.sleep(poll_s)
    pytest.fail(f"timed out waiting for {what}")


def listed(out: Path) -> int:
    """Frames the live run's manifest lists now (0 before it is there)."""
    partial = find_live(out)
    try:
        return len(json.loads((partial / "frames.json").read_text())["objects"][0]["frames"]) if partial else 0
    except (OSError, ValueError):
        return 0


class Frozen:
    """``gasp simulate scene -o out`` in a process, frozen (SIGSTOP) once ``n`` frames are listed; thawed on exit."""

    def __init__(self, scene: Path, out: Path, n: int):
        self.proc = subprocess.Popen([sys.executable, "-m", "gasp_core.cli.main", "simulate", str(scene), "-o",
                                      str(out), "-q"], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                                     cwd=out.parent)
        self.out, self.n = out, n

    def __enter__(self):
        try:
            wait_for(lambda: listed(self.out) >= self.n or self.proc.poll() is not None, f"{self.n} frames")
            self.proc.send_signal(signal.SIGSTOP)
            assert self.proc.poll() is None, "the run ended before the test could hold it in progress"
        except BaseException:
            self.__exit__()
            raise
        return self

    def go_on(self):
        self.proc.send_signal(signal.SIGCONT)

    def __exit__(self, *exc):
        if self.proc.poll() is None:
            self.proc.send_signal(signal.SIGCONT)
        try:
            self.proc.communicate(timeout=600)
        finally:
            if self.proc.poll() is None:
                self.proc.kill()


def same(a, b) -> bool:
    return a.n == b.n and all(np.array_equal(getattr(a, f), getattr(b, f)) for f in FIELDS)


def test_a_run_in_progress_is_read_then_followed_to_its_final_folder(tmp_path, donut_small, capsys):
    scene, out = write_scene(tmp_path, donut_small), tmp_path / "out"
    with Frozen(scene, out, 2) as run:
        partial = find_live(out)
        assert partial is not None and partial.name.startswith(".out.partial-") and find_live(partial) == partial
        assert not (out / "run.json").exists() and (out / CLAIM).exists()
        live = LiveRun(out)
        k = live.n_frames
        assert live.status == RUNNING and live.run.path == partial and 2 <= k < N_FRAMES + 1
        assert live.n_total == N_FRAMES + 1 and live.run.meta["status"] == "running"
        assert LiveRun(partial).n_frames == k                       # the partial folder itself is accepted
        early = {f: live.read(f, 0) for f in range(k)}
        assert main(["view", str(out), "--export", str(tmp_path / "page.html")]) == 2   # not a finished run yet
        assert "a run still in progress" in capsys.readouterr().err and not (tmp_path / "page.html").exists()
        run.go_on()
        seen = [f for _, f in follow(live, poll_s=0.05, start=k)]   # the new frames, as they come, then the end
        assert run.proc.wait(timeout=600) == 0, run.proc.stderr.read()
    assert seen == list(range(k, N_FRAMES + 1))
    live.refresh()                                                  # once the partial folder is renamed
    assert live.status == FINISHED and live.run.path == out and live.n_frames == N_FRAMES + 1
    assert find_live(out) is None and locate(out) == (out, FINISHED) and locate(partial) == (out, FINISHED)
    final = load_run(out)
    for f in range(N_FRAMES + 1):                                   # what was read live is the finished run
        assert same(early[f] if f < k else live.read(f, 0), final.read(f, 0)), f
    assert not same(final.read(0, 0), final.read(N_FRAMES, 0))     # and it moved


def test_a_link_to_a_run_in_progress_is_followed(tmp_path, donut_small):
    # issue 41: through a symlink the viewer showed the first frames and did not follow the run
    scene, out = write_scene(tmp_path, donut_small), tmp_path / "out"
    link = tmp_path / "link"
    link.symlink_to(out, target_is_directory=True)
    with Frozen(scene, out, 2) as run:
        assert find_live(link) == find_live(out) is not None
        live = LiveRun(link)
        assert live.status == RUNNING
        run.go_on()
        assert run.proc.wait(timeout=600) == 0, run.proc.stderr.read()
    live.refresh()
    assert live.status == FINISHED and live.n_frames == N_FRAMES + 1 and locate(link) == (out.resolve(), FINISHED)


def test_the_viewer_of_a_run_in_progress_grows_and_follows_the_newest_frame(tmp_path, donut_small):
    """Two viewers of one run: one at the newest frame follows the new ones, one left at frame 0 stays there."""
    pytest.importorskip("viser", reason="the view extra is not installed: pip install -e '.[view]'")
    from gasp_core.render.viewer import RunViewer
    scene, out = write_scene(tmp_path, donut_small), tmp_path / "out"
    with Frozen(scene, out, 2) as run:
        v, w = RunViewer(out, port=0, poll_s=0.05), RunViewer(out, port=0, poll_s=0.05)
        try:
            n0 = len(v.frames)
            assert 2 <= n0 < N_FRAMES + 1 and v.frame.max == n0 - 1 and v.run.path.name.startswith(".out.partial-")
            assert v.status.content == f"**running**: {n0} of {N_FRAMES + 1} frames"
            v.frame.value, w.frame.value = n0 - 1, 0                # v at the newest frame: it follows
            run.go_on()
            for x in (v, w):
                wait_for(lambda: "finished" in x.status.content, "the viewer to say finished", poll_s=0.1)
                wait_for(lambda: x.run.path == out, "the viewer to switch to the final folder", poll_s=0.1)
                assert len(x.frames) == N_FRAMES + 1 and x.frame.max == N_FRAMES
                assert x.status.content == f"**finished**: {N_FRAMES + 1} frames"
            assert v.frame.value == N_FRAMES and w.frame.value == 0
            final = load_run(out)
            for f in range(N_FRAMES + 1):
                assert np.array_equal(v.frames[f].means, final.splats(f).means), f
        finally:
            v.stop()
            w.stop()


def test_the_manifest_lists_a_frame_only_once_its_files_are_complete(tmp_path, donut_small, monkeypatch):
    """In-process, split layout (a static object, unselected rows written once): each file being written is not
    yet listed, and by the time frame f is handed on every earlier frame reads back through the live reader."""
    from gasp_core.run import layout
    from gasp_core.run.pipeline import simulate_scene
    from gasp_core.scene.spec import load_scene
    static = f'\n[[object]]\nfile = "{donut_small}"\nposition = [0.5, 0.0, 0.0]\nstatic = true\n'
    scene = write_scene(tmp_path, donut_small, n_frames=3, extra=static)
    scene.write_text(scene.read_text().replace('up_axis = "+z"', f'up_axis = "+z"\n{SELECT}', 1))
    out = tmp_path / "out"
    checked = []
    real_write = layout.write_file

    def write_file(path, g, fmt, overwrite=False):
        partial = find_live(out)
        if partial is not None and (partial / "frames.json").is_file():
            manifest = json.loads((partial / "frames.json").read_text())
            names = {f for o in manifest["objects"] for f in [*o["frames"], o.get("rest"), o.get("static")]}
            assert Path(path).relative_to(partial).as_posix() not in names, f"{path} listed before it is written"
            checked.append(path)
        return real_write(path, g, fmt, overwrite)

    seen = {}

    def on_frame(frame, gs):
        live = LiveRun(out)
        assert live.status == RUNNING and live.n_frames >= frame   # frames 0..frame-1 are on disk and listed
        if frame > 0:
            assert live.run.meta["layout"] == "split" and live.n_total == 4
        for f in range(live.n_frames):           # read while the run goes on (compared with the final run below)
            seen.setdefault(f, [live.read(f, k) for k in range(len(gs))])

    monkeypatch.setattr(layout, "write_file", write_file)
    simulate_scene(load_scene(scene), out, quiet=True, layout="split", on_frame=on_frame)
    final = load_run(out)
    assert len(checked) == 3 and final.n_frames == 4   # frames 1..3 (frame 0 comes before any manifest)
    assert {0, 1, 2} <= set(seen)
    assert all(same(g, final.read(f, k)) for f, gs in seen.items() for k, g in enumerate(gs))


def test_a_stopped_run_shows_its_kept_frames_and_a_killed_one_what_it_wrote(tmp_path, donut_small):
    from gasp_core.run.pipeline import simulate_scene
    from gasp_core.run.stop import Stopped
    from gasp_core.scene.spec import load_scene
    scene, out = write_scene(tmp_path, donut_small, n_frames=5), tmp_path / "out"

    def interrupt(frame, gs):
        if frame == 3:
            raise KeyboardInterrupt

    with pytest.raises(Stopped):
        simulate_scene(load_scene(scene), out, quiet=True, on_frame=interrupt)
    (partial,) = tmp_path.glob(".out.partial-*")
    kept = json.loads((partial / "run.json").read_text())["stopped"]["after_frame"]
    live = LiveRun(out)
    assert live.status == STOPPED_STATUS and live.run.path == partial and live.n_frames >= kept + 1
    assert LiveRun(partial).status == STOPPED_STATUS and find_live(out) is None
    assert [f for _, f in follow(out, poll_s=0.01)] == list(range(live.n_frames))   # ends: nothing more comes

    # as kill -9 leaves it: the claim and the partial's pid name a process that is gone
    gone = subprocess.Popen([sys.executable, "-c", "pass"])
    gone.wait()
    (out / CLAIM).write_text(f"0123456789abcdef {gone.pid}\n")
    (partial / ".gasp-pid").write_text(str(gone.pid))
    record = json.loads((partial / "run.json").read_text())
    (partial / "run.json").write_text(json.dumps({**record, "status": "running"}))
    live = LiveRun(out)
    assert live.status == FAILED and live.run.path == partial and live.n_frames >= kept + 1

    # its partial folder followed: renamed onto the output folder, it is that run's; removed, the output
    # folder holding another run's results (as --overwrite leaves it after a failed run) is not
    finished = {k: v for k, v in record.items() if k != "stopped"}
    (partial / "run.json").write_text(json.dumps(finished))            # as a finished run's record
    (out / CLAIM).unlink()
    other = tmp_path / "other"
    shutil.copytree(partial, other)
    live = LiveRun(partial)
    out.rmdir()
    os.rename(partial, out)
    assert live.refresh() and (live.status, live.run.path) == (FINISHED, out)
    os.rename(other, partial)
    live = LiveRun(partial)
    shutil.rmtree(partial)
    assert live.refresh() and (live.status, live.run.path) == (FAILED, partial)


def test_a_zombie_is_not_running():
    """A child that exited but was not waited for still answers ``kill(pid, 0)``; it is not a run in progress."""
    p = subprocess.Popen([sys.executable, "-c", "pass"])
    stat = Path(f"/proc/{p.pid}/stat")
    if not stat.exists():
        p.wait()
        pytest.skip("no /proc on this system")
    try:
        wait_for(lambda: stat.read_text().rsplit(")", 1)[1].split()[0] == "Z", "the child to exit", timeout_s=60)
        os.kill(p.pid, 0)                        # still there for the kernel
        assert not live_mod._running(p.pid) and live_mod._running(os.getpid())
    finally:
        p.wait()


@pytest.mark.slow
def test_the_page_of_a_run_in_progress_says_so_and_shows_the_new_frames(tmp_path, donut_small):
    """Headless Chromium (as tests/test_view.py): the page of a run held at a few frames says ``running``, then
    ``finished`` once it completes, and the picture changes as the viewer follows the newest frame."""
    pytest.importorskip("viser", reason="the view extra is not installed: pip install -e '.[view]'")
    iio = pytest.importorskip("imageio.v3", reason='the render extra is not installed: pip install -e ".[render]"')
    sync_api = pytest.importorskip("playwright.sync_api", reason="playwright is not installed: pip install playwright")
    import shutil
    chromium = shutil.which("chromium") or shutil.which("chromium-headless-shell")
    if chromium is None:
        pytest.skip("no Chromium found: apt-get install -y chromium (or chromium-headless-shell)")
    from gasp_core.render.viewer import RunViewer
    args = ["--headless", "--no-sandbox", "--disable-gpu", "--use-gl=swiftshader", "--enable-unsafe-swiftshader"]
    scene, out = write_scene(tmp_path, donut_small), tmp_path / "out"
    middle = (slice(200, 500), slice(150, 650))            # the donut, away from the panels and the axes

    def drawn(page, path):
        """A screenshot once the donut's saturated pixels are on it and the picture stops changing."""
        prev = None
        for _ in range(45):
            time.sleep(2.0)
            page.screenshot(path=str(path))
            img = iio.imread(path)[..., :3].astype(int)[middle]
            if ((img.max(axis=2) - img.min(axis=2)) > 60).sum() > 500 and prev is not None \
                    and np.abs(img - prev).mean() < 0.05:
                return img
            prev = img
        pytest.fail(f"the page did not settle ({path})")

    with Frozen(scene, out, 2) as run:
        v = RunViewer(out, port=0, poll_s=0.1)
        try:
            with sync_api.sync_playwright() as p:
                browser = p.chromium.launch(executable_path=chromium, args=args)
                page = browser.new_page(viewport={"width": 800, "height": 600})
                page.goto(f"http://127.0.0.1:{v.port}")
                page.get_by_text(f"running: {len(v.frames)} of {N_FRAMES + 1} frames").wait_for(timeout=120_000)
                v.frame.value = len(v.frames) - 1
                a = drawn(page, tmp_path / "running.png")
                run.go_on()
                page.get_by_text(f"finished: {N_FRAMES + 1} frames").wait_for(timeout=300_000)
                b = drawn(page, tmp_path / "finished.png")
                browser.close()
        finally:
            v.stop()
    # the newest frame is on screen: the donut changed (a repeated screenshot of one frame differs by < 0.05)
    assert np.abs(a - b).mean() > 1.0, np.abs(a - b).mean()
    assert v.frame.value == N_FRAMES
