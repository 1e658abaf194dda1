"""The ``taichi_mpm`` engine: a :class:`gasp_core.engine.PointEngine` over :class:`MPMSolver`.

Taichi has one runtime per process and ``ti.init`` resets it: **one taichi_mpm engine is live
per process at a time**. Building a new engine invalidates every earlier one; calling an
invalidated engine raises :class:`gasp_core.engine.EngineError`.
"""
from __future__ import annotations

import os
from typing import Any

import numpy as np

from gasp_core.engine import EngineDivergence, EngineError, SimSetup, check_options
from gasp_core.mpm import check_time_options, mpm_substeps

from . import CAPABILITIES, OPTIONS  # noqa: F401

ENGINE = "taichi_mpm"
DEFAULT_OPTIONS = {"device": "cpu", "precision": "f32", "dt": None, "n_substeps": None, "cfl": 0.4,
                   "threads": None}
#: Private grid copies are used on CPU while they take at most this many bytes in all.
MAX_PRIVATE_GRID_BYTES = 1 << 30

CAUSE_DT = "time step above the stability limit or material too stiff for dt"
CAUSE_DOMAIN = "points left the domain: add walls/ground or enlarge the domain"

_generation = 0  # bumped by every engine built; an engine is live while its generation is current


def _validate_options(setup: SimSetup) -> dict[str, Any]:
    opt = check_options(setup.options, OPTIONS, ENGINE)
    check_time_options(opt, ENGINE)
    return opt


def _validate_setup(setup: SimSetup) -> None:
    """What this engine adds to ``SimSetup``'s own checks: its capabilities."""
    # checked by gasp_core.engine.build_engine (capabilities) before the factory runs


def time_step(setup: SimSetup, opt: dict[str, Any]) -> tuple[int, float]:
    """Substeps per frame and substep length (``gasp_core.physics.mpm_substeps``, docs/mpm.md)."""
    return mpm_substeps(setup, opt["dt"], opt["n_substeps"], opt["cfl"])


class TaichiMPMEngine:
    """MLS-MPM engine on Taichi (``docs/mpm.md``).

    Parameters
    ----------
    setup : SimSetup
        World frame, SI units. ``setup.options`` may hold ``device`` ("cpu" | "cuda"),
        ``precision`` ("f32" | "f64"), ``dt`` (s) or ``n_substeps`` (per frame), ``cfl`` (0.4) and
        ``threads`` (CPU threads, Taichi's ``cpu_max_num_threads``; default all cores).

    Raises
    ------
    SceneError
        Unknown or invalid option (the message names it), unsupported material or boundary.
    EngineError
        ``device="cuda"`` where Taichi has no CUDA.

    Notes
    -----
    Calls ``ti.init`` (``offline_cache=True``, ``fast_math=False``: IEEE semantics, closer to the
    Warp engine, and measured ~10 % faster here than Taichi's fast math): this resets Taichi, so any earlier engine of this
    plugin in the process stops working. On CPU a run repeats bit for bit for a fixed ``threads``
    (each thread scatters into its own grid copy, summed in a fixed order); the capability
    ``deterministic={"cpu"}`` is promised for ``threads=1``.
    """

    def __init__(self, setup: SimSetup):
        global _generation
        opt = _validate_options(setup)
        _validate_setup(setup)
        import taichi as ti

        self.setup = setup
        self.options = opt
        self.n_substeps, self.dt = time_step(setup, opt)
        real = ti.f32 if opt["precision"] == "f32" else ti.f64
        if opt["device"] == "cuda":
            if not ti.lang.misc.is_arch_supported(ti.cuda):
                raise EngineError(f"engine '{ENGINE}': device 'cuda' requested but this Taichi build "
                                  "or machine has no CUDA; use device='cpu'")
            ti.init(arch=ti.cuda, default_fp=real, offline_cache=True, fast_math=False, log_level=ti.WARN)
            if ti.lang.impl.current_cfg().arch != ti.cuda:
                raise EngineError(f"engine '{ENGINE}': device 'cuda' requested but Taichi could not "
                                  "start CUDA (no GPU or driver); use device='cpu'")
            threads = None
        else:
            threads = int(opt["threads"]) if opt["threads"] is not None else (os.cpu_count() or 1)
            ti.init(arch=ti.cpu, default_fp=real, offline_cache=True, cpu_max_num_threads=threads,
                    fast_math=False, log_level=ti.WARN)
        _generation += 1
        self._gen = _generation
        self._ti = ti
        self.threads = threads
        from .solver import KIND, MPMSolver, material_params, node_ranges

        dx = setup.dx
        n = len(setup.x)
        # Sort points by grid cell for memory locality; outputs go back to the setup order.
        cell = np.floor((setup.x - setup.domain_lo) / dx).astype(np.int64)
        cell = np.clip(cell, 0, setup.n_grid - 1)
        key = (cell[:, 0] * setup.n_grid + cell[:, 1]) * setup.n_grid + cell[:, 2]
        self._order = np.argsort(key, kind="stable")
        self._inverse = np.empty(n, np.int64)
        self._inverse[self._order] = np.arange(n)
        o = self._order

        walls, grounds, regions = node_ranges(setup, dx)
        fixed = np.zeros(n, bool)
        for b in setup.boundaries:
            if b.kind == "fixed_region":
                fixed |= np.all((setup.x >= np.asarray(b.lo)) & (setup.x <= np.asarray(b.hi)), axis=1)
        kinds = [KIND[m.name] for m in setup.materials]
        jp0 = np.where(np.asarray(kinds)[setup.body_id] == KIND["plasticine"], 0.0, 1.0)
        params = np.stack([material_params(m) for m in setup.materials])
        bytes_per = 4 if real == ti.f32 else 8
        grid_bytes = 4 * bytes_per * setup.n_grid ** 3
        atomic = opt["device"] == "cuda" or threads * grid_bytes > MAX_PRIVATE_GRID_BYTES
        C0 = getattr(setup, "C", None)
        C0 = np.zeros((n, 3, 3)) if C0 is None else np.asarray(C0, float)[o]
        self.solver = MPMSolver(
            x=setup.x[o], v=setup.v[o], C0=C0, p_mass=setup.p_mass[o], p_vol=setup.p_vol[o],
            body=setup.body_id[o], fixed=fixed[o], jp0=jp0[o], params=params, kinds=kinds,
            n_grid=setup.n_grid, lo=setup.domain_lo, dx=dx, dt=self.dt, gravity=setup.gravity,
            walls=walls, grounds=grounds, regions=regions, real=real,
            n_chunks=threads or 1, atomic=atomic)
        self._p2g_mode = "atomic" if atomic else f"private grids x{self.solver.n_chunks}"
        self.frame = 0
        self._x = setup.x.astype(np.float32 if real == ti.f32 else np.float64)
        self._v = setup.v.astype(self._x.dtype)
        self._closed = False

    # ------------------------------------------------------------------ interface
    def _check_live(self) -> None:
        if self._closed:
            raise EngineError(f"engine '{ENGINE}': this engine was closed")
        if self._gen != _generation:
            raise EngineError(f"engine '{ENGINE}': this engine was invalidated because a newer "
                              f"taichi_mpm engine was built in the process (ti.init is global: "
                              f"one engine per process at a time)")

    def step_frame(self) -> None:
        """Advance ``frame_dt`` seconds in ``n_substeps`` substeps of ``dt``.

        Raises
        ------
        EngineDivergence
            Non-finite position or velocity, or a point out of the grid during the frame (the
            message gives the count and the first point index in setup order).
        EngineError
            The engine was closed or invalidated by a newer one.

        After an EngineDivergence, :meth:`positions` and :meth:`velocities` still return the last
        frame that passed the checks.
        """
        self._check_live()
        s = self.solver
        s.reset_out()
        s.substeps(self.n_substeps)
        self.frame += 1
        x = s.get(s.x)[self._inverse]
        v = s.get(s.v)[self._inverse]
        n_out = int(s.n_out[None])
        finite = np.isfinite(x).all(axis=1) & np.isfinite(v).all(axis=1)
        if not finite.all():
            bad = np.flatnonzero(~finite)
            raise EngineDivergence(f"{len(bad)} point(s) with non-finite position or velocity "
                                   f"(first index {bad[0]})", self.frame, CAUSE_DT)
        X = (x - self.setup.domain_lo) / self.setup.dx
        base = np.floor(X - 0.5)
        out = ((base < 0) | (base > self.setup.n_grid - 3)).any(axis=1)
        if out.any() or n_out > 0:
            bad = np.flatnonzero(out)
            where = f" (first index {bad[0]} at {x[bad[0]].tolist()})" if len(bad) else ""
            fast = float(np.max(np.linalg.norm(v, axis=1))) * self.dt > self.setup.dx
            raise EngineDivergence(
                f"{max(len(bad), 1)} point(s) left the grid{where}; {n_out} out-of-grid "
                f"point-substeps in this frame", self.frame, CAUSE_DT if fast else CAUSE_DOMAIN)
        self._x, self._v = x, v

    def positions(self) -> np.ndarray:
        """Current positions, shape (n, 3), float32 (f32) or float64 (f64), metres, setup order."""
        return self._x.copy()

    def velocities(self) -> np.ndarray:
        """Current velocities, shape (n, 3), m/s, setup order."""
        return self._v.copy()

    def stats(self) -> dict[str, Any]:
        """``device, precision, n_points, dt, n_substeps, n_grid, threads`` and ``dx``, ``p2g``, ``frame``."""
        return {
            "device": self.options["device"],
            "precision": self.options["precision"],
            "n_points": int(len(self.setup.x)),
            "dt": float(self.dt),
            "n_substeps": int(self.n_substeps),
            "n_grid": int(self.setup.n_grid),
            "dx": float(self.setup.dx),
            "threads": self.threads,
            "p2g": self._p2g_mode,
            "frame": self.frame,
        }

    def close(self) -> None:
        """Drop the fields (Taichi memory is reclaimed at the next ``ti.init``/``ti.reset``)."""
        self._closed = True
        self.solver = None
