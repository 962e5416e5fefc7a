"""``femref figures [-o FOLDER]``: the verification figures (:mod:`femref.verification`).

Each figure takes seconds to compute: progress is shown per figure, and each PNG is written
(atomically) as soon as its figure is made.
"""

from __future__ import annotations

from pathlib import Path

import click
from rich.console import Console

from femref.cli.common import check_output, model_progress

@click.command("figures")
@click.option("-o", "--output", "folder", type=click.Path(file_okay=False, path_type=Path), default=Path("docs/figures"), show_default=True, help="folder for the PNG files")
def figures_command(folder: Path) -> None:
    """Regenerate the verification figures: FEM convergence orders, FEM and quasi-rigid vs exact, the ε slope.

    The folder is created if missing (its parent must exist and be writable; the default is
    docs/figures relative to the working folder); PNG files of the same names are replaced.
    Progress on stderr: a bar per figure on a terminal, a line when each starts and ends
    with femref --progress.

    Exit codes: 0 written, 2 bad output folder (nothing written).
    """
    defaulted = click.get_current_context().get_parameter_source("folder") == click.core.ParameterSource.DEFAULT
    check_output(folder, "-o", folder=True, default=defaulted)
    for path in write_figures(folder, Console(stderr=True)):
        click.echo(f"wrote {path}")


def write_figures(folder: Path, console: Console) -> list[Path]:
    """Make each figure of :data:`femref.verification.FIGURES` as a stage of :func:`model_progress` on ``console`` and write it as
    ``<folder>/<name>.png`` (atomically: a temporary renamed into place); return the paths written."""
    import femref.verification as verification
    from femref.core.publishing import atomic_path

    folder.mkdir(parents=True, exist_ok=True)
    written = []
    with model_progress(console) as progress_for:
        for name, make in verification.FIGURES:
            progress_for(f"figure {name}")
            figure = make()
            path = folder / f"{figure.name}.png"
            with atomic_path(path) as tmp:
                tmp.write_bytes(figure.png)
            written.append(path)
    return written
