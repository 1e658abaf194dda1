"""Conformance tests of this repository: every case goes into the kit's result table.

The table is printed at the end of the session and written to ``build/conformance/RESULTS.md`` by the
kit's pytest plugin (:mod:`gasp_core.testing.pytest_plugin`); the committed ``RESULTS.md`` beside this
file is replaced only on request: ``python -m pytest conformance_tests --gasp-update-results`` (or
``GASP_UPDATE_RESULTS=1``), and only by a run without ``-k``.
"""
from __future__ import annotations

from pathlib import Path

import pytest

from gasp_core.testing.pytest_plugin import MARK, configure_results

HERE = Path(__file__).resolve().parent


def pytest_configure(config):
    configure_results(config, committed=HERE / "RESULTS.md", titles={
        "test_conformance.py": "Conformance scenes",
        "test_extremes.py": "Stability at the extremes",
        "test_checks_catch_broken.py": "Checks against deliberately broken engines",
        "test_error_contract.py": "The error contract through the command line",
    })


def pytest_collection_modifyitems(config, items):
    for item in items:
        if Path(str(item.fspath)).resolve().parent == HERE:
            item.add_marker(getattr(pytest.mark, MARK))
