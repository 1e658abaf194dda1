"""Tests of the MPM engines' shared half (gasp_core.mpm) that the grid engines share."""
import math

import numpy as np
import pytest

from gasp_core.errors import SceneError
from gasp_core.seam.options import check_options
from gasp_core.seam.setup import Boundary, Material
from gasp_core.mpm.materials import (initial_Jp, MATERIAL_CODES, material_table, N_PARAMS, P_ALPHA, P_K, P_LAM,
                                         P_MU, P_THETA_C)
from gasp_core.mpm.options import mpm_options
from gasp_core.mpm.points import HELD_STRAINED, cell_order, fixed_mask, held_codes, image_gradient
from gasp_core.mpm.sweep import mpm_sweep


def test_material_table_holds_the_lame_parameters_and_the_derived_constants():
    mats = [Material("jelly", E=1e5, nu=0.3), Material("sand", E=3.5e5, nu=0.3, friction_angle=30.0),
            Material("liquid", E=1e4, nu=0.45)]
    kinds, params = material_table(mats)
    assert kinds.tolist() == [MATERIAL_CODES["jelly"], MATERIAL_CODES["sand"], MATERIAL_CODES["liquid"]]
    assert params.shape == (3, N_PARAMS) and params.dtype == np.float64
    # E = 1e5, nu = 0.3: mu = E / 2.6, lam = E 0.3 / (1.3 * 0.4)
    assert params[0, P_MU] == pytest.approx(1e5 / 2.6)
    assert params[0, P_LAM] == pytest.approx(1e5 * 0.3 / 0.52)
    # Drucker-Prager alpha for 30 degrees: sqrt(2/3) * 2 * 0.5 / 2.5 (Klar et al. 2016)
    assert params[1, P_ALPHA] == pytest.approx(math.sqrt(2 / 3) * 0.4)
    # bulk modulus K = E / (3 (1 - 2 nu))
    assert params[2, P_K] == pytest.approx(1e4 / (3 * 0.1))
    assert params[0, P_THETA_C] == Material().theta_c


def test_material_without_an_mpm_model_is_a_scene_error():
    with pytest.raises(SceneError, match="rigid"):
        material_table([Material("rigid")])


def test_initial_Jp_is_zero_plastic_strain_for_plasticine_and_unit_volume_ratio_otherwise():
    mats = [Material("snow"), Material("plasticine"), Material("jelly")]
    assert initial_Jp(mats, np.array([0, 1, 2, 1])).tolist() == [1.0, 0.0, 1.0, 0.0]


def test_fixed_mask_is_the_closed_box_of_every_fixed_region():
    x = np.array([[0.0, 0, 0], [0.1, 0.1, 0.1], [0.2, 0.2, 0.2], [0.5, 0.5, 0.5]])
    b = [Boundary("ground"), Boundary("fixed_region", lo=(0, 0, 0), hi=(0.1, 0.1, 0.1)),
         Boundary("fixed_region", lo=(0.45, 0.45, 0.45), hi=(0.6, 0.6, 0.6))]
    assert fixed_mask(x, b).tolist() == [True, True, False, True]
    assert not fixed_mask(x, b[:1]).any()


def test_held_codes_give_the_nearest_face_axis_near_a_face_and_rigid_deeper():
    dx = 0.1
    b = [Boundary("fixed_region", lo=(0, 0, 0), hi=(0.5, 1, 1)), Boundary("fixed_region", lo=(0, 0, 0), hi=(1, 0.3, 1))]
    x = np.array([[0.45, 0.6, 0.5],    # 0.5 dx from region 0's x face: strained across x
                  [0.2, 0.6, 0.5],     # 3 dx deep in region 0: rigid
                  [0.7, 0.25, 0.5],    # only in region 1, 0.5 dx from its y face: strained across y
                  [0.45, 0.1, 0.5],    # near a face of both regions: the first region's face
                  [0.2, 0.2, 0.5],     # deep in both
                  [0.8, 0.6, 0.5]])    # free
    assert held_codes(x, b, dx).tolist() == [HELD_STRAINED + 0, 1, HELD_STRAINED + 1, HELD_STRAINED + 0, 1, 0]


def test_the_image_gradient_of_a_ghost_field_is_the_material_beside_the_face():
    """A bar's uniaxial stretch with lateral contraction beside a face x = 0 (``v = G x``): the ghost field inside,
    ``-v(R x)``, has the gradient ``-G R``, whose lateral strain is an expansion; :func:`image_gradient` gives ``G``
    back (the engines' held points near a face take it; the raw one damaged a clamp at half the strength)."""
    nu = 0.25
    G = np.diag([1.0, -nu, -nu]) + np.array([[0, 0.3, 0], [0.2, 0, 0], [0, 0, 0]])
    R = np.diag([-1.0, 1.0, 1.0])
    ghost = -G @ R
    assert np.diag(ghost)[1:].tolist() == [nu, nu]                 # the raw ghost: lateral expansion
    assert np.allclose(image_gradient(ghost, 0), G)
    assert np.allclose(image_gradient(-G @ np.diag([1.0, -1.0, 1.0]), 1), G)


def test_cell_order_sorts_by_flat_cell_stably_and_tolerates_nan():
    dx, n = 0.25, 4
    x = np.array([[0.9, 0.1, 0.1], [0.1, 0.1, 0.9], [0.1, 0.1, 0.1], [np.nan, 0.5, 0.5], [0.12, 0.1, 0.1]])
    # cells: (3,0,0) -> 48, (0,0,3) -> 3, (0,0,0) -> 0, (0,2,2) -> 10, (0,0,0) -> 0
    assert cell_order(x, np.zeros(3), dx, n).tolist() == [2, 4, 1, 3, 0]


def test_device_rule_is_declared_per_engine():
    default_gpu_only, any_gpu = mpm_options(), mpm_options(cuda_index=True)
    assert check_options({"device": "cuda:1"}, any_gpu, "e")["device"] == "cuda:1"
    with pytest.raises(SceneError, match="device='cuda:1'"):
        check_options({"device": "cuda:1"}, default_gpu_only, "e")
    for opts in (default_gpu_only, any_gpu):
        with pytest.raises(SceneError, match="device='gpu'"):
            check_options({"device": "gpu"}, opts, "e")


def test_the_core_checks_mpm_options_from_their_declarations_alone():
    """dt excludes n_substeps as declared data (Option.excludes): check_options is the one checker."""
    opts = check_options({}, mpm_options(), "e")
    assert opts == {"device": "cpu", "precision": "f32", "dt": None, "n_substeps": None, "cfl": 0.4,
                    "cfl_rule": "sum", "max_substeps": 20000}
    assert check_options(opts, mpm_options(), "e") == opts  # idempotent
    with pytest.raises(SceneError, match="engine 'e': give option dt or option n_substeps, not both"):
        check_options({"dt": 1e-4, "n_substeps": 3}, mpm_options(), "e")
    with pytest.raises(SceneError, match="cfl=1.5"):
        check_options({"cfl": 1.5}, mpm_options(), "e")


def test_negative_poisson_ratio_is_accepted_once_and_gives_positive_wave_speeds():
    """SimSetup's -1 < nu < 0.5 is the one rule: the MPM moduli stay positive on all of it."""
    kinds, params = material_table([Material("jelly", nu=-0.5), Material("liquid", nu=-0.9)])
    assert params[0, P_MU] > 0 and params[0, P_LAM] + 2 * params[0, P_MU] > 0
    assert 3 * params[0, P_LAM] + 2 * params[0, P_MU] > 0 and params[1, P_K] > 0


def test_mpm_sweep_reference_is_the_finest_and_never_repeated():
    settings, ref = mpm_sweep(False)
    assert ref == {"n_grid": 96, "cfl": 0.2, "particles_per_cell": 8, "fill": True, "precision": "f64",
                   "core_fraction": 1.0, "surface": "material"}
    assert {s.get("surface") for s in settings} == {"material", "passive"}
    keys = [tuple(sorted(s.items())) for s in settings]
    assert len(keys) == len(set(keys)) and ref not in settings
    assert all(s["n_grid"] <= ref["n_grid"] and s["cfl"] >= ref["cfl"] for s in settings)
    quick, qref = mpm_sweep(True, precisions={"f32", "f64"})
    assert {s["precision"] for s in quick} | {qref["precision"]} == {"f32"} and qref["n_grid"] == 48
    assert all("surface" not in s for s in quick + [qref])   # one model: the key is left out
    only64, ref64 = mpm_sweep(False, precisions={"f64"})
    assert {s["precision"] for s in only64} == {"f64"} and ref64["precision"] == "f64"


def test_causes_are_words():
    from gasp_core.seam.runner import CAUSE_LEFT_DOMAIN, CAUSE_UNSTABLE
    assert "time step" in CAUSE_UNSTABLE and "domain" in CAUSE_LEFT_DOMAIN
