"""The capture's unseen Gaussians are not drawn once a body can break (issue 66, "What a user sees";
:mod:`gasp_core.gs.unseen`, docs/fracture.md "Round 61: the capture's inside").

Known answers, no physics: a closed shell of opaque flat Gaussians (a sphere tiled at half their spacing) with
Gaussians of random colours inside it. Every inside Gaussian's seen share is under a tenth of UNSEEN (the shell's
transmittance is ``(1 - 0.99)^k``), every shell Gaussian's is above :data:`UNSEEN`; hiding the inside leaves the rest
renders from six other directions within 50 dB; the NumPy and numba sums agree. On a broken biscuit run
(``broken_run``): from frame 1 the rows :func:`unseen_rows` names carry the hidden logit and no other row changes
its opacity; frame 0 is the input; ``run.json`` counts them. The catches: :data:`HIDE_UNSEEN` off names no row; a
share blind to the transmittance (``T`` taken as 1) calls the inside seen.
"""
from __future__ import annotations

import json

import numpy as np
import pytest

from gasp_core.gs.splat_numpy import Splats
import gasp_core.gs.unseen as unseen
from gasp_testing import biscuit_scene_text, needs_package


def shell_gaussians(n_shell: int = 3000, n_inside: int = 400, radius: float = 0.05, seed: int = 3) -> tuple:
    """:class:`Gaussians` of a sphere of ``radius`` m tiled by flat discs (opacity 0.99, in-plane sigma the mean
    spacing, grey) and ``n_inside`` round Gaussians of random colours within 0.6 ``radius`` (opacity 0.9); and the
    inside mask."""
    from gasp_core.gs.gaussians import Gaussians, rotmat_to_quat
    rng = np.random.default_rng(seed)
    u = unseen.view_directions(n_shell)
    spacing = radius * np.sqrt(4 * np.pi / n_shell)
    t = np.cross(u, np.where(np.abs(u[:, 2:]) < 0.9, [[0.0, 0.0, 1.0]], [[1.0, 0.0, 0.0]]))
    t /= np.linalg.norm(t, axis=1, keepdims=True)
    R = np.stack([u, t, np.cross(u, t)], axis=2)          # columns: the normal, two in-plane axes
    inner = rng.normal(size=(n_inside, 3))
    inner *= (0.6 * radius * rng.random(n_inside) ** (1 / 3) / np.linalg.norm(inner, axis=1))[:, None]
    n = n_shell + n_inside
    rot = np.concatenate([rotmat_to_quat(R), np.tile([1.0, 0.0, 0.0, 0.0], (n_inside, 1))])
    scales = np.concatenate([np.tile([1e-4 * radius, spacing, spacing], (n_shell, 1)),
                             np.full((n_inside, 3), 0.1 * radius)])
    logit = lambda p: np.log(p / (1 - p))
    op = np.concatenate([np.full(n_shell, logit(0.99)), np.full(n_inside, logit(0.9))]).astype(np.float32)
    colour = np.concatenate([np.full((n_shell, 3), 0.8), rng.random((n_inside, 3))])
    g = Gaussians(np.concatenate([radius * u, inner]), scales, rot, op, ((colour - 0.5) / 0.28209479).astype(np.float32),
                  np.zeros((n, 0, 3), np.float32))
    return g, np.arange(n) >= n_shell


def shell_and_inside(*a, **k) -> tuple:
    """:func:`shell_gaussians` as world-frame splats, and the inside mask."""
    from gasp_core.gs.splat_numpy import splats_from_gaussians
    g, inside = shell_gaussians(*a, **k)
    return splats_from_gaussians(g), inside


def test_the_inside_of_a_closed_shell_is_unseen_and_its_skin_is_seen():
    sp, inside = shell_and_inside()
    s = unseen.seen_share(sp, views=unseen.VIEWS, resolution=128)
    assert np.nanmax(s[inside]) < 0.1 * unseen.UNSEEN, np.nanmax(s[inside])
    skin = s[~inside]
    assert np.isfinite(skin).all() and (skin > unseen.UNSEEN).all(), np.nanmin(skin)
    assert unseen.rest_psnr(sp, ~inside, n=6, resolution=160).min() > 50.0


def test_the_numpy_and_numba_sums_agree(monkeypatch):
    pytest.importorskip("numba")
    import builtins
    from gasp_core.gs.splat_numpy import shares
    sp, _ = shell_and_inside(800, 100)
    cam = unseen.ring_cameras(sp, unseen.view_directions(3), 96)[1]
    jit = shares(sp, cam)
    real = builtins.__import__

    def no_numba(name, *a, **kw):
        if name == "gasp_core.gs._splat_numba":
            raise ImportError(name)
        return real(name, *a, **kw)
    monkeypatch.setattr(builtins, "__import__", no_numba)
    ref = shares(sp, cam)
    assert (np.isnan(jit) == np.isnan(ref)).all()
    np.testing.assert_allclose(jit[~np.isnan(jit)], ref[~np.isnan(ref)], atol=1e-9)


@pytest.mark.parametrize("numba", [True, False])
def test_the_numpy_path_shows_its_progress_on_a_terminal(monkeypatch, numba):
    """Without numba the views run in NumPy (about 80 s on the README donut): a tqdm bar on an interactive stderr
    names the path and the extra that speeds it; with numba (3.7 s) nothing is written."""
    import importlib.util
    import io
    import sys

    class Tty(io.StringIO):
        def isatty(self):
            return True
    find = importlib.util.find_spec
    monkeypatch.setattr(importlib.util, "find_spec", lambda name, *a: (find(name, *a) if numba else None)
                        if name == "numba" else find(name, *a))
    monkeypatch.setattr(unseen, "shares", lambda splats, cam, **kw: np.zeros(splats.n))
    monkeypatch.setattr(sys, "stderr", Tty())
    sp, _ = shell_and_inside(200, 20)
    unseen.seen_share(sp, views=4, resolution=32)
    said = sys.stderr.getvalue()
    assert ("unseen Gaussians (NumPy" in said) != numba and ("/4" in said) != numba, said


def test_catch_a_share_blind_to_what_lies_in_front(monkeypatch):
    """A share that takes every pixel's transmittance as 1 (``num = den``) calls the inside seen."""
    monkeypatch.setattr(unseen, "shares", lambda splats, cam, **kw: np.ones(splats.n))
    sp, inside = shell_and_inside(800, 100)
    assert not (unseen.seen_share(sp, views=8, resolution=64)[inside] < unseen.UNSEEN).any()


def test_a_selected_part_is_judged_by_itself_not_by_what_stands_around_it():
    """An object that is only the inside (``moving`` the inside rows, as ``select`` makes it) is seen: its own
    surface, not the shell around it in the capture, decides; the whole capture hides exactly the inside."""
    from types import SimpleNamespace
    g, inside = shell_gaussians(1500, 60)
    spec = SimpleNamespace(static=False, material=SimpleNamespace(name="brittle"))
    place = SimpleNamespace(R=np.eye(3), scale=1.0, t=np.zeros(3))
    whole = SimpleNamespace(spec=spec, gaussians=g, placement=place, moving=None)
    np.testing.assert_array_equal(unseen.unseen_rows(whole), inside)
    part = SimpleNamespace(spec=spec, gaussians=g, placement=place, moving=np.flatnonzero(inside))
    assert not unseen.unseen_rows(part).any()
    jelly = SimpleNamespace(spec=SimpleNamespace(static=False, material=SimpleNamespace(name="jelly")), gaussians=g,
                            placement=place, moving=None)
    assert unseen.unseen_rows(jelly) is None


@pytest.fixture(scope="module")
def masked_run(tmp_path_factory, donut_small):
    """The donut_small biscuit thrown down (2 frames, warp_mpm) with every 7th row named unseen: the plumbing's known
    answer (the subsampled capture has no row unseen of its own: its holes let every view in)."""
    needs_package("gasp_warp_mpm")
    from gasp_core.run.pipeline import simulate_scene
    from gasp_core.scene.spec import load_scene
    tmp = tmp_path_factory.mktemp("unseen")
    (tmp / "scene.toml").write_text(biscuit_scene_text(donut_small, 2, 4.43))
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(unseen, "seen_share", lambda sp, *a, **k: np.where(np.arange(sp.n) % 7 == 0, 0.0, 1.0))
        simulate_scene(load_scene(tmp / "scene.toml"), tmp / "run", quiet=True)
    return tmp / "run"


def test_a_broken_biscuit_hides_its_unseen_rows_after_frame_0(masked_run, donut_small):
    from gasp_core.gs.io import read_gaussians
    meta = json.loads((masked_run / "run.json").read_text())
    g_in = read_gaussians(donut_small)
    hidden = np.arange(g_in.n) % 7 == 0
    name = meta["objects"][0]["name"]
    g0 = read_gaussians(masked_run / name / "frame_0000.ply")
    np.testing.assert_array_equal(g0.opacities, g_in.opacities)   # frame 0: the input
    for f in (1, 2):
        g = read_gaussians(masked_run / name / f"frame_{f:04d}.ply")
        np.testing.assert_allclose(g.opacities[hidden], unseen.HIDDEN)
        np.testing.assert_array_equal(g.opacities[~hidden], g_in.opacities[~hidden])
    rows = {r["frame"]: r for r in meta["frames"]}
    assert rows[1]["unseen"] == rows[2]["unseen"] == int(hidden.sum()) and "unseen" not in rows[0]


def test_catch_the_switch_off_names_no_row(donut_small, monkeypatch, tmp_path):
    from gasp_core.prepare.scene import prepare_scene
    from gasp_core.scene.spec import load_scene
    (tmp_path / "scene.toml").write_text(biscuit_scene_text(donut_small, 2, 4.43))
    prep = prepare_scene(load_scene(tmp_path / "scene.toml"))
    monkeypatch.setattr(unseen, "seen_share", lambda sp, *a, **k: np.zeros(sp.n))
    assert unseen.unseen_rows(prep.objects[0]).all()
    monkeypatch.setattr(unseen, "HIDE_UNSEEN", False)
    assert unseen.unseen_rows(prep.objects[0]) is None


@pytest.mark.slow
def test_the_real_donut_hides_its_inside_and_looks_the_same_at_rest(donut):
    """The README donut (45 624 Gaussians): 5 % to 25 % of it is unseen (4 414 measured, 9.7 %), and drawn without
    them it is the same at rest from six other directions (53.6 dB and more measured)."""
    from gasp_core.gs.splat_numpy import splats_from_gaussians
    sp = splats_from_gaussians(donut)
    s = unseen.seen_share(sp)
    hide = s < unseen.UNSEEN
    assert 0.05 * donut.n < hide.sum() < 0.25 * donut.n, hide.sum()
    assert unseen.rest_psnr(sp, ~hide).min() > 45.0
