"""What GASP exists for (paper Sec. 3): :mod:`.games` (the GaMeS maps ``T``, ``T^-1``, flattening and the
alpha rule), :mod:`.hierarchy` (Core Gaussians, D-MiSo binding), :mod:`.fill` and :mod:`.occupancy`
(interior points and per-point volumes), :mod:`.floaters` (Gaussians detached from their object)."""
