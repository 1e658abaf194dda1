"""Every installed engine against every conformance scene of the installed kit (ids ``engine-scene``).

A scene whose requirements the engine lacks is skipped with the missing capability as the reason; an
entry of the engine's ``EngineInfo.known_failures`` runs as a strict xfail. The scenes, tolerances
and their reasons are in ``gasp_core/testing/``; ``gasp conform ENGINE`` runs the same outside pytest.
"""
from gasp_core.testing import assert_conformance, parametrize_conformance


@parametrize_conformance()
def test_conformance(gasp_engine, gasp_scene, request):
    assert_conformance(gasp_engine, gasp_scene, request)
