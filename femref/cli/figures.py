"""``femref figures [-o FOLDER]``: the verification figures (:mod:`femref.verification`)."""

from __future__ import annotations

from pathlib import Path

import click

from femref.cli.common import check_output


@click.command("figures")
@click.option("-o", "--output", "folder", type=click.Path(file_okay=False, path_type=Path), default=Path("docs/figures"), show_default=True, help="folder for the PNG files")
def figures_command(folder: Path) -> None:
    """Regenerate the verification figures: FEM convergence orders, FEM and quasi-rigid vs exact, the ε slope.

    The folder is created if missing (its parent must exist and be writable; the default is
    docs/figures relative to the working folder); PNG files of the same names are replaced.

    Exit codes: 0 written, 2 bad output folder (nothing written).
    """
    defaulted = click.get_current_context().get_parameter_source("folder") == click.core.ParameterSource.DEFAULT
    check_output(folder, "-o", folder=True, default=defaulted)
    from femref.verification import write_figures

    for path in write_figures(folder):
        click.echo(f"wrote {path}")
