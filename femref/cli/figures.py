"""``femref figures [-o FOLDER]``: the verification figures (:mod:`femref.verification`)."""

from __future__ import annotations

from pathlib import Path

import click


@click.command("figures")
@click.option("-o", "--output", "folder", type=click.Path(file_okay=False, path_type=Path), default=Path("docs/figures"), show_default=True, help="folder for the PNG files")
def figures_command(folder: Path) -> None:
    """Regenerate the verification figures: FEM convergence orders, FEM and quasi-rigid vs exact, the ε slope."""
    from femref.verification import write_figures

    for path in write_figures(folder):
        click.echo(f"wrote {path}")
