"""One home per coupler law: the registry, the compiled form, the generic dispatcher and its cache.

* validation refuses a law without a compiled form, naming the key path and the rule;
* a toy law defined here — a spring with a cubic hardening term and a dashpot, one module of
  plain functions and one class, registered in a fresh process — is compiled by the generic
  dispatcher of :mod:`femref.impact.kernels.laws` and agrees with its dataclass methods (an
  independent check: the engine names no law);
* numba's on-disk cache serves a second process, and an edit of the law's source is not served
  stale: the engine's stamp hashes the laws' sources (:func:`femref.impact.kernels.engine_stamp`).
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path
from typing import ClassVar

import pytest
from pydantic import ValidationError

import femref
from femref.case.couplers import COUPLER_LAW_SPECS, CouplerLawSpec
from femref.case.errors import problems_from
from femref.case.fields import CaseModel, PositiveReal, tagged_union
from reduced.couplers import COUPLER_LAWS, OPERATIONS, PackedLaw, compiled_form_rule

REPO = Path(femref.__file__).resolve().parents[1]


@dataclass(frozen=True)
class Uncompiled(PackedLaw):
    """A law whose module (this test module) defines none of the law functions."""

    stiffness: float

    def pack(self) -> tuple[list[float], list[list[float]]]:
        return [self.stiffness], []


class UncompiledLaw(CouplerLawSpec):
    """The schema class of :class:`Uncompiled`."""

    tag: ClassVar[str] = "uncompiled"
    law: ClassVar[type] = Uncompiled
    stiffness: PositiveReal

    def build(self) -> Uncompiled:
        return Uncompiled(self.stiffness)


class Holder(CaseModel):
    """A coupler's ``law`` key, with the toy schema class among the registry's."""

    law: tagged_union({**COUPLER_LAW_SPECS, "uncompiled": UncompiledLaw}, "coupler law")  # type: ignore[valid-type]


def test_every_registered_law_has_a_compiled_form():
    assert set(COUPLER_LAWS) == {"kelvin_voigt", "power_law", "standard_linear", "draft_gear", "table"}
    assert all(compiled_form_rule(law) is None for law in COUPLER_LAWS.values())
    assert all(spec.law in COUPLER_LAWS.values() for spec in COUPLER_LAW_SPECS.values())


def test_validation_refuses_a_law_without_a_compiled_form():
    data = {"law": {"uncompiled": {"stiffness": 1.0e7}}}
    with pytest.raises(ValidationError) as raised:
        Holder.model_validate(data)
    (problem,) = problems_from(raised.value, data)
    assert problem.key_path == "law.uncompiled"
    assert problem.rule.startswith(f"law Uncompiled has no compiled form: its module {__name__} lacks the plain functions {', '.join(OPERATIONS)}")
    assert Holder.model_validate({"law": {"kelvin_voigt": {"stiffness": 1.0e7}}}).law.build().stiffness == 1.0e7


TOY_LAW = '''
"""A toy coupler law: ``P = c δ + c3 δ³ + μ δ̇``, on ``p = [c, c3, μ]``."""

from dataclasses import dataclass

from reduced.couplers import PackedLaw


def piece(p, table, closure, state, strict):
    return 0


def force(p, table, closure, rate, state, piece):
    return p[0] * closure + p[1] * closure**3 + p[2] * rate


def state_rate(p, table, closure, rate, state, transmitted, piece):
    return 0.0


def tangent(p, table, closure, rate, state, transmitted, piece):
    return p[0] + 3.0 * p[1] * closure**2, p[2], 0.0, 0.0, 0.0, 0.0, 0.0


def stored_energy(p, table, closure, state, engaged, piece):
    return 0.5 * p[0] * closure**2 + 0.25 * p[1] * closure**4 if engaged else 0.0


def dissipation_rate(p, table, closure, rate, state, transmitted, engaged, piece):
    return p[2] * rate**2 if engaged else 0.0


@dataclass(frozen=True)
class ToySpring(PackedLaw):
    stiffness: float
    cubic: float
    damping: float

    @property
    def reference_stiffness(self):
        return self.stiffness

    def pack(self):
        return [self.stiffness, self.cubic, self.damping], []


LAW = ToySpring
NAMES = ("toy_spring",)
'''

PROBE = '''
import json, sys
import numpy as np
sys.path.insert(0, sys.argv[1])
import toy_spring
from reduced.couplers import COUPLER_LAWS, Coupling
COUPLER_LAWS["toy_spring"] = toy_spring.LAW  # registered before the engine is built
from femref.impact.kernels import coupling as C, engine_stamp, laws as L
law = toy_spring.ToySpring(4.0e7, 2.0e10, 3.0e5)
coupling = Coupling(law, "bilateral")
packed = L.pack_laws([coupling, Coupling(law)])
rows = []
for closure, rate in [(0.01, 0.5), (-0.02, 1.0), (0.05, -2.0), (0.0, 0.0)]:
    got, want = C.evaluate(packed, 0, closure, rate, 0.0), coupling.evaluate(closure, rate)
    rows.append([got[0], want.force, got[3], want.tangent.force_closure, got[4], want.tangent.force_rate,
                 C.stored_energy_of(packed, 0, closure, 0.0, True), law.stored_energy(closure, np.zeros(0), True),
                 C.dissipation_rate_of(packed, 0, closure, rate, 0.0, 0.0, True), law.dissipation_rate(closure, rate, np.zeros(0), 0.0, True)])
print(json.dumps({"rows": rows, "kind": int(packed.kind[0]), "modules": len(L.LAW_MODULES), "stamp": engine_stamp(),
                  "hits": sum(C.evaluate.stats.cache_hits.values()), "misses": sum(C.evaluate.stats.cache_misses.values())}))
'''


def probe(directory: Path) -> dict:
    """Run :data:`PROBE` in a fresh process with the toy law of ``directory`` and numba's cache there."""
    env = {**os.environ, "NUMBA_CACHE_DIR": str(directory / "cache"), "PYTHONPATH": os.pathsep.join([str(REPO), str(REPO / "tests")])}
    done = subprocess.run([sys.executable, "-c", PROBE, str(directory)], env=env, capture_output=True, text=True, timeout=600, check=False)
    assert done.returncode == 0, done.stderr[-3000:]
    return json.loads(done.stdout.strip().splitlines()[-1])


def test_a_toy_law_compiles_by_the_generic_dispatcher_and_its_edits_are_never_served_stale(tmp_path: Path):
    """The toy law of one module and one class runs compiled and equals its methods; a second process takes the
    compiled engine from numba's cache; after an edit of the law's source the engine compiles afresh."""
    toy = tmp_path / "toy_spring.py"
    toy.write_text(TOY_LAW)
    first = probe(tmp_path)
    assert first["kind"] == first["modules"] - 1  # the toy is the last registered module
    for got_force, force, *rest in first["rows"]:
        assert got_force == pytest.approx(force, rel=1e-15, abs=0.0)
        for a, b in zip(rest[::2], rest[1::2]):
            assert a == pytest.approx(b, rel=1e-15, abs=1e-300)
    assert first["misses"] == 1 and first["hits"] == 0
    second = probe(tmp_path)
    assert second["rows"] == first["rows"] and second["stamp"] == first["stamp"]
    assert second["hits"] == 1 and second["misses"] == 0  # served from the cache
    toy.write_text(TOY_LAW.replace("p[1] * closure**3 + p[2] * rate", "2.0 * p[1] * closure**3 + p[2] * rate"))
    edited = probe(tmp_path)
    assert edited["stamp"] != first["stamp"] and edited["misses"] == 1  # compiled afresh, not served stale
    closure = 0.01
    assert edited["rows"][0][0] == pytest.approx(first["rows"][0][0] + 2.0e10 * closure**3, rel=1e-12)
    assert edited["rows"][0][0] == edited["rows"][0][1]  # the methods and the compiled form run the same source
