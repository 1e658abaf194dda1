"""The engine's conformance through the installed GASP kit: the scenes its capabilities select run,
the rest are skipped with the missing capability as the reason (``pytest tests``)."""
from gasp_core.testing import assert_conformance, parametrize_conformance


@parametrize_conformance(engines=["example_springs"])
def test_conformance(gasp_engine, gasp_scene, request):
    assert_conformance(gasp_engine, gasp_scene, request)
