"""The Warp MLS-MPM engine: :class:`WarpMPMEngine`, built from a :class:`~gasp_core.engine.SimSetup`.

Implements ``docs/mpm.md`` (3D MLS-MPM, quadratic B-splines, APIC; Hu et al. 2018) with the
kernels of :mod:`gasp_warp_mpm.kernels`. Per substep three launches: P2G (return mapping, stress
once per point, scatter), grid update over nodes (which also clears the accumulation grid), and
G2P fused with the position update. On CUDA the substeps of a frame are captured once in a CUDA
graph; on CPU the launches are pre-recorded ``wp.Launch`` objects. The host synchronises once per
frame, for the blow-up check.

Notes
-----
Choices where docs/mpm.md leaves room (the Taichi plugin agrees to ~1e-5 m on all seven materials):

- ``jelly`` takes ``R = U V^T`` from a Newton polar iteration (Higham 1986) when ``det F > 0``,
  which is the same matrix as the SVD's ``U V^T``; ``wp.svd3`` (U, V proper rotations, the sign of
  a reflection on ``sig[2]``, checked in the tests) is used when ``det F <= 0`` and for every
  plastic material. On the CPU ``wp.svd3`` costs about 0.8 us per call, the iteration ~0.1 us.
- ``metal`` / ``plasticine`` rebuild ``F = U diag(exp(eps)) V^T`` only when ``dg > 0``;
  ``sand`` always rebuilds it (the spec's punctuation).
- Wall friction is applied axis by axis, x then y then z, the low face before the high face.
- A point out of the grid neither scatters nor gathers and keeps its ``x, v, C`` for the rest of
  the frame; the frame then raises :class:`EngineDivergence`.
- The momentum sum ``p_mass v + affine dpos`` and the APIC ``C`` are evaluated in an equivalent
  factored form (``affine dpos = A (i, j, k) - A fx``), which changes rounding only.
- On CPU the points are kept sorted by grid cell (re-sorted after every frame, stable, so runs
  repeat bit for bit); outputs are returned in the order of ``setup.x``.
"""
from __future__ import annotations

import math
from typing import Any

import numpy as np
import warp as wp

from gasp_core import mpm as physics
from gasp_core.engine import EngineDivergence, EngineError, SceneError, SimSetup, check_options

from . import kernels as K

ENGINE = "warp_mpm"
DEFAULT_OPTIONS = {"device": "cpu", "precision": "f32", "dt": None, "n_substeps": None,
                   "cfl": 0.4, "threads": None}
SUPPORTED_BOUNDARIES = frozenset({"ground", "walls", "fixed_region"})

CAUSE_UNSTABLE = "time step above the stability limit or material too stiff for dt"
CAUSE_LEFT = "points left the domain: add walls/ground or enlarge the domain"


def _check(cond: bool, msg: str) -> None:
    if not cond:
        raise SceneError(f"engine '{ENGINE}': {msg}")


def _validate_options(options: dict[str, Any]) -> dict[str, Any]:
    from . import OPTIONS
    opts = check_options(options, OPTIONS, ENGINE)
    dev = opts["device"]
    _check(isinstance(dev, str) and (dev == "cpu" or dev == "cuda" or dev.startswith("cuda:")),
           f"option 'device' must be \"cpu\" or \"cuda\", got {dev!r}")
    _check(opts["precision"] in ("f32", "f64"),
           f"option 'precision' must be \"f32\" or \"f64\", got {opts['precision']!r}")
    dt = opts["dt"]
    _check(dt is None or (isinstance(dt, (int, float)) and not isinstance(dt, bool)
                          and math.isfinite(dt) and dt > 0),
           f"option 'dt' must be a positive number of seconds, got {dt!r}")
    ns = opts["n_substeps"]
    _check(ns is None or (isinstance(ns, (int, np.integer)) and not isinstance(ns, bool) and ns >= 1),
           f"option 'n_substeps' must be an integer >= 1, got {ns!r}")
    _check(dt is None or ns is None, "options 'dt' and 'n_substeps' are exclusive; give one")
    cfl = opts["cfl"]
    _check(isinstance(cfl, (int, float)) and not isinstance(cfl, bool) and 0 < cfl <= 1,
           f"option 'cfl' must be a number in (0, 1], got {cfl!r}")
    th = opts["threads"]
    _check(th is None or (isinstance(th, (int, np.integer)) and not isinstance(th, bool) and th >= 1),
           f"option 'threads' must be an integer >= 1 or omitted, got {th!r}")
    return opts


def choose_dt(setup: SimSetup, opts: dict[str, Any]) -> tuple[int, float]:
    """Substeps per frame and substep (``gasp_core.physics.mpm_substeps``, docs/mpm.md "Time step")."""
    return physics.mpm_substeps(setup, opts["dt"], opts["n_substeps"], opts["cfl"])


def _material_tables(setup: SimSetup) -> tuple[np.ndarray, np.ndarray]:
    kinds = np.zeros(len(setup.materials), dtype=np.int32)
    par = np.zeros((len(setup.materials), K.N_PAR), dtype=np.float64)
    for b, m in enumerate(setup.materials):
        if m.name not in K.MATERIAL_CODES:
            raise EngineError(f"engine '{ENGINE}' does not offer material '{m.name}' (body {b}); "
                              f"it offers {sorted(K.MATERIAL_CODES)}")
        _check(m.E > 0 and math.isfinite(m.E), f"material {b} ('{m.name}'): E must be > 0 Pa, got {m.E}")
        _check(0 <= m.nu < 0.5, f"material {b} ('{m.name}'): nu must be in [0, 0.5), got {m.nu}")
        _check(m.rho > 0, f"material {b} ('{m.name}'): rho must be > 0 kg/m^3, got {m.rho}")
        kinds[b] = K.MATERIAL_CODES[m.name]
        s = math.sin(math.radians(m.friction_angle))
        par[b, K.P_MU] = m.mu
        par[b, K.P_LAM] = m.lam
        par[b, K.P_YIELD] = m.yield_stress
        par[b, K.P_SOFTENING] = m.softening
        par[b, K.P_HARDENING] = m.hardening
        par[b, K.P_THETA_C] = m.theta_c
        par[b, K.P_THETA_S] = m.theta_s
        par[b, K.P_ALPHA] = math.sqrt(2.0 / 3.0) * 2.0 * s / (3.0 - s)
        par[b, K.P_K] = m.E / (3.0 * (1.0 - 2.0 * m.nu))
    return kinds, par


class WarpMPMEngine:
    """MLS-MPM in Warp (docs/mpm.md), one instance per simulation.

    Parameters
    ----------
    setup : SimSetup
        Points, materials (``jelly, neo_hookean, metal, sand, snow, plasticine, liquid``),
        boundaries (``ground, walls, fixed_region``), domain and ``n_grid``. ``setup.options``
        may hold ``device`` ("cpu" | "cuda"), ``precision`` ("f32" | "f64"), ``dt`` (s) or
        ``n_substeps``, ``cfl`` (0.4) and ``threads`` (accepted and ignored: Warp runs CPU
        kernels on one thread, so CPU runs repeat bit for bit).

    Raises
    ------
    SceneError
        Unknown or malformed option, bad material parameters, ``n_grid < 4``.
    EngineError
        Material or boundary this engine does not offer; ``device="cuda"`` without a CUDA device.
    """

    def __init__(self, setup: SimSetup):
        self.setup = setup
        opts = _validate_options(dict(setup.options))
        self.options = opts
        _check(isinstance(setup.n_grid, (int, np.integer)) and setup.n_grid >= 4,
               f"n_grid must be an integer >= 4, got {setup.n_grid!r}")
        _check(setup.frame_dt > 0, f"frame_dt must be > 0 s, got {setup.frame_dt}")
        for bd in setup.boundaries:
            if bd.kind not in SUPPORTED_BOUNDARIES:
                raise EngineError(f"engine '{ENGINE}' does not offer boundary '{bd.kind}'; "
                                  f"it offers {sorted(SUPPORTED_BOUNDARIES)}")
        kinds, par = _material_tables(setup)

        wp.init()
        dev = opts["device"]
        if dev.startswith("cuda") and not wp.is_cuda_available():
            raise EngineError(f"engine '{ENGINE}': device '{dev}' requested but Warp finds no CUDA "
                              f"device here (driver missing or no GPU); use device = \"cpu\"")
        try:
            self.device = wp.get_device(dev)
        except Exception as e:  # e.g. "cuda:3" on a one-GPU machine
            raise EngineError(f"engine '{ENGINE}': device '{dev}' is not available: {e}") from e
        self.precision = opts["precision"]
        Ft = wp.float32 if self.precision == "f32" else wp.float64
        self._np_dtype = np.float32 if self.precision == "f32" else np.float64
        self.k = K.build_kernels(Ft)

        self.n_points = n = len(setup.x)
        self.n_grid = int(setup.n_grid)
        self.dx = setup.dx
        self.inv_dx = 1.0 / self.dx
        self.n_substeps, self.dt = choose_dt(setup, opts)
        self.frame = 0
        self.sim_time = 0.0
        lo = setup.domain_lo

        # Points that start inside a fixed region are held (docs/mpm.md G2P).
        fixed = np.zeros(n, dtype=np.int32)
        fixed_lo, fixed_hi, ground, wall_mu = [], [], [], []
        for bd in setup.boundaries:
            if bd.kind == "fixed_region":
                blo, bhi = np.asarray(bd.lo, float), np.asarray(bd.hi, float)
                fixed_lo.append(blo)
                fixed_hi.append(bhi)
                fixed |= np.all((setup.x >= blo) & (setup.x <= bhi), axis=1).astype(np.int32)
            elif bd.kind == "ground":
                ground.append((bd.height, bd.friction, 0.0))
            else:
                wall_mu.append(bd.friction)

        # Sort points by grid cell (cache locality of scatter and gather); order[i] is the
        # setup index of internal point i.
        order = self._cell_order(setup.x) if n else np.zeros(0, dtype=np.int64)
        self._order = order
        jp0 = np.array([1.0 if m.name == "snow" else 0.0 for m in setup.materials])[setup.body_id]
        d, dt_np = self.device, self._np_dtype
        k = self.k

        def arr(a, dtype):
            return wp.array(np.ascontiguousarray(a), dtype=dtype, device=d)

        self.x = arr(setup.x[order].astype(dt_np), k.vec3)
        self.v = arr(setup.v[order].astype(dt_np), k.vec3)
        self.F = arr(np.broadcast_to(np.eye(3, dtype=dt_np), (n, 3, 3)), k.mat33)
        self.C = (wp.zeros(n, dtype=k.mat33, device=d) if setup.C is None
                  else arr(setup.C[order].astype(dt_np), k.mat33))
        self.Jp = arr(jp0[order].astype(dt_np), Ft)
        self.p_mass = arr(setup.p_mass[order].astype(dt_np), Ft)
        self.p_vol = arr(setup.p_vol[order].astype(dt_np), Ft)
        self.body = arr(setup.body_id[order], wp.int32)
        self.fixed = arr(fixed[order], wp.int32)
        self.mat_kind = arr(kinds, wp.int32)
        self.mat_par = arr(par.astype(dt_np), Ft)
        n_nodes = self.n_grid ** 3
        self.grid_mv = wp.zeros(n_nodes, dtype=k.vec4, device=d)
        self.grid_vel = wp.zeros(n_nodes, dtype=k.vec3, device=d)
        self.flags = wp.zeros(2, dtype=wp.int32, device=d)  # [out-of-grid count, non-finite count]
        self.wall_mu = arr(np.array(wall_mu, dtype=dt_np), Ft)
        self.ground = arr(np.array(ground, dtype=dt_np).reshape(-1, 3), k.vec3)
        self.fixed_lo = arr(np.array(fixed_lo, dtype=dt_np).reshape(-1, 3), k.vec3)
        self.fixed_hi = arr(np.array(fixed_hi, dtype=dt_np).reshape(-1, 3), k.vec3)

        lo_v = k.vec3(*[float(c) for c in lo])
        hi_v = k.vec3(*[float(c) for c in setup.domain_hi])
        g_v = k.vec3(*[float(c) for c in setup.gravity])
        inv_dx, dx, dt_f, ng = Ft(self.inv_dx), Ft(self.dx), Ft(self.dt), self.n_grid
        self._launches = []
        if n:
            self._launches = [
                wp.launch(k.p2g, dim=n, device=d, record_cmd=True, inputs=[
                    self.x, self.v, self.F, self.C, self.Jp, self.p_mass, self.p_vol, self.body,
                    self.mat_kind, self.mat_par, self.grid_mv, self.flags, lo_v, inv_dx, dx, dt_f, ng]),
                wp.launch(k.grid_update, dim=n_nodes, device=d, record_cmd=True, inputs=[
                    self.grid_mv, self.grid_vel, g_v, lo_v, hi_v, dx, dt_f, ng, self.wall_mu,
                    self.ground, self.fixed_lo, self.fixed_hi]),
                wp.launch(k.g2p, dim=n, device=d, record_cmd=True, inputs=[
                    self.x, self.v, self.C, self.fixed, self.grid_vel, lo_v, inv_dx, dt_f, ng]),
            ]
            self._check_launch = wp.launch(k.check, dim=n, device=d, record_cmd=True,
                                           inputs=[self.x, self.v, self.flags])
        self._graph = None
        self._closed = False

    # ------------------------------------------------------------------ helpers
    def _cell_order(self, x: np.ndarray) -> np.ndarray:
        """Stable order of points by flat cell index (deterministic)."""
        X = (np.asarray(x, dtype=np.float64) - self.setup.domain_lo) * self.inv_dx
        with np.errstate(invalid="ignore"):
            c = np.clip(np.nan_to_num(np.floor(X), nan=0.0), 0, self.n_grid - 1).astype(np.int64)
        key = (c[:, 0] * self.n_grid + c[:, 1]) * self.n_grid + c[:, 2]
        return np.argsort(key, kind="stable")

    def _resort(self) -> None:
        """Re-sort the points by cell (CPU only: the arrays are host memory, numpy views)."""
        perm = self._cell_order(self.x.numpy())
        if np.array_equal(perm, np.arange(self.n_points)):
            return
        for a in (self.x, self.v, self.F, self.C, self.Jp, self.p_mass, self.p_vol, self.body, self.fixed):
            view = a.numpy()
            view[...] = view[perm]
        self._order = self._order[perm]

    def _substeps(self) -> None:
        for _ in range(self.n_substeps):
            for cmd in self._launches:
                cmd.launch()

    # ------------------------------------------------------------------ PointEngine
    def step_frame(self) -> None:
        """Advance by ``setup.frame_dt`` seconds (``n_substeps`` substeps of ``dt``).

        Raises
        ------
        EngineDivergence
            If after the frame a point's ``x`` or ``v`` is not finite, or a point is out of the
            grid (docs/mpm.md "Blow-up detection"); ``frame`` is the 1-based frame number.
        """
        if self._closed:
            raise EngineError(f"engine '{ENGINE}': step_frame() after close()")
        self.frame += 1
        if self.n_points == 0:
            self.sim_time += self.setup.frame_dt
            return
        self.flags.zero_()
        if self.device.is_cuda:
            if self._graph is None:
                with wp.ScopedCapture(device=self.device) as capture:
                    self._substeps()
                self._graph = capture.graph
            wp.capture_launch(self._graph)
        else:
            self._substeps()
        self._check_launch.launch()
        n_out, n_bad = (int(c) for c in self.flags.numpy())
        self.sim_time += self.setup.frame_dt
        if n_bad:
            raise EngineDivergence(
                f"{n_bad} of {self.n_points} points have non-finite position or velocity "
                f"(dt = {self.dt:.3g} s, {self.n_substeps} substeps/frame)", self.frame, CAUSE_UNSTABLE)
        if n_out:
            raise EngineDivergence(
                f"{n_out} point-substeps were out of the grid (domain {self.setup.domain_lo.tolist()} to "
                f"{self.setup.domain_hi.tolist()}, n_grid {self.n_grid})", self.frame, CAUSE_LEFT)
        if not self.device.is_cuda:
            self._resort()

    def _to_setup_order(self, a: wp.array) -> np.ndarray:
        if self._closed:
            raise EngineError(f"engine '{ENGINE}': engine was closed")
        internal = a.numpy()
        out = np.empty_like(internal)
        out[self._order] = internal
        return out

    def positions(self) -> np.ndarray:
        """Current positions, shape (n, 3), float32 (f32) or float64 (f64), metres, setup order."""
        return self._to_setup_order(self.x)

    def velocities(self) -> np.ndarray:
        """Current velocities, shape (n, 3), float32 or float64, m/s, setup order."""
        return self._to_setup_order(self.v)

    def stats(self) -> dict[str, Any]:
        """``device, precision, n_points, dt`` (s), ``n_substeps`` (per frame), ``n_grid``, ``dx`` (m),
        ``frame``, ``sim_time`` (s)."""
        return {"device": str(self.device), "precision": self.precision, "n_points": self.n_points,
                "dt": self.dt, "n_substeps": self.n_substeps, "n_grid": self.n_grid, "dx": self.dx,
                "frame": self.frame, "sim_time": self.sim_time}

    def close(self) -> None:
        """Release the Warp arrays and the CUDA graph."""
        self._graph = None
        self._launches = []
        self._check_launch = None
        for name in ("x", "v", "F", "C", "Jp", "p_mass", "p_vol", "body", "fixed", "grid_mv", "grid_vel"):
            if hasattr(self, name):
                setattr(self, name, None)
        self._closed = True
