"""Dotted key paths into case data (``couplers.0.law.kelvin_voigt.stiffness``): the sweep's rule.

Integer parts index lists; every part but the last must exist, and a list entry must
exist to be replaced. A path that does not lead anywhere raises :class:`PathError`
(a ``LookupError``) whose message is the rule, worded for sweep-file errors.
"""

from __future__ import annotations

import copy
from collections.abc import Mapping
from typing import Any

from femref.case.errors import did_you_mean

__all__ = ["assign_key_path"]


class PathError(LookupError):
    """A key path that does not lead anywhere; the message is the rule."""


def key_parts(path: str) -> tuple[str, ...]:
    return tuple(path.split("."))


def _child(node: Any, part: str, where: str) -> Any:
    """``node[part]`` with integer parts indexing lists; raises :class:`PathError` saying why not."""
    if isinstance(node, list):
        if not part.isdigit():
            raise PathError(f"{where or 'the case'} is a list; index it with an integer 0…{len(node) - 1}, not {part!r}")
        if int(part) >= len(node):
            raise PathError(f"index {part} is out of range; {where} has {len(node)} entries")
        return node[int(part)]
    if isinstance(node, Mapping):
        if part not in node:
            keys = [str(k) for k in node]
            raise PathError(f"no key {part!r} under {where or 'the top level'}{did_you_mean(part, keys)}; keys there: {', '.join(keys)}")
        return node[part]
    raise PathError(f"{where} is a single value ({node!r}), not a mapping or a list")


def parent_of(root: Any, parts: tuple[str, ...]) -> Any:
    """The container that holds the last part of ``parts``, checking that the last part may go there."""
    node = root
    for k, part in enumerate(parts[:-1]):
        node = _child(node, part, ".".join(parts[:k]))
    where = ".".join(parts[:-1])
    if isinstance(node, list):
        _child(node, parts[-1], where)  # a list entry must exist to be replaced
    elif not isinstance(node, Mapping):
        raise PathError(f"{where} is a single value ({node!r}), not a mapping or a list")
    return node


def assign(root: Any, parts: tuple[str, ...], value: Any) -> None:
    node = parent_of(root, parts)
    if isinstance(node, list):
        node[int(parts[-1])] = copy.deepcopy(value)
    else:
        node[parts[-1]] = copy.deepcopy(value)


def assign_key_path(data: Any, path: str, value: Any) -> None:
    """Set ``value`` at the dotted key ``path`` of case data in place (the sweep's rule for key paths).

    Raises LookupError saying why when the path does not lead anywhere.
    """
    assign(data, key_parts(path), value)
