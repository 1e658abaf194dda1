"""The ``gasp`` command: :mod:`.main` (sub-commands, one-line errors, exit codes) and :mod:`.args` (argument checks)."""
from gasp_core.cli import early as _early

if _early.is_command_line():   # first thing: a signal during start-up is one line (see the module)
    _early.install()
