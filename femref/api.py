"""The Python API: run a case and read its result file without the command line.

A thin layer over the flow ``femref run`` drives (:func:`femref.flow.plan_case`, :func:`femref.flow.run_plan`),
plus readers of the result file (docs/design.md §4) into labelled arrays, and :func:`run_fleet`, ``femref fleet``'s
run of a fleet manifest into its event store.

>>> from femref.api import run_case, open_result
>>> outcome = run_case("cases/impact_free_roll.yaml", output="free_roll.h5")   # doctest: +SKIP
>>> outcome.scores["rigid"]["coupler_force_peak_error_c1"]                     # doctest: +SKIP
>>> fem = open_result("free_roll.h5", "fem")                                   # doctest: +SKIP
>>> fem["force"].sel(coupler="c1").max()                                      # doctest: +SKIP

:func:`open_result` (xarray) and :func:`open_frames` (pandas) read the datasets by their paths with h5py,
so they read every femref result file, with or without HDF5 dimension scales. A measured case's event file is read
by :func:`open_events` (its table: one row per event × estimator × coupler) and :func:`open_event_histories` (one
event's records and force histories):

>>> events = open_events("yard.h5")                                            # doctest: +SKIP
>>> events[events.above_alarm_limit][["event", "estimator", "peak_force_N"]]   # doctest: +SKIP
>>> open_event_histories("yard.h5", 1)["force"].sel(estimator="kalman")        # doctest: +SKIP

Nothing here prints.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any

from femref.events import FileKindError, attribute_value
from femref.results import AXIS_NAMES
from femref.core.publishing import OutputPathError
from femref.flow import plan_case, run_plan
from femref.models import ProgressFor
from femref.run import RunOutcome, run_scene

if TYPE_CHECKING:  # the readers' return types; neither library is needed to run a case
    import pandas
    import xarray

__all__ = ["FileKindError", "OutputPathError", "RunOutcome", "check_run_output", "open_event_histories", "open_events", "open_frames", "open_result",
           "result_models", "run_case", "run_fleet", "run_scene"]

#: The extra that installs what :func:`open_result` and :func:`open_frames` need.
READ_EXTRA = "femref[xarray]"

#: The axis datasets a model group may hold (``/<model>/<axis>``), the first present is the index.
AXES = ("time", "omega")


def run_case(case: str | Path | Mapping[str, Any], output: str | Path | None = None, *, base_dir: str | Path | None = None,
             tolerance: float | None = None, progress_for: ProgressFor | None = None) -> Any:
    """Validate a case and run it as ``femref run`` does, deciding its flow once.

    Parameters
    ----------
    case : str, Path or Mapping
        A case file's path, or its parsed mapping.
    output : str or Path, optional
        Also write the result file, atomically: the file ``femref run -o output`` writes.
    base_dir : str or Path, optional
        Folder that resolves a mapping's relative file paths (CSV profiles, networks, records); default the
        working directory. A case file's own folder is used for a path.
    tolerance : float, optional
        Overrides the case's ``tolerance:`` as ``--tolerance`` does (impact cases only).
    progress_for : callable, optional
        ``progress_for(label)`` → a progress callback per model, rung or event, or None.

    Returns
    -------
    femref.run.RunOutcome
        A simulated case: every model's result (a failed model is a result with ``status == "failed"`` and its
        message) and the scores against the reference.
    femref.choice.ModelChoice
        An impact case with a tolerance: the ladder climbed, every run made (``.results``), the ``chosen``
        model and whether it ``met`` the tolerance.
    femref.run.measured.MeasuredOutcome
        A measured case: the records as read, the event search and every event (``.events``); with
        ``output`` the events are streamed to the file and kept as summaries (read their histories from the
        file), without it they keep their histories.

    Raises
    ------
    femref.case.CaseError
        Bad input, a tolerance on a case that is not an impact, runs over the work budget: before any work.
    femref.core.publishing.OutputPathError
        An ``output`` that ``femref run -o`` would refuse (:func:`check_run_output`), before any work.
    femref.sensing.recordings.RecordError
        A measured case's record changed since validation.
    RuntimeError
        A tolerance case in which no rung ran.
    """
    from femref.case import load_case, parse_case

    if isinstance(case, Mapping):
        source = "<mapping>"
        loaded = parse_case(dict(case), source=source, base_dir=Path(base_dir) if base_dir is not None else None)
        folder = Path(base_dir) if base_dir is not None else Path.cwd()
    else:
        source = str(case)
        loaded = load_case(case)
        folder = Path(case).resolve().parent
    plan = plan_case(loaded, folder, source, tolerance)
    if output is not None:
        output = Path(output)
        check_run_output(output, plan.case, None if isinstance(case, Mapping) else Path(case), folder)
    outcome = run_plan(plan, output, progress_for)
    return {"simulate": outcome.run, "choose": outcome.choice, "measure": outcome.measured}[outcome.flow]


def run_fleet(manifest: str | Path, out: str | Path, workers: int | None = None, scheduler: str | None = None) -> Any:
    """Run every recording of a fleet manifest on Dask into its event store, as ``femref fleet`` does.

    Recordings stored ``ok`` and unchanged (their case, their files' sizes and modification times) are skipped;
    the others run, one Dask task each, and their rows are committed to ``<out>/events.sqlite`` one recording at a
    time, their histories written to ``<out>/events/<recording>.h5``. Read the store with
    :func:`femref.fleet.store.read_events` and :func:`femref.fleet.store.read_estimates`.

    Parameters
    ----------
    manifest : str or Path
        The fleet manifest (YAML): defaults, cars, gears and recordings; relative paths from its folder.
    out : str or Path
        The output folder, made if absent (its parent must exist); a rerun into it resumes.
    workers : int, optional
        Worker processes of the local Dask cluster; default one per CPU.
    scheduler : str, optional
        Address of a Dask scheduler to run on instead (``tcp://host:8786``); its workers run the same femref.

    Returns
    -------
    femref.fleet.runner.FleetSummary
        Recordings run, skipped and failed (``failures``: name and message; a failed recording is stored
        ``failed`` and the others run), events by type, alarms by level, values and bytes read, wall time and
        throughput (``events_per_second``, ``megabytes_per_second``, ``samples_per_second``).

    Raises
    ------
    femref.case.CaseError
        A bad manifest (every problem named by its manifest key path), before anything is written.
    femref.fleet.store.StoreError
        ``out`` holds a file at ``events.sqlite`` that is not this fleet's event store.
    femref.fleet.runner.FleetInterrupted
        Ctrl-C: the recordings committed stay (its ``summary``); run again to resume.
    """
    from femref.fleet.runner import run_fleet as run

    return run(manifest, out, workers=workers, scheduler=scheduler)


def check_run_output(output: Path, case: Any, case_path: Path | None = None, base_dir: Path | None = None) -> None:
    """Check a result path as ``femref run -o`` does, before any work, and remove stale temporaries.

    The rule is :func:`femref.core.publishing.check_output_path`'s; the field files a run writes beside
    ``output`` may not be inputs either.

    Parameters
    ----------
    output : Path
        The result file to be written.
    case : validated case
        The case whose input files ``output`` may not overwrite.
    case_path : Path, optional
        The case file itself.
    base_dir : Path, optional
        Folder that resolves the case's relative file paths.

    Raises
    ------
    femref.core.publishing.OutputPathError
        A ``ValueError`` naming ``output`` and the rule; nothing is written.

    Warns
    -----
    UserWarning
        A temporary an older femref left that is not certainly unused is kept, and named.
    """
    import warnings

    from femref.case.inputs import case_inputs, field_models
    from femref.results import field_file_paths
    from femref.core.publishing import check_output_path, clean_leftovers

    inputs: dict[str, Path | None] = {"case": case_path}
    inputs.update({f"{key} of the case": path for key, path in case_inputs(case, base_dir).items()})
    check_output_path(output, "output", inputs, writes=field_file_paths(output, field_models(case)))
    for kept, why in clean_leftovers(output).kept:
        warnings.warn(f"kept {kept}: it looks like an older femref's temporary of {output.name}, but {why}; "
                      "remove it yourself if no femref run is writing it", UserWarning, stacklevel=3)


def result_models(path: str | Path) -> list[str]:
    """The model and estimator groups of a result file.

    Parameters
    ----------
    path : str or Path
        A femref result file.

    Returns
    -------
    list of str
        The groups that carry a ``status`` attribute, in file order.
    """
    import h5py

    with h5py.File(path, "r") as h5:
        return [name for name, item in h5.items() if isinstance(item, h5py.Group) and "status" in item.attrs]


def open_result(path: str | Path, model: str | None = None) -> "xarray.Dataset":
    """One model of a result file as an :class:`xarray.Dataset` with its time (or ω) coordinate.

    Parameters
    ----------
    path : str or Path
        A femref result file (read by dataset paths with h5py, with or without dimension scales).
    model : str, optional
        The model group; default ``fem`` when the file has it, else the file's first model.

    Returns
    -------
    xarray.Dataset
        Per probe ``acceleration``, ``displacement``, … ``(time, probe)`` (NaN for a probe without that
        quantity, e.g. the vertical ones on a car that does not bend); per coupler ``force`` ``(time, coupler)``
        (a network estimator's ``peak_force`` has ``(coupler,)`` only); ``energy_<term>`` ``(time,)``; the
        measurement chain's records ``measured_<quantity>`` on their own ``measured_time``; a field ``u``
        ``(field_time, x)``. Each keeps its ``units``. Attributes: ``status``, ``message``, ``wall_time_s``,
        ``settings`` (JSON), ``scores`` (a dict, empty for the reference), ``femref_version`` and ``case_yaml``.

    Raises
    ------
    ImportError
        xarray is missing (the message names the extra to install).
    KeyError
        No such model in the file.
    femref.events.FileKindError
        The file is a measured case's event file (the message points to :func:`open_events`).
    """
    try:
        import xarray as xr
    except ImportError as error:
        raise ImportError(f"femref.api.open_result needs xarray: pip install '{READ_EXTRA}' (or use open_frames with pandas)") from error
    group = _read_model(path, model)
    coords: dict[str, Any] = {}
    variables: dict[str, Any] = {}
    axis = group["axis"]
    if axis is not None:
        coords[axis[0]] = (axis[0], axis[1], {"units": axis[2]})
        coords.update({name: (axis[0], values, {"units": units}) for name, (values, units) in group["along"].items()})
    for family, dim in (("probes", "probe"), ("couplers", "coupler")):
        members = group[family]
        if not members:
            continue
        coords[dim] = list(members)
        for quantity in _quantities(members):
            stacked, units, time_dim = _stack(members, quantity, axis)
            dims = (time_dim, dim) if time_dim else (dim,)
            variables[quantity] = (dims, stacked, {"units": units} if units else {})
    for name, (values, units) in group["energy"].items():
        variables[f"energy_{name}"] = (_dims_of(values, axis), values, {"units": units} if units else {})
    measured = group["measured"]
    if measured["time"] is not None:
        coords["measured_time"] = ("measured_time", measured["time"][0], {"units": measured["time"][1]})
        probes = measured["probes"]
        coords.setdefault("probe", list(group["probes"]) or list(probes))
        for quantity in _quantities(probes):
            stacked, units, _ = _stack(probes, quantity, ("measured_time", measured["time"][0], ""), names=coords["probe"])
            variables[f"measured_{quantity}"] = (("measured_time", "probe"), stacked, {"units": units} if units else {})
    fields = group["fields"]
    if fields:
        for name, dim in (("time", "field_time"), ("x", "x")):
            if name in fields:
                coords[dim] = (dim, fields[name][0], {"units": fields[name][1]})
        if "u" in fields:
            variables["u"] = (("field_time", "x"), fields["u"][0], {"units": fields["u"][1]})
    return xr.Dataset(variables, coords=coords, attrs=group["attrs"])


def open_frames(path: str | Path) -> dict[str, "pandas.DataFrame"]:
    """Every model of a result file as a :class:`pandas.DataFrame` indexed by its time (or ω) axis.

    Parameters
    ----------
    path : str or Path
        A femref result file.

    Returns
    -------
    dict of str to pandas.DataFrame
        Model name → frame with columns ``probes/<probe>/<quantity>``, ``couplers/<coupler>/force`` and
        ``energy/<term>`` (the file's own paths below the model); ``df.attrs`` holds the status, message, wall
        time, settings and scores. A model's measured records are a frame of their own, ``"<model>/measured"``,
        on their own time axis; a network estimator (a peak force, no history) is a one-row frame of
        ``couplers/<coupler>/peak_force`` without index. Fields (2-D) are left out: read them with
        :func:`open_result`.

    Raises
    ------
    ImportError
        pandas is missing (the message names the extra to install).
    femref.events.FileKindError
        The file is a measured case's event file (the message points to :func:`open_events`).
    """
    try:
        import pandas as pd
    except ImportError as error:
        raise ImportError(f"femref.api.open_frames needs pandas: pip install '{READ_EXTRA}'") from error
    _refuse_event_file(path)
    frames = {}
    for model in result_models(path):
        group = _read_model(path, model)
        axis = group["axis"]
        columns = {}
        for family in ("probes", "couplers"):
            for member, outputs in group[family].items():
                for quantity, (values, _) in outputs.items():
                    columns[f"{family}/{member}/{quantity}"] = values
        columns.update({f"energy/{name}": values for name, (values, _) in group["energy"].items()})
        index = pd.Index(axis[1], name=axis[0]) if axis is not None else None
        frame = pd.DataFrame({k: v for k, v in columns.items() if v.ndim == 1 and (index is None or len(v) == len(index))}, index=index)
        if index is None:
            frame = pd.DataFrame({k: [v.reshape(-1)[0]] for k, v in columns.items() if v.size == 1})
        frame.attrs.update(group["attrs"])
        frames[model] = frame
        measured = group["measured"]
        if measured["time"] is not None:
            records = {f"{probe}/{q}": v for probe, outputs in measured["probes"].items() for q, (v, _) in outputs.items()}
            frames[f"{model}/measured"] = pd.DataFrame(records, index=pd.Index(measured["time"][0], name="time"))
    return frames


def open_events(path: str | Path) -> "pandas.DataFrame":
    """A measured case's event file as a table: one row per event × estimator × coupler.

    Parameters
    ----------
    path : str or Path
        An event file (``femref run`` of a ``kind: measured`` case, or a fleet's ``events/<recording>.h5``).

    Returns
    -------
    pandas.DataFrame
        Columns :data:`femref.events.TABLE_COLUMNS`, in event order: the event (``event``, ``trigger_time_s``,
        ``start_s``, ``end_s``, ``type``, the closing speed and its 95 % interval, ``alarm``, ``wear``, ``flags`` and
        a column each for ``gap``, ``saturated``, ``implausible`` and ``clock_corrected``), the estimate
        (``estimator``, ``coupler``, ``status``, ``peak_force_N`` with its band ``peak_force_lower_N`` /
        ``peak_force_upper_N``, ``time_of_peak_s``, ``above_alarm_limit`` against ``alarm_limit_N``) and the
        coupler's closure (``closure_status``, ``closure_force_N`` …). A unit is in each name (``_s``, ``_N``,
        ``_m_per_s``; none: a ratio or text) and in ``df.attrs["units"]``; ``df.attrs`` also holds the file's
        ``femref_version``, whether it is ``complete`` and its ``events``. An event that ran no estimator
        (``not_an_impact``) is one row with ``estimator`` and ``coupler`` None.

    Raises
    ------
    ImportError
        pandas is missing (the message names the extra to install).
    femref.events.FileKindError
        The file is a simulated result, not an event file (the message points to :func:`open_result`).
    """
    try:
        import pandas as pd
    except ImportError as error:
        raise ImportError(f"femref.api.open_events needs pandas: pip install '{READ_EXTRA}'") from error
    from femref.events import TABLE_COLUMNS, TABLE_UNITS, event_rows

    rows, facts = event_rows(path)
    frame = pd.DataFrame(rows, columns=list(TABLE_COLUMNS))
    frame = frame.astype({"event": "int64", **{flag: "bool" for flag in ("gap", "saturated", "implausible", "clock_corrected", "above_alarm_limit")},
                          **{column: "float64" for column in TABLE_UNITS}})
    frame.attrs.update(facts, units=dict(TABLE_UNITS))
    return frame


def open_event_histories(path: str | Path, event: int) -> "xarray.Dataset":
    """One event of an event file as an :class:`xarray.Dataset`: its records and every estimator's force with its band.

    Parameters
    ----------
    path : str or Path
        An event file (see :func:`open_events`).
    event : int
        The event's index (``open_events(path).event``).

    Returns
    -------
    xarray.Dataset
        ``acceleration`` ``(time, probe)`` (m/s², the records on the event's grid, offsets removed); ``force``,
        ``force_lower``, ``force_upper`` ``(time, estimator, coupler)`` (N, compression positive; NaN where an
        estimator has no number or no band); an estimate on a time axis of its own (a network's peak: one sample)
        is NaN there and given as ``force_<estimator>`` … ``(time_<estimator>, coupler)``;
        ``peak_force``, ``peak_force_lower``, ``peak_force_upper`` and ``status`` ``(estimator, coupler)`` for
        every estimate. Each keeps its ``units``; the event's attributes (type, closing speed, alarm, wear, flags …)
        are the Dataset's.

    Raises
    ------
    ImportError
        xarray is missing (the message names the extra to install).
    femref.events.FileKindError
        The file is not an event file (the message points to :func:`open_result`), or holds no such event (the
        message lists the events it holds).
    """
    try:
        import xarray as xr
    except ImportError as error:
        raise ImportError(f"femref.api.open_event_histories needs xarray: pip install '{READ_EXTRA}'") from error
    import numpy as np

    from femref.events import event_histories

    found = event_histories(path, event)
    time, time_units = found["time"]
    probes = list(found["records"])
    coords: dict[str, Any] = {"time": ("time", time, {"units": time_units}), "probe": probes}
    variables: dict[str, Any] = {}
    if probes:
        variables["acceleration"] = (("time", "probe"), np.stack([found["records"][p][0] for p in probes], axis=1),
                                     {"units": found["records"][probes[0]][1]})
    estimates = found["estimates"]
    estimators = list(dict.fromkeys(e for e, _ in estimates))
    couplers = list(dict.fromkeys(c for _, c in estimates))
    if estimates:
        coords.update(estimator=estimators, coupler=couplers)
        shared = [e for e in estimators if all(np.array_equal(d["time"][0], time) for (k, _), d in estimates.items() if k == e)]
        for name in ("force", "force_lower", "force_upper"):
            units = next(iter(estimates.values()))[name][1]
            stacked = np.full((time.size, len(estimators), len(couplers)), np.nan)
            for (e, c), data in estimates.items():
                if e in shared:
                    stacked[:, estimators.index(e), couplers.index(c)] = data[name][0]
            variables[name] = (("time", "estimator", "coupler"), stacked, {"units": units})
            for e in (e for e in estimators if e not in shared):
                own = next(d["time"] for (k, _), d in estimates.items() if k == e)
                coords[f"time_{e}"] = (f"time_{e}", own[0], {"units": own[1]})
                columns = [estimates[(e, c)][name][0] if (e, c) in estimates else np.full(own[0].size, np.nan) for c in couplers]
                variables[f"{name}_{e}"] = ((f"time_{e}", "coupler"), np.stack(columns, axis=1), {"units": units})
        for name, key, units in (("peak_force", "peak_force", "N"), ("peak_force_lower", "peak_lower", "N"), ("peak_force_upper", "peak_upper", "N"),
                                 ("status", "status", "")):
            table = [[estimates[(e, c)]["attrs"].get(key, np.nan) if (e, c) in estimates else (np.nan if units else "") for c in couplers] for e in estimators]
            variables[name] = (("estimator", "coupler"), np.array(table, dtype=float if units else object), {"units": units} if units else {})
    return xr.Dataset(variables, coords=coords, attrs=found["attrs"])


def _refuse_event_file(path: str | Path) -> None:
    """FileKindError naming ``path`` when it is an event file: a reader of simulated results does not read it."""
    import h5py

    from femref.events import is_event_file

    with h5py.File(path, "r") as h5:
        if is_event_file(h5):
            raise FileKindError(f"{path}: the event file of a measured case, not a simulated result: read its table with "
                                "femref.api.open_events and an event's histories with femref.api.open_event_histories")


def _read_model(path: str | Path, model: str | None) -> dict[str, Any]:
    """The arrays and attributes of ``/<model>`` as plain dicts of ``(values, units)``, by the file's paths.

    Probes are nested for impacts (``probes/<car>/<sensor>``): a member is every group below
    ``probes`` (``couplers``, ``measured``) that holds datasets, named by its path there. The
    axis datasets a history group may hold as links to its model's dimension scale (``time``,
    ``omega``, ``lambda``) are coordinates, not outputs, and are skipped there.
    """
    import h5py

    _refuse_event_file(path)
    with h5py.File(path, "r") as h5:
        models = [name for name, item in h5.items() if isinstance(item, h5py.Group) and "status" in item.attrs]
        if model is None:
            if not models:
                raise KeyError(f"{path}: no model groups in this file")
            model = "fem" if "fem" in models else models[0]
        if model not in models:
            raise KeyError(f"{path}: no model {model!r}; the file holds {', '.join(models) or 'none'}")
        g = h5[model]
        axis_name = next((name for name in AXES if isinstance(g.get(name), h5py.Dataset)), None)
        axis = None if axis_name is None else (axis_name, g[axis_name][()], _units(g[axis_name]))
        along = {  # further coordinates along the axis (harmonic: lambda beside omega)
            name: (g[name][()], _units(g[name])) for name in AXIS_NAMES
            if axis is not None and name != axis_name and isinstance(g.get(name), h5py.Dataset) and g[name].shape == axis[1].shape
        }
        scores = dict(h5[f"scores/{model}"].attrs) if f"scores/{model}" in h5 else {}
        attrs = {key: attribute_value(g.attrs[key]) for key in ("status", "message", "wall_time_s", "settings") if key in g.attrs}
        attrs.update(model=model, scores={k: attribute_value(v) for k, v in scores.items()})
        attrs.update({key: attribute_value(h5.attrs[key]) for key in ("femref_version", "case_yaml") if key in h5.attrs})
        measured: dict[str, Any] = {"time": None, "probes": {}}
        if isinstance(g.get("measured"), h5py.Group):
            m = g["measured"]
            if isinstance(m.get("time"), h5py.Dataset):
                measured["time"] = (m["time"][()], _units(m["time"]))
            measured["probes"] = {name: data for name, data in _members(m).items() if name}
        return {
            "axis": axis,
            "along": along,
            "attrs": attrs,
            "probes": _members(g["probes"]) if "probes" in g else {},
            "couplers": _members(g["couplers"]) if "couplers" in g else {},
            "energy": _datasets(g["energy"]) if "energy" in g else {},
            "measured": measured,
            "fields": _datasets(g["fields"], skip=()) if "fields" in g else {},
        }


def _members(group: Any) -> dict[str, dict[str, tuple[Any, str]]]:
    """Every group at or below ``group`` that holds output datasets: its path below ``group`` → its datasets."""
    import h5py

    found: dict[str, dict[str, tuple[Any, str]]] = {}

    def visit(node: Any, prefix: str) -> None:
        data = _datasets(node)
        if data:
            found[prefix] = data
        for name, item in node.items():
            if isinstance(item, h5py.Group):
                visit(item, f"{prefix}/{name}" if prefix else name)

    visit(group, "")
    return found


def _datasets(group: Any, skip: tuple[str, ...] = AXIS_NAMES) -> dict[str, tuple[Any, str]]:
    """The datasets directly in ``group`` but the axis links in ``skip``: name → (values, units)."""
    import h5py

    return {name: (item[()], _units(item)) for name, item in group.items() if isinstance(item, h5py.Dataset) and name not in skip}


def _units(dataset: Any) -> str:
    return str(attribute_value(dataset.attrs.get("units", "")))


def _quantities(members: dict[str, dict[str, tuple[Any, str]]]) -> list[str]:
    """The quantities any member holds, in first-seen order."""
    return list(dict.fromkeys(quantity for outputs in members.values() for quantity in outputs))


def _stack(members, quantity: str, axis, names: list[str] | None = None):
    """``quantity`` of every member side by side: (N_axis, N_members), NaN where a member lacks it;
    a per-member scalar (a network's peak force) gives (N_members,) and no time dimension."""
    import numpy as np

    names = list(members) if names is None else names
    present = [members[name][quantity] for name in names if quantity in members.get(name, {})]
    units = present[0][1] if present else ""
    values = [members.get(name, {}).get(quantity, (None, ""))[0] for name in names]
    if all(v is None or np.ndim(v) == 0 or np.size(v) == 1 for v in values):
        return np.array([np.nan if v is None else np.asarray(v).reshape(-1)[0] for v in values]), units, None
    length = len(axis[1]) if axis is not None else max(np.size(v) for v in values if v is not None)
    dtype = np.result_type(*[np.asarray(v).dtype for v in values if v is not None], np.float64)
    stacked = np.full((length, len(names)), np.nan, dtype=dtype)
    for j, v in enumerate(values):
        if v is not None:
            stacked[:, j] = v
    return stacked, units, axis[0] if axis is not None else "index"


def _dims_of(values, axis) -> tuple[str, ...]:
    if axis is not None and getattr(values, "ndim", 0) == 1 and len(values) == len(axis[1]):
        return (axis[0],)
    return tuple(f"dim_{k}" for k in range(getattr(values, "ndim", 0)))
