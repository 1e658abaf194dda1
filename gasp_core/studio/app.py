"""``gasp studio``: a splat file or scene in the browser (viser); click to select, pick a material, run, watch.

* **select:** a click casts the browser camera's ray and takes the splat a renderer shows there
  (:func:`gasp_core.studio.pick.ray_pick`), then its whole connected piece (the ``grow`` rule of
  :mod:`gasp_core.prepare.selection`), or on a dynamic model the moving piece it belongs to
  (:mod:`gasp_core.studio.pieces`); shift-click adds a piece, a click on a selected piece removes it, a
  click on the background selects nothing and says so; ctrl-drag draws a box that selects the centres inside
  it (ctrl-shift-drag adds), for what clicks cannot separate. The selection is drawn tinted, with its count
  and size.
* **set up:** material (the installed engines' models, with their keys; typical values from ``docs/``), up
  axis (guessed as ``gasp info`` guesses), drop height, ground, engine, quality level, frames.
* **run:** :class:`gasp_core.studio.job.Job` runs ``gasp simulate`` on the studio's scene file in another
  process; its frames appear as their files are written, its warnings and its one-line errors in the page.
  Stop keeps the finished frames; resume continues them.
* **keep:** save the scene (TOML with ``select = { mask = ... }``), which ``gasp simulate`` reproduces bit for
  bit, and export the run as a self-contained page (``gasp view --export``).
"""
from __future__ import annotations

import contextlib
import io
import threading
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

from gasp_core.errors import GaspError, SceneError
from gasp_core.render.viewer import until_interrupted
from gasp_core.studio import form as form_mod
from gasp_core.studio.guard import Gate, QuietLogs, exposure_line, gated_serve, guard_messages, one_line
from gasp_core.studio.pieces import motion_pick, piece_labels
from gasp_core.studio.pick import box_rows, ray_pick
from gasp_core.studio.scene import StudioScene
from gasp_core.studio.stream import RunStream
from gasp_core.studio.warm import Warmer, choice_key, run_identity, studio_request

#: Tint of selected splats (orange), and how much of it.
HIGHLIGHT, HIGHLIGHT_MIX = np.array([1.0, 0.45, 0.0], np.float32), 0.6


#: Lines the page keeps (newest first): a run's warnings and what the scene around a selection supplied fit.
MESSAGES = 10


class Studio:
    """The studio's server: one :class:`StudioScene`, its page, and at most one run at a time.

    Parameters
    ----------
    path : path-like
        Splat file or scene TOML.
    workdir : path-like
        The studio's folder (working scene, masks, runs ``run1``, ``run2``, ...).
    host, port : str, int
        Where viser listens (port 0: the next free one from 8080).
    save_dir : path-like, optional
        The folder "Save scene" and "Export page" write into (``--save-dir``; default ``workdir``): the page
        names a file inside it, nothing outside (:func:`gasp_core.studio.guard.inside`).
    token : str, optional
        The token the page and its websocket must hold (default: a new random one; :class:`Gate`).
    warm : bool
        Build the chosen engine's kernels in the background from the start (:mod:`gasp_core.studio.warm`).

    Attributes
    ----------
    url : str
        The address to open, with its token.
    written : set of Path
        Files the studio wrote this session (saved scenes, their masks, exported pages): the only ones
        "Overwrite" may replace.

    Raises
    ------
    SceneError
        The file or scene cannot be opened, or viser cannot be made to check the token (one line).
    ImportError
        Without viser (``pip install -e ".[view]"``).
    """

    def __init__(self, path, workdir, host: str = "127.0.0.1", port: int = 8080, save_dir=None,
                 token: str | None = None, warm: bool = True):
        import viser
        self.scene = StudioScene(path, workdir)
        self.save_dir = Path(save_dir if save_dir is not None else workdir).resolve()
        self.written: set[Path] = set()
        self._lock = threading.RLock()
        self.labels: list[np.ndarray | None] = [None] * len(self.scene.pieces)
        self.moving: list = [None] * len(self.scene.pieces)   # a dynamic object's moving pieces (studio.pieces)
        self.stream: RunStream | None = None
        self.message_log: list[str] = []
        self.n_said = 0                     # lines said so far (the page shows the newest six)
        self.form = None
        self.warmer = Warmer(self.scene.workdir) if warm else None
        self.warm_wanted = warm             # the page's choice changed: ask the warmer (the poller does)
        self.gate = Gate(host, token)
        self._quiet = QuietLogs().__enter__()
        with gated_serve(self.gate), contextlib.redirect_stdout(io.StringIO()):   # viser's banner: no token
            self.server = viser.ViserServer(host=host, port=port, verbose=False)
        if not self.gate.installed:
            self.server.stop()
            self._quiet.__exit__()
            raise SceneError(f"viser {viser.__version__} no longer starts its server through "
                             "websockets.asyncio.server.serve, so the studio cannot check its token; install "
                             "viser 1.1 (pip install 'viser==1.1.*')")
        guard_messages(self.server, self.say)
        self._handles: list = []
        self._frame_handle = None
        self._frame_shown = -1
        self._camera()
        self.form = form_mod.Form(self)
        self._draw()
        on_click, on_rect = self.server.scene.on_click, self.server.scene.on_rect_select
        on_click()(self.guarded("click", lambda e: self.click(e.ray_origin, e.ray_direction, add=False)))
        on_click(modifier="shift")(self.guarded("click", lambda e: self.click(e.ray_origin, e.ray_direction,
                                                                             add=True)))
        on_rect(modifier="cmd/ctrl")(self.guarded("box", lambda e: self.box(e, add=False)))
        on_rect(modifier="cmd/ctrl+shift")(self.guarded("box", lambda e: self.box(e, add=True)))
        self._stop = threading.Event()
        threading.Thread(target=self._find_pieces, daemon=True).start()
        self._poller = threading.Thread(target=self._poll, daemon=True)
        self._poller.start()

    @property
    def port(self) -> int:
        return self.server.get_port()

    @property
    def url(self) -> str:
        return self.gate.url(self.port)

    # -- what the page sends ----------------------------------------------------------------------------
    def guarded(self, what: str, fn):
        """``fn`` as a callback of the page: whatever it raises becomes one line in the page, never a traceback
        in the server's output (the server never raises on client input)."""
        def call(*args):
            try:
                return fn(*args)
            except (GaspError, OSError) as e:
                return self._said(one_line(str(e)))
            except Exception as e:  # noqa: BLE001 (client input must not reach the server's output)
                return self._said(one_line(f"{what}: the page's input could not be used ({type(e).__name__}: {e})"))
        return call

    # -- drawing ----------------------------------------------------------------------------------------
    def _camera(self) -> None:
        s = self.server
        means = np.concatenate([p.means for p in self.scene.pieces])
        lo, hi = np.percentile(means, 1, axis=0), np.percentile(means, 99, axis=0)
        size, centre = float(np.max(hi - lo)), 0.5 * (lo + hi)
        grounds = [float(b.get("height", 0.0)) for b in self.scene.doc.get("boundary", []) if b.get("kind") == "ground"]
        s.scene.set_up_direction("+z")
        s.scene.add_grid("/ground", width=4 * size, height=4 * size, cell_size=size / 8, section_size=size / 2,
                         position=(float(centre[0]), float(centre[1]), min(grounds) if grounds else float(lo[2])))
        aim = centre + np.array([0.3 * size, 0.0, 0.0])   # the object left of the page's panel, on the right
        s.initial_camera.look_at = tuple(float(x) for x in aim)
        s.initial_camera.position = tuple(float(x) for x in aim + size * np.array([0.0, -1.8, 1.2]))
        s.initial_camera.up = (0.0, 0.0, 1.0)

    def _draw(self) -> None:
        """Show every piece at rest with its selection tinted (the page before a run, or after "Clear run")."""
        with self._lock:
            self._drop_frames()
            for h in self._handles:
                h.remove()
            self._handles = []
            for p in self.scene.pieces:
                self._handles.append(self.server.scene.add_gaussian_splats(
                    f"/scene/object{p.index}", centers=p.means.astype(np.float32), covariances=p.covs,
                    rgbs=self._tinted(p), opacities=p.opacities[:, None]))

    def _tinted(self, p) -> np.ndarray:
        rgb = p.rgb.copy()
        rgb[p.selected] = (1 - HIGHLIGHT_MIX) * rgb[p.selected] + HIGHLIGHT_MIX * HIGHLIGHT
        return rgb

    def _retint(self) -> None:
        """Tint the selection; the run a click on Run would start has changed (the held run follows it)."""
        self.warm_wanted = getattr(self, "warmer", None) is not None
        with self._lock:
            for p, h in zip(self.scene.pieces, self._handles):
                h.rgbs = self._tinted(p)

    def say(self, text: str) -> None:
        """Show ``text`` (one line) in the page's message box, newest first."""
        self.message_log = [text, *self.message_log][:MESSAGES]
        self.n_said += 1
        if self.form is not None:
            self.form.set_messages(self.message_log)

    # -- selection --------------------------------------------------------------------------------------
    def _find_pieces(self) -> None:
        """The connected pieces of every object (``grow``'s graph, seconds on a large file), and a dynamic object's
        moving pieces (:func:`gasp_core.studio.pieces.moving_pieces`), once, in the background."""
        from gasp_core.gs.splatv import read_splatv
        from gasp_core.studio.pieces import displacement, moving_pieces
        for p in self.scene.pieces:
            try:       # the moving pieces first: a click waits for the labels only
                if p.dynamic_time is not None:
                    base, motion = read_splatv(self.scene.doc["object"][p.index]["file"])
                    self.moving[p.index] = moving_pieces(p.means, displacement(base, motion, p.dynamic_time, p.scale))
            except Exception as e:    # noqa: BLE001 (a thread: said, and a click then takes the connected piece)
                self.say(f"object #{p.index + 1}: its moving pieces were not found ({type(e).__name__}: {e})")
            finally:
                self.labels[p.index] = piece_labels(p.means, p.radii, p.linking)

    def click(self, origin, direction, add: bool = False) -> str:
        """A click's ray: select the piece it hits (module notes). Returns the line said in the page."""
        pieces = self.scene.pieces
        hit = ray_pick(*(np.concatenate([getattr(p, k) for p in pieces]) for k in ("means", "rotmats", "scales",
                                                                                   "opacities")), origin, direction)
        if hit is None:
            if not add:
                for p in self.scene.pieces:
                    p.selected[:] = False
                self._retint()
            return self._said("Nothing selected: the click hit no splat (the ray reached the background)")
        starts = np.cumsum([0] + [q.n for q in pieces])      # every object composited together, front to back
        p = pieces[int(np.searchsorted(starts, hit.row, side="right")) - 1]
        hit = replace(hit, row=hit.row - int(starts[p.index]))
        if p.static:
            return self._said(f"object #{p.index + 1} is static = true (never simulated): it cannot be selected")
        while self.labels[p.index] is None:
            time.sleep(0.05)
        mp = self.moving[p.index]
        piece = motion_pick(p.means, hit.row, mp) if mp is not None else None
        if piece is None:
            piece = self.labels[p.index] == self.labels[p.index][hit.row]
        if p.selected[hit.row]:
            p.selected[piece] = False
            verb = "removed"
        else:
            if not add:
                for q in self.scene.pieces:
                    q.selected[:] = False
            p.selected |= piece
            verb = "selected"
        self._retint()
        return self._said(f"{verb} {int(piece.sum()):,} Gaussians of object #{p.index + 1} (the selection: "
                          "Select, above)")

    def box(self, event, add: bool = False) -> str:
        """A ctrl-drag box: the Gaussians whose centres project inside it (the event's camera)."""
        cam = event.client.camera
        if not add:
            for p in self.scene.pieces:
                p.selected[:] = False
        n = 0
        for p in self.scene.pieces:
            if p.static:
                continue
            rows = box_rows(p.means, cam.position, cam.wxyz, cam.fov, cam.aspect, event.screen_min, event.screen_max)
            p.selected[rows] = True
            n += len(rows)
        self._retint()
        if not n:
            return self._said("Nothing selected: no splat centre lies inside the box")
        return self._said(f"box: {n:,} Gaussians (the selection: Select, above)")

    def selection_text(self) -> str:
        parts = [f"{int(p.selected.sum()):,} of {p.n:,} Gaussians of object #{p.index + 1} "
                 f"({self._extent(p.means[p.selected])})" for p in self.scene.pieces if p.selected.any()]
        return "; ".join(parts) if parts else "nothing selected"

    @staticmethod
    def _extent(x: np.ndarray) -> str:
        if not len(x):
            return "-"
        size = np.percentile(x, 99, axis=0) - np.percentile(x, 1, axis=0)
        return " x ".join(f"{v:.3g}" for v in size) + " m"

    def _said(self, text: str) -> str:
        self.say(text)
        self.form.set_selection(self.selection_text())
        return text

    # -- runs -------------------------------------------------------------------------------------------
    def run(self, resume: bool = False) -> str:
        """Write the studio's scene and start ``gasp simulate`` on it (or ``--resume`` the stopped run)."""
        with self._lock:
            if self.stream is not None and self.stream.job.running:
                return self._said("a run is in progress: stop it first")
            try:
                self.form.apply()
                held = None
                if self.warmer is not None and not resume:
                    self.scene.check()
                    held = self.warmer.take(run_identity(self.scene.doc, self.scene.selections()))
                if resume and self.stream is not None:
                    self.stream = self.stream.resumed()
                elif held is not None:       # the held run of this very choice: released, frame 1 already written
                    self.stream = RunStream(held, held.outdir, started=time.monotonic())
                else:
                    self.stream = RunStream.start(self.scene)
            except (GaspError, OSError) as e:
                return self._said(str(e))
            self._drop_frames()
            self.form.reset_timeline()
            return self._said(f"running {self.stream.outdir.name} ({self.stream.job.scene.name})")

    def stop_run(self) -> str:
        if self.stream is None or not self.stream.job.running:
            return self._said("no run in progress")
        outcome = self.stream.job.stop()
        self._said(f"{self.stream.outdir.name}: {outcome}" + (f" ({self.stream.job.last_error()})"
                                                             if outcome == "stopped" else ""))
        return f"{self.stream.outdir.name}: {outcome}"

    def _drop_frames(self) -> None:
        if self._frame_handle is not None:
            self._frame_handle.remove()
            self._frame_handle = None
            self._frame_shown = -1
            for h in self._handles:
                h.visible = True

    def show_frame(self, k: int) -> None:
        """Show frame ``k`` of the current run (the rest scene is hidden while a run's frame is shown)."""
        with self._lock:
            if self.stream is None or not 0 <= k < self.stream.n_ready or k == self._frame_shown:
                return
            sp = self.stream.splats(k)
            arrays = (sp.means.astype(np.float32), sp.covs.astype(np.float32), sp.rgb, sp.opacities[:, None])
            if self._frame_handle is None:
                self._frame_handle = self.server.scene.add_gaussian_splats(
                    "/run", centers=arrays[0], covariances=arrays[1], rgbs=arrays[2], opacities=arrays[3])
                for h in self._handles:
                    h.visible = False
            else:
                self._frame_handle.set_gaussians(*arrays)
            self._frame_shown = k

    def _poll(self) -> None:
        """Follow the run: new frames onto the timeline (the newest shown while the slider is at the end),
        its warnings and its end into the page."""
        seen_events = 0
        while not self._stop.wait(0.25):
            stream = self.stream
            self._follow_warm(stream is not None and stream.job.running)
            if stream is None:
                self.form.set_run_status((self.warmer.status() if self.warmer else "") or "no run yet")
                continue
            try:
                grew = stream.refresh()
            except GaspError as e:
                self.say(str(e))
                continue
            events = stream.job.snapshot()
            for e in events[seen_events:]:
                if e.get("event") in ("warning", "error", "result"):
                    self.say(f"{e['event']}: {e.get('message', '')}")
            seen_events = len(events)
            self.form.set_run_status(stream.status(self._before_frame1()))
            if grew:
                self.form.timeline_grew(stream.n_ready)

    def _follow_warm(self, busy: bool) -> None:
        """Ask the warmer for the page's choice when it changed; say when a warm-up ends."""
        if self.warmer is None:
            return
        if self.warm_wanted and studio_request(self):
            self.warm_wanted = False
        said = self.warmer.poll(busy=busy)
        if said:
            self.say(said)

    def _before_frame1(self) -> str:
        """What a run does before its frame 1, as the page says it."""
        w, key = self.warmer, choice_key(self.scene.doc)
        if w is not None and key in w.built:
            return "preparing frame 1 (kernels built in the background)"
        if w is not None and w.running and w.key == key:
            return w.status().rsplit("…", 1)[0] + " (in the background)"
        return f"compiling {key[0]} kernels (first run; cached afterwards)"

    def stop(self) -> None:
        """Stop following, stop a run in progress (its frames kept for resume) and any warm-up, close the server."""
        self._stop.set()
        if self.warmer is not None:
            self.warmer.stop()
        if self.stream is not None and self.stream.job.running:
            self.stream.job.stop()
        self.server.stop()
        self._quiet.__exit__()


def serve(path, workdir, host: str = "127.0.0.1", port: int = 8080, save_dir=None) -> None:
    """Serve the studio until interrupted (Ctrl-C); print its URL with the token (and, off loopback, what is
    exposed)."""
    st = Studio(path, workdir, host, port, save_dir=save_dir)
    exposed = exposure_line(host, ", ".join(sorted({str(Path(workdir).resolve()), str(st.save_dir)})))
    if exposed:
        print(exposed, flush=True)
    print(f"gasp studio: {st.url}  ({Path(path).name}; files in {workdir}; Ctrl-C to stop)", flush=True)
    until_interrupted(st)
