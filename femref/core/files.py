"""Files a user names are regular files: the rule every reader applies before it opens one.

A FIFO (named pipe) blocks the reader until a writer comes, which may be never; a device
(``/dev/zero``, ``/dev/urandom``) has no size and never ends; a folder or a socket is no
file at all. :func:`regular_file` ``stat``\\ s the path (symbolic links followed) and refuses
anything but a regular file before a byte is read, and names a loop of symbolic links as such
instead of the operating system's "too many levels of symbolic links".
"""

from __future__ import annotations

import errno
import os
import stat
from pathlib import Path

__all__ = ["NotRegularFile", "regular_file"]

#: What a path that is not a regular file is, by ``stat`` test.
_KINDS = (
    (stat.S_ISFIFO, "a FIFO (named pipe)"),
    (stat.S_ISCHR, "a character device"),
    (stat.S_ISBLK, "a block device"),
    (stat.S_ISSOCK, "a socket"),
    (stat.S_ISDIR, "a folder"),
)


class NotRegularFile(ValueError):
    """A path that is not a regular file, or a loop of symbolic links; the message says which (``"is not a regular
    file but a FIFO (named pipe)"``) without the path, for the caller to name it as its messages do."""


def regular_file(path: str | Path) -> os.stat_result:
    """``os.stat(path)`` (symbolic links followed) of a regular file.

    Raises :class:`NotRegularFile` for anything else (a FIFO, a device, a socket, a folder) and for a loop
    of symbolic links, ``FileNotFoundError`` for a missing path (a dangling link included), ``OSError``
    for a path that cannot be ``stat``\\ ed. Nothing is opened.
    """
    try:
        status = os.stat(path)
    except OSError as error:
        if error.errno == errno.ELOOP:
            raise NotRegularFile("is a loop of symbolic links (each points on to the next and none to a file)") from None
        raise
    if not stat.S_ISREG(status.st_mode):
        kind = next((name for test, name in _KINDS if test(status.st_mode)), "some other kind of file")
        raise NotRegularFile(f"is not a regular file but {kind}")
    return status
