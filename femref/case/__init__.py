"""Case files (docs/design.md §3): the YAML schema of a scene, its validation and its resolved form.

>>> from femref.case import load_case, resolved_yaml
>>> case = load_case("cases/rod_harmonic.yaml")          # doctest: +SKIP
>>> case.body.profiles()["stiffness"], case.omega()     # doctest: +SKIP

Every bad input raises :class:`CaseError` (a ``ValueError``) naming the file, the key
path, the rule and the value; several problems come in one error, one per line.
"""

from femref.case.errors import CaseError, Problem
from femref.case.impact import ImpactCase
from femref.case.kinds import CASE_KINDS, Case
from femref.case.loader import load_case, parse_case, resolved_yaml
from femref.case.single import HarmonicCase, TransientCase

__all__ = [
    "CASE_KINDS",
    "Case",
    "CaseError",
    "HarmonicCase",
    "ImpactCase",
    "Problem",
    "TransientCase",
    "load_case",
    "parse_case",
    "resolved_yaml",
]
