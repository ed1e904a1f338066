"""Errors eomc raises on purpose.  Each message is written for the user.

Every class derives from :class:`EomcError`; the ones about bad values also
derive from ``ValueError`` so ordinary ``except ValueError`` code keeps working.
The CLI prints these as one plain line, without a traceback.
"""

__all__ = [
    "EomcError",
    "ModelError",
    "ModelFileError",
    "CompilerNotFoundError",
    "CompileError",
    "SimulationError",
    "MissingExtraError",
    "EomcWarning",
    "EomcNote",
    "BuildNote",
    "DefaultStartWarning",
    "SingularStartWarning",
    "GimbalLockWarning",
]


class EomcError(Exception):
    """Base class of every error eomc raises deliberately."""


class ModelError(EomcError, ValueError):
    """The mechanics description is inconsistent (bodies, loads, coordinates, constraints)."""


class ModelFileError(EomcError, ValueError):
    """A model file is wrong; the message starts with ``file:line:``."""

    def __init__(self, message, filename=None, lineno=None):
        self.filename, self.lineno, self.detail = filename, lineno, message
        where = ""
        if filename:
            where = f"{filename}:{lineno}: " if lineno else f"{filename}: "
        super().__init__(where + message)


class CompilerNotFoundError(EomcError, RuntimeError):
    """No working C compiler was found."""


class CompileError(EomcError, RuntimeError):
    """The C compiler rejected generated code; the message holds its output and the kept source path."""


class SimulationError(EomcError, RuntimeError):
    """An integration stopped (singular mass matrix, non-finite state, step size underflow, ...)."""


class MissingExtraError(EomcError, ImportError):
    """An optional dependency is not installed; the message names the extra that brings it."""

    def __init__(self, what, extra, modules):
        self.extra = extra
        super().__init__(f"{what} needs {' and '.join(modules)}, which {'is' if len(modules) == 1 else 'are'} "
                         f"not installed: pip install \"eomc[{extra}]\" (from a clone of eomc: "
                         f"pip install \".[{extra}]\")")


class EomcWarning(UserWarning):
    """Something eomc accepted but the user probably did not mean (e.g. every parameter 1.0).

    The ``eomc`` command prints these as one ``eomc CMD: warning: ...`` line.
    """


class EomcNote(EomcWarning):
    """Something eomc did about the input that the user need not act on (links welded to the
    ground whose inertia is impossible: ignored, they move nothing).  An EomcWarning, so it is
    recorded, filtered and silenced as one; the ``eomc`` command prints it as one
    ``eomc: note: ...`` line, not a warning (first hour s21: ANYmal C's five cameras gave a
    680-character warning on every command)."""


class BuildNote(EomcNote):
    """A note about the model as built (impossible link inertias kept as given: the dynamics
    are fine), said once when the model is built -- the build's metadata keeps it -- and not
    again when a later command reuses the build (first hour s26: ANYmal's 840 characters on
    every simulate, check and animate).  ``details``: lines the note's one line leaves out (each
    kept link's moments and line), printed by ``eomc inspect MODEL``."""
    details = ()


class SingularStartWarning(EomcWarning):
    """The mass matrix is singular (to rounding) at the default start with the file's parameters:
    ``eomc.compile`` says so at the build, naming the speeds nothing resists and, where a body
    lacks inertia, the ``--param`` values that give it some (icub.urdf's head).  A category of its
    own so that the command line, given those parameters, can judge the start again with them
    and stay quiet when they mend it (facade/cli/common.load_model)."""


class GimbalLockWarning(EomcWarning):
    """A URDF's three hinges with axes through one point and no inertia between them (Euler angles
    of one rotation: human.urdf's hips) can reach their gimbal lock within the file's joint ranges;
    the warning gives the narrower ``--param limit_...`` ranges that keep a run clear.  A category
    of its own so that the command line, given such ranges, judges the locks again with them
    (facade/cli/common.load_model)."""


class DefaultStartWarning(EomcWarning):
    """The default start is not the file's zero pose: ``eomc.compile`` of a URDF whose joint
    ranges exclude 0 starts those joints just inside their nearest limit (Go2's knees), and
    says so naming each joint, its range and the value it starts at.

    Why a warning category and not a log record: it is shown once by default (a log record
    below WARNING is not shown at all unless logging is configured), and it can be silenced
    alone, ``warnings.filterwarnings("ignore", category=eomc.errors.DefaultStartWarning)``,
    or turned into an error in a test suite, as numpy's and scikit-learn's own categories are.
    The joints are also in ``model.metadata["start_in_range"]``; the ``eomc`` command prints a
    note instead (``eomc: note: ...``), leaving out the joints ``--x0`` gives."""
