"""`eomc --help` and `eomc COMMAND --help` speak to the user: what eomc does and how to start,
no developer wording or RST markup, required options marked required, and no
"(default: None)"-style noise after options that have no default worth reading."""
import re

import pytest

from eomc.cli import SUBCOMMANDS, main


def _help(*argv, capsys):
    with pytest.raises(SystemExit) as info:
        main([*argv, "--help"])
    assert info.value.code == 0
    return capsys.readouterr().out


def test_top_level_help_says_what_eomc_does_and_how_to_start(capsys):
    text = _help(capsys=capsys)
    assert "eomc compiles equations of motion to C" in text
    assert "examples:" in text and "eomc simulate examples/double_pendulum.py" in text
    assert "``" not in text and "dispatcher" not in text and "module per subcommand" not in text
    for name in SUBCOMMANDS:
        assert re.search(rf"^\s+{name}\b", text, re.M), name


@pytest.mark.parametrize("command", sorted(SUBCOMMANDS))
def test_subcommand_help_has_no_markup_and_no_empty_defaults(command, capsys):
    text = " ".join(_help(command, capsys=capsys).split())
    assert "``" not in text
    for noise in ("(default: None)", "(default: ())", "(default: [])", "(default: False)"):
        assert noise not in text, (command, noise)


# (simulate's --t-final and build's -o have defaults since s21: 10 s as check/animate, ./NAME)
@pytest.mark.parametrize("command, option", [("sweep", "--t-final T"), ("sweep", "--cases CSV")])
def test_required_options_are_shown_as_required(command, option, capsys):
    text = _help(command, capsys=capsys)
    entry = text[text.index(f"  {option}"):]
    entry = entry[:re.search(r"\n  -", entry[2:]).start() + 2] if re.search(r"\n  -", entry[2:]) else entry
    assert "(required)" in " ".join(entry.split()), entry


def test_defaults_worth_reading_are_still_shown(capsys):
    text = " ".join(_help("simulate", capsys=capsys).split())
    assert "(default: auto)" in text and "(default: 1e-06)" in text and "(default: 0.0)" in text


@pytest.mark.parametrize("command", sorted(set(SUBCOMMANDS)))
def test_every_subcommand_accepts_quiet(command, capsys):
    assert "-q, --quiet" in _help(command, capsys=capsys)


def test_x0_help_says_others_keep_the_initial_state(capsys):
    text = " ".join(_help("simulate", capsys=capsys).split())
    assert "states not named keep the model's initial_state" in text
    assert "others 0" not in text


def test_inspect_help_says_it_takes_a_built_directory(capsys):
    """inspect reads a built directory's NAME.json (build and show refuse one): its help says so."""
    text = " ".join(_help("inspect", capsys=capsys).split())
    assert "or a directory written by `eomc build` (or its NAME.json): inspected as built" in text
    assert "directory written by" not in " ".join(_help("build", capsys=capsys).split())
