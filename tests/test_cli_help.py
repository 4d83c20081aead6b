"""Every script's ``--help`` names each option's default (and so its unit, in the help text), and no
script takes an abbreviated option (a prefix of a removed option would otherwise still parse)."""

import argparse
import runpy
import sys
from pathlib import Path

import pytest

SCRIPTS = Path(__file__).resolve().parents[1] / "scripts"


class _Captured(Exception):
    pass


def _parser_of(script: Path, monkeypatch) -> argparse.ArgumentParser | None:
    """The parser the script builds, caught when it parses (no script body runs)."""
    captured = []

    def capture(self, args=None, namespace=None):
        captured.append(self)
        raise _Captured

    monkeypatch.setattr(argparse.ArgumentParser, "parse_args", capture)
    monkeypatch.setattr(sys, "argv", [str(script)])
    try:
        runpy.run_path(str(script), run_name="__main__")
    except (_Captured, SystemExit):
        pass
    return captured[0] if captured else None


@pytest.mark.parametrize("script", sorted(SCRIPTS.glob("*.py")), ids=lambda p: p.stem)
def test_every_option_says_what_it_is_and_its_default(script, monkeypatch):
    parser = _parser_of(script, monkeypatch)
    if parser is None:
        pytest.skip(f"{script.name} takes no options")
    assert not parser.allow_abbrev, f"{script.name} takes abbreviated options"
    formatter = parser.formatter_class(parser.prog)
    for action in parser._actions:
        if not action.option_strings or action.help == argparse.SUPPRESS or isinstance(action, argparse._HelpAction):
            continue
        name = action.option_strings[-1]
        assert action.help, f"{script.name} {name} has no help text"
        shown = formatter._get_help_string(action).lower()  # the help line as --help prints it
        if action.default not in (None, False, [], (), argparse.SUPPRESS):
            assert "default" in shown, f"{script.name} {name} does not name its default {action.default!r}"
        assert shown.count("default:") <= 1, f"{script.name} {name} names its default twice: {shown!r}"
