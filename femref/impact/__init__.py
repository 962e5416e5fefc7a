"""Impact scenes: cars in a line joined by couplers, each car modelled at its own fidelity.

:mod:`.scene` holds the resolved scene, :mod:`.cars` the car models stepped in time,
:mod:`.solver` the coupled time stepping with Newton on the coupler forces.
"""
