"""The case kinds: the ``kind:`` key of a case file, the one module that knows every kind."""

from collections.abc import Mapping
from typing import Annotated, Union

from pydantic import Field

from femref.case.base import SceneCase
from femref.case.impact import ImpactCase
from femref.case.measured import MeasuredCase
from femref.case.single import HarmonicCase, TransientCase

__all__ = ["CASE_KINDS", "Case"]

#: Case kinds by case-file name.
CASE_KINDS: Mapping[str, type[SceneCase]] = {
    "harmonic": HarmonicCase,
    "transient": TransientCase,
    "impact": ImpactCase,
    "measured": MeasuredCase,
}

#: Any case, discriminated on ``kind``.
Case = Annotated[Union[HarmonicCase, TransientCase, ImpactCase, MeasuredCase], Field(discriminator="kind")]  # noqa: UP007
