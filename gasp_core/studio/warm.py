"""The studio runs what its user is about to ask for while they choose: a held run (issue 39).

A first run of an engine spends most of its time before frame 1 compiling kernels (into the
engine's own kernel cache) and building the engine: docs/studio.md, "Time to the first frame".
As soon as a file is open, and again when the engine, the material or the quality level changes, :class:`Warmer`
starts the run a click on Run would start (the page's choice, the default model's typical values while no material
is chosen, the largest connected piece of the object or the selection already made) as ``gasp simulate --hold``
into the next ``runN`` (:mod:`gasp_core.run.hold`): it loads, prepares, builds the engine, compiles its kernels,
simulates frame 1 and waits. Run on that same run (the same document and masks, :func:`run_identity`) releases it
and the page shows frame 1 at once; Run on anything else stops it, removes what it wrote, and starts afresh with
the kernels it compiled in the engine's cache. The engine itself decides what it caches; nothing here names one.

At most one held run at a time. A change of choice stops it and starts the new one, except that a change which
keeps its kernels (:func:`choice_key`: the frame count, the selection) waits for its frame 1 (the kernels land in
the cache the next one reads); one that prepares for longer than :data:`WARM_MAX_S` is stopped. While one prepares the page says ``compiling <engine> kernels (first run; cached
afterwards)... N s``.
"""
from __future__ import annotations

import copy
import hashlib
import json
import shutil
import threading
import time
from pathlib import Path
from typing import Callable

import numpy as np

from gasp_core.fsmarker import CLAIM
from gasp_core.studio.job import Job
from gasp_core.studio.scene import write_document
from gasp_core.studio.stream import next_run_dir

#: Longest a held run may take to reach its frame 1, seconds (then it is stopped: a bound on two jobs sharing
#: the cores).
WARM_MAX_S = 600.0


def predicted_selection(selected: np.ndarray, labels: np.ndarray, linking: np.ndarray) -> np.ndarray:
    """What a run will most likely simulate, shape (n,), bool: the selection made (when any), else the largest
    connected piece of opaque Gaussians (``labels`` from :func:`gasp_core.studio.pieces.piece_labels`), which a
    click on the object selects."""
    if selected.any():
        return selected.copy()
    counts = np.bincount(labels[linking]) if linking.any() else np.bincount(labels)
    return labels == int(np.argmax(counts))


def run_identity(doc: dict, selections: dict[int, np.ndarray]) -> str:
    """What makes two studio runs the same run: a digest of the document (absolute paths) and the masks."""
    h = hashlib.sha256(json.dumps(doc, sort_keys=True, default=str).encode("utf-8"))
    for k in sorted(selections):
        h.update(f"{k}:".encode() + np.packbits(np.asarray(selections[k], bool)).tobytes())
    return h.hexdigest()


class Warmer:
    """At most one held run at a time, and what the held runs built (module notes).

    Parameters
    ----------
    workdir : Path
        The studio's folder: a held run writes ``runN.toml`` and ``runN`` there, its hold file in ``.warm``.
    start_job : callable, optional
        ``start_job(scene, outdir, hold) -> Job`` (default :class:`~gasp_core.studio.job.Job`: ``gasp simulate
        --hold``).

    Attributes
    ----------
    built : dict
        ``{key: seconds}`` of every choice whose held run reached frame 1 (its kernels are in the cache).
    failed : dict
        ``{key: one line}`` of the choices whose held run failed (not tried again).
    """

    def __init__(self, workdir: Path, start_job: Callable[[Path, Path, Path], Job] | None = None):
        self.workdir = Path(workdir)
        self.folder = self.workdir / ".warm"
        self._start_job = start_job or (lambda scene, outdir, hold: Job(scene, outdir, hold=hold))
        self._lock = threading.Lock()
        self.job: Job | None = None
        self.key = self.engine = self.identity = None
        self.hold: Path | None = None
        self.pending: tuple | None = None
        self.built: dict = {}
        self.failed: dict = {}

    def request(self, key, engine: str, doc: dict, selections: dict[int, np.ndarray]) -> bool:
        """Ask for the run of ``doc`` with ``selections`` on ``engine`` (``key``: what of it the kernels depend on,
        :func:`choice_key`). Returns False when that run is held already or its choice failed before."""
        identity = run_identity(doc, selections)
        with self._lock:
            if key in self.failed or (self.job is not None and identity == self.identity):
                self.pending = None if key not in self.failed else self.pending
                return False
            self.pending = (key, engine, identity, copy.deepcopy(doc), {k: v.copy() for k, v in selections.items()})
            return True

    def poll(self, busy: bool = False) -> str | None:
        """Follow the held run: say when it reached frame 1, stop it past :data:`WARM_MAX_S`; replace it by the
        pending choice unless a run is ``busy`` (once held, when the pending choice has the same kernels). Returns a
        line for the page, or None."""
        said = None
        with self._lock:
            if self.job is not None:
                elapsed = time.monotonic() - self.job.started
                ready = self.job.frames_done() >= 1
                if ready and self.key not in self.built:
                    self.built[self.key] = elapsed
                    said = f"{self.engine} kernels ready, frame 1 simulated ({elapsed:.1f} s while you chose)"
                if self.job.running and not ready and elapsed > WARM_MAX_S:
                    self.failed[self.key] = f"stopped after {WARM_MAX_S:.0f} s"
                    said = f"{self.engine}: kernels not built in the background ({self.failed[self.key]})"
                    self._drop()
                elif not self.job.running:
                    outcome = self.job.outcome()
                    self.failed.setdefault(self.key, outcome)
                    said = f"{self.engine}: kernels not built in the background ({outcome})"
                    self._drop()
                elif self.pending is None or busy or (not ready and self.pending[0] == self.key):
                    return said   # a choice with the same kernels waits for them: they land in the engine's cache
                else:
                    self._drop()
            if self.pending is not None and not busy:
                key, engine, identity, doc, selections = self.pending
                self.pending = None
                try:
                    self._start(key, engine, identity, doc, selections)
                except Exception as e:  # noqa: BLE001 (a held run is an optimisation: it never stops the studio)
                    self.failed[key] = f"{type(e).__name__}: {e}"
                    said = f"{engine}: kernels not built in the background ({self.failed[key]})"
        return said

    def _start(self, key, engine: str, identity: str, doc: dict, selections: dict) -> None:
        outdir = next_run_dir(self.workdir)
        self.folder.mkdir(parents=True, exist_ok=True)
        self.hold = self.folder / f"{outdir.name}.hold"
        self.hold.touch()
        scene = write_document(doc, selections, outdir.with_suffix(".toml"))
        self.job = self._start_job(scene, outdir, self.hold)
        self.key, self.engine, self.identity = key, engine, identity

    def _drop(self) -> None:
        """Stop the held run and remove what it wrote (its scene, masks, hold file and partial folder)."""
        job, self.job = self.job, None
        if job.running:
            job.stop(timeout=10.0)
        out = job.outdir
        for f in [job.scene, *out.parent.glob(f"{out.name}.select*.npy"), self.hold]:
            f.unlink(missing_ok=True)
        for p in out.parent.glob(f".{out.name}.partial-*"):
            shutil.rmtree(p, ignore_errors=True)
        if out.is_dir() and {p.name for p in out.iterdir()} <= {CLAIM}:   # the stopped run's claim, nothing else
            shutil.rmtree(out, ignore_errors=True)
        self.key = self.engine = self.identity = None

    @property
    def running(self) -> bool:
        return self.job is not None and self.job.running and self.job.frames_done() == 0

    def status(self) -> str:
        """``compiling <engine> kernels (first run; cached afterwards)... N s`` while a held run prepares, else
        ``""``."""
        if not self.running:
            return ""
        return f"compiling {self.engine} kernels (first run; cached afterwards)… " \
               f"{time.monotonic() - self.job.started:.0f} s"

    def take(self, identity: str) -> Job | None:
        """Run was clicked on the run ``identity``: the held run released and handed over when it is that run,
        else None (a held run of anything else stopped and removed; the pending choice dropped)."""
        with self._lock:
            self.pending = None
            if self.job is None:
                return None
            if self.identity == identity and self.job.running:
                job, self.job = self.job, None
                self.hold.unlink(missing_ok=True)
                self.key = self.engine = self.identity = None
                return job
            self._drop()
            return None

    def stop(self) -> None:
        """Stop and remove any held run (the studio closes)."""
        with self._lock:
            self.pending = None
            if self.job is not None:
                self._drop()


def choice_key(doc: dict) -> tuple:
    """What of the studio's document changes an engine's kernels: the engine, the quality level (its engine
    options and point layout), each object's material model and the boundaries' kinds."""
    return (doc.get("engine", {}).get("name"), doc.get("quality"),
            tuple(o.get("material", {}).get("name") for o in doc["object"]),
            tuple(sorted(b.get("kind", "") for b in doc.get("boundary", []))))


def studio_request(studio) -> bool:
    """Ask ``studio``'s :class:`Warmer` for the run of the page's choice (a material not chosen yet: the default
    model). Returns False while the pieces of a file are still being found (ask again later), else True."""
    sc, form = studio.scene, studio.form
    if any(label is None for label in studio.labels):
        return False
    doc = form.document(warm=True)
    engine = doc["engine"]["name"]
    if engine not in form.engine.options or engine.startswith("("):
        return True
    selections = sc.selections()
    if sc.is_file and not selections:
        p = sc.pieces[0]
        selections[0] = predicted_selection(p.selected, studio.labels[0], p.linking)
    studio.warmer.request(choice_key(doc), engine, doc, selections)
    return True
