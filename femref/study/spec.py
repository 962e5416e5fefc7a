"""The network study file: which impacts to simulate, which networks to train on them, how to score them.

A study answers the source study's question with the FEM as ground truth: *can a network
trained on simulated impacts estimate the peak coupler force from acceleration records,
and does it matter which model generated the training data?* (issue 5, docs/formulas.md §C).

Its keys and their defaults: docs/design.md §6.4.

Every set is a sweep (:mod:`femref.sweep`) of the base case over the shared ``parameters``,
with the set's own ``parameters`` replacing or adding key paths. ``train`` is required: each
of its ``models`` is a training source (a network per source and per entry of
``networks``, trained on that model's records and that model's peak force). Every other
set is an evaluation set and must run ``fem``: the networks and the inverse estimators
are scored on its fem records against its fem peak force.

Networks that train with scikit-learn need the optional extra ``femref[train]``, checked when the study
file is validated (:func:`training_dependency_problems`).
"""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Any, Literal, get_args

from pydantic import BeforeValidator, Field, TypeAdapter, ValidationError, model_validator
from pydantic_core import PydanticCustomError

from ann.networks import TRAIN_EXTRA
from femref.case.errors import CaseError, Problem, did_you_mean, problems_error, problems_from
from femref.case.loader import read_yaml_file
from femref.case.fields import CaseModel, Count, TaggedSpec, reject_bool, tagged_union
from femref.core.catalog import FIDELITIES

#: The training set's name; every other set is an evaluation set.
TRAIN = "train"


class SetSpec(CaseModel):
    """One sweep of the study: how many samples, the seed, the model runs, extra parameters."""

    samples: Count = Field(description="Samples (random draws) of this set, >= 1. Required.")
    seed: Annotated[int, BeforeValidator(reject_bool), Field(ge=0)] = Field(description="Seed of this set's draws. Required.")
    models: tuple[Literal[FIDELITIES], ...] = Field(  # the car fidelities of the catalog
        default=("fem",), min_length=1, description="Uniform model runs of every sample. Default [fem]."
    )
    parameters: dict[str, Any] = Field(default_factory=dict, description="Key path → distribution, replacing or adding to the shared ones.")


class FeatureSpec(CaseModel):
    """The feature pipeline (:class:`ann.features.FeatureSettings`) minus what the records fix."""

    length: Count = Field(default=50, description="Samples per channel after resampling. Default 50.")
    lowpass: float | None = Field(default=None, gt=0.0, description="Zero-phase low-pass (Hz) before resampling. Default none.")
    spectrum: bool = Field(default=False, description="Append |rfft| magnitudes. Default false.")
    normalise: Literal["none", "peak", "channel_peak"] = Field(default="channel_peak", description="Default channel_peak (log amplitudes).")


#: Hidden units by name (:data:`ann.backprop.UNITS`); scikit-learn's solvers take the first three.
UnitName = Literal["logistic", "tanh", "relu", "linear", "gaussian", "step"]
SKLEARN_UNITS = ("logistic", "tanh", "relu")
UNIT_NAMES: tuple[str, ...] = get_args(UnitName)
#: The solver that trains any unit, a unit per layer, in mini-batches, and from a saved network.
MOMENTUM = "momentum"


def _unit_names(value: Any) -> Any:
    """``activation``: a unit name, or a non-empty list of them (one per layer)."""
    expected = ", ".join(repr(n) for n in UNIT_NAMES[:-1]) + f" or {UNIT_NAMES[-1]!r}"
    if isinstance(value, str):
        if value not in UNIT_NAMES:
            raise PydanticCustomError("unit_name", "{rule}", {"rule": f"must be one of {expected}{did_you_mean(value, UNIT_NAMES)}"})
        return value
    if isinstance(value, (list, tuple)) and value:
        bad = [Problem((i,), f"must be one of {expected}{did_you_mean(v, UNIT_NAMES)}", v) for i, v in enumerate(value) if v not in UNIT_NAMES]
        if bad:
            raise problems_error(bad)
        return tuple(value)
    raise PydanticCustomError("unit_names", "{rule}", {"rule": "must be a unit name or a non-empty list of unit names (one per layer)"})


class MlpSpec(TaggedSpec):
    """A multilayer perceptron: :class:`ann.networks.MLPForceRegressor` (``solver`` sgd, adam,
    lbfgs: scikit-learn) or :class:`ann.networks.MomentumMLP` (``solver: momentum``:
    back-propagation with momentum, ``Δw(k+1) = −η ∂E/∂w + μ Δw(k)``).

    ``activation`` is one unit for every hidden layer, or (momentum only) a list: one unit per
    hidden layer, or one more for the output unit (linear, logistic or tanh; default linear),
    e.g. ``hidden: [70, 5], activation: [tanh, tanh, logistic]``. ``max_iter`` counts epochs for
    momentum. ``batch_size`` (default: the whole training set) and ``initial`` (a saved network
    file, relative to the study file, whose weights and feature pipeline training continues
    from) are momentum only.
    """

    tag = "mlp"
    hidden: tuple[Count, ...] = Field(default=(200, 21), min_length=1)
    activation: Annotated[str | tuple[str, ...], BeforeValidator(_unit_names)] = "logistic"
    solver: Literal["sgd", "adam", "lbfgs", "momentum"] = "lbfgs"
    alpha: float = Field(default=0.1, ge=0.0)
    learning_rate: float = Field(default=1e-3, gt=0.0)
    momentum: float = Field(default=0.9, ge=0.0, lt=1.0)
    max_iter: Count = 3000
    batch_size: Count | None = None
    initial: str | None = None
    seed: Annotated[int, BeforeValidator(reject_bool), Field(ge=0)] = 0

    @model_validator(mode="after")
    def _solver_can_train_it(self) -> "MlpSpec":
        problems = []
        if self.solver == MOMENTUM:
            from ann.backprop import layer_units  # numpy only

            try:
                layer_units(self.hidden, self.activation)
            except ValueError as error:
                problems.append(Problem(("activation",), str(error), _plain(self.activation)))
        else:
            units = ", ".join(SKLEARN_UNITS)
            if not isinstance(self.activation, str):
                rule = f"a unit per layer needs solver: momentum; {self.solver} (scikit-learn) takes one of {units} for every hidden layer"
                problems.append(Problem(("activation",), rule, _plain(self.activation)))
            elif self.activation not in SKLEARN_UNITS:
                rule = f"{self.activation} units need solver: momentum; {self.solver} (scikit-learn) takes {units}"
                problems.append(Problem(("activation",), rule, self.activation))
            for key in ("batch_size", "initial"):
                if getattr(self, key) is not None:
                    problems.append(Problem((key,), f"{key} needs solver: momentum (got solver: {self.solver})", getattr(self, key)))
        if problems:
            raise problems_error(problems)
        return self

    def build(self) -> Any:
        if self.solver == MOMENTUM:
            from ann.networks import MomentumMLP

            return MomentumMLP(
                hidden=self.hidden, activation=self.activation, learning_rate=self.learning_rate, momentum=self.momentum,
                epochs=self.max_iter, batch_size=self.batch_size, alpha=self.alpha, seed=self.seed, log_target=True,
            )
        from ann.networks import MLPForceRegressor

        return MLPForceRegressor(
            hidden=self.hidden, activation=self.activation, solver=self.solver, alpha=self.alpha,
            learning_rate=self.learning_rate, momentum=self.momentum, max_iter=self.max_iter, seed=self.seed, log_target=True,
        )


def _plain(value: Any) -> Any:
    return list(value) if isinstance(value, tuple) else value


class RbfSpec(TaggedSpec):
    """:class:`ann.networks.RBFNetwork` settings."""

    tag = "rbf"
    centres: Annotated[int, Field(ge=2)] = 120
    basis: Literal["gaussian", "multiquadric", "inverse_quadratic", "inverse_multiquadric"] = "gaussian"
    width_factor: float = Field(default=8.0, gt=0.0)
    ridge: float = Field(default=1e-6, ge=0.0)
    seed: int = 0

    def build(self) -> Any:
        from ann.networks import RBFNetwork

        return RBFNetwork(centres=self.centres, basis=self.basis, width_factor=self.width_factor, ridge=self.ridge, seed=self.seed, log_target=True)


NETWORK_SPECS: dict[str, type[TaggedSpec]] = {"mlp": MlpSpec, "rbf": RbfSpec}
NetworkSpec = tagged_union(NETWORK_SPECS, "network")


def training_dependency_available() -> bool:
    """scikit-learn can be imported (the extra ``femref[train]``): found by the import system, not imported (it is
    imported when training starts, :mod:`ann.networks`). False when it is missing or the import system refuses it."""
    import importlib.util

    try:
        return importlib.util.find_spec("sklearn") is not None
    except (ImportError, ValueError):  # refused by a finder; or sys.modules["sklearn"] is None / has no spec
        return False


def training_dependency_problems(networks: dict[str, Any]) -> list[Problem]:
    """A problem per network of ``networks`` that trains with scikit-learn when scikit-learn is not installed:
    an MLP with ``solver`` sgd, adam or lbfgs (at ``networks.<name>.mlp.solver``) and an RBF network (its centres
    by k-means; at ``networks.<name>.rbf``). ``solver: momentum`` trains without it (:class:`ann.networks.MomentumMLP`)."""
    needing = {name: spec for name, spec in networks.items() if isinstance(spec, RbfSpec) or (isinstance(spec, MlpSpec) and spec.solver != MOMENTUM)}
    if not needing or training_dependency_available():
        return []
    extra = f"femref[{TRAIN_EXTRA}]"
    install = f"scikit-learn, which is not installed: it is the optional extra {extra} (pip install '{extra}')"
    problems = []
    for name, spec in needing.items():
        if isinstance(spec, MlpSpec):
            rule = f"solver {spec.solver} trains with {install}; or use solver: momentum, which trains without it"
            problems.append(Problem(("networks", name, "mlp", "solver"), rule, spec.solver))
        else:
            problems.append(Problem(("networks", name, "rbf"), f"an RBF network trains (its k-means centres) with {install}"))
    return problems


class StudyFile(CaseModel):
    """A network study (module docstring)."""

    base: str = Field(description="Base impact case file, relative to the study file. Required.")
    base_overrides: dict[str, Any] = Field(default_factory=dict, description="Key path → value applied to the base case once.")
    parameters: dict[str, Any] = Field(default_factory=dict, description="Shared key path → distribution (sweep syntax).")
    sets: dict[str, SetSpec] = Field(description="train (required) and evaluation sets. Required.")
    coupler: str = Field(default="c1", description="The coupler whose peak force is estimated. Default c1.")
    probes: tuple[str, ...] | None = Field(default=None, description="Record channels <car>/<sensor>. Default: every sensor.")
    car_masses: bool = Field(default=True, description="Give the networks the car masses (kg) as inputs. Default true.")
    record_length: Annotated[int, Field(ge=2)] = Field(default=200, description="Samples per stored record. Default 200.")
    force_length: Annotated[int, Field(ge=2)] = Field(default=50, description="Samples per stored force history. Default 50.")
    validation_fraction: float = Field(default=0.15, gt=0.0, lt=0.5, description="Share of train held out to score each network on its own source.")
    features: FeatureSpec = Field(default_factory=FeatureSpec)
    networks: dict[str, NetworkSpec] = Field(min_length=1, description="Name → {mlp: {...}} or {rbf: {...}}. Required.")
    impact_types: bool = Field(
        default=False,
        description="Train one network per impact type (free_to_roll, coupled; each record classified by the zero harmonic of "
        "the coupler's relative acceleration) and read each evaluation record with its type's network. Default false.",
    )

    @model_validator(mode="after")
    def _sets(self) -> "StudyFile":
        problems = []
        if TRAIN not in self.sets:
            problems.append(Problem(("sets",), f"a study needs a {TRAIN!r} set (the training sources)"))
        if len(self.sets) < 2:
            problems.append(Problem(("sets",), "a study needs at least one evaluation set besides train"))
        for name, spec in self.sets.items():
            if name != TRAIN and "fem" not in spec.models:
                problems.append(Problem(("sets", name, "models"), "an evaluation set is scored against fem; add fem", list(spec.models)))
        problems += training_dependency_problems(self.networks)  # checked now, not when training starts after the sweeps
        if self.impact_types:
            for name, network in self.networks.items():
                if getattr(network, "initial", None) is not None:
                    problems.append(Problem(("networks", name, "mlp", "initial"), "impact_types trains a network per type from scratch; "
                                            "continue one from a saved network in a study without impact_types"))
        if problems:
            raise problems_error(problems)
        return self

    @property
    def evaluation_sets(self) -> list[str]:
        return [name for name in self.sets if name != TRAIN]

    def scaled(self, fraction: float) -> "StudyFile":
        """A quick version: every set's ``samples`` and every RBF network's ``centres`` times ``fraction``.

        (At least 1 sample and 2 centres.) The centres scale with the training set: an RBF
        network needs fewer centres than training samples.
        """
        sets = {name: s.model_copy(update={"samples": max(1, round(s.samples * fraction))}) for name, s in self.sets.items()}
        networks = {
            name: n.model_copy(update={"centres": max(2, round(n.centres * fraction))}) if isinstance(n, RbfSpec) else n
            for name, n in self.networks.items()
        }
        return self.model_copy(update={"sets": sets, "networks": networks})


_STUDY_ADAPTER: TypeAdapter[StudyFile] = TypeAdapter(StudyFile)


def load_study(path: str | Path) -> tuple[StudyFile, Path]:
    """Read and validate a study file; returns it and its directory. Raises :class:`CaseError`."""
    path = Path(path)
    data = read_yaml_file(path, "study")
    return parse_study(data, source=str(path)), path.parent


def parse_study(data: Any, *, source: str = "<study>") -> StudyFile:
    """Validate parsed study YAML. Raises :class:`CaseError` naming the key path."""
    if not isinstance(data, dict):
        raise CaseError(Problem((), "a study file must be a mapping of keys (base, parameters, sets, networks, ...)", data), source)
    try:
        return _STUDY_ADAPTER.validate_python(data)
    except ValidationError as error:
        raise CaseError(problems_from(error, data), source) from None


__all__ = [
    "MOMENTUM", "SKLEARN_UNITS", "TRAIN", "FeatureSpec", "MlpSpec", "RbfSpec", "SetSpec", "StudyFile", "load_study", "parse_study",
    "training_dependency_available", "training_dependency_problems",
]
