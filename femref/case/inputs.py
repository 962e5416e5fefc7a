"""The files a validated case reads: every file path it names, by the key path that names it.

The commands protect them as inputs: an output may not overwrite one (``femref.cli.common.check_output``).
:func:`case_inputs` walks the validated model, so a file path field added later is protected without a change here.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

from pydantic import BaseModel

from femref.case.errors import KeyPath, format_key_path
from femref.case.fields import TaggedSpec

__all__ = ["case_inputs", "field_models"]


def case_inputs(case: BaseModel, base_dir: Path | None = None) -> dict[str, Path]:
    """Every file path of the validated ``case`` by its key path (``records[0].file``, ``loads.F2.csv.path``), in
    the order of the case; a relative path (a model built without a loader) resolved against ``base_dir`` (default:
    the working folder)."""
    found: dict[str, Path] = {}
    _walk(case, (), found)
    base = Path.cwd() if base_dir is None else Path(base_dir)
    return {key: path if path.is_absolute() else base / path for key, path in found.items()}


def _walk(value: Any, at: KeyPath, found: dict[str, Path]) -> None:
    """Collect the :class:`~pathlib.Path` values under ``value`` (at key path ``at``) into ``found``."""
    if isinstance(value, Path):
        found[format_key_path(at)] = value.expanduser()
    elif isinstance(value, BaseModel):
        if isinstance(value, TaggedSpec):  # written {tag: {fields…}} in the case file
            at = (*at, value.tag)
        for name in type(value).model_fields:
            _walk(getattr(value, name), (*at, name), found)
    elif isinstance(value, Mapping):
        for key, item in value.items():
            _walk(item, (*at, str(key)), found)
    elif isinstance(value, (list, tuple)):
        for index, item in enumerate(value):
            _walk(item, (*at, index), found)


def field_models(case: Any) -> list[str]:
    """The models of the validated ``case`` that write field files beside its result file: ``fem`` with ``fem.fields: true``."""
    fem = getattr(case, "fem", None)
    models = getattr(case, "models", ()) or ()
    return ["fem"] if getattr(fem, "fields", False) and "fem" in models else []
