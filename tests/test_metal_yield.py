"""Metal (von Mises) yield: ``yield_stress`` Y is the uniaxial yield stress.

The return mapping of both MPM engines (docs/mpm.md) projects the Hencky strain's deviator onto
``||dev tau|| <= sqrt(2/3) Y`` (``dev tau = 2 mu e``), i.e. the von Mises equivalent stress
``sigma_vm = sqrt(3/2) ||dev tau||`` never exceeds Y (de Souza Neto, Peric & Owen, *Computational
Methods for Plasticity*, 2008, Ch. 6; Klar et al. 2016 Sec. 4 for the Hencky-strain form). Under
uniaxial stress ``sigma_vm = |sigma_11|``, so a bar yields at Y.

One particle, one substep: the state's ``F`` is set to an isochoric uniaxial stretch
``diag(exp(eps), exp(-eps/2), exp(-eps/2))`` (``C = 0``, so P2G's trial ``F`` is that stretch), and
the ``F`` the engine stores after the frame is the return-mapped one. Its uniaxial stress
``tau_11 - tau_22 = 3 mu eps_dev`` is compared with Y; before the fix it was ``sqrt(3/2) Y = 1.22 Y``.
"""
from __future__ import annotations

import numpy as np
import pytest

from gasp_core.seam.build import build_engine
from gasp_core.seam.setup import Material, SimSetup
from gasp_core.seam.plugins import engines

E, NU, Y = 1e6, 0.3, 1e4
MU = E / (2 * (1 + NU))
LAM = E * NU / ((1 + NU) * (1 - 2 * NU))


def _names():
    return [n for n, i in engines().items() if i.unavailable_reason() is None and n in ("taichi_mpm", "warp_mpm")]


def _return_mapped_F(name: str, eps: float, precision: str = "f64") -> np.ndarray:
    s = SimSetup(x=np.array([[0.5, 0.5, 0.5]]), v=0.0, p_vol=np.array([1e-6]), body_id=0,
                 materials=[Material("metal", E=E, nu=NU, rho=1000.0, yield_stress=Y)], gravity=[0, 0, 0],
                 domain_lo=np.zeros(3), domain_hi=np.ones(3), n_grid=16, frame_dt=1e-6,
                 options={"n_substeps": 1, "precision": precision, **({"threads": 1} if name == "taichi_mpm" else {})})
    e = build_engine(engines()[name], s)
    try:
        st = e.get_state()
        st["F"] = np.diag([np.exp(eps), np.exp(-eps / 2), np.exp(-eps / 2)])[None].astype(st["F"].dtype)
        st["C"] = np.zeros_like(st["C"])
        e.set_state(st)
        e.step_frame()
        return np.asarray(e.get_state()["F"][0], np.float64)
    finally:
        e.close()


def _uniaxial_stress(F: np.ndarray) -> float:
    """``tau_11 - tau_22`` (Pa) of the Hencky stress of a diagonal ``F`` (the uniaxial stress up to a
    hydrostatic part, which von Mises ignores)."""
    eps = np.log(np.diag(F))
    tau = 2 * MU * eps + LAM * eps.sum()
    return float(tau[0] - tau[1])


@pytest.mark.parametrize("name", _names())
def test_metal_yields_at_the_uniaxial_yield_stress(name):
    """Stretched 3x past yield, the return-mapped state carries uniaxial stress Y (within 2 %);
    below yield (0.8 Y) the state is untouched (elastic)."""
    eps_y = Y / (3 * MU)                       # isochoric uniaxial strain at which sigma_11 = Y
    F = _return_mapped_F(name, 3 * eps_y)
    assert np.allclose(F, np.diag(np.diag(F)), atol=1e-9)
    s = _uniaxial_stress(F)
    assert abs(s / Y - 1) < 0.02, f"{name}: uniaxial stress after the return mapping {s / Y:.4f} Y (expected 1)"
    F = _return_mapped_F(name, 0.8 * eps_y)
    assert abs(_uniaxial_stress(F) / Y - 0.8) < 1e-3
