"""A sample's case derived from the sweep's validated base case by substitution of its values at their key paths.

    case(sample) = base case with value_k at path_k (k in parameter order), then the sample's noise seed

Only what a substitution can break is validated again: the branch of each substituted key path — the whole
top-level value (``time``, ``measurement``), or one entry of a top-level list (``cars.0``, ``couplers.1``) — and
every rule of the case's top level (those that join branches: couplers between neighbouring cars, model
overrides naming cars). Every other branch enters as the validated model it is (pydantic keeps an instance
as given). A rule of a model only sees its own fields, so the rules that involve a substituted field are those
of the models on its key path, all of which are validated again. The result equals a parse of the whole
substituted case (``tests/sweep/test_derive.py``); a substitution that breaks a rule raises the same
:class:`~femref.case.CaseError`, with the key path and the rule.
"""

from __future__ import annotations

import copy
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from pydantic import BaseModel, ValidationError

from femref.case import CaseError, ImpactCase, Problem
from femref.case.errors import problems_from
from femref.sweep.keypaths import PathError, assign, key_parts, parent_of

__all__ = ["SubstitutionError", "derive_case", "substituted_branches", "substituted_data"]


class SubstitutionError(PathError):
    """A key path that does not lead anywhere in this sample: ``path``, and the rule as the message."""

    def __init__(self, path: str, rule: str) -> None:
        super().__init__(rule)
        self.path = path


def substituted_branches(base: ImpactCase, base_data: Mapping[str, Any], substitutions: Mapping[str, Any]) -> dict[str, Any]:
    """The top-level branches the substitutions touch, as data with the values assigned; a top-level list keeps its
    untouched entries as the base case's validated models. Raises :class:`SubstitutionError`."""
    branches: dict[str, Any] = {}
    for path, value in substitutions.items():
        parts = key_parts(path)
        top = parts[0]
        try:
            if top not in base_data:
                parent_of(base_data, parts)  # the rule with the keys there (a new top-level key: validation's)
            elif top not in branches:
                branches[top] = list(getattr(base, top)) if isinstance(base_data[top], list) else copy.deepcopy(base_data[top])
            branch = branches.get(top)
            if len(parts) > 2 and isinstance(branch, list) and parts[1].isdigit() and int(parts[1]) < len(branch):
                entry = int(parts[1])
                if isinstance(branch[entry], BaseModel):
                    branch[entry] = copy.deepcopy(base_data[top][entry])
            assign(branches, parts, value)
        except PathError as error:
            raise SubstitutionError(path, str(error)) from None
    return branches


def derive_case(base: ImpactCase, base_data: Mapping[str, Any], substitutions: Mapping[str, Any], base_dir: Path, source: str) -> ImpactCase:
    """The base case with ``substitutions`` (key path → value, in order) applied and validated (module docstring).

    ``base_data`` is ``base`` as resolved data (``base.model_dump(mode="json")``), read only. Raises
    :class:`CaseError` from ``source``: a key path that does not lead anywhere in this sample (under
    ``parameters.<path>``), or the rule a substituted value breaks (under the case's key path)."""
    try:
        branches = substituted_branches(base, base_data, substitutions)
    except SubstitutionError as error:
        raise CaseError(Problem(("parameters", error.path), f"{error} in this sample"), source) from None
    data = {name: getattr(base, name) for name in type(base).model_fields}
    data.update(branches)
    try:
        return type(base).model_validate(data, context={"base_dir": base_dir})
    except ValidationError as error:
        raise CaseError(problems_from(error, data), source) from None


def substituted_data(base_data: Mapping[str, Any], substitutions: Mapping[str, Any]) -> dict[str, Any]:
    """The whole case as data with ``substitutions`` assigned (what ``femref run`` of the sample reads). Raises
    :class:`SubstitutionError`."""
    data = copy.deepcopy(dict(base_data))
    for path, value in substitutions.items():
        try:
            assign(data, key_parts(path), value)
        except PathError as error:
            raise SubstitutionError(path, str(error)) from None
    return data
