"""Where ``package://NAME/...`` files live, found as ROS and Pinocchio find them.

A URDF names its meshes by ROS package (``package://go2_description/meshes/calf.dae``);
copied out of its package it loses them.  The folders searched, in order:

1. the caller's ``package_dirs`` (Pinocchio's name; ``--package-dir`` on the command line);
2. ``ROS_PACKAGE_PATH`` (ROS 1: folders holding packages);
3. ``AMENT_PREFIX_PATH`` (ROS 2: install prefixes, packages under ``share/``);
4. the ``share/`` folder of every ``cmeel.prefix`` on ``sys.path`` (the layout of the
   example-robot-data wheel: ``package://example-robot-data/robots/...``).

In each folder ``D`` the file is ``D/NAME/rest``, or ``D/rest`` when ``D`` is itself the
package (its last component is ``NAME``).
"""
import os
import sys
from pathlib import Path

__all__ = ["package_dirs", "find_package_file", "PACKAGE_HINT"]

PACKAGE_HINT = ("say where its package lives: --package-dir DIR (package_dirs=[DIR] in Python), "
                "ROS_PACKAGE_PATH or AMENT_PREFIX_PATH")


def package_dirs(extra=()):
    """The folders searched for packages, in order (see the module docstring)."""
    out = [str(d) for d in (extra or ())]
    out += [d for d in os.environ.get("ROS_PACKAGE_PATH", "").split(os.pathsep) if d]
    out += [os.path.join(d, "share") for d in os.environ.get("AMENT_PREFIX_PATH", "").split(os.pathsep) if d]
    for entry in sys.path:
        share = os.path.join(entry or ".", "cmeel.prefix", "share")
        if os.path.isdir(share):
            out.append(share)
    return list(dict.fromkeys(out))


def find_package_file(url, extra=()):
    """The file ``package://NAME/rest`` names, or None when no searched folder holds it."""
    if not url.startswith("package://"):
        return None
    name, _, rest = url[len("package://"):].partition("/")
    if not name or not rest:
        return None
    for folder in package_dirs(extra):
        for candidate in (Path(folder) / name / rest, Path(folder) / rest if Path(folder).name == name else None):
            if candidate is not None and candidate.is_file():
                return str(candidate)
    return None
