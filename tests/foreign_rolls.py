"""Rolls made of sounds drumroll's own simulator does not make: an independent reference.

``drumroll simulate`` and ``calibrate --audio`` render impacts from recorded drum hits and a
click model; the corpus in ``../shared/corpus`` from other recorded hits. A recording made by
someone else's simulator, or of another bouncer, has another sound again. These rolls are
written out here, with numpy alone, from sound shapes the project's renderer has no part in:

* ``sine``: a damped sinusoid from zero phase (its first quarter period rises from nothing,
  slowly at a low frequency);
* ``cosine``: a damped sinusoid from its crest (an abrupt start);
* ``noise``: a burst of white noise, decaying in 5 ms (a rattle, a coin);
* ``attack``: a damped sinusoid whose amplitude ramps up linearly over 1 ms (a soft
  mallet, a ball's rubber: a sound that grows out of the noise rather than stepping out);
* ``modes``: four inharmonic modes at 1, 2.3, 4.1 and 6.7 times the frequency, in random
  phases, the higher ones dying faster (a bar, a wood block).

The bounces follow the power law, τ_k − τ_{k−1} = T_k = t_B α^k (eq. 11: t_B is the
flight the first impact would give at α = 1), with 0.1 ms of Gaussian timing
noise; each impact's amplitude is proportional to its speed (α^k of the first, as the power
law makes it), and white noise is added at ``snr_db`` under the first impact's power over
its first 20 ms. An impact's time is the first sample of its sound (its start, with the
sub-sample part in its phase).
"""

from __future__ import annotations

import numpy as np

#: The sound shapes (module docstring).
SHAPES = ("sine", "cosine", "noise", "attack", "modes")
#: The priors the rolls are fitted with (``estimate``'s power law): α and t_B flat, the
#: jitter log-uniform.
POWER_LAW_PRIORS = {"alpha": {"dist": "uniform", "low": 0.5, "high": 1.0},
                    "t_b": {"dist": "uniform", "low": 0.01, "high": 2.0},
                    "jitter_ms": {"dist": "loguniform", "low": 0.01, "high": 10}}
#: Seconds: each sound's decay time, the attack's ramp, the silence before the first impact
#: and after the last, the timing noise.
DECAY_S, ATTACK_S, LEAD_S, TAIL_S, JITTER_S = 0.02, 1e-3, 0.5, 0.6, 1e-4


def impact_sound(shape: str, frequency: float, t: np.ndarray, rng: np.random.Generator
                 ) -> np.ndarray:
    """One impact's sound at times ``t`` (s) after its start."""
    decay = np.exp(-t / DECAY_S)
    if shape == "sine":
        return np.sin(2 * np.pi * frequency * t) * decay
    if shape == "cosine":
        return np.cos(2 * np.pi * frequency * t) * decay
    if shape == "noise":
        return rng.standard_normal(t.size) * np.exp(-t / (DECAY_S / 4))
    if shape == "attack":
        return np.sin(2 * np.pi * frequency * t) * decay * np.minimum(1.0, t / ATTACK_S)
    if shape == "modes":
        return sum(np.sin(2 * np.pi * ratio * frequency * t + rng.uniform(0, 2 * np.pi))
                   * np.exp(-t / (DECAY_S * life))
                   for ratio, life in ((1.0, 1.0), (2.3, 0.6), (4.1, 0.3), (6.7, 0.2)))
    raise ValueError(f"unknown shape {shape!r}; one of {', '.join(SHAPES)}")


def foreign_roll(rng: np.random.Generator, shape: str, frequency: float, snr_db: float, *,
                 alpha: float, t_b: float, n: int = 16, rate: int = 44100
                 ) -> tuple[np.ndarray, np.ndarray]:
    """A power-law roll of ``n`` impacts made of ``shape`` sounds: the samples (peak 0.5) and
    the impact times (s)."""
    flights = t_b * alpha ** np.arange(1, n)
    times = LEAD_S + np.concatenate(([0.0], np.cumsum(flights)))
    times = times + rng.normal(0.0, JITTER_S, n)
    x = np.zeros(int((times[-1] + TAIL_S) * rate))
    length = int(0.15 * rate)
    for k, start in enumerate(times):
        first = int(np.ceil(start * rate))
        t = (first - start * rate + np.arange(length)) / rate  # from the sound's start
        sound = alpha**k * impact_sound(shape, frequency, t, rng)
        stop = min(first + length, x.size)
        x[first:stop] += sound[: stop - first]
    head = int(np.ceil(times[0] * rate))
    power = np.mean(x[head: head + int(0.02 * rate)] ** 2)
    x = x + rng.standard_normal(x.size) * np.sqrt(power / 10 ** (snr_db / 10))
    return 0.5 * x / np.max(np.abs(x)), times


def draw_roll(seed: int, shape: str, frequency: float, snr_db: float, rate: int = 44100
              ) -> tuple[np.ndarray, np.ndarray, float, float]:
    """The roll of one seed, shape, frequency and noise level, α ~ U(0.85, 0.93) and t_B ~
    U(0.2, 0.3) s: its samples, impact times, α and t_B (the same for the same arguments)."""
    rng = np.random.default_rng([seed, SHAPES.index(shape), int(frequency), int(snr_db)])
    alpha, t_b = rng.uniform(0.85, 0.93), rng.uniform(0.2, 0.3)
    samples, times = foreign_roll(rng, shape, frequency, snr_db, alpha=alpha, t_b=t_b,
                                  rate=rate)
    return samples, times, alpha, t_b
