"""A channel's slowly varying offset (a sensor bias, a drift) and its noise, followed chunk by chunk through a stream
(docs/design.md §3.7: what they do to the trigger, measured).

**The baseline.** The stream's time is cut into blocks of ``B`` = :data:`BLOCK` s from its first sample. Per channel,
``m_j`` is the median of block ``j``'s samples, and the baseline at the block's centre ``c_j = t_0 + (j + ½)B`` is

    b_j = median{ m_i : |i − j| ≤ H }        (m/s², blocks without samples left out)

linearly interpolated in time between the centres: ``a(t) − b(t)`` is what the trigger sees. A constant bias is ``b``
exactly; a drift is followed (a centred median of a linear trend is the trend at the centre), except within ``H``
blocks of the stream's ends, where the window is one-sided and lags the trend by up to about ``H B r``.

**The window from the contact.** An impact's contact of length ``T`` moves the samples of at most ``⌈T/B⌉ + 1``
blocks, and the median of ``2H + 1`` block medians stays a median of quiet blocks while fewer than ``H + 1`` of them
move: ``H = ⌈T_max/B⌉ + 1`` (:func:`half_blocks`) with ``T_max`` = :data:`LONGEST_CONTACT` leaves every impact up to
``T_max`` long in ``a − b``. ``T_max = 1.2`` s is the half period ``π √(m*/k)`` of a 130 t car against a long consist
on the softest plausible gear (``k = 1e6`` N/m: ``1.13`` s). Measured on fem impacts of the default scene and the
pulses of tests/measured/test_phantom_impacts.py.

**The noise** (:class:`NoiseMeter`, of ``a − b``). Per block of :data:`NOISE_BLOCK` s,
``σ_j = 1.4826 · median |a − median a|`` (from at least :data:`MIN_NOISE_SAMPLES` samples); the channel's noise is
the :data:`NOISE_QUANTILE` quantile of ``σ_j`` over the stream (the ``⌊n/10⌋``-th smallest of ``n``, at least the
smallest), the noise of its quiet stretches: an impact rises for tens of milliseconds before a weak one crosses the
trigger and its cars may ring for most of a stream. The ``σ_j`` are counted in a histogram of :data:`NOISE_BINS`
bins per decade from 1e-6 to 1e6 m/s², so memory stays bounded for a stream of any length.

:class:`RunningBaseline` returns each sample less its baseline once the blocks ``H + 1`` beyond its own are complete
(a delay of about ``(H + 1.5) B``), the rest at :meth:`RunningBaseline.finish`: any cutting of the stream into chunks
gives the same samples, to the bit.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray

from femref.sensing.noise_gate import MAD_SCALE

BLOCK = 0.5
"""``B`` (s): the blocks whose medians make the baseline."""
LONGEST_CONTACT = 1.2
"""``T_max`` (s): the longest contact the baseline leaves whole in ``a − b`` (module docstring)."""


NOISE_BLOCK = 0.1
"""The blocks (s) whose median absolute deviations make a channel's noise."""
MIN_NOISE_SAMPLES = 10
"""Samples of a channel a noise block needs to count."""
NOISE_QUANTILE = 0.1
"""The quantile of the blocks' ``σ_j`` that is a channel's noise (module docstring)."""
NOISE_BINS = 100
"""Histogram bins per decade of the blocks' ``σ_j``."""
_NOISE_DECADES = (-6, 6)


def half_blocks(block: float = BLOCK, longest_contact: float = LONGEST_CONTACT) -> int:
    """``H = ⌈T_max/B⌉ + 1``: block medians on each side of a block's own (module docstring)."""
    return math.ceil(longest_contact / block - 1e-9) + 1


Chunk = tuple[NDArray[np.float64], dict[str, NDArray[np.float64]]]


@dataclass
class _Buffered:
    """A stream fed in chunks: its channels, first time (s; ``origin`` when given: the blocks of streams fed apart, a
    recorder's each, then line up), and the samples not yet used (``(channels, samples)``)."""

    origin: float = field(default=math.nan, kw_only=True)
    _names: list[str] | None = field(default=None, init=False)
    _t0: float = field(default=math.nan, init=False)
    _time: NDArray[np.float64] = field(default_factory=lambda: np.empty(0), init=False)
    _values: NDArray[np.float64] = field(default_factory=lambda: np.empty((0, 0)), init=False)

    def _append(self, t: NDArray[np.float64], channels: Mapping[str, ArrayLike]) -> None:
        names = list(channels)
        if self._names is None:
            self._names, self._t0 = names, float(t[0]) if math.isnan(self.origin) else self.origin
            self._values = np.empty((len(names), 0))
        if names != self._names:
            raise ValueError(f"every chunk needs the channels {self._names}, got {names}")
        values = np.array([np.asarray(channels[name], dtype=float) for name in names]).reshape(len(names), t.size)
        self._time = np.concatenate([self._time, t])
        self._values = np.concatenate([self._values, values], axis=1)


@dataclass
class RunningBaseline(_Buffered):
    """The baseline as a state machine over chunks of a stream (module docstring): :meth:`feed` each chunk in time
    order, then :meth:`finish`; each returns ``(t, {channel: a − b})`` for the samples decided (possibly none)."""

    block: float = BLOCK
    longest_contact: float = LONGEST_CONTACT
    half: int = field(default=0, init=False)
    """``H``: block medians on each side of a block's own (:func:`half_blocks`)."""
    _medians: dict[int, NDArray[np.float64]] = field(default_factory=dict, init=False)
    _complete: int = field(default=0, init=False)  # blocks 0 … _complete − 1 have their medians
    _emitted: int = field(default=0, init=False)  # blocks 0 … _emitted − 1 are returned

    def __post_init__(self) -> None:
        if not (math.isfinite(self.block) and self.block > 0.0 and math.isfinite(self.longest_contact) and self.longest_contact > 0.0):
            raise ValueError(f"the baseline's block and longest contact must be positive times (s), got {self.block!r}, {self.longest_contact!r}")
        self.half = half_blocks(self.block, self.longest_contact)

    @property
    def window(self) -> float:
        """The baseline's window ``(2H + 1) B`` (s)."""
        return (2 * self.half + 1) * self.block

    def feed(self, time: ArrayLike, channels: Mapping[str, ArrayLike]) -> Chunk:
        """The samples of the stream so far whose baseline is now known, less it (m/s²; NaN stays NaN)."""
        self._append(np.asarray(time, dtype=float), channels)
        self._medians_until(self._block_of(float(self._time[-1])) if self._time.size else self._complete)
        return self._emit(self._complete - self.half - 1)

    def finish(self) -> Chunk:
        """The rest of the stream, less its baseline (the blocks' medians up to the stream's end)."""
        if self._names is None:
            return np.empty(0), {}
        if self._time.size:
            self._medians_until(self._block_of(float(self._time[-1])) + 1)
        return self._emit(self._complete)

    def _block_of(self, t: float) -> int:
        return int(math.floor((t - self._t0) / self.block))

    def _medians_until(self, end: int) -> None:
        """Medians of the blocks ``_complete … end − 1`` (all their samples are in)."""
        if end <= self._complete:
            return
        blocks = np.floor((self._time - self._t0) / self.block).astype(np.int64)
        bounds = np.searchsorted(blocks, np.arange(self._complete, end + 1), side="left")
        medians = _nanmedian(_groups(self._values, bounds[:-1], bounds[1:]), overwrite=True)  # (channels, blocks)
        self._medians.update((j, medians[:, i]) for i, j in enumerate(range(self._complete, end)))
        self._complete = end

    def _baselines(self, blocks: range) -> NDArray[np.float64]:
        """``b_j`` of each block ``j`` of ``blocks`` (blocks × channels): the median of the block medians within ``H``
        of it that are known (a block not known counts as no sample)."""
        first = blocks.start - self.half
        known = np.full((blocks.stop - blocks.start + 2 * self.half, len(self._names or ())), np.nan)
        for j, median in self._medians.items():
            if 0 <= j - first < known.shape[0]:
                known[j - first] = median
        around = known[np.arange(len(blocks))[:, None] + np.arange(2 * self.half + 1)]  # (blocks, 2H + 1, channels)
        return _nanmedian(np.ascontiguousarray(np.moveaxis(around, 1, 2)), overwrite=True)

    def _emit(self, end: int) -> Chunk:
        """The samples of blocks ``_emitted … end − 1`` less the baseline interpolated between block centres."""
        assert self._names is not None
        if end <= self._emitted:
            return np.empty(0), {name: np.empty(0) for name in self._names}
        blocks = range(max(self._emitted - 1, 0), end + 1)
        centres = self._t0 + (np.array(blocks) + 0.5) * self.block
        levels = self._baselines(blocks)  # (blocks, channels)
        cut = int(np.searchsorted(np.floor((self._time - self._t0) / self.block), end, side="left"))
        t, values = self._time[:cut], self._values[:, :cut]
        out = {name: values[k] - np.interp(t, centres, levels[:, k]) for k, name in enumerate(self._names)}
        self._time, self._values = self._time[cut:], self._values[:, cut:]
        self._emitted = end
        for j in [j for j in self._medians if j < end - self.half - 1]:
            del self._medians[j]
        return t, out


@dataclass
class NoiseMeter(_Buffered):
    """Each channel's noise in the quiet stretches of a stream fed in chunks (module docstring): :meth:`feed` each chunk
    in time order, :meth:`noise` at the end (any cutting into chunks gives the same counts)."""

    block: float = NOISE_BLOCK
    _counts: NDArray[np.int64] = field(default_factory=lambda: np.zeros((0, 0), dtype=np.int64), init=False)

    def feed(self, time: ArrayLike, channels: Mapping[str, ArrayLike]) -> None:
        """Take the chunk ``time`` (s) with each channel's samples (m/s², NaN: no sample); count the blocks it completes."""
        t = np.asarray(time, dtype=float)
        if t.size == 0:
            return
        if self._names is None:
            self._counts = np.zeros((len(channels), NOISE_BINS * (_NOISE_DECADES[1] - _NOISE_DECADES[0])), dtype=np.int64)
        self._append(t, channels)
        blocks = np.floor((self._time - self._t0) / self.block)
        done = int(np.searchsorted(blocks, blocks[-1], side="left"))  # samples of the blocks before the last one's
        self._count(blocks[:done], self._values[:, :done])
        self._time, self._values = self._time[done:], self._values[:, done:]

    def noise(self) -> dict[str, float]:
        """Each channel's noise std (m/s²) over the stream so far, its last block included (NaN: no block counted)."""
        if self._names is None:
            return {}
        counts = self._counts.copy()
        blocks = np.floor((self._time - self._t0) / self.block)
        self._count(blocks, self._values, counts)
        edges = 10.0 ** (_NOISE_DECADES[0] + np.arange(counts.shape[1] + 1) / NOISE_BINS)
        found = {}
        for name, row in zip(self._names, counts):
            total = int(row.sum())
            k = int(np.searchsorted(np.cumsum(row), max(1, math.floor(NOISE_QUANTILE * total)), side="left")) if total else -1
            found[name] = float(math.sqrt(edges[k] * edges[k + 1])) if total else math.nan
        return found

    def _count(self, blocks: NDArray[np.float64], values: NDArray[np.float64], counts: NDArray[np.int64] | None = None) -> None:
        """Add each block's ``σ_j`` (``blocks``: each sample's block) to ``counts`` (default: the meter's)."""
        counts = self._counts if counts is None else counts
        if blocks.size == 0:
            return
        starts = np.flatnonzero(np.diff(blocks, prepend=-math.inf) > 0.0)
        samples = _groups(values, starts, np.append(starts[1:], blocks.size))  # (channels, blocks, samples)
        spread = MAD_SCALE * _nanmedian(np.abs(samples - _nanmedian(samples)[..., None]), overwrite=True)
        channel, block = np.nonzero((np.count_nonzero(np.isfinite(samples), axis=2) >= MIN_NOISE_SAMPLES) & (spread > 0.0))
        bins = np.floor((np.log10(spread[channel, block]) - _NOISE_DECADES[0]) * NOISE_BINS).astype(np.int64)
        np.add.at(counts, (channel, np.clip(bins, 0, counts.shape[1] - 1)), 1)


def _groups(values: NDArray[np.float64], lo: NDArray[np.int64], hi: NDArray[np.int64]) -> NDArray[np.float64]:
    """The samples ``lo[g] … hi[g] − 1`` of each row of ``values`` as ``(rows, groups, width)``, +inf past a group's end
    (no sample: :func:`_nanmedian` and the counts of finite samples leave it out)."""
    width = int((hi - lo).max()) if lo.size else 0
    if values.shape[1] == 0:
        return np.full((values.shape[0], lo.size, width), np.inf)
    index = lo[:, None] + np.arange(width)
    gathered = values[:, np.minimum(index, values.shape[1] - 1)]
    if width and np.any(hi - lo < width):
        gathered[:, index >= hi[:, None]] = np.inf
    return gathered


def _nanmedian(x: NDArray[np.float64], overwrite: bool = False) -> NDArray[np.float64]:
    """The median of the finite values along the last axis (NaN where there is none), all rows at once: the others
    moved past them (as +inf), the middle order statistics of every count of finite values there is put in place by
    one partition, and each row's two middle ones averaged (numpy's median of the finite values, to the bit);
    ``overwrite``: ``x`` may be reordered in place (a C-contiguous array of floats the caller no longer needs)."""
    if not x.shape[-1]:
        return np.full(x.shape[:-1], np.nan)
    rows = (x if overwrite else np.array(x, dtype=float)).reshape(-1, x.shape[-1])
    finite = np.isfinite(rows)
    n = np.count_nonzero(finite, axis=-1)
    out = np.full(n.size, np.nan)
    if not n.any():
        return out.reshape(x.shape[:-1])
    if not finite.all():
        rows[~finite] = np.inf
    counts = np.unique(n[n > 0])
    kth = np.unique(np.concatenate([(counts - 1) // 2, counts // 2]))
    rows.partition(kth, axis=-1)
    some = n > 0
    low = np.take_along_axis(rows, ((n - 1) // 2)[:, None].clip(0), axis=-1)[:, 0]
    high = np.take_along_axis(rows, (n // 2)[:, None].clip(0, rows.shape[1] - 1), axis=-1)[:, 0]
    out[some] = (low[some] + high[some]) / 2
    return out.reshape(x.shape[:-1])


__all__ = ["BLOCK", "LONGEST_CONTACT", "MIN_NOISE_SAMPLES", "NOISE_BINS", "NOISE_BLOCK", "NOISE_QUANTILE", "NoiseMeter", "RunningBaseline",
           "half_blocks"]
