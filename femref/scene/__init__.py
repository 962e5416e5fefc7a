"""Resolved scenes: frozen value objects a model reads, built from a validated case by :mod:`.build`.

* :class:`Scene` (:mod:`.single`) — one body, harmonic or transient;
* :class:`ImpactScene`, :class:`Car`, :class:`Coupler`, :class:`ModelRun` (:mod:`.impact`) —
  cars in a line joined by couplers;
* :class:`MeasuredScene` (:mod:`.measured`) — recorded accelerations of such cars.

``from femref.scene.build import scene_from_case`` turns a case into one of them.
"""

from femref.scene.impact import Car, Coupler, ImpactScene, ModelRun
from femref.scene.measured import MeasuredScene
from femref.scene.single import Scene

__all__ = ["Car", "Coupler", "ImpactScene", "MeasuredScene", "ModelRun", "Scene"]
