"""HDF5 files written so that a failing write (a full disk, a quota, an I/O error) ends in one clean ``OSError``.

After a write fails, the HDF5 library (2.0, through h5py's default driver) leaves its caches
inconsistent: on a full disk ``femref run`` printed a traceback per object it released
("Exception ignored in h5py._objects.ObjectID.__dealloc__ … errno = 28") and then crashed in
``H5Fclose`` with SIGSEGV, never reaching an ``error:`` line. :func:`hdf5_writer` keeps the
library from ever seeing a failure: every write goes through Python (h5py's file-object driver,
as fast as the default one for femref's files), the first failing one is recorded and the rest
dropped, so the library closes a file it believes whole, and the recorded error is raised then.
Within :func:`femref.core.publishing.atomic_path` it is noted with the final path it did not
reach (:func:`~femref.core.publishing.note_output`).
"""

from __future__ import annotations

import contextlib
import io
import os
from collections.abc import Iterator
from pathlib import Path
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    import h5py


@contextlib.contextmanager
def hdf5_writer(temporary: str | Path, mode: str = "w") -> Iterator[h5py.File]:
    """``h5py.File(temporary, mode)`` (``w``: created anew; ``r+``/``a``: an existing file extended), whose first
    failing write is recorded and raised as that ``OSError`` (naming ``temporary``) once the file is closed
    (module docstring); an error the dropped writes caused meanwhile (a read back) comes out as the recorded one."""
    import h5py

    temporary = Path(temporary)
    stream = _RecordingStream(temporary, truncate=mode in ("w", "w-", "x") or (mode == "a" and not temporary.exists()))
    try:
        with h5py.File(stream, mode) as h5:
            yield h5
    except Exception as error:  # a failure the dropped writes caused (a read back) is the recorded one's
        stream.close()
        if stream.failure is not None:
            raise stream.failure from error
        raise
    except BaseException:
        stream.close()
        raise
    stream.close()
    if stream.failure is not None:
        raise stream.failure


class _RecordingStream(io.RawIOBase):
    """The file :func:`hdf5_writer` gives h5py: reads and writes go to ``path``; the first failing write (or
    truncate, or close) is kept in ``failure`` and every later write is dropped as if done."""

    def __init__(self, path: Path, truncate: bool) -> None:
        super().__init__()
        self.path = path
        self.failure: OSError | None = None
        self.file = open(path, "w+b" if truncate else "r+b", buffering=0)

    def readable(self) -> bool:
        return True

    def writable(self) -> bool:
        return True

    def seekable(self) -> bool:
        return True

    def seek(self, offset: int, whence: int = os.SEEK_SET) -> int:
        return self.file.seek(offset, whence)

    def tell(self) -> int:
        return self.file.tell()

    def readinto(self, buffer) -> int:
        return self.file.readinto(buffer)

    def write(self, data) -> int:
        size = memoryview(data).nbytes
        if self.failure is None:
            try:
                view, done = memoryview(data).cast("B"), 0
                while done < size:  # a raw write may write part (a disk filling up)
                    done += self.file.write(view[done:])
                return size
            except OSError as error:
                self._record(error)
        self.file.seek(size, os.SEEK_CUR)
        return size

    def truncate(self, size: int | None = None) -> int:
        if self.failure is None:
            try:
                return self.file.truncate(size)
            except OSError as error:
                self._record(error)
        return self.tell() if size is None else size

    def flush(self) -> None:
        pass  # unbuffered

    def close(self) -> None:
        if not self.file.closed:
            try:
                self.file.close()  # where a network file system reports a failed write
            except OSError as error:
                self._record(error)
        super().close()

    def _record(self, error: OSError) -> None:
        if self.failure is None:
            self.failure = error if error.filename else OSError(error.errno, error.strerror, str(self.path))


__all__ = ["hdf5_writer"]
