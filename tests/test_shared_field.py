"""Solids that share one grid velocity field are named (issue 67 item 4: "three or more bodies still share one field",
``docs/contact.md``): the two-field contact (``gasp_core.mpm.fields``) gives two bodies on the particle contact a
field each, and flowing bodies one against the others; any other solids in a scene share one field, where, as in any
single-field MPM, they move as one where they touch (no slip, no Coulomb law). The MPM engines warn at build, naming
the bodies, so that a scene of three solids is not silently glued. Round 61 (``gasp_core.mpm.colouring``): three or
more soft bodies take the two fields by a 2-colouring of the bodies within reach; only the pairs the colouring cannot
separate (odd cycles: three bodies touching each other) still share, and only they are named."""
from __future__ import annotations

import warnings
from dataclasses import replace

import numpy as np
import pytest

from gasp_core.mpm.shared_fields import shared_field_bodies
from gasp_core.seam.plugins import engines
from gasp_core.testing import sand_ball as S


def with_bodies(materials, options=None):
    """The sand-and-ball scene's points split into ``len(materials)`` bodies along x, ``materials`` in order."""
    s = S.pair_setup(options=options)
    edges = np.quantile(s.x[:, 0], np.linspace(0, 1, len(materials) + 1)[1:-1])
    return replace(s, body_id=np.searchsorted(edges, s.x[:, 0]), materials=list(materials))


def wedges(materials):
    """The sand-and-ball scene's points split into three wedges about the vertical through their centre: each
    touches the other two (an odd cycle)."""
    s = S.pair_setup()
    c = s.x.mean(0)
    ang = np.arctan2(s.x[:, 1] - c[1], s.x[:, 0] - c[0])
    return replace(s, body_id=np.minimum(((ang + np.pi) / (2 * np.pi / 3)).astype(int), 2), materials=list(materials))


def test_shared_field_bodies_names_the_solids_left_in_one_field():
    jelly, sand, rigid = S.BALL, S.SAND, replace(S.BALL, model="rigid")
    assert shared_field_bodies(with_bodies([jelly, jelly])) == []                 # a field each
    assert shared_field_bodies(with_bodies([sand, jelly])) == []                  # sand against the ball
    assert shared_field_bodies(with_bodies([jelly, jelly, jelly])) == []          # round 61: coloured, a path
    assert len(shared_field_bodies(wedges([jelly, jelly, jelly]))) == 2          # an odd cycle: one pair shares
    assert shared_field_bodies(with_bodies([jelly, rigid, jelly])) == []          # round 62: coloured with them
    assert shared_field_bodies(with_bodies([sand, jelly, rigid])) == [1, 2]       # field B holds both solids
    assert shared_field_bodies(with_bodies([sand, sand, jelly])) == []            # flowing bodies share theirs
    assert shared_field_bodies(with_bodies([jelly, jelly, jelly], {"contact_fields": False})) == []   # asked for
    assert shared_field_bodies(with_bodies([jelly, jelly], {"contact": "grid"})) == [0, 1]


@pytest.mark.parametrize("name", ["taichi_mpm", "warp_mpm"])
def test_the_engines_warn_of_the_solids_that_still_share(name):
    if name not in engines() or engines()[name].unavailable_reason() is not None:
        pytest.skip(f"{name} not installed")
    from gasp_core.seam.build import build_engine
    said = {}
    for n, setup in ((2, with_bodies([S.BALL] * 2)), (3, with_bodies([S.BALL] * 3)), ("odd", wedges([S.BALL] * 3)),
                     ("rigid", with_bodies([S.BALL, replace(S.BALL, model="rigid"), S.BALL]))):
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            build_engine(engines()[name], setup).close()
        said[n] = [str(w.message) for w in caught if "share one grid velocity field" in str(w.message)]
    assert not said[2] and not said[3], (said[2], said[3])     # a field each; three in a row coloured (round 61)
    shared = shared_field_bodies(wedges([S.BALL] * 3))
    assert len(said["odd"]) == 1 and "odd cycle" in said["odd"][0], said["odd"]
    assert ", ".join(f"{i} (jelly)" for i in shared) in said["odd"][0], said["odd"]
    assert not said["rigid"], said["rigid"]   # round 62: a rigid body among three is coloured (rigid_pairs)
