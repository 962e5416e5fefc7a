"""Resolved scenes: frozen value objects a model reads, built from a validated case by
:func:`femref.scene.build.scene_from_case`, so that the models never see YAML or pydantic."""

from femref.scene.impact import Car, Coupler, ImpactScene, ModelRun
from femref.scene.measured import MeasuredScene
from femref.scene.single import Scene

__all__ = ["Car", "Coupler", "ImpactScene", "MeasuredScene", "ModelRun", "Scene"]
