"""The split accuracy report (gasp_studies.accuracy / trade / images) on cases with a known answer.

Each figure is checked two-sided against an exact or analytic value with a tolerance well inside 5 %, and the
Kabsch-based checks are shown to catch deliberately broken fits (no centroid removal, the transposed rotation,
no reflection fix).
"""
from __future__ import annotations

import numpy as np
import pytest
from gasp_testing import needs_package

from gasp_studies import accuracy
from gasp_studies.accuracy import Track, events, kabsch, split_errors, split_frame
from gasp_studies.trade import accuracy_report, choose_default, rule_checks

G = 9.81


def _rot(axis, deg):
    axis = np.asarray(axis, float) / np.linalg.norm(axis)
    a = np.radians(deg)
    K = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    return np.eye(3) + np.sin(a) * K + (1 - np.cos(a)) * K @ K


def _cloud(n=400, seed=0):
    """An asymmetric cloud (a box 0.3 x 0.2 x 0.1 m, with a lump), so its rotation is unique."""
    rng = np.random.default_rng(seed)
    p = rng.uniform(-1, 1, (n, 3)) * [0.15, 0.1, 0.05]
    p[: n // 8] += [0.1, 0.05, 0.03]
    return p


def _track(frames, dt=1 / 30, ground=0.0, dx=0.01, label="t"):
    m = np.stack(frames)
    return Track(m, np.array([0, m.shape[1]]), ["obj"], dt, ground, dx, label)


def _known_answers(split) -> bool:
    """The split of a rotated + translated copy and of a scaled copy against their exact values."""
    a = _cloud()
    R0, t = _rot([1, 2, 3], 30.0), np.array([0.02, -0.01, 0.005])
    b = (a - a.mean(0)) @ R0.T + a.mean(0) + t
    r = split(b, a)
    ok = abs(r["rotation_deg"] - 30.0) < 1e-6 and r["shape_m"] < 1e-9 and abs(r["centroid_m"] - np.linalg.norm(t)) < 1e-9
    s = 1.03
    c = a.mean(0) + s * (a - a.mean(0))
    r = split(c, a)
    expect = (s - 1) * np.linalg.norm(a - a.mean(0), axis=1).mean()
    return ok and r["rotation_deg"] < 1e-6 and abs(r["shape_m"] - expect) < 1e-3 * expect


def test_rotated_translated_and_scaled_copies():
    assert _known_answers(split_frame)
    # a mirror image is not a rotation: Kabsch still returns det +1
    a = _cloud()
    R, _, _ = kabsch(a * [1, 1, -1], a)
    assert abs(np.linalg.det(R) - 1.0) < 1e-9


def _broken_no_centroid(a, b):
    a, b = np.asarray(a, float), np.asarray(b, float)
    U, _, Vt = np.linalg.svd(a.T @ b)
    d = np.sign(np.linalg.det(Vt.T @ U.T))
    return Vt.T @ np.diag([1, 1, d]) @ U.T, a.mean(0), b.mean(0)


def _broken_transposed(a, b):
    R, ca, cb = kabsch(a, b)
    return R.T, ca, cb


def _broken_no_reflection_fix(a, b):
    a, b = np.asarray(a, float), np.asarray(b, float)
    ca, cb = a.mean(0), b.mean(0)
    U, _, Vt = np.linalg.svd((a - ca).T @ (b - cb))
    return Vt.T @ U.T, ca, cb


@pytest.mark.parametrize("broken", [_broken_no_centroid, _broken_transposed])
def test_known_answers_catch_a_broken_fit(monkeypatch, broken):
    monkeypatch.setattr(accuracy, "kabsch", broken)
    assert not _known_answers(accuracy.split_frame)


def test_reflection_fix_is_needed():
    """A flat (planar) cloud against its mirror image: without the fix the 'rotation' is a reflection."""
    rng = np.random.default_rng(1)
    a = np.c_[rng.uniform(-1, 1, (200, 2)), np.zeros(200)] * [0.1, 0.05, 0]
    a[:, 2] = 0.01 * rng.standard_normal(200)
    b = a * [1, 1, -1]
    assert abs(np.linalg.det(kabsch(a, b)[0]) - 1) < 1e-9
    assert np.linalg.det(_broken_no_reflection_fix(a, b)[0]) < 0


def _bounce(e=0.6, h=0.05, vx=0.02, spin_deg_s=30.0, dt=1e-3, t_end=0.4):
    """A rigid cloud dropped from ``h`` (its lowest point) onto z = 0 with an instantaneous bounce of
    restitution ``e``, drifting at ``vx`` and spinning about z: frames and the analytic events."""
    a = _cloud()
    a = a - a.mean(0)
    lowest = np.percentile(a[:, 2], accuracy.BOTTOM_QUANTILE)
    z0 = h - lowest
    t_hit = np.sqrt(2 * h / G)
    v_in = G * t_hit
    frames, zc = [], []
    for t in np.arange(0, t_end + dt / 2, dt):
        if t <= t_hit:
            z = z0 - 0.5 * G * t * t
        else:
            s = t - t_hit
            v0 = e * v_in
            n_up = 2 * v0 / G
            z = z0 - h + v0 * s - 0.5 * G * s * s if s <= n_up else z0 - h   # one bounce, then at rest
        R = _rot([0, 0, 1], spin_deg_s * t)
        frames.append(a @ R.T + [vx * t, 0, z])
        zc.append(z)
    return frames, {"t_hit": t_hit, "v_in": v_in, "z_end": zc[-1], "t_end": t_end}


def test_events_of_an_analytic_bounce():
    e, vx, spin = 0.6, 0.02, 30.0
    frames, ref = _bounce(e=e, vx=vx, spin_deg_s=spin)
    gap = 0.002
    tr = _track(frames, dt=1e-3, dx=2 * gap / accuracy.CONTACT_GAP_DX)
    ev = events(tr, 0, gap)
    level = ev["contact_level_m"]          # the lowest the sampled bottom gets (under a millimetre) + the gap
    assert gap < level < gap + 1.5e-3
    gap = level
    t_gap = np.sqrt(2 * (0.05 - gap) / G)
    assert ev["impact_s"] == pytest.approx(t_gap, rel=1e-3)
    assert ev["restitution"] == pytest.approx(e, rel=0.02)
    v_in, v_out = ref["v_in"], e * ref["v_in"]
    contact = (ref["t_hit"] - t_gap) + (v_out - np.sqrt(v_out ** 2 - 2 * G * gap)) / G
    assert ev["contact_s"] == pytest.approx(contact, rel=0.02)
    assert ev["rest_height_m"] == pytest.approx(ref["z_end"], rel=1e-9)
    assert ev["drift_m"] == pytest.approx(vx * ref["t_end"], rel=1e-9)
    assert ev["final_rotation_deg"] == pytest.approx(spin * ref["t_end"], rel=1e-6)


def test_ballistic_restitution_of_a_bounce_filmed_at_30_fps():
    """The analytic bounce (restitution 0.6, instantaneous) sampled at 30 fps from four drop heights (four phases of
    the frames around the impact): the free flights give e within 2 % at each; the frame differences, which see the
    impact inside one frame's interval, read 0.23-0.59 (issue 40's stiff block: its rigid bounce read 0.40 against
    the explicit 0.58 by them, 0.85 against 0.81 by the free flights)."""
    e, dt, every = 0.6, 1e-3, 33
    by_frames = []
    for h in (0.040, 0.045, 0.050, 0.055):
        frames, _ = _bounce(e=e, h=h, dt=dt, t_end=0.4)
        ev = events(_track(frames[::every], dt=every * dt, dx=0.004), 0, 0.008)
        assert ev["restitution_ballistic"] == pytest.approx(e, rel=0.02)
        by_frames.append(ev["restitution"])
    assert min(by_frames) < 0.5 * e and max(by_frames) < e


def test_report_in_units_of_the_twin():
    """A run 2 mm off and 2 % larger than the reference, its twin 1 mm off and 1 % larger: 2 U each."""
    a = _cloud()
    ref = _track([a, a + [0, 0, 0.0]], label="ref")

    def copy(shift, s):
        b = a.mean(0) + s * (a - a.mean(0)) + [shift, 0, 0]
        return [a, b]
    run, twin = _track(copy(0.002, 1.02), label="run"), _track(copy(0.001, 1.01), dx=0.02, label="twin")
    rep = accuracy_report(run, ref, twin)
    f = rep["objects"]["obj"]
    assert f["in_u"]["centroid"] == pytest.approx(2.0, rel=1e-6)
    assert f["in_u"]["shape"] == pytest.approx(2.0, rel=1e-6)
    # with an observed order 2 and r = 2 the Richardson U is a third of the twin's distance (1 / (2^2 - 1))
    rep2 = accuracy_report(run, ref, twin, order=2.0)
    assert rep2["objects"]["obj"]["in_u"]["shape"] == pytest.approx(2.0 * 3.0, rel=1e-6)
    checks = rule_checks(rep)
    assert not checks["shape_u"]["ok"] and checks["shape_u"]["value"] == pytest.approx(2.0)
    assert not checks["drift_m"]["ok"] and checks["drift_m"]["value"] == pytest.approx(0.002)
    rep_ok = accuracy_report(_track(copy(0.0005, 1.012)), ref, twin)
    assert rule_checks(rep_ok)["shape_u"]["ok"]


def test_split_rejects_other_scenes():
    a = _cloud()
    with pytest.raises(ValueError, match="Gaussians"):
        split_errors(_track([a]), _track([a[:-1]]))


def test_choose_default_picks_the_cheapest_passing():
    ok = {"x": {"value": 0.1, "limit": 1, "ok": True}}
    bad = {"x": {"value": 2.0, "limit": 1, "ok": False}}
    chosen, why = choose_default([{"name": "cheap", "cost": 1, "checks": bad},
                                  {"name": "mid", "cost": 2, "checks": ok},
                                  {"name": "dear", "cost": 3, "checks": ok}])
    assert chosen["name"] == "mid" and why == ["cheap: x 2 (limit 1)"]


def test_psnr_and_ssim_known_values():
    needs_package("skimage")
    from gasp_studies.images import image_scores
    rng = np.random.default_rng(0)
    ref = rng.uniform(0.2, 0.8, (48, 64, 3)).astype(np.float32)
    s = image_scores([ref], [ref + np.float32(0.01)])
    assert s["psnr_db"] == pytest.approx(40.0, abs=0.01)
    assert image_scores([ref], [ref])["ssim"] == pytest.approx(1.0)
    assert image_scores([ref], [ref])["psnr_db"] == float("inf")
    assert "LPIPS" in s["not_computed"]


def test_rendered_copies():
    """A track rendered against itself is identical; moved by a tenth of its size it is not."""
    needs_package("skimage")
    needs_package("numba")
    from gasp_core.gs.splat_numpy import Splats
    from gasp_studies.images import cameras_for, image_scores, render_frames
    a = _cloud(300)
    n = len(a)

    def track(shift):
        frames = [a, a + [shift, 0, 0]]
        t = _track(frames)
        t.splats = lambda f: Splats(frames[f].astype(np.float32), np.tile(np.eye(3, dtype=np.float32) * 1e-4, (n, 1, 1)),
                                    np.full((n, 3), 0.9, np.float32), np.full(n, 0.8, np.float32))
        return t
    ref = track(0.0)
    cams, how = cameras_for(ref, [0, 1])
    assert len(cams) == 4 and "orbit" in how
    same = image_scores(render_frames(ref, [1], cams), render_frames(track(0.0), [1], cams))
    moved = image_scores(render_frames(ref, [1], cams), render_frames(track(0.03), [1], cams))
    assert same["psnr_db"] == float("inf") and same["ssim"] == pytest.approx(1.0)
    assert moved["psnr_db"] < 40 and moved["ssim"] < 0.99


def test_bench_twin_is_the_reference_model_one_grid_coarser():
    from gasp_studies.bench_rank import twin_index
    s = [{"n_grid": 48, "cfl": 0.4, "precision": "f64"}, {"n_grid": 32, "cfl": 0.4, "precision": "f32"},
         {"n_grid": 40, "cfl": 0.8, "precision": "f32"}, {"n_grid": 40, "cfl": 0.4, "precision": "f32"},
         {"n_grid": 48, "cfl": 0.4, "precision": "f32"}]
    assert twin_index(s) == 3
    assert twin_index([{"cells": 8}, {"cells": 4}]) is None


def test_bench_ranking_orders_passing_runs_and_says_not_ranked_only_within_u():
    """Runs scaled by 0.5 % (passes: 0.5 U) and 3 % (3 U: misses the shape) against a twin scaled by 1 %."""
    needs_package("skimage")
    needs_package("numba")
    from gasp_core.gs.splat_numpy import Splats
    from gasp_studies.bench_rank import rank_engine, ranking_lines
    a = _cloud(300)
    n = len(a)

    def track(s, label):
        b = a.mean(0) + s * (a - a.mean(0))
        frames = [a, b]
        t = Track(np.stack(frames), np.array([0, n]), ["obj"], 1 / 30, None, 0.01, label)
        t.splats = lambda f: Splats(frames[f].astype(np.float32), np.tile(np.eye(3, dtype=np.float32) * 1e-4, (n, 1, 1)),
                                    np.full((n, 3), 0.9, np.float32), np.full(n, 0.8, np.float32))
        return t
    settings = [{"n_grid": 48}, {"n_grid": 32}, {"n_grid": 48, "x": 1}, {"n_grid": 48, "x": 2}]
    scales = [1.0, 1.01, 1.005, 1.03]
    rows = [{"setting": f"s{i}", "end_to_end_s": 10.0 - i} for i in range(4)]
    tracks = [track(s, f"s{i}") for i, s in enumerate(scales)]
    rank = rank_engine(rows, tracks, settings, [1])
    assert rank["twin"] == "s1" and rank["not_ranked"] == ""
    assert rank["ranked"] == ["s2", "s1"]            # both within 1.5 U, the cheaper first
    assert rows[2]["shape_u"] == pytest.approx(0.5, rel=1e-6) and rows[3]["shape_u"] == pytest.approx(3.0, rel=1e-6)
    assert "shape_u 3" in dict(rank["rest"])["s3"]
    assert any("U = shape" in line for line in ranking_lines("e", rows, rank))
    # every run within 1 U of the others: U is larger than the differences, nothing is ranked
    rows2 = [dict(r) for r in rows[:3]]
    rank2 = rank_engine(rows2, tracks[:3], settings[:3], [1])
    assert rank2["not_ranked"].startswith("U (shape") and rank2["ranked"] == [] and rank2["unranked"] == ["s2", "s1"]
    assert any(line.startswith("- not ranked: U") for line in ranking_lines("e", rows2, rank2))


def test_cameras_come_from_the_captures_cameras_json(tmp_path):
    """With a graphdeco cameras.json the views are 4 of its cameras, evenly through the list."""
    import json
    from gasp_studies.images import cameras_for
    cams = []
    for i in range(10):
        a = np.radians(36 * i)
        pos = [2 * np.cos(a), 2 * np.sin(a), 0.0]
        fwd = -np.asarray(pos) / 2.0
        right = np.cross(fwd, [0, 0, 1.0])
        down = np.cross(fwd, right)
        cams.append({"id": i, "position": pos, "rotation": np.stack([right, down, fwd], 1).tolist(),
                     "width": 64, "height": 48, "fx": 50.0, "fy": 50.0})
    path = tmp_path / "cameras.json"
    path.write_text(json.dumps(cams))
    t = _track([_cloud()])
    t.cameras_json, t.placement = path, {"R": np.eye(3), "scale": 1.0, "t": np.zeros(3)}
    got, how = cameras_for(t, [0])
    assert "capture's cameras [0, 3, 6, 9]" in how and len(got) == 4
    assert np.allclose(got[1].position, cams[3]["position"])
