"""femref: verified finite-element reference solver for freight-car impacts.

The solver (scikit-fem rods and beams with Kelvin-Voigt viscosity), its exact
solutions, case files, HDF5 results and the ``femref`` command.
"""

__version__ = "0.1.0"
