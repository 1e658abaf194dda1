"""``python -m gasp_core ...``: the ``gasp`` command (how ``gasp studio`` starts its runs, with the same Python)."""
import sys

from gasp_core.cli.main import main

sys.exit(main())
