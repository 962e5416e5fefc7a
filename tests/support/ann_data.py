"""A known regression problem for the networks: noisy sin² pulses and their amplitudes."""

import numpy as np

RATE = 1000.0  # Hz
SAMPLES = 200


def pulse_problem(n: int = 500, seed: int = 1) -> tuple[np.ndarray, np.ndarray]:
    """Records ``(n, 1, SAMPLES)`` of noisy sin² pulses and their amplitudes ``(n,)``."""
    rng = np.random.default_rng(seed)
    t = np.arange(SAMPLES) / RATE
    amplitude = rng.uniform(1.0, 5.0, n)
    duration = rng.uniform(0.05, 0.15, n)
    inside = t[None, :] < duration[:, None]
    pulse = np.where(inside, np.sin(np.pi * t[None, :] / duration[:, None]) ** 2, 0.0)
    records = amplitude[:, None] * pulse + 0.01 * rng.standard_normal((n, SAMPLES))
    return records[:, None, :], amplitude
