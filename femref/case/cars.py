"""The ``cars`` of an impact case: rods in line order (a rod with a bending stiffness is also a beam on the
same axis), their initial velocities, accelerometers and coupler offsets."""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import Annotated, Any

from pydantic import AfterValidator, Field, ValidationInfo, field_validator
from pydantic_core import PydanticCustomError

from femref.case.bodies import CarBody
from femref.case.errors import Problem, problems_error
from femref.case.fields import CaseModel, ProbeName, Real, duplicates, name_rule
from femref.case.plausibility import plausible

__all__ = ["CarName", "CarSpec"]


CarName = Annotated[str, AfterValidator(name_rule("car"))]


class CarSpec(CaseModel):
    """One car: a rod body (longitudinal impact) that may also bend, its initial velocity, its accelerometers
    and how far below the body's neutral axis its couplers act."""

    name: CarName = Field(description="Car name, unique; letters, digits, '_', '-', '.'. Probes are named <car>/<sensor>. Required.")
    body: CarBody = Field(
        description="The car body: a rod (type: rod) as in transient cases, any profiles; with bending_stiffness (and "
        "bending_viscosity) also a beam on the same axis. Required."
    )
    velocity: Annotated[Real, plausible("velocity")] = Field(description="Initial velocity (m/s), finite, positive toward the front of the line (+x). Required.")
    sensors: dict[ProbeName, Real] = Field(
        default_factory=lambda: {"center": 0.0},
        description="Accelerometers: name → position x (m) within [−l, l]; at least one. Default {center: 0}.",
    )
    coupler_offset: tuple[Real, Real] = Field(
        default=(0.0, 0.0),
        description="Height of the body's neutral axis above the coupler line at its rear (−l) and front (+l) end (m): "
        "a coupler force there also bends the car (end moment offset × force). Needs bending_stiffness unless both are 0. Default [0, 0].",
    )

    @field_validator("coupler_offset", mode="after")
    @classmethod
    def _offset_needs_bending(cls, value: tuple[float, float], info: ValidationInfo) -> tuple[float, float]:
        body = info.data.get("body")
        if body is not None and not body.bends and any(h != 0.0 for h in value):
            raise problems_error([Problem((), "a coupler offset bends the car: give the body a bending_stiffness (or offsets [0, 0])", list(value))])
        l = body.half_length if body is not None else None  # noqa: E741
        if l is not None and any(abs(h) > l for h in value):
            raise problems_error([Problem((), f"must be shorter than the car's half-length l = {l} m", list(value))])
        return value

    @field_validator("body", mode="wrap")
    @classmethod
    def _a_rod(cls, value: Any, handler: Callable[[Any], Any]) -> Any:
        """Refuse beams before checking their keys: an impact car is loaded along its axis."""
        if isinstance(value, Mapping):
            if "type" not in value:
                raise problems_error([Problem(("type",), "required key is missing; impact cars are rods (type: rod)")])
            if value["type"] == "beam":
                rule = "impact cars are rods (type: rod); a car that bends is a rod with bending_stiffness (and bending_viscosity)"
                raise problems_error([Problem(("type",), rule, "beam")])
        return handler(value)

    @field_validator("sensors", mode="after")
    @classmethod
    def _sensors_on_the_car(cls, value: dict[str, float], info: ValidationInfo) -> dict[str, float]:
        if not value:
            raise PydanticCustomError("sensors_empty", "must name at least one sensor (or be left out for {default})", {"default": "{center: 0}"})
        body = info.data.get("body")
        if body is None:
            return value
        l = body.half_length  # noqa: E741
        rule = f"must lie on the car, |x| <= l = {l} m (within [{-l}, {l}])"
        problems = [Problem((name,), rule, x) for name, x in value.items() if abs(x) > l]
        if problems:
            raise problems_error(problems)
        return value


def cars_rule(what: str) -> Callable[[tuple[Any, ...]], tuple[Any, ...]]:
    """A validator of ``cars``: at least two cars (``what`` needs them), unique names."""

    def check(cars: tuple[Any, ...]) -> tuple[Any, ...]:
        if len(cars) < 2:
            raise problems_error([Problem((), f"{what} needs at least 2 cars, in line order (rear to front); got {len(cars)}")])
        problems = duplicates([car.name for car in cars], "car", lambda i: (i, "name"))
        if problems:
            raise problems_error(problems)
        return cars

    return check
