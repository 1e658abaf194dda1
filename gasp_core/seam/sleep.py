"""Sleep: a scene at rest is not simulated (scene key ``sleep``, ``docs/performance.md`` "Sleep").

Rigid-body engines (Bullet, PhysX) put a resting body to sleep and wake it when something touches it. Here there
are two units. **The body** (engines with the feature ``sleep``; :mod:`gasp_core.seam.body_sleep`): a body at rest
is frozen while the others go on, and woken before anything can reach it. **The scene** (every engine; this
module): once, for :data:`SLEEP_FRAMES` frames in a row, no simulated point of it has moved more than
:data:`SLEEP_TOL` cells in a frame (what is left of its vibration) and no body's centroid more than
:data:`SLEEP_DRIFT` cells (a steady slide or creep is not rest; per body, so that two bodies moving opposite ways do
not add up to rest) and no point's damage or plastic strain grew more than :data:`FLOW_TOL` (engines with the
feature ``damage`` / ``plastic_strain``: a body still cracking or yielding flows, and a creep under the displacement
bounds accumulates), or every body sleeps on its own, and nothing that varies in time can reach it any more (no
moving collider, no wind or attractor, no impulse still to come), the engine is no longer stepped and each later
frame repeats the last one. Nothing can wake such a scene: a scene with anything still moving or still to come (a
second body in flight, a collider on its path, an impulse window ahead) never sleeps as a whole, because its points
move or because :func:`sleep_blockers` names what is still to come.

What sleep costs in accuracy is the motion the scene would still have made. Measured on the README donut (36
frames awake, its default engine; ``docs/performance.md`` "Sleep"): with these thresholds it falls asleep after frame 30, and
no Gaussian's centre of the awake run moves farther than 0.21 mm (0.068 % of the donut's size, about 0.1 U of
``docs/speed_accuracy.md``'s shape unit, 0.62 %) from where the sleeping run leaves it.
"""
from __future__ import annotations

import numpy as np

#: Largest displacement of any simulated point in one frame (in cells ``dx``) that counts as rest.
SLEEP_TOL = 0.2
#: Largest displacement of a body's centroid (its simulated points') in one frame (in cells ``dx``) that counts as rest.
SLEEP_DRIFT = 0.02
#: The entry of an engine state (``get_state``) that carries the sleep's count (:meth:`SleepWatch.state`).
SLEEP_KEY = "gasp_sleep"
#: Frames in a row at rest before the scene (or a body) sleeps.
SLEEP_FRAMES = 5
#: Largest growth in one frame of any point's irreversible state (dimensionless: a brittle point's damage in
#: [0, 1], a plasticine point's accumulated plastic strain; engines with the feature ``damage`` /
#: ``plastic_strain``) that counts as rest. Such a state grows only while the material yields or cracks, so a body
#: whose state still grows is flowing, not resting, however slowly its points move (the plasticine T rod of
#: ``benchmarks/tear_split.py`` creeps 0.03 dx a frame, under both displacement bounds, while its largest growth
#: falls no lower than about 1e-4 a frame before it tears: docs/performance.md, "Sleep"). 1e-5 is ten times below
#: that and far above the float32 rounding of a strain near 0.01 (1e-9).
FLOW_TOL = 1e-5
#: The entry of a checkpoint that carries the per-body watch (:meth:`gasp_core.seam.body_sleep.BodySleep.state`).
BODY_SLEEP_KEY = "gasp_body_sleep"


def sleep_blockers(setup, t: float) -> list[str]:
    """What in ``setup`` can still move a resting scene after time ``t`` (s); empty: it may sleep.

    Parameters
    ----------
    setup : SimSetup
        ``colliders`` (their ``motion``), ``forces``, ``impulses`` (their ``t1``), ``passive``.
    t : float
        Seconds since the start.
    """
    out = [f"collider '{c.name}' moves" for c in (setup.colliders or []) if c.motion.moving]
    out += [f"a {f.kind} force acts" for f in (setup.forces or [])]
    out += [f"an impulse ends at t = {i.t1:g} s" for i in (setup.impulses or []) if float(i.t1) >= t]
    return out


class SleepWatch:
    """Counts the frames a scene has been at rest and says when it falls asleep.

    Parameters
    ----------
    setup : SimSetup
    enabled : bool
        The scene's ``sleep`` key.
    bodies : BodySleep, optional
        The per-body watch (:mod:`gasp_core.seam.body_sleep`; engines with the feature ``sleep``): updated after each
        frame, its wake test run by :meth:`before_frame`; the scene also sleeps once all its bodies sleep.
    """

    def __init__(self, setup, enabled: bool = True, bodies=None):
        self.setup = setup
        self.enabled = bool(enabled)
        self.bodies = bodies if self.enabled else None
        self.quiet = 0
        #: The frame after which the engine was no longer stepped (None: awake).
        self.asleep_after: int | None = None
        self._material = None if setup.passive is None else ~np.asarray(setup.passive, dtype=bool)
        body = np.asarray(setup.body_id, dtype=np.int64)
        self._body = body if self._material is None else body[self._material]
        self._tol = SLEEP_TOL * float(setup.dx)
        self._drift = SLEEP_DRIFT * float(setup.dx)

    def moved(self, x_prev: np.ndarray, x: np.ndarray) -> tuple[float, float]:
        """Largest displacement of a simulated (non-passive) point between two frames and the largest of the bodies'
        centroids (m, per axis for the first). Per body: two bodies moving opposite ways (one rising to its apex,
        the other ringing after their impact) do not add up to a centroid at rest."""
        d = np.asarray(x, dtype=np.float64) - np.asarray(x_prev, dtype=np.float64)
        if self._material is not None:
            d = d[self._material]
        if not d.size:
            return 0.0, 0.0
        if len(d) != len(self._body):   # positions not of this setup (a synthetic check): one centroid
            return float(np.abs(d).max()), float(np.linalg.norm(d.mean(axis=0)))
        count = np.bincount(self._body)
        has = count > 0
        mean = np.stack([np.bincount(self._body, weights=d[:, a])[has] for a in range(3)], axis=1) / count[has, None]
        return float(np.abs(d).max()), float(np.linalg.norm(mean, axis=1).max())

    def flowing(self, growth: np.ndarray | None) -> np.ndarray:
        """Per body (``n_bodies``,), bool: whether any of its points' irreversible state (damage, plastic strain)
        grew by more than :data:`FLOW_TOL` over the frame. ``growth``: shape (n,), setup order, dimensionless, the
        state after the frame less the state before (None: the engine exposes none, no body flows)."""
        n_bodies = len(self.setup.materials)
        if growth is None:
            return np.zeros(n_bodies, bool)
        body = np.asarray(self.setup.body_id, dtype=np.int64)
        return np.bincount(body, weights=np.asarray(growth, np.float64) > FLOW_TOL, minlength=n_bodies) > 0

    def update(self, frame: int, x_prev: np.ndarray, x: np.ndarray, growth: np.ndarray | None = None) -> bool:
        """After simulated frame ``frame``: whether the scene is asleep from the next frame on. ``growth``: the
        growth of each point's damage or plastic strain over the frame (:meth:`flowing`; None: none known)."""
        if not self.enabled or self.asleep_after is not None:
            return self.asleep_after is not None
        most, centroid = self.moved(x_prev, x)
        flowing = self.flowing(growth)
        self.quiet = self.quiet + 1 if most <= self._tol and centroid <= self._drift and not flowing.any() else 0
        if self.bodies is not None:
            self.bodies.after_frame(frame, x_prev, x, flowing)
        rest = self.quiet >= SLEEP_FRAMES or (self.bodies is not None and self.bodies.all_asleep())
        if rest and not sleep_blockers(self.setup, frame * float(self.setup.frame_dt)):
            self.asleep_after = frame
        return self.asleep_after is not None

    def before_frame(self, frame: int, x: np.ndarray) -> None:
        """Before simulated frame ``frame``: the per-body wake test (:meth:`BodySleep.before_frame`), if any."""
        if self.bodies is not None and self.asleep_after is None:
            self.bodies.before_frame(frame, x)

    def state(self) -> np.ndarray:
        """``[quiet, asleep_after or -1]`` for a checkpoint."""
        return np.array([self.quiet, -1 if self.asleep_after is None else self.asleep_after], dtype=np.int64)

    def restore(self, state) -> None:
        quiet, after = (int(v) for v in np.asarray(state).ravel()[:2])
        self.quiet, self.asleep_after = quiet, (None if after < 0 else after)

    def take_from(self, state: dict) -> dict:
        """An engine state (``get_state``) without the sleep's entry, which restores this watch when present."""
        state = dict(state)
        if SLEEP_KEY in state:
            saved = state.pop(SLEEP_KEY)
            if self.enabled:   # a run resumed with sleep = false stays awake
                self.restore(saved)
        if BODY_SLEEP_KEY in state:
            saved = state.pop(BODY_SLEEP_KEY)
            if self.bodies is not None:
                self.bodies.restore(saved)
        return state

    def saving(self, get_state):
        """``get_state`` wrapped to add the sleep's entry (when sleep is on), for a checkpoint."""
        def saved() -> dict:
            out = dict(get_state())
            if self.enabled:
                out[SLEEP_KEY] = self.state()
            if self.bodies is not None:
                out[BODY_SLEEP_KEY] = self.bodies.state()
            return out
        return saved
