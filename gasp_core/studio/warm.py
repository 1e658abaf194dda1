"""The studio compiles while the user chooses (issue 39): the chosen engine's kernels built in the background.

A first run of an engine spends most of its time before frame 1 compiling kernels (Warp's kernel cache,
``WARP_CACHE_PATH``; Taichi's offline cache): docs/studio.md, "Time to the first frame". As soon as a file is open,
and again when the engine, the material or the quality level changes, :class:`Warmer` runs ``gasp simulate`` for
one frame (:data:`WARM_FRAMES`) on the studio's own scene with the selection a click would make (the largest
connected piece of the object, or the selection already made): the same engine, options, material model, ground
and point counts as the run the user is about to start, so the run finds every kernel in the engine's cache.
The engine itself decides what it caches; nothing here names an engine.

At most one warm-up runs at a time and never beside a run that does not need it: a run of the same choice lets
the warm-up finish (its kernels land in the cache the run reads), a run of another choice stops it; a request
made while a run goes waits for it. A warm-up that takes longer than :data:`WARM_MAX_S` is stopped. While one
runs, the page says ``compiling <engine> kernels (first run; cached afterwards)... N s``.
"""
from __future__ import annotations

import copy
import shutil
import threading
import time
from pathlib import Path
from typing import Callable

import numpy as np

from gasp_core.scene.spec import parse_scene
from gasp_core.studio.job import Job

#: Frames a warm-up simulates: frame 1 launches every kernel of a substep.
WARM_FRAMES = 1
#: Longest a warm-up may run, seconds (then it is stopped: a bound on two jobs sharing the cores).
WARM_MAX_S = 600.0


def predicted_selection(selected: np.ndarray, labels: np.ndarray, linking: np.ndarray) -> np.ndarray:
    """What a run will most likely simulate, shape (n,), bool: the selection made (when any), else the largest
    connected piece of opaque Gaussians (``labels`` from :func:`gasp_core.studio.app.piece_labels`), which a
    click on the object selects."""
    if selected.any():
        return selected.copy()
    counts = np.bincount(labels[linking]) if linking.any() else np.bincount(labels)
    return labels == int(np.argmax(counts))


def write_warm_scene(doc: dict, selections: dict[int, np.ndarray], path: Path) -> Path:
    """Write ``doc`` (absolute paths) for a warm-up at ``path``: :data:`WARM_FRAMES` frames, each object ``k`` of
    ``selections`` selecting its mask (``<stem>.select<k>.npy`` beside it).

    Raises
    ------
    SceneError
        The scene checker refuses the document (nothing is run).
    """
    import tomli_w
    doc = copy.deepcopy(doc)
    doc["n_frames"] = WARM_FRAMES
    path.parent.mkdir(parents=True, exist_ok=True)
    for k, sel in selections.items():
        mask = path.with_name(f"{path.stem}.select{k}.npy")
        np.save(mask, sel)
        doc["object"][k]["select"] = {"mask": str(mask.resolve())}
    parse_scene(doc, path)
    path.write_text(tomli_w.dumps(doc), encoding="utf-8")
    return path


class Warmer:
    """At most one warm-up process at a time, and what the warm-ups built (module notes).

    Parameters
    ----------
    folder : Path
        Where the warm-up scenes and their runs are written (each run removed when it ends).
    start_job : callable, optional
        ``start_job(scene, outdir) -> Job`` (default :class:`~gasp_core.studio.job.Job`: ``gasp simulate``).

    Attributes
    ----------
    built : dict
        ``{key: seconds}`` of every choice whose warm-up finished.
    failed : dict
        ``{key: one line}`` of the warm-ups that failed (not tried again).
    """

    def __init__(self, folder: Path, start_job: Callable[[Path, Path], Job] | None = None):
        self.folder = Path(folder)
        self._start_job = start_job or (lambda scene, outdir: Job(scene, outdir))
        self._lock = threading.Lock()
        self.job: Job | None = None
        self.key = self.engine = None
        self.pending: tuple | None = None
        self.built: dict = {}
        self.failed: dict = {}
        self._n = 0

    def request(self, key, engine: str, write: Callable[[Path], Path]) -> bool:
        """Ask for the kernels of choice ``key`` (hashable) on ``engine``; ``write(path)`` writes its scene when it
        starts. Returns False when that choice is built, failed or warming already."""
        with self._lock:
            if key in self.built or key in self.failed or (self.job is not None and key == self.key):
                self.pending = None if self.job is not None and key == self.key else self.pending
                return False
            self.pending = (key, engine, write)
            return True

    def poll(self, busy: bool = False) -> str | None:
        """Follow the warm-up: record its end, stop it past :data:`WARM_MAX_S`, start the pending one unless a run
        is ``busy``. Returns a line for the page when a warm-up ended, else None."""
        said = None
        with self._lock:
            if self.job is not None:
                elapsed = time.monotonic() - self.job.started
                if self.job.running and elapsed > WARM_MAX_S:
                    self.job.stop(timeout=5.0)
                    self.failed[self.key] = f"stopped after {WARM_MAX_S:.0f} s"
                if self.job.running:
                    return None
                said = self._ended(elapsed)
            if self.pending is not None and not busy:
                key, engine, write = self.pending
                self.pending = None
                self._n += 1
                try:
                    scene = write(self.folder / f"warm{self._n}.toml")
                    self.job = self._start_job(scene, self.folder / f"warm{self._n}")
                    self.key, self.engine = key, engine
                except Exception as e:  # noqa: BLE001 (a warm-up is an optimisation: it never stops the studio)
                    self.failed[key] = f"{type(e).__name__}: {e}"
                    said = f"{engine}: kernels not built in the background ({self.failed[key]})"
        return said

    def _ended(self, elapsed: float) -> str:
        outcome = self.job.outcome()
        if outcome == "finished":
            self.built[self.key] = elapsed
            said = f"{self.engine} kernels ready (built in {elapsed:.1f} s while you chose)"
        elif outcome == "stopped" and self.key not in self.failed:   # for a run of another choice: asked again later
            said = f"{self.engine}: background build stopped"
        else:
            self.failed.setdefault(self.key, outcome)
            said = f"{self.engine}: kernels not built in the background ({self.failed[self.key]})"
        shutil.rmtree(self.job.outdir, ignore_errors=True)
        self.job = None
        return said

    @property
    def running(self) -> bool:
        return self.job is not None and self.job.running

    def status(self) -> str:
        """``compiling <engine> kernels (first run; cached afterwards)... N s`` while a warm-up runs, else ``""``."""
        job = self.job
        if job is None or not job.running:
            return ""
        return f"compiling {self.engine} kernels (first run; cached afterwards)… {time.monotonic() - job.started:.0f} s"

    def for_run(self, key) -> None:
        """A run of choice ``key`` starts: a warm-up of another choice is stopped, the pending one dropped (a later
        change asks again)."""
        with self._lock:
            self.pending = None
            if self.job is not None and self.key != key and self.job.running:
                self.job.stop(timeout=5.0)

    def stop(self) -> None:
        """Stop any warm-up (the studio closes)."""
        with self._lock:
            self.pending = None
            if self.job is not None and self.job.running:
                self.job.stop(timeout=5.0)


def choice_key(doc: dict) -> tuple:
    """What of the studio's document changes an engine's kernels: the engine, the quality level (its engine
    options and point layout), each object's material model and the boundaries' kinds."""
    return (doc.get("engine", {}).get("name"), doc.get("quality"),
            tuple(o.get("material", {}).get("name") for o in doc["object"]),
            tuple(sorted(b.get("kind", "") for b in doc.get("boundary", []))))


def studio_request(studio) -> bool:
    """Ask ``studio``'s :class:`Warmer` for the kernels of the page's choice (a material not chosen yet: the default
    model). Returns False while the pieces of a file are still being found (ask again later), else True."""
    sc, form = studio.scene, studio.form
    if any(label is None for label in studio.labels):
        return False
    doc = form.document(warm=True)
    engine = doc["engine"]["name"]
    if engine not in form.engine.options or engine.startswith("("):
        return True
    selections = {p.index: p.selected.copy() for p in sc.pieces if p.selected.any()}
    if sc.is_file and not selections:
        p = sc.pieces[0]
        selections[0] = predicted_selection(p.selected, studio.labels[0], p.linking)
    studio.warmer.request(choice_key(doc), engine, lambda path: write_warm_scene(doc, selections, path))
    return True
