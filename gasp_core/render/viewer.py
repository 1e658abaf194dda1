"""``gasp view``: play a run's frames in the browser through viser (Gaussian splats, WebGL).

The page has play/pause, a frame slider and a speed (frames per second); the scene is the
world frame, z up, with a grid at the run's ground height.
"""
from __future__ import annotations

import threading
import time

import numpy as np

from gasp_core.render.run import Run, load_run, sequence_bounds


class RunViewer:
    """A viser server showing one run.

    Parameters
    ----------
    run_dir : path
        Run folder written by ``gasp simulate``.
    host : str
        Interface to listen on (default loopback only).
    port : int
        TCP port (0: viser picks the next free one from 8080).

    Attributes
    ----------
    server : viser.ViserServer
    frame : GuiSliderHandle
        The frame slider (setting ``.value`` shows that frame).

    Raises
    ------
    SceneError
        If the run folder is unusable.
    ImportError
        Without viser (``pip install -e ".[view]"``).
    """

    def __init__(self, run_dir, host: str = "127.0.0.1", port: int = 8080):
        import viser
        self.run: Run = load_run(run_dir)
        self.frames = [self.run.splats(i) for i in range(self.run.n_frames)]
        lo, hi = sequence_bounds(self.frames)
        gz = self.run.ground_z if self.run.ground_z is not None else float(lo[2])
        self.server = viser.ViserServer(host=host, port=port, verbose=False)
        s = self.server
        s.scene.set_up_direction("+z")
        size = float(np.max(hi - lo))
        centre = 0.5 * (lo + hi)
        s.scene.add_grid("/ground", width=4 * size, height=4 * size, cell_size=size / 8,
                         section_size=size / 2, position=(float(centre[0]), float(centre[1]), gz))
        s.initial_camera.look_at = tuple(float(x) for x in centre)
        s.initial_camera.position = tuple(float(x) for x in centre + size * np.array([0.9, -1.6, 0.9]))
        s.initial_camera.up = (0.0, 0.0, 1.0)
        self.playing = s.gui.add_checkbox("Play", initial_value=False)
        self.fps = s.gui.add_slider("Speed (frames/s)", min=1, max=60, step=1,
                                    initial_value=int(round(min(60.0, 1.0 / self.run.frame_dt))))
        self.frame = s.gui.add_slider("Frame", min=0, max=max(self.run.n_frames - 1, 1), step=1, initial_value=0)
        self.frame.on_update(lambda _: self._show(int(self.frame.value)))
        self._splats = None
        self._show(0)
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._loop, daemon=True)
        self._thread.start()

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

    def _loop(self) -> None:
        while not self._stop.is_set():
            if self.playing.value:
                self.frame.value = (int(self.frame.value) + 1) % self.run.n_frames
            time.sleep(1.0 / max(float(self.fps.value), 1.0))

    def stop(self) -> None:
        self._stop.set()
        self.server.stop()


def serve(run_dir, host: str = "127.0.0.1", port: int = 8080) -> None:
    """Serve ``run_dir`` until interrupted (Ctrl-C)."""
    v = RunViewer(run_dir, host, port)
    print(f"gasp view: http://{host}:{v.port}  ({v.run.n_frames} frames; Ctrl-C to stop)", flush=True)
    try:
        while True:
            time.sleep(1.0)
    finally:
        v.stop()
