"""The engines' constants of Grady's cells parted at their faces (``gasp_core.run.grady_cells`` lays them; each MPM
plugin's ``cells.py`` parts them; ``docs/fracture.md`` "Round 102: Grady's cells in the engines")."""
from gasp_core.seam.options import Option

#: Engine option: lay a soft brittle body out in Grady's cells at its landing (``gasp_core.run.grady_cells``).
CELLS = Option("fracture_cells", True, "a soft brittle body that lands hard enough to break is laid out in Grady's "
               "fragments (Voronoi cells of his size), cut by the cracks a probe of its landing finds, and the cells "
               "part at their faces (docs/fracture.md, rounds 102-103); false: it cracks where its stress puts the "
               "damage, as one velocity field", kind="bool")

#: The crack faces' Coulomb coefficient between two cells' fields (round 101's study, ``benchmarks/studies/cells101.py
#: --mu``).
FACE_MU = 0.5
#: The node key is ``int(weight * KEY_SCALE) * 256 + cell``: the largest quadratic weight (0.75^3) times it, times 256,
#: stays under 2^31, and a cell id takes the low 8 bits (``gasp_core.seam.setup_checks.check_cells``: at most 255).
KEY_SCALE = float(1 << 22)
#: A broken point of a body in cells keeps its crack's opening in ``F`` up to this principal log stretch (ln 2: an
#: opening of its cell's width, where the pieces count apart); beyond it the two fields carry the contact. Without the
#: bound the stretch grew until the run diverged (10 m/s on n_grid 48, frame 25, round 102).
OPENING = 0.6931471805599453
