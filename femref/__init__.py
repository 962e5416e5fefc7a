"""femref: verified finite-element reference solver for freight-car impacts.

The solver (scikit-fem rods and beams with Kelvin-Voigt viscosity), its exact
solutions, case files, HDF5 results and the ``femref`` command. From Python, use
:mod:`femref.api` (``run_case``, ``run_scene``, ``open_result``, ``open_frames``). The
package root holds only the version (docs/design.md §9.1: it sits below every layer), so
``import femref`` and ``femref --help`` stay light.
"""

__version__ = "0.1.0"
