"""Sleep per body (issue 39, item 1; ``docs/performance.md`` "Sleep"): a body at rest is frozen while the others
go on, and wakes when anything can reach it.

The unit is the body (one ``SimSetup.body_id`` value, one scene object). After each simulated frame a body's quiet
count grows when none of its material points moved more than :data:`~gasp_core.seam.sleep.SLEEP_TOL` cells and its
centroid no more than :data:`~gasp_core.seam.sleep.SLEEP_DRIFT` cells and none of its points' damage or plastic
strain grew more than :data:`~gasp_core.seam.sleep.FLOW_TOL` (a creep is not rest), and is reset otherwise; after
:data:`~gasp_core.seam.sleep.SLEEP_FRAMES` quiet frames in a row the body falls asleep, unless something that varies
in time is still to come (:func:`~gasp_core.seam.sleep.sleep_blockers`: then no body sleeps) or an awake point of
another body is within its reach (then it stays awake with its count, and sleeps with that body). An engine with
the feature ``sleep`` is then told (``set_asleep``): it leaves the body's points out of its transfers, so their
``x, v, F, C, Jp`` stay as they are and cost nothing.

**The wake rule.** Before each frame, a sleeping body wakes when an awake material point of another body lies in
the box of its own points grown by the reach

    reach = u + |g| frame_dt^2 + 3 dx,

``u`` the largest move (per axis) of any awake point over the last frame, ``|g| frame_dt^2`` what gravity adds to
it in one more frame, ``3 dx`` the grid kernel's support (a point's stencil spans 3 nodes) plus the contact's skin:
nothing can touch the body during the next frame without first being in that box. Waking repeats until no more
bodies wake (a woken body can reach a third one). A woken body goes on with the ``v, F, C`` it slept with; it may
sleep again. Bodies with passive points or a rigid material (``model = "rigid"``) do not sleep on their own (the
engines move them with the rest of the grid; the scene's sleep still stops them).

The watch's state (counts, flags, the last move, the events) is part of a checkpoint, so a run stopped and
resumed sleeps and wakes where the uninterrupted one does.
"""
from __future__ import annotations

import numpy as np

from gasp_core.seam.sleep import SLEEP_DRIFT, SLEEP_FRAMES, SLEEP_TOL, sleep_blockers
#: Cells added to a sleeping body's box beyond the moves: the kernel's support (3 nodes) and the contact's skin.
REACH_CELLS = 3.0


class BodySleep:
    """Per-body quiet counts, asleep flags and the wake test.

    Parameters
    ----------
    setup : SimSetup
        ``body_id`` (n,), ``materials`` (one per body), ``passive`` (n,) bool or None, ``dx`` (m), ``frame_dt`` (s),
        ``gravity`` (3,) m/s^2.

    Attributes
    ----------
    asleep : ndarray, shape (n_bodies,), bool
        Which bodies are frozen now (what the engine's ``set_asleep`` is given).
    events : list of (int, int, str)
        ``(frame, body, "slept" | "woke")``: "slept" after simulated frame ``frame``, "woke" before it.
    """

    def __init__(self, setup):
        self.setup = setup
        self.n_bodies = len(setup.materials)
        body = np.asarray(setup.body_id, dtype=np.int64)
        material = np.ones(len(body), bool) if setup.passive is None else ~np.asarray(setup.passive, dtype=bool)
        self._body = body[material]
        self._material = material
        self._index = [np.flatnonzero(self._body == b) for b in range(self.n_bodies)]
        passive_bodies = set(np.unique(body[~material]).tolist())
        self.can_sleep = np.array([len(self._index[b]) > 0 and b not in passive_bodies
                                   and getattr(setup.materials[b], "model", "auto") != "rigid"
                                   for b in range(self.n_bodies)], dtype=bool)
        self.quiet = np.zeros(self.n_bodies, np.int64)
        self.asleep = np.zeros(self.n_bodies, bool)
        self.last_move = 0.0
        self.events: list[tuple[int, int, str]] = []
        self._dx = float(setup.dx)
        self._tol, self._drift = SLEEP_TOL * self._dx, SLEEP_DRIFT * self._dx
        self._fall = float(np.linalg.norm(np.asarray(setup.gravity, float))) * float(setup.frame_dt) ** 2

    def reach(self) -> float:
        """Margin (m) around a sleeping body's box: ``last_move + |g| frame_dt^2 + REACH_CELLS dx``."""
        return self.last_move + self._fall + REACH_CELLS * self._dx

    def _reached(self, xm: np.ndarray, b: int, awake: np.ndarray) -> bool:
        """Whether a material point of an awake body other than ``b`` lies in ``b``'s box grown by the reach."""
        others = awake[self._body] & (self._body != b)
        if not others.any():
            return False
        pts = xm[self._index[b]]
        r = self.reach()
        lo, hi = pts.min(axis=0) - r, pts.max(axis=0) + r
        q = xm[others]
        return bool(((q >= lo) & (q <= hi)).all(axis=1).any())

    def after_frame(self, frame: int, x_prev: np.ndarray, x: np.ndarray, flowing: np.ndarray | None = None) -> bool:
        """Count the quiet frames of the awake bodies after simulated frame ``frame`` and put to sleep those that
        may sleep. ``x_prev``, ``x``: (n, 3) positions, m, setup order; ``flowing``: (n_bodies,) bool, the bodies
        whose damage or plastic strain grew over the frame (:meth:`gasp_core.seam.sleep.SleepWatch.flowing`; not at
        rest; None: none). Returns whether ``asleep`` changed."""
        xm = np.asarray(x, np.float64)[self._material]
        d = xm - np.asarray(x_prev, np.float64)[self._material]
        awake_pts = ~self.asleep[self._body]
        self.last_move = float(np.abs(d[awake_pts]).max()) if awake_pts.any() else 0.0
        for b in np.flatnonzero(~self.asleep & self.can_sleep):
            db = d[self._index[b]]
            rest = np.abs(db).max() <= self._tol and np.linalg.norm(db.mean(axis=0)) <= self._drift \
                and not (flowing is not None and flowing[b])
            self.quiet[b] = self.quiet[b] + 1 if rest else 0
        if sleep_blockers(self.setup, frame * float(self.setup.frame_dt)):
            return False
        cand = ~self.asleep & self.can_sleep & (self.quiet >= SLEEP_FRAMES)
        changed = True
        while changed and cand.any():   # a candidate another awake body can reach stays awake, and can reach others
            changed = False
            for b in np.flatnonzero(cand):
                if self._reached(xm, b, ~self.asleep & ~cand):
                    cand[b], changed = False, True
        for b in np.flatnonzero(cand):
            self.events.append((frame, int(b), "slept"))
        self.asleep |= cand
        return bool(cand.any())

    def before_frame(self, frame: int, x: np.ndarray) -> bool:
        """Wake, before simulated frame ``frame``, every sleeping body that an awake point can reach (repeated
        until none more wakes). ``x``: (n, 3) positions, m. Returns whether ``asleep`` changed."""
        if not self.asleep.any():
            return False
        xm = np.asarray(x, np.float64)[self._material]
        woke = False
        changed = True
        while changed:
            changed = False
            for b in np.flatnonzero(self.asleep):
                if self._reached(xm, b, ~self.asleep):
                    self.asleep[b], self.quiet[b], changed, woke = False, 0, True, True
                    self.events.append((frame, int(b), "woke"))
        return woke

    def all_asleep(self) -> bool:
        """Every body with material points asleep (the scene may then stop stepping the engine)."""
        has = np.array([len(i) > 0 for i in self._index], bool)
        return bool(has.any() and self.asleep[has].all())

    def record(self, names=None) -> list[dict]:
        """Per body: ``body``, ``name``, ``slept_after_frames`` and ``woke_before_frames`` (lists of int), for
        ``run.json``."""
        out = []
        for b in range(self.n_bodies):
            ev = [(f, k) for f, bb, k in self.events if bb == b]
            out.append({"body": b, "name": None if names is None else names[b], "can_sleep": bool(self.can_sleep[b]),
                        "slept_after_frames": [f for f, k in ev if k == "slept"],
                        "woke_before_frames": [f for f, k in ev if k == "woke"]})
        return out

    def state(self) -> np.ndarray:
        """float64 ``[last_move, n_bodies, quiet (n_bodies), asleep (n_bodies), (frame, body, woke) per event]``."""
        ev = [v for f, b, k in self.events for v in (f, b, 1.0 if k == "woke" else 0.0)]
        return np.concatenate([[self.last_move, self.n_bodies], self.quiet, self.asleep, ev]).astype(np.float64)

    def restore(self, state) -> None:
        """Set counts, flags, last move and events from :meth:`state`."""
        s = np.asarray(state, np.float64).ravel()
        n = int(s[1])
        self.last_move = float(s[0])
        self.quiet = s[2:2 + n].astype(np.int64)
        self.asleep = s[2 + n:2 + 2 * n] != 0
        ev = s[2 + 2 * n:].reshape(-1, 3)
        self.events = [(int(f), int(b), "woke" if k else "slept") for f, b, k in ev]
