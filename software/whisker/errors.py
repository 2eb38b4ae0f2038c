"""One error path for the whole `whisker` CLI: every failure becomes one line and an exit status.

`explain(err)` turns an exception into (exit status, one-line message):

- status 2, bad input: a domain error (every ``...Error`` of this package derives from ValueError,
  or is listed in :data:`BAD_INPUT`), a file that is not text, a path that does not exist, is a
  folder where a file was expected (or the reverse);
- status 1, a fault of the environment: no space left, a read-only or forbidden folder, an I/O
  error, no memory, a camera or optional module that is not there;
- status 1, an internal error (a bug): the line says so and how to get the traceback.

The line says what failed, the path or value, and what to do. ``whisker --debug`` or
``WHISKER_DEBUG=1`` re-raises instead, so the traceback is shown.
"""

from __future__ import annotations

import errno
import os

BAD_INPUT = 2
ENVIRONMENT = 1


# Bases defined here, at the bottom, so that explain() needs none of the modules that raise them.
class BadInput(RuntimeError):
    """The user's input, though not a ValueError (a recording folder that cannot be used): status 2."""


class EnvironmentFault(RuntimeError):
    """The machine's fault, not the input's (a camera that cannot be opened): status 1."""


class BomError(ValueError):
    """The BOM cannot be made for this design (one-line message)."""

#: errno -> (exit status, what to do)
_OS_HINTS = {
    errno.ENOENT: (BAD_INPUT, "check the path"),
    errno.EISDIR: (BAD_INPUT, "give a file, not a folder"),
    errno.ENOTDIR: (BAD_INPUT, "a part of the path is a file, not a folder: choose another path"),
    errno.ENAMETOOLONG: (BAD_INPUT, "use a shorter path"),
    errno.EEXIST: (BAD_INPUT, "choose a path that does not exist yet"),
    errno.ENOTEMPTY: (BAD_INPUT, "choose an empty or new folder"),
    errno.ENOSPC: (ENVIRONMENT, "free some space or write to another disk"),
    errno.EDQUOT: (ENVIRONMENT, "free some space (disk quota exceeded) or write elsewhere"),
    errno.EROFS: (ENVIRONMENT, "the file system is read-only: write to a writable folder"),
    errno.EACCES: (ENVIRONMENT, "no permission: write to a folder you own or fix its permissions"),
    errno.EPERM: (ENVIRONMENT, "operation not permitted: use a folder you own"),
    errno.EIO: (ENVIRONMENT, "input/output error: check the disk or device"),
    errno.EMFILE: (ENVIRONMENT, "too many open files: raise `ulimit -n`"),
}


def debug_requested() -> bool:
    """True when WHISKER_DEBUG is set to something other than '', '0', 'false' or 'no'."""
    return os.environ.get("WHISKER_DEBUG", "").strip().lower() not in ("", "0", "false", "no")


def _one_line(text: str) -> str:
    return " ".join(str(text).split())


def explain(err: BaseException) -> tuple[int, str]:
    """(exit status, one line) for an exception raised by a command."""
    if isinstance(err, OSError):
        code, hint = _OS_HINTS.get(err.errno, (ENVIRONMENT, "check the path and the disk"))
        where = err.filename if err.filename is not None else ""
        if getattr(err, "filename2", None):
            where = f"{where} -> {err.filename2}"
        what = err.strerror or type(err).__name__
        return code, _one_line(f"{where + ': ' if where else ''}{what} ({hint})")
    if isinstance(err, UnicodeError):
        return BAD_INPUT, _one_line(f"input is not UTF-8 text ({err}); give a text file saved as UTF-8")
    if isinstance(err, MemoryError):
        return ENVIRONMENT, "out of memory: make the job smaller (fewer steps, samples or frames)"
    if isinstance(err, (ValueError, BadInput)):
        return BAD_INPUT, _one_line(str(err) or type(err).__name__)
    if isinstance(err, EnvironmentFault):
        return ENVIRONMENT, _one_line(str(err))
    if type(err).__name__ in ("MissingModule", "SimulationError"):
        return ENVIRONMENT, _one_line(str(err))
    return ENVIRONMENT, _one_line(f"internal error ({type(err).__name__}: {err}); rerun with --debug "
                                  "(or WHISKER_DEBUG=1) for the traceback and report it")


def is_internal(message: str) -> bool:
    """True for the line :func:`explain` gives an unexpected exception (a bug, not bad input)."""
    return "internal error (" in message
