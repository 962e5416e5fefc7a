"""The readable impact loop, in Python: the oracle the compiled loop (:mod:`femref.impact.kernels.loop`) is held to.

:func:`solve_reference` steps the Python cars (:mod:`.cars`) and couplers (:mod:`.couplers`)
as :func:`femref.impact.solve_impact` steps the compiled ones (its docstring: the method, the
status of a failed step, the energy bookkeeping).
"""

from __future__ import annotations

import time as _time
from typing import Callable

import numpy as np
from numpy.typing import NDArray

from femref.core.timegrid import output_steps, steps_to
from femref.fem import INTEGRATORS
from femref.impact.couplers import CouplerConvergenceError
from femref.impact.response import ImpactResponse, failure_message, sensor_histories
from femref.impact.systems import CarSystem
from femref.scene import ImpactScene

from .cars import CarModel, reference_car
from .couplers import CouplerSolve


def initial_end_loads(scene: ImpactScene) -> NDArray[np.float64]:
    """End loads ``(F1, F2)`` of every car at t = 0, ``(n_cars, 2)`` (N): the couplers' forces at zero
    closure and the initial closure rates (a dashpot engaged at contact pushes from the start)."""
    couplers = CouplerSolve(scene, dt=1.0)  # the step does not enter the forces at t = 0
    couplers.start(_closure_rates(scene, couplers))
    return couplers.loads(couplers.force)


def _closure_rates(scene: ImpactScene, couplers: CouplerSolve) -> NDArray[np.float64]:
    velocity = np.array([car.velocity for car in scene.cars])
    return velocity[couplers.rear] - velocity[couplers.front]


def reference_cars(scene: ImpactScene, systems: list[CarSystem], dt: float) -> list[CarModel]:
    """The Python steppers of ``systems`` (:func:`femref.impact.cars.reference_car`) at t = 0, under
    the initial end loads."""
    integrator = INTEGRATORS[scene.integrator](scene.rho_inf)
    loads = initial_end_loads(scene)
    return [reference_car(system, integrator, dt, car.velocity, loads[i]) for i, (system, car) in enumerate(zip(systems, scene.cars))]


def step_reference(
    scene: ImpactScene, cars: list[CarModel], dt: float, progress: Callable[[int, int], None] | None = None
) -> ImpactResponse:
    """The readable loop: step the Python ``cars`` (:func:`reference_cars`) from contact (t = 0) to
    ``scene.end``; a step that fails ends the run with ``status = −1`` (module docstring)."""
    started = _time.perf_counter()
    couplers = CouplerSolve(scene, dt)
    couplers.start(_closure_rates(scene, couplers))
    steps = steps_to(scene.end, dt)
    outputs = output_steps(steps, scene.output_stride)
    out = _Recorder(scene, dt * outputs)
    out.record(0, cars, couplers)
    k = 1
    iterations = [0]
    changes = 0
    status, message = 0, "reached the end time"
    for step in range(1, steps + 1):
        predictions = [car.predict() for car in cars]
        previous_modes = couplers.modes
        try:
            iterations.append(couplers.solve(predictions))
        except CouplerConvergenceError as error:
            name = scene.couplers[error.coupler].name
            status = -1
            message = failure_message(name, step, steps, dt, error.detail)
            break
        changes += int(np.count_nonzero(couplers.modes != previous_modes))
        for car, loads in zip(cars, couplers.loads(couplers.force)):
            car.advance(loads)
        if k < outputs.size and step == outputs[k]:
            out.record(k, cars, couplers)
            k += 1
            if progress is not None:
                progress(step, steps)
    response = out.response()
    response.status, response.message = status, message
    response.steps = step if status == 0 else step - 1
    response.newton_iterations = int(np.sum(iterations))
    response.newton_iterations_max = int(np.max(iterations))
    response.contact_changes = changes
    response.car_settings = [car.car_settings() for car in cars]
    response.wall_time = _time.perf_counter() - started
    return response


class _Recorder:
    """Preallocated output histories on the output ``times``, filled at the output steps (NaN until then)."""

    def __init__(self, scene: ImpactScene, times: NDArray[np.float64]) -> None:
        self.scene = scene
        self.time = np.asarray(times, dtype=float)
        n_out = self.time.size
        channels = len(scene.channels)
        self.displacement, self.velocity, self.acceleration = (np.full((n_out, channels), np.nan) for _ in range(3))
        self.couplers = {c.name: {"force": np.full(n_out, np.nan), "closure": np.full(n_out, np.nan)} for c in scene.couplers}
        names = ("kinetic", "strain", "body_dissipated", "coupler_stored", "coupler_dissipated")
        self.energy = {name: np.full(n_out, np.nan) for name in names}
        self.coupler_work = np.full(n_out, np.nan)

    def record(self, k: int, cars: list[CarModel], couplers: CouplerSolve) -> None:
        for name in self.energy:
            self.energy[name][k] = 0.0
        column = 0
        for car in cars:
            seen = car.observe()
            rows = slice(column, column + seen.displacement.size)
            self.displacement[k, rows], self.velocity[k, rows], self.acceleration[k, rows] = seen.displacement, seen.velocity, seen.acceleration
            column = rows.stop
            self.energy["kinetic"][k] += seen.energy.kinetic
            self.energy["strain"][k] += seen.energy.strain
            self.energy["body_dissipated"][k] += seen.energy.dissipated
        for j, c in enumerate(self.scene.couplers):
            self.couplers[c.name]["force"][k] = couplers.force[j]
            self.couplers[c.name]["closure"][k] = couplers.closure[j]
        self.energy["coupler_stored"][k] = float(np.sum(couplers.stored))
        self.energy["coupler_dissipated"][k] = float(np.sum(couplers.dissipated))
        self.coupler_work[k] = float(np.sum(couplers.work))

    def response(self) -> ImpactResponse:
        energy = dict(self.energy)
        energy["total"] = sum(energy.values())
        sensors = sensor_histories(self.scene.channels, self.displacement, self.velocity, self.acceleration)
        return ImpactResponse(self.time, sensors, self.couplers, energy, coupler_work=self.coupler_work)


def solve_reference(
    scene: ImpactScene, systems: list[CarSystem], dt: float, progress: Callable[[int, int], None] | None = None
) -> ImpactResponse:
    """:func:`femref.impact.solve_impact` by the readable loop: :func:`step_reference` over :func:`reference_cars`."""
    return step_reference(scene, reference_cars(scene, systems, dt), dt, progress)
