"""The passive gather's spanned inverse, fast path against the rule (round 39, docs/performance.md).

``spanned_inverse(M, wsum)`` is ``M^+`` over the eigen-directions with ``lam wsum > span_mass`` (round 38, by
cyclic Jacobi). Round 39 skips the Jacobi where Gershgorin's lower bound on the smallest eigenvalue proves all
three spanned and takes ``M``'s plain inverse, the same ``M^+``. Checked on families of random symmetric ``M`` of
rank 1, 2 and 3 (rotated ``diag(lam)``, the unspanned eigenvalues 1e-9 cells^2) and of rank 3 with the smallest
eigenvalue 0.2 % above and below the threshold, against the exact ``sum_k V_k V_k^T / lam_k`` over the spanned
directions (numpy, f64): within 1e-5 relative (Frobenius) in f64 and f32, both engines, with the fast path on and
off. The catch: a bound that always says "all spanned" fails the rank-1 and rank-2 families.
"""
# no `from __future__ import annotations`: Warp reads the kernels' annotations

import numpy as np
import pytest

SPAN = 0.01   # span_mass, kg cells^2
TOL = 1e-5    # relative, Frobenius


def family(rank: int, n: int = 64, seed: int = 0, near: float = 0.0):
    """``n`` symmetric 3x3 ``M`` (cells^2), ``wsum`` (kg), and their exact spanned inverses."""
    rng = np.random.default_rng(seed + 10 * rank)
    Ms, ws, refs = [], [], []
    for _ in range(n):
        q, r = np.linalg.qr(rng.normal(size=(3, 3)))
        V = q * np.sign(np.diag(r))
        w = rng.uniform(0.5, 5.0)
        lam = rng.uniform(0.02, 0.3, 3)
        lam[rank:] = 1e-9
        if near:
            lam[2] = SPAN / w * near
        if rng.random() < 0.25:   # axis-aligned: Gershgorin's bound is the smallest eigenvalue itself
            V = np.eye(3)
        keep = lam * w > SPAN
        Ms.append((V * lam) @ V.T)
        ws.append(w)
        refs.append((V[:, keep] / lam[keep]) @ V[:, keep].T)
    return np.array(Ms), np.array(ws), np.array(refs)


def taichi_inverses(Ms, ws, real: str, fast: bool, always_full: bool = False) -> np.ndarray:
    """Taichi's ``Transfers.spanned_inverse`` of each M (a harness class of the mixins)."""
    import taichi as ti
    from gasp_taichi_mpm.constitutive import Constitutive
    from gasp_taichi_mpm.transfers import Transfers
    ft = ti.f64 if real == "f64" else ti.f32
    ti.init(arch=ti.cpu, default_fp=ft, cpu_max_num_threads=1, offline_cache=False, log_level=ti.WARN)

    @ti.data_oriented
    class Harness(Transfers, Constitutive):
        PASSIVE_FAST_INVERSE = fast

        def __init__(self):
            self.real = ft
            self.span_mass = ti.field(ft, shape=())
            self.span_mass[None] = SPAN
            self.M = ti.Matrix.field(3, 3, ft, shape=len(ws))
            self.w = ti.field(ft, shape=len(ws))
            self.out = ti.Matrix.field(3, 3, ft, shape=len(ws))

        if always_full:
            @ti.func
            def spans_all(self, M, wsum):
                return True

        @ti.kernel
        def run(self):
            for n in range(self.w.shape[0]):
                self.out[n] = self.spanned_inverse(self.M[n], self.w[n])

    h = Harness()
    h.M.from_numpy(Ms.astype(np.float64 if real == "f64" else np.float32))
    h.w.from_numpy(ws.astype(np.float64 if real == "f64" else np.float32))
    h.run()
    return h.out.to_numpy().astype(np.float64)


def warp_inverses(Ms, ws, real: str, fast: bool, always_full: bool = False) -> np.ndarray:
    """Warp's ``build_spanned_inverse`` of each M (uncached builds, the switches patched in)."""
    import warp as wp
    from gasp_warp_mpm import spanned as wt
    from gasp_warp_mpm.precision import build_types
    Ft = wp.float64 if real == "f64" else wp.float32
    vec3, vec4, mat33 = build_types(Ft)
    keep = wt.PASSIVE_FAST_INVERSE, wt.build_spans_all
    try:
        wt.PASSIVE_FAST_INVERSE = fast
        if always_full:
            @wp.func
            def spans_all(M: mat33, wsum: Ft, span_mass: Ft):
                return True
            wt.build_spans_all = lambda Ft_: spans_all
        inv = wt.build_spanned_inverse.__wrapped__(Ft)
    finally:
        wt.PASSIVE_FAST_INVERSE, wt.build_spans_all = keep

    @wp.kernel(module="unique")
    def run(M: wp.array(dtype=mat33), w: wp.array(dtype=Ft), span: Ft, out: wp.array(dtype=mat33)):
        n = wp.tid()
        out[n] = inv(M[n], w[n], span)

    np_t = np.float64 if real == "f64" else np.float32
    M = wp.array(Ms.astype(np_t), dtype=mat33, device="cpu")
    w = wp.array(ws.astype(np_t), dtype=Ft, device="cpu")
    out = wp.zeros(len(ws), dtype=mat33, device="cpu")
    wp.launch(run, dim=len(ws), inputs=[M, w, Ft(SPAN), out], device="cpu")
    return out.numpy().astype(np.float64)


ENGINES = {"taichi_mpm": taichi_inverses, "warp_mpm": warp_inverses}
FAMILIES = [("rank1", 1, 0.0), ("rank2", 2, 0.0), ("rank3", 3, 0.0), ("above", 3, 1.002), ("below", 3, 0.998)]


def worst_error(engine: str, real: str, fast: bool, always_full: bool = False) -> dict[str, float]:
    """The largest relative error of each family."""
    out = {}
    for name, rank, near in FAMILIES:
        Ms, ws, refs = family(rank, near=near)
        got = ENGINES[engine](Ms, ws, real, fast, always_full)
        err = np.linalg.norm(got - refs, axis=(1, 2)) / np.linalg.norm(refs, axis=(1, 2))
        out[name] = float(np.nan_to_num(err, nan=np.inf).max())
    return out


@pytest.mark.parametrize("engine", sorted(ENGINES))
@pytest.mark.parametrize("real", ["f64", "f32"])
@pytest.mark.parametrize("fast", [True, False])
def test_the_spanned_inverse_is_the_spanned_pseudo_inverse(engine, real, fast):
    err = worst_error(engine, real, fast)
    assert all(e <= TOL for e in err.values()), err


@pytest.mark.parametrize("engine", sorted(ENGINES))
def test_catch_a_bound_that_always_says_full_rank_fails(engine):
    err = worst_error(engine, "f64", True, always_full=True)
    assert err["rank1"] > TOL and err["rank2"] > TOL, err
