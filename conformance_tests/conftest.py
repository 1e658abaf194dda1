"""Conformance tests of this repository: every case goes into the kit's result table.

The table is printed at the end of the session and written to ``build/conformance/RESULTS.md`` by the
kit's pytest plugin (:mod:`gasp_core.testing.pytest_plugin`); the committed ``RESULTS.md`` beside this
file is replaced only on request: ``python -m pytest conformance_tests --gasp-update-results`` (or
``GASP_UPDATE_RESULTS=1``), and only by a run without ``-k``.
"""
from __future__ import annotations

import os
from pathlib import Path

import pytest

from gasp_core.testing.pytest_plugin import MARK, configure_results

HERE = Path(__file__).resolve().parent


def pytest_configure(config):
    configure_results(config, committed=HERE / "RESULTS.md", titles={
        "test_conformance.py": "Conformance scenes",
        "test_extremes.py": "Stability at the extremes",
        "test_stiffness_ladder.py": "E from 1e4 to 2e11 Pa: the same drop (issue 40)",
        "test_checks_catch_broken.py": "Checks against deliberately broken engines",
        "test_error_contract.py": "The error contract through the command line",
    })


#: Engines whose full conformance run is too long for the default test run, with the scenes (and
#: test_extremes cases) they run by default, one per kind of check; the rest are marked ``slow``
#: (``python -m pytest conformance_tests -m slow``, or ``GASP_FULL_CONFORMANCE=1`` to run all by default).
#: newton: Newton's implicit MPM runs Warp kernels on one CPU thread and compiles them per configuration
#: (~90 s each with a cold cache): its scenes took ~1,000 s on this 2-core machine under load, 67 s lightly
#: loaded with the kernel cache warm.
DEFAULT_SCENES = {
    "newton": frozenset({"free_fall", "bounce", "self_weight_sag", "mass_agreement", "contract_declarations",
                         "contract_refusals", "contract_declared_accepted", "contract_outside_domain",
                         "nominal", "E_1e10", "outside_domain"}),   # test_extremes cases
}


@pytest.hookimpl(tryfirst=True)     # before pytest's own -m selection
def pytest_collection_modifyitems(config, items):
    full = os.environ.get("GASP_FULL_CONFORMANCE") == "1"
    for item in items:
        if Path(str(item.fspath)).resolve().parent == HERE:
            item.add_marker(getattr(pytest.mark, MARK))
            engine, _, case = getattr(getattr(item, "callspec", None), "id", "").partition("-")  # "engine-scene"
            subset = DEFAULT_SCENES.get(engine)
            if not full and subset is not None and case not in subset:
                item.add_marker(pytest.mark.slow)
