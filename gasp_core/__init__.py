"""GASP core: GaMeS maps, control rules, hierarchy, scene format, I/O and the engine interface."""
__version__ = "0.1.0"
