"""The converged reference (gasp_studies.convergence): Richardson from grid sequences of known order.

The sequences come from integrators whose order is known analytically: a harmonic oscillator
x'' = -w^2 x integrated to time T with n steps by explicit Euler (first order) and by the
midpoint rule (second order); "n_grid" is the step count, so h = T / n. Every Gaussian is one
oscillator with its own amplitude and phase, and the frames are the times T_k.
"""
from __future__ import annotations

import numpy as np
import pytest
from gasp_testing import needs_package

needs_package("gasp_studies")
from gasp_studies.convergence import observed_order, reference, verdict  # noqa: E402

W = 2 * np.pi          # 1 Hz
TIMES = np.linspace(0.0, 1.0, 9)   # frames: 0 .. 1 s


def exact(x0: np.ndarray, v0: np.ndarray) -> np.ndarray:
    """Means (n_frames, n, 3) of the exact oscillators: each coordinate independent."""
    t = TIMES[:, None, None]
    return x0[None] * np.cos(W * t) + v0[None] / W * np.sin(W * t)


def integrate(x0: np.ndarray, v0: np.ndarray, steps_per_second: int, scheme: str) -> np.ndarray:
    """Means (n_frames, n, 3) from ``scheme`` ("euler": order 1, "midpoint": order 2)."""
    dt = 1.0 / steps_per_second
    x, v = x0.copy(), v0.copy()
    out, t = [x.copy()], 0.0
    for t_next in TIMES[1:]:
        while t < t_next - 1e-12:
            if scheme == "euler":
                x, v = x + dt * v, v - dt * W * W * x
            else:
                xm, vm = x + 0.5 * dt * v, v - 0.5 * dt * W * W * x
                x, v = x + dt * vm, v - dt * W * W * xm
            t += dt
        out.append(x.copy())
    return np.stack(out)


@pytest.fixture(scope="module")
def oscillators():
    rng = np.random.default_rng(0)
    return rng.normal(0.0, 0.1, (50, 3)), rng.normal(0.0, 0.3, (50, 3))


@pytest.mark.parametrize("scheme, order", [("euler", 1.0), ("midpoint", 2.0)])
def test_richardson_finds_the_schemes_order_and_beats_the_finest(oscillators, scheme, order):
    x0, v0 = oscillators
    grids = (400, 800, 1600) if scheme == "euler" else (48, 64, 96)
    runs = {n: integrate(x0, v0, n, scheme) for n in grids}
    size = float(np.linalg.norm(np.ptp(x0, axis=0)))
    ref = reference(runs, size)
    assert ref.method == "richardson"
    assert ref.order == pytest.approx(order, rel=0.05)       # a 5 % bias in the order fails
    truth = exact(x0, v0)
    err_fine = np.linalg.norm(runs[grids[-1]] - truth, axis=2).mean(axis=1).max() / size
    err_ref = np.linalg.norm(ref.means - truth, axis=2).mean(axis=1).max() / size
    assert err_ref < 0.2 * err_fine                          # the estimate is closer than the finest run
    # the stated uncertainty is the finest run's true error, within 20 %, not an arbitrary number
    assert ref.bound == pytest.approx(err_fine, rel=0.2)


def test_two_grids_give_the_finest_with_its_distance(oscillators):
    x0, v0 = oscillators
    runs = {n: integrate(x0, v0, n, "euler") for n in (400, 800)}
    size = float(np.linalg.norm(np.ptp(x0, axis=0)))
    ref = reference(runs, size)
    assert ref.method == "finest" and ref.grids == [400, 800]
    d = np.linalg.norm(runs[800] - runs[400], axis=2).mean(axis=1) / size
    np.testing.assert_allclose(ref.uncertainty, d)
    np.testing.assert_array_equal(ref.means, runs[800])


def test_a_sequence_that_does_not_converge_is_not_extrapolated(oscillators):
    """Grids whose differences grow (an unresolved bouncing body) fall back to the finest run."""
    x0, v0 = oscillators
    truth = exact(x0, v0)
    rng = np.random.default_rng(1)
    runs = {n: truth + rng.normal(0.0, 0.01 * (1 + 0.02 * n), truth.shape) for n in (48, 64, 96)}
    size = float(np.linalg.norm(np.ptp(x0, axis=0)))
    ref = reference(runs, size)
    assert ref.method == "finest" and "no order" in ref.note


def test_verdict_does_not_rank_against_an_unconverged_reference(oscillators):
    x0, v0 = oscillators
    size = float(np.linalg.norm(np.ptp(x0, axis=0)))
    runs = {n: integrate(x0, v0, n, "euler") for n in (100, 200)}     # coarse: far from converged
    ref = reference(runs, size)
    assert ref.bound > 0.01
    v = verdict(np.zeros(len(TIMES)), ref, 0.01)
    assert v["ranked"] is False and v["within"] is None and "uncertain" in v["why"]
    # against "the full model's own distance + 0.5 %" (own = the finest run's distance: the uncertainty) it is
    v = verdict(ref.uncertainty + 0.004, ref, 0.01, own=ref.uncertainty)
    assert v["ranked"] is True and v["within"] is True
    assert verdict(ref.uncertainty + 0.006, ref, 0.01, own=ref.uncertainty)["within"] is False
    # against a reference known well enough, the 1 % rule is two-sided
    fine = reference({n: integrate(x0, v0, n, "midpoint") for n in (200, 300, 400)}, size)
    assert fine.converged(0.01)
    e = np.linalg.norm(runs[200][: len(TIMES)] - fine.means, axis=2).mean(axis=1) / size
    assert verdict(e, fine, 0.01)["within"] is False and e.max() > 0.01   # Euler at 200 steps: 2.5 %
    assert verdict(np.full(len(TIMES), 0.009), fine, 0.01)["within"] is True
    assert verdict(np.full(len(TIMES), 0.011), fine, 0.01)["within"] is False
    # the second criterion: within the full model's own distance + 0.5 %
    own = np.full(len(TIMES), 0.02)
    assert verdict(np.full(len(TIMES), 0.024), fine, 0.01, own=own)["within"] is True
    assert verdict(np.full(len(TIMES), 0.026), fine, 0.01, own=own)["within"] is False


def test_observed_order_inverts_a_pure_power_law():
    for p in (0.8, 1.0, 1.7, 2.0, 3.0):
        n = (48, 64, 96)
        e1, e2 = (1 / n[0]) ** p - (1 / n[1]) ** p, (1 / n[1]) ** p - (1 / n[2]) ** p
        assert observed_order(e1, e2, n) == pytest.approx(p, rel=1e-6)
    assert observed_order(1.0, 2.0, (48, 64, 96)) is None     # diverging
    assert observed_order(0.0, 1.0, (48, 64, 96)) is None
