"""The event trigger on records whose cars ring for seconds: one impact is one event, two impacts apart stay two.

The records are built here, not by a model: a known impact — a half-sine contact pulse of duration
``T``, each car's rigid acceleration ``∓(P/m) sin(πτ/T)`` (τ from contact) — plus each car's first
two free-free axial modes ringing after it, lightly damped,
``A_i cos(iπ(x/L + 1/2)) e^(−ζ_i ω_i τ) sin(ω_i √(1−ζ_i²) τ)``, sent through the measurement chain
(:func:`femref.sensing.measurement.measure`: 100 Hz anti-alias low-pass, 1 kHz, 0.05 m/s² noise).
The expected windows are computed in the tests from the records themselves by the rule the
trigger states: it opens at the first sample of ``max |a| > trigger``, its window ends ``post``
after the last sample above the re-arm level.
"""

from __future__ import annotations

import math
import re

import numpy as np
import pytest
import yaml

from femref.case import load_case
from femref.scene.build import scene_from_case
from femref.sensing.stream import stream_chunks
from femref.sensing.trigger import QUIET, EventTrigger, TriggerSettings
from support.measured import find_events
from femref.sensing.measurement import Measurement, measure
from femref.sensing.recordings import Channel, Recordings
from support.case_helpers import expect, load_bad

TRIGGER, PRE, POST = 3.0, 0.05, 0.5  # m/s², s, s
REARM = 0.5 * TRIGGER  # the default re-arm level
LENGTH = 17.0  # m, each car
SENSORS = {"hammer": (0.0, 8.3), "anvil": (-8.3, 0.0)}  # x (m)
MODEL_DT = 2e-4  # s: the grid the accelerations are built on, before the measurement chain
CHAIN = dict(rate=1000.0, lowpass=100.0, noise=0.05)


def ringing(t: np.ndarray, contact: float, rng: np.random.Generator) -> dict[str, np.ndarray]:
    """``{probe: a}`` (m/s²) on the model grid ``t``: an impact at ``contact`` and the cars' ringing after it
    (module docstring), its parameters drawn from ``rng``: P/m 10–25 m/s², T 0.08–0.15 s, f₁ 16–22 Hz,
    f₂ ≈ 2 f₁, ζ 0.6–1.0 %, A₁ 8–14 m/s², A₂ 2–4 m/s²."""
    tau = t - contact
    after = tau >= 0.0
    width, peak = rng.uniform(0.08, 0.15), rng.uniform(10.0, 25.0)
    rigid = np.where(after & (tau < width), peak * np.sin(np.pi * np.clip(tau / width, 0.0, 1.0)), 0.0)
    probes = {}
    for sign, (car, positions) in zip((-1.0, 1.0), SENSORS.items()):
        f1, zeta = rng.uniform(16.0, 22.0), rng.uniform(0.006, 0.010)
        modes = [(1, f1, rng.uniform(8.0, 14.0)), (2, 2.0 * f1 * rng.uniform(0.95, 1.05), rng.uniform(2.0, 4.0))]
        for x in positions:
            ring = np.zeros_like(t)
            for i, f, amplitude in modes:
                omega = 2.0 * np.pi * f
                shape = np.cos(i * np.pi * (x / LENGTH + 0.5))
                ring += amplitude * shape * np.exp(-zeta * omega * tau) * np.sin(omega * math.sqrt(1.0 - zeta**2) * tau)
            probes[f"{car}/{'center' if x == 0.0 else 'end'}"] = sign * rigid + np.where(after, ring, 0.0)
    return probes


def recorded(t: np.ndarray, probes: dict[str, np.ndarray], seed: int) -> Recordings:
    """The model accelerations through the measurement chain, as read records (one recorder)."""
    names = list(probes)
    time, a = measure(t, np.column_stack([probes[p] for p in names]), Measurement(**CHAIN, seed=seed))
    return Recordings({p: Channel(p, time, a[:, k], CHAIN["rate"], "simulated", ()) for k, p in enumerate(names)})


def envelope(recordings: Recordings) -> tuple[np.ndarray, np.ndarray]:
    """``(t, max over channels |a|)`` of records on one time axis."""
    channels = list(recordings.channels.values())
    return channels[0].time, np.max([np.abs(c.acceleration) for c in channels], axis=0)


def last_ringing(t: np.ndarray, e: np.ndarray, trigger_time: float, quiet: float = QUIET) -> float:
    """The last sample above the re-arm level after ``trigger_time`` before the first lull of ``quiet`` s."""
    loud = t[(e > REARM) & (t >= trigger_time)]
    lulls = np.flatnonzero(np.diff(loud) >= quiet)
    return float(loud[lulls[0]] if lulls.size else loud[-1])


def ringing_set(records: int = 24) -> list[tuple[float, Recordings]]:
    """``records`` single impacts at 1 s in 7 s records, with their contact times."""
    t = np.arange(0.0, 7.0, MODEL_DT)
    return [(1.0, recorded(t, ringing(t, 1.0, np.random.default_rng(seed)), seed)) for seed in range(records)]


def test_one_impact_whose_cars_ring_for_seconds_is_one_event():
    """24 single impacts whose cars ring above the trigger longer than ``post`` after it (the old fixed
    window ``[t − pre, t + post]`` ended while they still rang): exactly one event each, triggered at the
    first sample above the trigger, its window ending ``post`` after the last sample above the re-arm level,
    no flag."""
    for contact, recordings in ringing_set():
        t, e = envelope(recordings)
        first = t[np.argmax(e > TRIGGER)]
        assert np.any(e[t > first + POST] > TRIGGER), "the set must ring above the trigger past the fixed window"
        last_loud = last_ringing(t, e, first)
        assert last_loud - first > 1.0 and not np.any(e[t > last_loud] > REARM)  # rings for seconds, then falls quiet
        (event,) = find_events(recordings, TRIGGER, PRE, POST)
        assert contact <= event.trigger_time == first < contact + 0.02
        assert event.start == pytest.approx(first - PRE) and event.end == pytest.approx(last_loud + POST)
        assert event.flags == ()


def two_impacts(gap: float, seed: int = 3) -> tuple[Recordings, float, float]:
    """A ringing impact at 1 s and a second one ``gap`` s after the last sample of the first's ringing above
    the re-arm level: the records, that last sample and the second contact."""
    t = np.arange(0.0, 9.0, MODEL_DT)
    first = ringing(t, 1.0, np.random.default_rng(seed))
    time, e = envelope(recorded(t, first, seed))
    last_loud = time[np.flatnonzero(e > REARM)[-1]]
    second_contact = last_loud + gap
    second = ringing(t, second_contact, np.random.default_rng(seed + 100))
    return recorded(t, {p: first[p] + second[p] for p in first}, seed), last_loud, second_contact


def test_two_impacts_more_than_the_quiet_time_apart_stay_two_events():
    """A second impact 0.4 s after the first's ringing fell below the re-arm level (quiet 0.25 s, post 0.5 s):
    two events, the first's window cut short where the second's starts (``t₂ − pre``); 1.0 s after: two
    events, the first whole. 0.1 s after (less than the quiet time): the trigger has not re-armed, one
    event spanning both."""
    records, last_loud, second = two_impacts(0.4)
    one, two = find_events(records, TRIGGER, PRE, POST, quiet=0.25)
    assert second <= two.trigger_time < second + 0.02
    assert one.end == pytest.approx(two.trigger_time - PRE) and one.flags == (f"cut short: the next event triggers at {two.trigger_time:.6g} s",)
    records, last_loud, second = two_impacts(1.0)
    one, two = find_events(records, TRIGGER, PRE, POST, quiet=0.25)
    assert one.end == pytest.approx(last_loud + POST) and one.flags == () and second <= two.trigger_time < second + 0.02
    records, last_loud, second = two_impacts(0.1)
    (both,) = find_events(records, TRIGGER, PRE, POST, quiet=0.25)
    assert both.trigger_time < 1.02 and both.end > second + 1.0


def test_the_window_cap_holds_and_is_flagged():
    """Cars that ring above the trigger past a 2 s cap: the window is 2 s long and flagged ``capped``, the
    rest of the ringing (above the trigger again after the cap) is no event; an impact after the ringing
    has gone quiet is the next event (capped too)."""
    t = np.arange(0.0, 9.0, MODEL_DT)
    first = ringing(t, 1.0, np.random.default_rng(5))
    second = ringing(t, 7.0, np.random.default_rng(6))
    calm = np.where(t < 6.0, 1.0, 0.0)  # the first ring stops at 6 s (a brake), before the second impact
    records = recorded(t, {p: first[p] * calm + second[p] for p in first}, 5)
    capped, later = find_events(records, TRIGGER, PRE, POST, max_window=2.0)
    time, e = envelope(records)
    assert np.any(e[(time > capped.end) & (time < 6.0)] > TRIGGER)  # the tail rings above the trigger
    assert capped.end - capped.start == pytest.approx(2.0) and len(capped.flags) == 1 and capped.flags[0].startswith("capped")
    assert 7.0 <= later.trigger_time < 7.02 and later.flags == capped.flags  # it rings as long


def test_a_trigger_that_never_re_arms_says_so():
    """A re-arm level below the sensor noise (0.1 m/s² against 0.05 m/s² of noise: |a| > 0.1 m/s² every few
    samples): the first impact's window is capped and the trigger never re-arms, so a second impact 5 s later
    is not found — and the event says so rather than the stream reading as one impact."""
    t = np.arange(0.0, 9.0, MODEL_DT)
    first, second = ringing(t, 1.0, np.random.default_rng(5)), ringing(t, 6.0, np.random.default_rng(6))
    records = recorded(t, {p: first[p] + second[p] for p in first}, 7)
    (only,) = find_events(records, TRIGGER, PRE, POST, rearm=0.1, max_window=2.0)
    assert only.flags[0].startswith("capped") and any(f.startswith("never re-armed") for f in only.flags), only.flags
    assert not any(f.startswith("never re-armed") for e in find_events(records, TRIGGER, PRE, POST, max_window=2.0) for f in e.flags)


def stream() -> Recordings:
    """Two recorders at different rates and clocks (1 kHz, and 400 Hz 1.3 ms late) over a stream of four
    impacts: with a 3 s cap and a 0.25 s quiet time, windows capped, cut short by the next impact, capped, whole."""
    t = np.arange(0.0, 16.0, MODEL_DT)
    pieces = [ringing(t, contact, np.random.default_rng(seed)) for seed, contact in enumerate((1.0, 6.0, 8.3, 13.0))]
    probes = {p: sum(piece[p] for piece in pieces) for p in pieces[0]}
    fast = recorded(t, {p: a for p, a in probes.items() if p.startswith("hammer")}, 1)
    slow_time, slow = measure(t, np.column_stack([probes[p] for p in ("anvil/center", "anvil/end")]), Measurement(rate=400.0, lowpass=100.0, noise=0.05, seed=2))
    anvil = {p: Channel(p, slow_time + 0.0013, slow[:, k], 400.0, "slow", ()) for k, p in enumerate(("anvil/center", "anvil/end"))}
    return Recordings({**fast.channels, **anvil})


def test_chunks_of_any_size_give_the_events_of_the_whole_stream():
    """The trigger fed the merged stream of two recorders in one chunk, and in 30 random cuttings (chunks of
    1 to 5000 samples, log-uniform): the same windows, to the bit (:func:`stream`'s four, capped and cut short among them)."""
    settings = TriggerSettings(TRIGGER, PRE, POST, quiet=0.25, max_window=3.0)
    (t, values), = stream_chunks(stream(), samples=10**9)
    whole = EventTrigger(settings)
    expected = whole.feed(t, values) + whole.finish()
    flags = [w.flags[0].split(":")[0] for w in expected if w.flags]
    assert len(expected) == 4 and flags == ["capped", "cut short", "capped"], expected
    rng = np.random.default_rng(0)
    for _ in range(30):
        cuts = np.cumsum(np.exp(rng.uniform(0.0, np.log(5000.0), size=t.size)).astype(int) + 1)  # log-uniform sizes
        trigger, found = EventTrigger(settings), []
        for piece in np.split(np.arange(t.size), cuts[cuts < t.size]):
            found += trigger.feed(t[piece], {p: v[piece] for p, v in values.items()})
        assert found + trigger.finish() == expected


def test_a_chunk_out_of_order_or_a_level_out_of_range_is_refused():
    """A chunk that goes back in time or whose channels do not match its times, and settings out of their
    range, are ValueErrors naming the rule."""
    trigger = EventTrigger(TriggerSettings(TRIGGER, PRE, POST))
    trigger.feed(np.array([0.0, 1.0]), {"a/x": np.zeros(2)})
    with pytest.raises(ValueError, match=r"a chunk's times must increase, after the previous chunk's last time 1 s"):
        trigger.feed(np.array([1.0, 2.0]), {"a/x": np.zeros(2)})
    with pytest.raises(ValueError, match=r"one value per time \(2\)"):
        trigger.feed(np.array([3.0, 4.0]), {"a/x": np.zeros(3)})
    for settings, rule in (({"rearm": 4.0}, r"rearm must be a level in \(0, trigger = 3\]"), ({"quiet": 0.0}, r"quiet must be a positive time"),
                           ({"max_window": 0.5}, r"max_window must be >= pre \+ post = 0.55 s")):
        with pytest.raises(ValueError, match=rule):
            TriggerSettings(TRIGGER, PRE, POST, **settings)


@pytest.fixture
def case(tmp_path) -> dict:
    """A measured case reading one 2 s record of two cars."""
    t = np.arange(0.0, 2.0, 1e-3)
    np.savetxt(tmp_path / "cars.csv", np.column_stack([t, np.zeros_like(t), np.zeros_like(t)]), delimiter=",", header="t,h,a", comments="")
    return {
        "kind": "measured",
        "records": [{"file": "cars.csv", "time": {"column": "t"}, "channels": {"hammer/center": {"column": "h", "unit": "m/s^2"},
                                                                               "anvil/center": {"column": "a", "unit": "m/s^2"}}}],
        "cars": [{"name": "hammer", "mass": 119e3, "length": 17.0, "sensors": {"center": 0.0}},
                 {"name": "anvil", "mass": 100e3, "length": 17.0, "sensors": {"center": 0.0}}],
        "couplers": [{"between": ["hammer", "anvil"]}],
        "events": {"trigger": 3.0},
    }


def test_the_event_keys_resolve_with_their_defaults_and_bad_ones_name_their_rule(tmp_path, case):
    """Defaults (re-arm ½ trigger, quiet 0.5 s, max_window 5 s) reach the scene; a re-arm level above the
    trigger, a cap shorter than pre + post, a window or quiet time as long as the 2 s of records are refused."""
    path = tmp_path / "ok.yaml"
    path.write_text(yaml.safe_dump({**case, "events": {"trigger": 3.0, "rearm": 1.0, "quiet": 0.3, "max_window": 1.5}}))
    scene = scene_from_case(load_case(path))
    assert (scene.rearm, scene.quiet, scene.max_window) == (1.0, 0.3, 1.5)
    path.write_text(yaml.safe_dump(case))
    scene = scene_from_case(load_case(path))
    assert (scene.rearm, scene.quiet, scene.max_window) == (None, 0.5, 5.0)
    assert TriggerSettings(scene.trigger, scene.pre, scene.post, scene.rearm).rearm_level == 1.5
    for events, key_path, rule in (
        ({"rearm": 3.5}, "events.rearm", r"must be <= events\.trigger = 3 m/s² \(the hysteresis lies below the trigger\); got 3\.5"),
        ({"max_window": 0.5}, "events.max_window", r"must be >= events\.pre \+ events\.post = 0\.55 s; got 0\.5"),
        ({"post": 2.0}, "events.post", r"pre \+ post = 2\.05 s must be shorter than the records' common span of 1\.999 s"),
        ({"quiet": 2.5}, "events.quiet", r"must be shorter than the records' common span of 1\.999 s \(the trigger could never re-arm\)"),
        ({"quiet": -1.0}, "events.quiet", r"must be > 0"),
    ):
        message = str(load_bad(tmp_path, {**case, "events": {"trigger": 3.0, **events}}))
        assert re.search(expect(key_path, rule), message), message


def fem_ringing(rng: np.random.Generator, kind: str, seed: int) -> Recordings:
    """A fem impact of the default scene's hoppers (1–3 m/s, lading ±20 %) through its measurement chain (1 kHz,
    100 Hz, 0.05 m/s²), 3 s from contact after 0.5 s of noise: ``free_to_roll`` with lightly damped cars
    (axial viscosity 1.5e5–6e5 N·s, the default's 2e6 ÷ 3–13), or ``coupled`` (the bilateral friction-gear
    table of tests/measured/test_measured_statistics.py) with the default cars."""
    from femref.case import parse_case
    from femref.case.defaults import default_scene_data
    from femref.run.runner import run_scene
    from measured.test_measured_statistics import COUPLED_LAW

    data = default_scene_data()
    data.update(models=["fem"], estimators=[], time={"end": 3.0})
    data["measurement"]["seed"] = seed
    data["cars"][0]["velocity"] = float(rng.uniform(1.0, 3.0))
    viscosity = float(np.exp(rng.uniform(np.log(1.5e5), np.log(6e5))))
    for car in data["cars"]:
        car["body"]["mass_per_length"]["piecewise"]["values"][1] *= float(rng.uniform(0.8, 1.2))
        if kind == "free_to_roll":
            car["body"]["axial_viscosity"] = viscosity
    if kind == "coupled":
        data["couplers"][0].update(law=COUPLED_LAW, contact="bilateral", tension_slack=0.025)
    fem = run_scene(scene_from_case(parse_case(data, source="<ringing>"))).results[0]
    assert fem.ok, fem.message
    t = fem.measured["time"]
    before = np.arange(-500, 0) * float(t[1] - t[0])
    time = np.concatenate([before, t])
    return Recordings({p: Channel(p, time, np.concatenate([rng.normal(0.0, 0.05, before.size), a]), CHAIN["rate"], "fem", ())
                       for p, a in fem.measured.items() if p != "time"})


@pytest.mark.slow
def test_fem_impacts_whose_cars_ring_are_one_event_each():
    """24 fem impacts through the measurement chain, 12 free to roll with lightly damped cars and 12 coupled
    (cars surging against each other through the gear): each one event, triggered within 20 ms of contact
    and ending ``post`` after the last sample above the re-arm level before a lull of ``quiet`` (or at the
    records' end, truncated).
    Measured: the fixed window ``[t − pre, t + post]`` of the trigger before gave 63 events on these 24 (1–6 per
    free-to-roll record, 10 of 12 with more than one; 2–3 per coupled record), 67 with post 0.45 s."""
    rng = np.random.default_rng(28)
    for k in range(24):
        kind = ("free_to_roll", "coupled")[k % 2]
        recordings = fem_ringing(rng, kind, k)
        (event,) = find_events(recordings, TRIGGER, PRE, POST)
        t, e = envelope(recordings)
        last_loud = last_ringing(t, e, event.trigger_time)
        assert 0.0 <= event.trigger_time < 0.02 and event.trigger_time == t[np.argmax(e > TRIGGER)], (kind, k)
        assert event.end == pytest.approx(min(last_loud + POST, t[-1])), (kind, k)
        assert event.flags == (("truncated",) if last_loud + POST > t[-1] else ()), (kind, k)
