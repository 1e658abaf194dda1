"""``gasp view``: play a run's frames in the browser through viser (Gaussian splats, WebGL).

The page has play/pause, a frame slider and a speed (frames per second); the scene is the
world frame, z up, with a grid at the run's ground height. A run still in progress
(:mod:`gasp_core.render.live`) shows the frames written so far; a thread looks for new ones every
``poll_s`` seconds, the slider grows, a viewer at the last frame follows the newest, and a line on the page
says ``running: 12 of 37 frames``, then ``finished`` (``stopped``, ``failed``).
"""
from __future__ import annotations

import threading
import time

import numpy as np

from gasp_core.errors import SceneError
from gasp_core.render.live import FINISHED, LIVE, RUNNING, LiveRun
from gasp_core.render.quiet_logs import QuietLogs
from gasp_core.render.run import Run, framed_bounds, sequence_bounds


class RunViewer:
    """A viser server showing one run.

    Parameters
    ----------
    run_dir : path or LiveRun
        Run folder written by ``gasp simulate``, finished or in progress (its output folder, or its partial
        folder ``.NAME.partial-*``), or a stopped run's; a run still starting is waited for until its first
        frame is written.
    host : str
        Interface to listen on (default loopback only).
    port : int
        TCP port (0: viser picks the next free one from 8080).
    poll_s : float
        Seconds between looks for new frames of a run in progress.
    framing : str
        What the first camera looks at (:func:`gasp_core.render.run.framed_bounds`): ``"moving"`` the simulated
        part of the frames so far, ``"scene"`` everything.

    Attributes
    ----------
    server : viser.ViserServer
    frame : GuiSliderHandle
        The frame slider (setting ``.value`` shows that frame); its ``max`` grows with a run in progress.
    run : Run
        The frames' run folder (the partial folder of a run in progress, the output folder once it finished).
    live : LiveRun
    status : GuiMarkdownHandle or None
        The line saying how far a run that was in progress when the page opened has come; None for a
        finished run.

    Raises
    ------
    SceneError
        If the run folder is unusable, or a run in progress ends before writing its first frame.
    ImportError
        Without viser (``pip install -e ".[view]"``).
    """

    def __init__(self, run_dir, host: str = "127.0.0.1", port: int = 8080, poll_s: float = 0.5,
                 framing: str = "moving"):
        import viser
        self.live = run_dir if isinstance(run_dir, LiveRun) else LiveRun(run_dir)
        if self.live.wait(1, poll_s) == 0:
            raise SceneError(f"{run_dir}: the run {self.live.status} before writing its first frame; nothing to show")
        self.run: Run = self.live.run
        self.poll_s = poll_s
        self.frames = [self.live.splats(i) for i in range(self.live.n_frames)]
        lo, hi = sequence_bounds(self.frames)
        gz = self.run.ground_z if self.run.ground_z is not None else float(lo[2])
        self._quiet = QuietLogs("gasp view").__enter__()   # a half HTTP request: one line, no traceback
        self.server = viser.ViserServer(host=host, port=port, verbose=False)
        s = self.server
        s.scene.set_up_direction("+z")
        size = float(np.max(hi - lo))
        centre = 0.5 * (lo + hi)
        s.scene.add_grid("/ground", width=4 * size, height=4 * size, cell_size=size / 8,
                         section_size=size / 2, position=(float(centre[0]), float(centre[1]), gz))
        f_lo, f_hi = framed_bounds([self.run], self.frames, framing)      # the camera: what moves, by default
        f_size, f_centre = float(np.max(f_hi - f_lo)), 0.5 * (f_lo + f_hi)
        s.initial_camera.look_at = tuple(float(x) for x in f_centre)
        s.initial_camera.position = tuple(float(x) for x in f_centre + f_size * np.array([0.9, -1.6, 0.9]))
        s.initial_camera.up = (0.0, 0.0, 1.0)
        self.status = None if self.live.status == FINISHED else s.gui.add_markdown(self.status_line())
        self.playing = s.gui.add_checkbox("Play", initial_value=False)
        self.fps = s.gui.add_slider("Speed (frames/s)", min=1, max=60, step=1,
                                    initial_value=int(round(min(60.0, 1.0 / self.run.frame_dt))))
        self.frame = s.gui.add_slider("Frame", min=0, max=max(len(self.frames) - 1, 1), step=1, initial_value=0)
        self.frame.on_update(lambda _: self._show(int(self.frame.value)))
        self._splats = None
        self._show(0)
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._loop, daemon=True)
        self._thread.start()
        self._follower = None
        if self.live.status in LIVE:
            self._follower = threading.Thread(target=self._follow, daemon=True)
            self._follower.start()

    @property
    def port(self) -> int:
        return self.server.get_port()

    def _show(self, i: int) -> None:
        """Show frame ``i``: the splats are added once, then updated in place (viser's
        ``GaussianSplatHandle.set_gaussians``, one buffer message per frame)."""
        sp = self.frames[min(max(i, 0), len(self.frames) - 1)]
        arrays = (sp.means.astype(np.float32), sp.covs.astype(np.float32), sp.rgb, sp.opacities[:, None])
        if self._splats is None:
            self._splats = self.server.scene.add_gaussian_splats(
                "/run", centers=arrays[0], covariances=arrays[1], rgbs=arrays[2], opacities=arrays[3])
        else:
            self._splats.set_gaussians(*arrays)

    def status_line(self) -> str:
        """What the page says of the run: ``running: 12 of 37 frames``, ``finished: 37 frames``, ``stopped: ...``."""
        n, total, status = len(self.frames), self.live.n_total, self.live.status
        if status in LIVE:
            return f"**{RUNNING}**: {n} of {total if total is not None else '?'} frames"
        if status == FINISHED:
            return f"**{FINISHED}**: {n} frames"
        return f"**{status}**: {n} of {total if total is not None else '?'} frames written"

    def _follow(self) -> None:
        """Poll the run in progress; append its new frames, grow the slider, follow the newest at the end."""
        settle = 2                 # refreshes after it ended: a finished run's folder is renamed right after
        while not self._stop.wait(self.poll_s) and settle > 0:
            before = len(self.frames)
            try:
                self.live.refresh()
                for i in range(before, self.live.n_frames):
                    self.frames.append(self.live.splats(i))
            except (SceneError, OSError) as e:       # the run's folder became unreadable: say so, stop following
                self.status.content = f"**error**: {e}"
                return
            if self.live.run is not None:
                self.run = self.live.run
            if len(self.frames) > before:
                at_end = int(self.frame.value) >= before - 1
                self.frame.max = max(len(self.frames) - 1, 1)
                if at_end:
                    self.frame.value = len(self.frames) - 1
            self.status.content = self.status_line()
            if self.live.status not in LIVE:
                settle -= 1

    def _loop(self) -> None:
        while not self._stop.is_set():
            if self.playing.value:
                self.frame.value = (int(self.frame.value) + 1) % len(self.frames)
            time.sleep(1.0 / max(float(self.fps.value), 1.0))

    def stop(self) -> None:
        self._stop.set()
        self.server.stop()
        self._quiet.__exit__()


def serve(run_dir, host: str = "127.0.0.1", port: int = 8080, framing: str = "moving") -> None:
    """Serve ``run_dir`` until interrupted (Ctrl-C); a run in progress is followed (one line says so); the first
    camera frames ``framing`` (:class:`RunViewer`)."""
    import viser  # noqa: F401  (without the view extra: that error first, whatever the folder)
    live = LiveRun(run_dir)
    if live.status in LIVE and live.n_frames == 0:
        print(f"gasp view: {run_dir} is a run in progress; waiting for its first frame", flush=True)
    v = RunViewer(live, host, port, framing=framing)
    if v.live.status in LIVE:
        print(f"gasp view: http://{host}:{v.port}  (following a run in progress: {len(v.frames)} of "
              f"{v.live.n_total} frames so far; Ctrl-C to stop)", flush=True)
    else:
        what = "" if v.live.status == FINISHED else f", a run that {v.live.status}"
        print(f"gasp view: http://{host}:{v.port}  ({len(v.frames)} frames{what}; Ctrl-C to stop)", flush=True)
    until_interrupted(v)


def until_interrupted(app) -> None:
    """Wait until the process is interrupted (Ctrl-C, a stop signal: ``KeyboardInterrupt``), then ``app.stop()``."""
    try:
        while True:
            time.sleep(1.0)
    finally:
        app.stop()
