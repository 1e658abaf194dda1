"""Every ``gasp`` argument explains itself: a help text, and for an option with a default, that default."""
import argparse

import pytest
from gasp_testing import needs_package

from gasp_core.cli.main import build_parser


def _arguments():
    for name, sub in build_parser()._subparsers._group_actions[0].choices.items():
        for a in sub._actions:
            if not isinstance(a, argparse._HelpAction):
                yield name, a


@pytest.mark.parametrize("command, action", list(_arguments()),
                         ids=lambda x: x if isinstance(x, str) else "/".join(x.option_strings) or x.dest)
def test_every_argument_has_help_with_its_default(command, action):
    where = f"gasp {command} {'/'.join(action.option_strings) or action.dest}"
    assert action.help and len(action.help) > 8, f"{where}: no help text"
    flag = isinstance(action, (argparse._StoreTrueAction, argparse._VersionAction))   # off unless given
    if action.option_strings and not action.required and not flag:
        assert "default" in action.help, f"{where}: the help does not say the default ({action.help!r})"


def test_gasp_studies_timeouts_match_the_help():
    studies = needs_package("gasp_studies.bench")
    from gasp_studies.run import RUN_TIMEOUT_S
    text = next(a.help for c, a in _arguments() if c == "bench" and "--timeout" in a.option_strings)
    assert f"default {RUN_TIMEOUT_S:g} for compare, {studies.BENCH_TIMEOUT_S:g} for bench" in text
