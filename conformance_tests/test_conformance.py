"""Every installed engine against every conformance scene it can run (ids ``engine-scene``).

A scene whose requirements the engine lacks is skipped with the missing capability as the reason;
an entry of ``gasp_conformance.KNOWN_FAILURES`` runs as a strict xfail. The checks, tolerances and
their reasons are in ``gasp_conformance.py``.
"""
from __future__ import annotations

import pytest

from gasp_conformance import KNOWN_FAILURES, SCENES, evaluate_scene, installed_engines, record


def _cases():
    found = installed_engines()
    if not found:
        yield pytest.param(None, None, id="no-engine",
                           marks=pytest.mark.skip(reason="no engine plugin installed"))
        return
    for name, info in found.items():
        reason = info.unavailable_reason()
        for scene in SCENES:
            marks = [pytest.mark.slow] if scene.slow else []
            missing = scene.requires.missing(info.capabilities)
            if missing:
                marks.append(pytest.mark.skip(reason="missing capability: " + ", ".join(missing)))
            elif reason:
                marks.append(pytest.mark.skip(reason=f"engine unavailable: {reason}"))
            known = KNOWN_FAILURES.get(name, {}).get(scene.name)
            if known:
                marks.append(pytest.mark.xfail(reason=known, strict=True))
            yield pytest.param(name, scene, id=f"{name}-{scene.name}", marks=marks)


@pytest.mark.parametrize("engine_name,scene", list(_cases()))
def test_conformance(engine_name, scene, request):
    info = installed_engines()[engine_name]
    result = evaluate_scene(info, scene, known_failures={})  # xfail is pytest's business here
    record(request.node, result)
    assert result.status == "pass", f"{engine_name}-{scene.name}: {result.message}"
