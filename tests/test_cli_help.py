"""``femcal COMMAND --help`` teaches: every command and subcommand has a description and
examples, each example is a command line the parser takes, on files the project ships."""

from __future__ import annotations

import shlex

import pytest

from femcal.cli import build_parser, main
from femcal.cli.examples import EXAMPLES, commands

from .conftest import ROOT

ALL = [" ".join(words) for words, _ in commands(build_parser())]


@pytest.mark.parametrize("command", ALL)
def test_every_command_has_a_description_and_examples(command, capsys):
    with pytest.raises(SystemExit) as e:
        main([*command.split(), "--help"])
    assert e.value.code == 0
    text = capsys.readouterr().out
    _usage, _, rest = text.partition("\n\n")
    description = rest.split("\n\n")[0]
    assert not description.startswith(("positional arguments", "options")), text
    assert len(description.split()) >= 8, description
    examples = text.split("examples:\n")[1].splitlines()
    assert examples and all(e.startswith(f"  femcal {command.split()[0]}") for e in examples)


@pytest.mark.parametrize("line", [e for lines in EXAMPLES.values() for e in lines])
def test_each_example_parses_and_names_shipped_files(line):
    words = shlex.split(line)
    assert words[0] == "femcal"
    build_parser().parse_args(words[1:])  # exits (status 2) on an option it does not take
    for w in words:
        for part in w.split("="):
            if part.startswith("models/"):
                assert (ROOT / part).is_file(), part


def test_the_examples_cover_every_command():
    assert sorted(EXAMPLES) == sorted(ALL)
