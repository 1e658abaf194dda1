"""The conformance kit on the newton engine (slow: every scene compiles and runs Newton's solver)."""
import pytest

from gasp_core.testing import assert_conformance, parametrize_conformance


@pytest.mark.slow
@parametrize_conformance(engines=["newton"])
def test_conformance(gasp_engine, gasp_scene, request):
    assert_conformance(gasp_engine, gasp_scene, request)
