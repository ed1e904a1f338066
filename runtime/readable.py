"""Reading a user's file: what is not a regular file is refused before it is opened.

A FIFO, a character device (``/dev/zero``) or a socket named as a model, an ``<include>`` or
a mesh would block the reader forever or feed it without end; a directory gives a confusing
error.  One check, before any ``open``: the path (symbolic links followed) must be a
regular file.  A path that does not exist is left to the reader (it says so itself).
"""
import os
import stat

from .errors import ModelFileError

__all__ = ["check_regular_file"]

_KINDS = ((stat.S_ISFIFO, "a FIFO (named pipe)"), (stat.S_ISCHR, "a character device"),
          (stat.S_ISBLK, "a block device"), (stat.S_ISSOCK, "a socket"), (stat.S_ISDIR, "a directory"))


def check_regular_file(path, what="file", where=None, line=None):
    """ModelFileError (at ``where``:``line`` when given, else at ``path``) if ``path`` exists and
    is not a regular file; nothing otherwise."""
    try:
        mode = os.stat(path).st_mode
    except OSError:
        return
    if stat.S_ISREG(mode):
        return
    kind = next((label for test, label in _KINDS if test(mode)), "not a regular file")
    if where is None:
        raise ModelFileError(f"the {what} is {kind}, not a regular file: refused before reading it", str(path))
    raise ModelFileError(f"the {what} {path} is {kind}, not a regular file: refused before reading it",
                         str(where), line)
