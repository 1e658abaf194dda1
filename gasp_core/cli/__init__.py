"""The ``gasp`` command: :mod:`.main` (sub-commands, one-line errors, exit codes) and :mod:`.args` (argument checks)."""
