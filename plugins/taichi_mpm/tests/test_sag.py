"""A filled real object under its own weight sags by the static estimate (passive surface, taichi_mpm).

The README donut (real trained Gaussians, ``examples/donut_jelly.toml``) is set on the ground at
rest, as soft jelly, with a passive surface (its fill is the whole solid) and few cores.

Static estimate, two parts (``a`` tube radius of the fill, ``w = rho g pi a^2`` weight per unit
length of the tube, ``E* = E / (1 - nu^2)``):

1. Flattening on the ground. The tube rests on a line: a cylinder pressed on a plane by ``w`` per
   unit length has the contact half-width ``b = sqrt(4 w a / (pi E*))`` and its centre approaches
   the plane by ``delta_c = (2 w / (pi E*)) (ln(4 a / b) - 1/2)`` (Hertz line contact, Johnson,
   "Contact Mechanics", 1985, Sec. 5.6, plane strain).
2. Its own weight above the contact. Cut the tube into vertical fibres; a fibre of height ``H``
   free to bulge sideways shortens like a column (stress ``rho g (H - z)`` at height ``z``): its
   centre of mass drops by ``rho g H^2 / (3 E)``. Over the cross-section (``H = 2 sqrt(a^2 - y^2)``,
   mass proportional to ``H``) the body's centre of mass drops by ``delta_f = rho g a^2 / E``.

``delta = delta_c + delta_f``. (With part 2 alone, the first version of this test, the measured
sag was 4.1 times the estimate: for a soft round body the contact flattening dominates.)

Measurement. With no damping the body oscillates about the sagged state, drop ``d(t) = delta (1 -
cos w t)`` with period ``2 pi sqrt(delta / g)``, so the mean drop over whole periods is ``delta``;
the mean is taken over every frame of the 0.6 s run: 3.3 periods of the soft body (``delta`` = 8.2
mm, 0.18 s), 8.4 of the stiff one. The grid's contact holds the body a fraction of a cell
off the ground; that offset does not depend on ``E``, so it is removed by subtracting the same run
with ``10 E``: the test compares ``drop(E) - drop(10 E)`` with ``delta(E) - delta(10 E)``.

Tolerance: 35 % either way, the sum of four error sources. (a) The mean over a not-whole number of
periods is off by up to ``delta / (2 pi N)``: 4.8 % of the soft drop, 0.3 % of the stiff one, about
6 % of the difference. (b) Both parts are plane-strain, small-strain estimates for a 3-D torus
whose tube radius is about half its centre-line radius (a / R = 0.49; the icing makes it no exact
torus either).
(c) The contact half-width is 0.48 times the tube radius, beyond Hertz's small-contact assumption.
(d) The grid has about five cells across the tube (n_grid 32). (b)-(d) are first-order modelling
errors, each put at about 10 %. The test takes about 15 s (two runs of 18 frames at n_grid 32,
2 % of the Gaussians as cores), so it runs in the default tier.
"""
from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("taichi")

from gasp_core.prepare.scene import prepare_scene
from gasp_core.seam.runner import simulate  # noqa: E402
from gasp_core.scene.spec import load_scene  # noqa: E402

ROOT = Path(__file__).resolve().parents[3]
RHO, E_SOFT, G = 300.0, 1500.0, 9.81
N_FRAMES = 18


def mean_drop(E: float) -> tuple[float, float]:
    """Mean centre-of-mass drop over the frames (m) and the tube radius a = h / 2 of the fill (m)."""
    scene = load_scene(ROOT / "examples" / "donut_jelly.toml")
    # undamped (viscosity 0), as the measurement above needs: the example's 4 Pa s (issue 29) damps the ringing
    # within the run, the mean over frames no longer equals delta, and the ratio came out 1.46
    objs = [dataclasses.replace(o, position=(0.0, 0.0, 0.0), surface="passive", core_fraction=0.02,
                                material=dataclasses.replace(o.material, E=E, rho=RHO, viscosity=0.0)) for o in scene.objects]
    scene = dataclasses.replace(scene, objects=objs, domain=dataclasses.replace(scene.domain, n_grid=32))
    prep = prepare_scene(scene)
    setup = prep.setup
    # the grid contact, for which this test was written (its offset off the ground does not depend on E); the
    # default particle contact lets a point of the E 1500 Pa donut sink through the ground and leave the grid at
    # frame 10 (EngineDivergence, measured; docs/contact.md "Not done")
    setup.options = {**setup.options, "threads": 1, "contact": "grid"}
    xs, _ = simulate(prep.info, setup, N_FRAMES)
    m = setup.p_mass
    zc = xs[:, :, 2] @ m / m.sum()
    mat = setup.material_mask
    a = 0.5 * float(np.ptp(setup.x[mat, 2]))
    return float(zc[0] - zc[1:].mean()), a


def static_sag(E: float, a: float, nu: float = 0.3) -> float:
    """Centre-of-mass drop of the resting tube, m: Hertz line contact plus fibre compression."""
    w = RHO * G * np.pi * a ** 2
    E_star = E / (1.0 - nu ** 2)
    b = np.sqrt(4.0 * w * a / (np.pi * E_star))
    return 2.0 * w / (np.pi * E_star) * (np.log(4.0 * a / b) - 0.5) + RHO * G * a ** 2 / E


@pytest.mark.slow   # about 15 s; round 49 (docs/contact.md "Round 49"): ratio 0.675 (0.472 with round 48's rule)
def test_donut_sags_by_static_estimate():
    soft, a = mean_drop(E_SOFT)
    stiff, _ = mean_drop(10 * E_SOFT)
    measured = soft - stiff
    expected = static_sag(E_SOFT, a) - static_sag(10 * E_SOFT, a)
    ratio = measured / expected
    assert 0.65 <= ratio <= 1.35, (f"sag {measured * 1e3:.3f} mm vs static estimate {expected * 1e3:.3f} mm "
                                     f"(ratio {ratio:.3f}; drops {soft * 1e3:.3f} / {stiff * 1e3:.3f} mm, a = {a * 1e3:.1f} mm)")
