"""How ``eomc --help`` and ``eomc COMMAND --help`` read: written for the person at the terminal.

Why a module: argparse's ArgumentDefaultsHelpFormatter appends "(default: None)" to every
option, including required ones and flags, which reads as if ``--t-final`` were optional.
The formatter below shows a default only when there is one worth reading, and marks required
options as required.
"""
import argparse

__all__ = ["DESCRIPTION", "EPILOG", "OptionHelp"]

DESCRIPTION = """\
eomc compiles equations of motion to C and runs them.  MODEL is a model file (.py: a SymPy
mechanics System or KanesMethod), a URDF robot (.urdf), a MuJoCo model (.xml) or a
directory written by `eomc build`."""

EPILOG = """\
examples:
  eomc simulate examples/double_pendulum.py --t-final 10 -o traj.csv --plot traj.png
  eomc build robot.urdf --floating-base --frame tool0 -o out
  eomc simulate out --t-final 5 --x0 q_shoulder=0.3
  eomc animate examples/double_pendulum.py --t-final 10 -o anim.html

Each command's options: eomc COMMAND --help.  The guide: README.md; references: docs/."""


def _silent(default):
    """Defaults that say nothing a reader needs: "(default: None)", "(default: False)", "(default: ())"."""
    return default is None or default is False or (isinstance(default, (tuple, list)) and not default)


class OptionHelp(argparse.HelpFormatter):
    """Each option's help with its default when it has a meaningful one, "(required)" when it
    must be given."""

    def _get_help_string(self, action):
        text = action.help or ""
        if action.required and action.option_strings:
            return f"{text} (required)" if text else "required"
        if "%(default)" in text or action.default is argparse.SUPPRESS:
            return text
        if _silent(action.default):
            return text
        if action.option_strings or action.nargs in (argparse.OPTIONAL, argparse.ZERO_OR_MORE):
            return f"{text} (default: %(default)s)"
        return text
