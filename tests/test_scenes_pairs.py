"""The contact-pair conformance scenes' checks (``gasp_core/testing/scenes_pairs.py``, issue 53 item 6) against
traces whose answer is known by construction: the engines are run by ``conformance_tests/``, and the broken engines
that the restitution and rest checks catch are in ``conformance_tests/test_checks_catch_broken.py``. The stacked
balls' check is shown here on the scene's own balls put at known gaps: it passes them touching and fails them a fifth
of a cell too far apart or too deep; on the MLS-MPM engines with their contact broken in ``tests/test_stacked_balls.py``.
"""
import numpy as np
import pytest

from gasp_core.seam.runner import RunStats
from gasp_core.testing.kit import Trace
from gasp_core.testing.scenes_pairs import _build_stack, _eval_stack, DX, STACK_DROP, surface_gap


def _trace_at(gap_dx: float) -> Trace:
    s = _build_stack(None)
    x = np.array(s.x, np.float64)
    top = np.asarray(s.body_id) == 1
    start = surface_gap(x, np.asarray(s.body_id), s.p_vol) / DX
    x[top, 2] += (gap_dx - start) * DX          # the top ball moved to the gap asked
    xs = np.repeat(x[None], 31, axis=0)
    return Trace(s, xs, np.zeros_like(xs), np.arange(31) / 30.0, RunStats())


def test_the_stacked_balls_gap_is_measured_from_their_surfaces():
    s = _build_stack(None)
    assert surface_gap(s.x, np.asarray(s.body_id), s.p_vol) / DX == pytest.approx(STACK_DROP, abs=0.01)


@pytest.mark.parametrize("gap, ok", [(0.0, True), (0.2, True), (-0.2, True), (0.3, False), (-0.3, False),
                                     (0.84, False)])
def test_the_stacked_gap_check_is_two_sided(gap, ok):
    (c,) = _eval_stack(None, _trace_at(gap))
    assert c.passed is ok and c.figures["signed"] == pytest.approx(gap, abs=1e-6), c
