"""What a model is: a name and any of three forms, one per way a scene uses it.

* ``harmonic(scene) -> ModelResult`` — a single body's frequency response;
* ``transient(scene, progress) -> ModelResult`` — a single body under end-load histories;
* ``car(car, scene, dt) -> CarSystem`` — one car of an impact as the linear system the
  impact solver steps (:mod:`femref.impact.systems`), stepped by :func:`femref.impact.solve_impact`.

A model that lacks a form cannot serve that scene kind; which kinds each model serves
is :data:`femref.core.catalog.MODELS`, and a test holds the two together. The runner
(:mod:`femref.run`) times every call and records a failure as the model's status.

A model with the car form is a car fidelity (:class:`CarFidelity`): its module also says at
what step its cars run, what they cost and at which resolutions the model choice and the
bench run them, so the time step, the work budget, the ladder, the bench and the validity
checks loop over the fidelities and name none.
"""

from __future__ import annotations

import math
import sys
from collections import OrderedDict
from dataclasses import dataclass
from typing import TYPE_CHECKING, Callable, ClassVar, Hashable, Protocol, TypeVar

if TYPE_CHECKING:
    from femref.core.body import Body
    from femref.impact.systems import CarSystem
    from femref.scene import Car, ImpactScene

Progress = Callable[[int, int], None]
"""``progress(done, total)`` steps, called at output steps."""

ProgressFor = Callable[[str], "Progress | None"]
"""``progress_for(stage)`` → the stage's :data:`Progress` callback, or None: the progress hook of a run of several
stages (models of a scene, events of a measured case, estimators being calibrated), called when each starts
(``femref.cli.common.model_progress`` supplies it)."""

#: The method a model offers for each scene kind.
FORMS: dict[str, str] = {"harmonic": "harmonic", "transient": "transient", "impact": "car"}


class Model(Protocol):
    """A model: its catalog name; the forms it offers are plain methods (module docstring)."""

    name: str


@dataclass(frozen=True)
class CarCost:
    """One car's share of an impact run of ``steps`` steps, ``setup + steps · step`` µs on the machine that fitted
    the costs (:meth:`CarFidelity.cost`), and the bytes of its matrices; ``dofs`` the mesh DOFs it steps (0: none),
    ``meshed`` when the case's ``fem.elements`` sizes it."""

    setup: float
    step: float
    memory: float = 0.0
    dofs: int = 0
    meshed: bool = False


@dataclass(frozen=True)
class Resolution:
    """One resolution a fidelity runs at, a rung of the model choice's ladder or a row of the bench: ``label``,
    the ``setting`` varied and its ``value`` (``""`` and NaN when none), the ``scene`` at it, and its step: the
    automatic step of ``step_scene`` (default ``scene``) × ``scale[0]/scale[1]``, its rule read as ``rule``
    with ``{rule}`` the automatic one."""

    label: str
    scene: ImpactScene
    setting: str = ""
    value: float = math.nan
    step_scene: ImpactScene | None = None
    scale: tuple[float, float] = (1.0, 1.0)
    rule: str = "{rule}"


class CarFidelity(Protocol):
    """What a car modelled at one fidelity is, steps at, costs and is refined to (module docstring); the defaults
    are those of a car without a mesh (rigid, quasi-rigid): no step of its own, a constant cost, one resolution.

    ``setup_us``, ``step_us`` are its fitted cost coefficients (:meth:`cost`); ``expansion_order`` the term of the
    low-frequency expansion in ``ε = (T_wave/T_load)²`` it carries up to (rigid 0, quasi-rigid 1: the two consecutive
    terms estimate each other's error, :func:`femref.choice.estimates.asymptotic_errors`), None when it is no term of
    it; ``range_limit`` the local ``ε_loc`` of its end loads above which a car is outside its range
    (:mod:`femref.run.validity`), None when it has none.
    """

    name: str
    setup_us: tuple[float, ...]
    step_us: tuple[float, ...]
    expansion_order: ClassVar[int | None] = None
    range_limit: ClassVar[float | None] = None

    def car(self, car: Car, scene: ImpactScene, dt: float) -> CarSystem:
        """The car as the system the impact solver steps."""
        ...

    def step_candidates(self, car: Car, scene: ImpactScene, elements: int, speed: Callable[[Body], float]) -> dict[str, float]:
        """The car's candidate steps, rule → s, on ``elements`` elements if it has a mesh, ``speed(body)`` a body's
        largest wave speed (:func:`femref.run.timestep.impact_candidates`)."""
        return {}

    def cost_regressors(self, car: Car, scene: ImpactScene) -> tuple[tuple[float, ...], tuple[float, ...]]:
        """``(x_setup, x_step)``, what ``setup_us`` and ``step_us`` multiply (:meth:`cost`)."""
        return (1.0,), (1.0,)

    def matrices(self, car: Car, scene: ImpactScene) -> tuple[float, int, bool]:
        """``(memory, dofs, meshed)`` of :class:`CarCost`."""
        return 0.0, 0, False

    def cost(self, car: Car, scene: ImpactScene) -> CarCost:
        """``½ s·x_setup``, ``½ t·x_step`` (``s, t = setup_us, step_us``, :meth:`cost_regressors`): a car's half of a
        two-car run, the one cost model of the work budget and the model choice's ladder.

        The coefficients are fitted by ``benchmarks/fit_ladder_costs.py`` (its docstring: the runs, the fit and how
        well it predicts); re-run it when the build or the stepping changes. No bending car was fitted: one costs as
        its rod.
        """
        x_setup, x_step = self.cost_regressors(car, scene)
        setup = sum(s * x for s, x in zip(self.setup_us, x_setup, strict=True))
        step = sum(t * x for t, x in zip(self.step_us, x_step, strict=True))
        return CarCost(0.5 * setup, 0.5 * step, *self.matrices(car, scene))

    def rungs(self, scene: ImpactScene, mesh_dofs: int | None) -> list[Resolution]:
        """Its ladder rungs, coarsest first, each the Richardson partner of the one before (``mesh_dofs``: the
        smallest car's mesh DOFs when known without a mesh, else None)."""
        return [Resolution(self.name, scene)]

    def bench(self, scene: ImpactScene) -> list[Resolution]:
        """Its bench rows."""
        return [Resolution(self.name, scene)]


T = TypeVar("T")

_BUILT: OrderedDict[Hashable, object] = OrderedDict()
BUILT_CAPACITY = 64
"""How many built cars (operators, modes, coefficients) are kept for reuse."""


def built_once(key: Hashable, build: Callable[[], T]) -> T:
    """``build()``, or what an earlier call with an equal ``key`` built (least recently used first out).

    The models key a car by its body's geometry (:attr:`femref.core.body.Body.geometry`), its
    sensor positions and their own settings, so the runs of a scene, of a sweep, a study,
    the bench or the choice ladder assemble, factorise and reduce each car once per process.
    What is built is shared: it must not be changed.
    """
    try:
        hash(key)
    except TypeError:  # a profile that cannot be a key is built every time
        return build()
    if key in _BUILT:
        _BUILT.move_to_end(key)
        return _BUILT[key]  # type: ignore[return-value]
    value = build()
    _BUILT[key] = value
    if len(_BUILT) > BUILT_CAPACITY:
        _BUILT.popitem(last=False)
    return value


def forget_built() -> None:
    """Drop every kept build: the next run of any geometry builds its cars afresh (what a benchmark
    times when it compares a cold run with a tool that keeps nothing between runs) — with what is kept per
    mesh or car size, the assembly's sparsity patterns and the pool's layouts. What stays is one per process
    and family, as a tool's code stays loaded: the compiled kernels, the reference-element tables."""
    _BUILT.clear()
    for module, forget in (("femref.fem.reference", "forget_patterns"), ("femref.impact.kernels.packing", "forget_layouts")):
        if module in sys.modules:  # a module never imported has kept nothing (and numba is not imported for it)
            getattr(sys.modules[module], forget)()
