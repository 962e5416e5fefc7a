"""What femref reads of an HDF5 file a user names: a regular file, objects stored in it, sizes known first.

An HDF5 file can make its reader read elsewhere or allocate without bound, and h5py follows it
silently:

- an **external link** opens another file (any path the file names) and a **soft link** may point
  anywhere in the file or at itself (a loop is a traceback deep in the library);
- a dataset with **external raw storage** (``H5Pset_external``) reads its bytes from any file the
  dataset names (``/etc/passwd`` reads as numbers);
- a **virtual dataset** maps the slices of datasets in other files, and a source that is missing
  reads as the fill value, without a word;
- a chunk **filter** the library cannot decode (Blosc, an unregistered id) fails on read, and one
  it skips (an optional filter) reads the fill value;
- a dataset's **declared shape** is free: a few kB of compressed chunks may declare gigabytes.

A femref reader therefore takes only hard-linked objects (:func:`hard_link`, :func:`members`), reads
a dataset only after :func:`check_plain_dataset` (stored in the file, contiguous, chunked or
compact, filters from :data:`DECODED_FILTERS` only, at most a given number of values, of the
kinds it expects), and opens only what :func:`check_regular_file` passes (not a FIFO, which blocks
the open forever, nor a device or directory; a symlink loop named as such). Each check raises
:class:`HDF5ObjectError` with a message naming the object and the rule; the reader prefixes the
file.
"""

from __future__ import annotations

import math
import os

import h5py

from femref.core.files import NotRegularFile, regular_file

#: Chunk filters read here: the ones HDF5 itself defines and h5py's LZF (id → name).
DECODED_FILTERS: dict[int, str] = {
    h5py.h5z.FILTER_DEFLATE: "deflate (gzip)",
    h5py.h5z.FILTER_SHUFFLE: "shuffle",
    h5py.h5z.FILTER_FLETCHER32: "fletcher32",
    h5py.h5z.FILTER_SZIP: "szip",
    h5py.h5z.FILTER_NBIT: "nbit",
    h5py.h5z.FILTER_SCALEOFFSET: "scaleoffset",
    h5py.h5z.FILTER_LZF: "lzf",
}

#: Largest HDF5 chunk (bytes, unpacked; 64 MiB): a chunk is unpacked whole whatever part of it is read (h5py's own
#: chunks are at most 1 MiB).
MAX_CHUNK_BYTES = 2**26

#: Names of a few registered filters femref does not read, for the message.
_KNOWN_OTHERS: dict[int, str] = {307: "bzip2", 32001: "blosc", 32004: "lz4", 32008: "bitshuffle", 32015: "zstd"}


class HDF5ObjectError(ValueError):
    """An HDF5 file or object femref refuses to read: the message names the object and the rule."""


def check_regular_file(path: str | os.PathLike, max_bytes: int | None = None) -> int:
    """The size (bytes) of ``path``, a regular file (symlinks followed, :func:`femref.core.files.regular_file`) of at
    most ``max_bytes``; :class:`HDF5ObjectError` otherwise."""
    try:
        found = regular_file(path)
    except FileNotFoundError:
        raise HDF5ObjectError("not found") from None
    except NotRegularFile as error:
        raise HDF5ObjectError(f"{error} (refused unopened)") from None
    except OSError as error:
        raise HDF5ObjectError(f"cannot be read: {error.strerror or error}") from None
    if max_bytes is not None and found.st_size > max_bytes:
        raise HDF5ObjectError(f"holds {found.st_size} bytes, more than the {max_bytes} bytes this file may hold (refused unread)")
    return found.st_size


def hard_link(group: h5py.Group, name: str) -> h5py.Group | h5py.Dataset:
    """The object ``group[name]`` when ``name`` is a hard link (an object stored in this file); :class:`HDF5ObjectError`
    for a missing member, a soft or an external link (unfollowed)."""
    path = f"{group.name.rstrip('/')}/{name}"
    link = group.get(name, getlink=True)
    if link is None:
        raise HDF5ObjectError(f"{path} is missing")
    if isinstance(link, h5py.ExternalLink):
        raise HDF5ObjectError(f"{path} is an external link to {link.path} in the file {link.filename}: "
                              "only objects stored in this file are read (refused unfollowed)")
    if isinstance(link, h5py.SoftLink):
        raise HDF5ObjectError(f"{path} is a soft link to {link.path}: only hard links are read (refused unfollowed)")
    return group[name]


def members(group: h5py.Group, max_members: int) -> dict[str, h5py.Group | h5py.Dataset]:
    """Every member of ``group`` by name, each a hard link (:func:`hard_link`), at most ``max_members`` of them
    (counted before any is listed)."""
    count = group.id.get_num_objs()
    if count > max_members:
        raise HDF5ObjectError(f"{group.name} has {count} members, more than {max_members} (refused unread)")
    return {name: hard_link(group, name) for name in group.keys()}


def check_plain_dataset(dataset: h5py.Dataset, max_values: int, kinds: str = "fiu") -> None:
    """``dataset`` is stored in its own file and may be read: not virtual, no external raw storage, every chunk
    filter in :data:`DECODED_FILTERS` and available in this HDF5 build, a declared size of at most ``max_values``
    values, of a numpy dtype kind in ``kinds`` (default real numbers: float, signed and unsigned integers), chunks
    of at most :data:`MAX_CHUNK_BYTES` unpacked. Nothing is read."""
    where = dataset.name
    if dataset.is_virtual:
        raise HDF5ObjectError(f"{where} is a virtual dataset (its data live in other files; a missing one reads as "
                              "the fill value): only data stored in this file are read (refused unread)")
    if dataset.external:
        files = ", ".join(str(entry[0]) for entry in dataset.external)
        raise HDF5ObjectError(f"{where} keeps its raw data in external file(s) {files}: only data stored in this file are read (refused unread)")
    plist = dataset.id.get_create_plist()
    for k in range(plist.get_nfilters()):
        code = plist.get_filter(k)[0]
        if code not in DECODED_FILTERS or not h5py.h5z.filter_avail(code):
            name = DECODED_FILTERS.get(code) or _KNOWN_OTHERS.get(code, "unknown")
            readable = ", ".join(name for c, name in DECODED_FILTERS.items() if h5py.h5z.filter_avail(c))
            raise HDF5ObjectError(f"{where} is stored through chunk filter {code} ({name}); femref reads only {readable} (refused unread)")
    if dataset.dtype.kind not in kinds:
        raise HDF5ObjectError(f"{where} holds values of type {dataset.dtype} (dtype kind {dataset.dtype.kind!r}); "
                              f"expected {_kind_names(kinds)}")
    if dataset.chunks is not None:
        chunk_bytes = math.prod(dataset.chunks) * dataset.dtype.itemsize
        if chunk_bytes > MAX_CHUNK_BYTES:
            raise HDF5ObjectError(f"{where} has chunks {dataset.chunks} that unpack to {chunk_bytes / 2**20:.4g} MiB each; a chunk "
                                  f"may hold at most {MAX_CHUNK_BYTES // 2**20} MiB (refused unread)")
    declared = math.prod(dataset.shape) if dataset.shape is not None else 0
    if declared > max_values:
        raise HDF5ObjectError(f"{where} declares shape {dataset.shape}, {declared} values, more than the {max_values} it may hold (refused unread)")


def _kind_names(kinds: str) -> str:
    names = {"f": "floating-point", "i": "integer", "u": "unsigned integer", "b": "boolean", "S": "byte-string", "U": "text"}
    return " or ".join(names.get(kind, kind) for kind in kinds) + " values"


__all__ = ["DECODED_FILTERS", "HDF5ObjectError", "check_plain_dataset", "check_regular_file", "hard_link", "members"]
