"""The passive gather of round 36 and before (each node with mass at its full B-spline weight, renormalised over the
nodes with mass), switched on for a catch test: ``with gather_by_weight_alone("taichi_mpm"): ...``."""
from __future__ import annotations

import contextlib


@contextlib.contextmanager
def gather_by_weight_alone(engine: str):
    """The engine's passive gather by the weight alone inside the block (its kernels rebuilt), mass-weighted after."""
    if engine == "taichi_mpm":
        from gasp_taichi_mpm.transfers import Transfers
        Transfers.PASSIVE_BY_MASS = False
        try:
            yield
        finally:
            Transfers.PASSIVE_BY_MASS = True
        return
    from gasp_warp_mpm import kernels, transfers

    def clear():
        transfers.build_g2p_passive.cache_clear()
        kernels.build_kernels.cache_clear()
    transfers.PASSIVE_BY_MASS = False
    clear()
    try:
        yield
    finally:
        transfers.PASSIVE_BY_MASS = True
        clear()
