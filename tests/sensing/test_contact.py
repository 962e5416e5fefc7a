"""The onset of a rise seen through a linear chain (femref.sensing.contact)."""

from __future__ import annotations

import functools
import math

import numpy as np
import pytest
from scipy.signal import butter, lsim

from femref.sensing.contact import onset_time

DT = 1e-3  # s: the records' step
T0 = 0.1234  # s: the onset, between samples
FINE = 1e-5  # s: the chain is simulated on this step


def _butterworth(u: np.ndarray, fine: np.ndarray) -> np.ndarray:
    num, den = butter(4, 2.0 * math.pi * 100.0, analog=True)
    return lsim((num, den), u, fine)[1]


def _gaussian_blur(u: np.ndarray, fine: np.ndarray) -> np.ndarray:
    """A symmetric (non-causal) blur of 1.5 ms standard deviation, as a smoother spreads a sharp start."""
    width = 1.5e-3
    kernel_t = np.arange(-6 * width, 6 * width + FINE, FINE)
    kernel = np.exp(-0.5 * (kernel_t / width) ** 2)
    return np.convolve(u, kernel / kernel.sum(), mode="same")


CHAINS = {"butterworth 100 Hz": _butterworth, "gaussian blur": _gaussian_blur}


def _through(chain, jump: float, slope: float, noise: float, seed: int = 0):
    """``J 1(t > T0) + s (t − T0)₊`` for 40 ms, then a linear fall over 40 ms, through the chain,
    sampled at 1 kHz with white noise; and the chain's step and ramp responses on lags about 0.25 s."""
    t, seen, lags, step, ramp = _noise_free(chain, jump, slope)
    return t, seen + noise * np.random.default_rng(seed).standard_normal(t.size), lags, step, ramp


@functools.cache
def _noise_free(chain, jump: float, slope: float):
    """:func:`_through` without noise, computed once per chain and rise (``lsim`` steps 50 000 fine samples in Python,
    ~1 s busy a call), read-only."""
    fine = np.arange(0.0, 0.5, FINE)
    s = fine - T0
    top = jump + slope * 0.04
    force = np.where(s <= 0.0, 0.0, np.where(s < 0.04, jump + slope * s, np.maximum(top * (1.0 - (s - 0.04) / 0.04), 0.0)))
    seen = chain(force, fine)[::100]
    step, ramp = _chain_responses(chain)
    return tuple(_read_only(a) for a in (fine[::100], seen, (fine - 0.25)[::100], step, ramp))


@functools.cache
def _chain_responses(chain):
    """The chain's step and ramp responses on lags about 0.25 s, sampled at 1 kHz (once per chain)."""
    fine = np.arange(0.0, 0.5, FINE)
    reference = fine - 0.25
    return chain(np.where(reference > 0.0, 1.0, 0.0), fine)[::100], chain(np.maximum(reference, 0.0), fine)[::100]


def _read_only(a: np.ndarray) -> np.ndarray:
    a = a.copy()
    a.flags.writeable = False
    return a


@pytest.mark.parametrize("chain", list(CHAINS))
@pytest.mark.parametrize(("jump", "slope"), [(0.0, 400.0), (3.0, 100.0), (5.0, 0.0)])
def test_the_onset_is_found_through_the_chain(chain, jump, slope):
    """A ramp, a jump and a ramp, a pure jump, through a causal 100 Hz Butterworth (4 ms delay) or a
    symmetric 1.5 ms blur: the onset within 0.05 ms noise-free, within 1.5 ms with white noise of 1 %
    of the jump-plus-10-ms level over three seeds."""
    t, seen, lags, step, ramp = _through(CHAINS[chain], jump, slope, 0.0)
    found = onset_time(t, seen, lags, step, ramp)
    assert found.time == pytest.approx(T0, abs=5e-5)
    level = jump + slope * 0.01
    for seed in range(3):
        t, seen, lags, step, ramp = _through(CHAINS[chain], jump, slope, 0.01 * level, seed)
        assert onset_time(t, seen, lags, step, ramp).time == pytest.approx(T0, abs=1.5e-3)


def test_ignoring_the_chain_reads_a_delayed_onset_late():
    """The Butterworth-delayed rise read with the bare step and ramp as the chain: more than 1 ms late."""
    t, seen, lags, _, _ = _through(_butterworth, 3.0, 100.0, 0.0)
    bare = onset_time(t, seen, lags, np.where(lags > 0.0, 1.0, 0.0), np.maximum(lags, 0.0))
    assert bare.time - T0 > 1e-3


@pytest.mark.parametrize(
    ("record", "match"),
    [
        (np.zeros(200), "no positive rise"),
        (np.r_[np.ones(10), np.zeros(190)], "starts above half its peak"),
        (np.r_[np.zeros(5), np.linspace(0.0, 1.0, 195)], "quiet samples"),
        (np.zeros(10), "at least 60 samples"),
    ],
)
def test_records_without_a_quiet_start_and_a_rise_are_refused(record, match):
    lags = np.linspace(-0.1, 0.1, 201)
    with pytest.raises(ValueError, match=match):
        onset_time(DT * np.arange(record.size), record, lags, np.where(lags > 0, 1.0, 0.0), np.maximum(lags, 0.0))
