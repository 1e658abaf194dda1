"""Running a prepared scene: :mod:`.pipeline` (``gasp simulate``), :mod:`.frames` (``T^-1`` and the alpha rule
per frame), :mod:`.layout` (the frame files, ``frames.json`` and the one reader of every layout), :mod:`.record`
and :mod:`.contact` (``run.json``), :mod:`.resume` (checkpoints) and :mod:`.soup` (triangle-soup exchange with
mesh tools)."""
