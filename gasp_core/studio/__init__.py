"""``gasp studio``: open a splat file or scene in the browser, select an object, pick a material, run, watch
(:mod:`gasp_core.studio.app`)."""
