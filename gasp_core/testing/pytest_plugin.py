"""pytest plugin of the GASP conformance kit (registered as the ``pytest11`` entry point ``gasp``).

It gives:

- :func:`parametrize_conformance`, a ``pytest.mark.parametrize`` over installed engines x scenes with
  ids ``engine-scene`` (so ``-k my_engine`` or ``-k free_fall`` select), a missing capability as a skip
  with its reason, an ``EngineInfo.known_failures`` entry as a strict xfail, slow scenes marked
  ``slow``; and :func:`assert_conformance`, the test body;
- a result table of every test marked ``gasp_conformance`` (the parametrised ones are), printed at
  the end of the session and written to ``<rootdir>/build/conformance/RESULTS.md``;
- ``--gasp-update-results`` (or ``GASP_UPDATE_RESULTS=1``): also replace the committed results
  file named by :func:`configure_results` (only for a run that deselects nothing: ``-m ''``, no ``-k``); the engines
  the run could not load keep their rows from the committed file
  (:func:`gasp_core.testing.results.keep_other_environments`), so engines that need an environment of their own are
  each run in theirs.

An engine developed elsewhere needs only ``pip install gasp`` and a test file::

    from gasp_core.testing import assert_conformance, parametrize_conformance

    @parametrize_conformance(engines=["my_engine"])
    def test_conformance(gasp_engine, gasp_scene, request):
        assert_conformance(gasp_engine, gasp_scene, request)

Without the entry point (a non-installed checkout), add ``-p gasp_core.testing.pytest_plugin``.
"""
from __future__ import annotations

import os
from pathlib import Path
from typing import Iterable

import pytest

from gasp_core.testing.results import keep_other_environments, render_results, write_atomic

_STORE = pytest.StashKey[dict]()
_SETTINGS = pytest.StashKey[dict]()
_RUNS = pytest.StashKey[dict]()   # evaluate_once's results of this session
_config = None  # the session's config, for pytest_runtest_logreport (which gets no config)
MARK = "gasp_conformance"


def pytest_addoption(parser):
    group = parser.getgroup("gasp", "GASP engine conformance")
    group.addoption("--gasp-update-results", action="store_true", default=False,
                    help="also replace the committed conformance results file (GASP_UPDATE_RESULTS=1 does too)")


def pytest_configure(config):
    global _config
    _config = config
    config.stash[_STORE] = {}
    config.stash.setdefault(_SETTINGS, {"committed": None, "titles": {}})
    config.addinivalue_line("markers", f"{MARK}: a GASP conformance case; its outcome goes into the result table")


def configure_results(config, committed: str | os.PathLike | None = None, titles: dict[str, str] | None = None) -> None:
    """Name the committed results file (replaced only with ``--gasp-update-results``) and the section
    titles per test file name; call from a ``conftest.py``'s ``pytest_configure``."""
    s = config.stash.setdefault(_SETTINGS, {"committed": None, "titles": {}})
    if committed is not None:
        s["committed"] = Path(committed)
    s["titles"].update(titles or {})


def conformance_params(engines: Iterable | None = None, scenes: Iterable | None = None) -> list:
    """``pytest.param(EngineInfo, Scene)`` for every engine x scene, with ids ``engine-scene`` and marks.

    Parameters
    ----------
    engines : iterable of str or EngineInfo, optional
        Default: every installed engine (:func:`gasp_core.seam.plugins.engines`).
    scenes : iterable of str or Scene, optional
        Default: every scene of :data:`gasp_core.testing.SCENES` (slow ones marked ``slow``).
    """
    from gasp_core.seam.plugins import engines as installed
    from gasp_core.testing.kit import resolve_engine
    from gasp_core.testing.scenes import select_scenes
    infos = list(installed().values()) if engines is None else [resolve_engine(e) for e in engines]
    chosen = select_scenes(scenes, include_slow=True)
    if not infos:
        return [pytest.param(None, None, id="no-engine", marks=pytest.mark.skip(reason="no engine plugin installed"))]
    out = []
    for info in infos:
        reason = info.unavailable_reason()
        for scene in chosen:
            marks = [getattr(pytest.mark, MARK)] + ([pytest.mark.slow] if scene.slow else [])
            missing = scene.requires.missing(info.capabilities)
            if missing:
                marks.append(pytest.mark.skip(reason="missing capability: " + ", ".join(missing)))
            elif reason:
                marks.append(pytest.mark.skip(reason=f"engine unavailable: {reason}"))
            known = info.known_failures.get(scene.name)
            if known:
                marks.append(pytest.mark.xfail(reason=known, strict=True))
            out.append(pytest.param(info, scene, id=f"{info.name}-{scene.name}", marks=marks))
    return out


def engine_case_params(cases: Iterable[str], id_prefix: str = "", why_not=None, slow=None) -> list:
    """``pytest.param(engine, case)`` for every installed engine and case, ids ``engine-<id_prefix>case``, for the
    tests that run their own cases on an elastic body on the ground (``test_extremes``, ``test_stiffness_ladder``).

    An unavailable engine, one without the material ``jelly`` or the boundary ``ground``, and a case for which
    ``why_not(name, info, case)`` gives a reason are skipped with the reason (in that order); ``slow(name, case)``
    true marks the case ``slow``. Without an installed engine: one skipped param ``no-engine``.
    """
    from gasp_core.seam.plugins import engines
    found = engines()
    if not found:
        return [pytest.param(None, None, id="no-engine", marks=pytest.mark.skip(reason="no engine plugin installed"))]
    out = []
    for name, info in found.items():
        reason = info.unavailable_reason()
        needs = "jelly" in info.capabilities.materials and "ground" in info.capabilities.boundaries
        for case in cases:
            marks = [pytest.mark.slow] if slow is not None and slow(name, case) else []
            why = None if reason or not needs or why_not is None else why_not(name, info, case)
            if reason:
                marks.append(pytest.mark.skip(reason=f"engine unavailable: {reason}"))
            elif not needs:
                marks.append(pytest.mark.skip(reason="missing capability: material 'jelly' or boundary 'ground'"))
            elif why:
                marks.append(pytest.mark.skip(reason=why))
            out.append(pytest.param(name, case, id=f"{name}-{id_prefix}{case}", marks=marks))
    return out


def parametrize_conformance(engines: Iterable | None = None, scenes: Iterable | None = None):
    """``pytest.mark.parametrize("gasp_engine,gasp_scene", conformance_params(engines, scenes))``."""
    return pytest.mark.parametrize("gasp_engine,gasp_scene", conformance_params(engines, scenes))


def evaluate_once(gasp_engine, gasp_scene):
    """``evaluate_scene(gasp_engine, gasp_scene, known_failures={})`` (a ``SceneResult``) run once per pytest session
    for an engine (``EngineInfo``) and a scene object: the broken-engine checks' screen of the real engine
    (``conformance_tests/test_checks_catch_broken.py``) and the conformance test of the same engine and scene share the
    run (the engines give the same result on a scene run again; round 64: about 30 s of the default tier). Keyed by the
    engine's name and the scene object itself, so a scene built apart under the same name runs on its own."""
    from gasp_core.testing.kit import evaluate_scene
    runs = _config.stash.setdefault(_RUNS, {}) if _config is not None else {}
    key = (gasp_engine.name, gasp_scene.name, id(gasp_scene))
    if key not in runs:
        runs[key] = (gasp_scene, evaluate_scene(gasp_engine, gasp_scene, known_failures={}))  # the scene kept alive
    return runs[key][1]


def assert_conformance(gasp_engine, gasp_scene, request=None) -> None:
    """Run one scene on one engine (:func:`evaluate_once`), record it for the result table, and assert it passed."""
    from gasp_core.testing.kit import record
    result = evaluate_once(gasp_engine, gasp_scene)  # xfail is pytest's business here
    if request is not None:
        record(request.node, result)
    assert result.status == "pass", f"{gasp_engine.name}-{gasp_scene.name}: {result.message}"


def _reason(report) -> str:
    if getattr(report, "wasxfail", None):
        return str(report.wasxfail)
    lr = report.longrepr
    if isinstance(lr, tuple) and len(lr) == 3:
        return str(lr[2]).removeprefix("Skipped: ")
    text = str(getattr(report, "longreprtext", "") or lr or "")
    lines = [ln for ln in text.splitlines() if ln.startswith("E ")]
    return lines[0][1:].strip() if lines else (text.strip().splitlines()[-1] if text.strip() else "")


def pytest_runtest_logreport(report):
    if _config is None or MARK not in report.keywords:
        return
    store = _config.stash[_STORE]
    detail = " ".join(v for k, v in report.user_properties if k == "conformance_detail")
    measured = " ".join(v for k, v in report.user_properties if k == "conformance_measured")
    tolerance = " ".join(v for k, v in report.user_properties if k == "conformance_tolerance")
    if report.when == "setup" and report.skipped:
        store[report.nodeid] = ("xfail" if getattr(report, "wasxfail", None) else "skip", _reason(report))
    elif report.when == "call":
        if getattr(report, "wasxfail", None) is not None and report.skipped:
            status, text = "xfail", f"{report.wasxfail} | observed: {detail}"
        elif report.failed and "XPASS" in str(report.longrepr):
            status, text = "XPASS(strict)", detail
        elif report.passed:
            status, text = "pass", detail
        elif report.skipped:
            status, text = "skip", _reason(report)
        else:
            status, text = "FAIL", detail or _reason(report)
        store[report.nodeid] = (status, text, measured, tolerance)
    elif report.failed and report.nodeid not in store:  # setup/teardown error
        store[report.nodeid] = ("ERROR", _reason(report))


def why_not_update(keyword: str, n_deselected: int) -> str | None:
    """Why a run may not replace the committed results (a row it did not run would be lost), or None: ``-k`` selects a
    subset; tests deselected otherwise (the default ``-m 'not slow'`` leaves out the slow tier, whose scenes have
    rows too). ``n_deselected``: the session's deselected items."""
    if keyword:
        return f"-k '{keyword}' selects a subset"
    if n_deselected:
        return (f"{n_deselected} tests deselected (the default -m 'not slow' leaves out the slow tier); "
                "run with -m '' to regenerate every row")
    return None


def pytest_terminal_summary(terminalreporter, exitstatus, config):
    store = config.stash.get(_STORE, {})
    if not store:
        return
    settings = config.stash.get(_SETTINGS, {"committed": None, "titles": {}})
    text, table = render_results(store, config, int(exitstatus), settings["titles"])
    terminalreporter.section("GASP conformance results")
    terminalreporter.write_line(table)
    out = config.rootpath / "build" / "conformance" / "RESULTS.md"
    write_atomic(out, text)
    terminalreporter.write_line(f"wrote {out}")
    update = config.getoption("gasp_update_results") or os.environ.get("GASP_UPDATE_RESULTS", "") not in ("", "0")
    committed = settings["committed"]
    if not update:
        return
    if committed is None:
        terminalreporter.write_line("--gasp-update-results: no committed results file configured (configure_results)")
    elif refused := why_not_update(config.option.keyword, len(terminalreporter.stats.get("deselected", []))):
        terminalreporter.write_line(f"{committed} not updated: {refused}")
    else:
        old = Path(committed).read_text(encoding="utf-8") if Path(committed).is_file() else ""
        owned = None
        if os.environ.get("GASP_LOAD_PLUGINS"):  # a partial environment: it owns only the engines it loaded
            from gasp_core.seam.plugins import engines
            owned = set(engines())
        write_atomic(Path(committed), keep_other_environments(text, old, owned) if old else text)
        terminalreporter.write_line(f"updated {committed} (engines this run could not load keep their rows)")
