"""Sample-accurate onset refinement and a per-onset timing uncertainty.

The detection function locates a click to a frame (≤ 0.5 ms). Inside a few milliseconds
around it the high-passed waveform is split into "before" and "after" at the sample that best
explains it as two stretches of zero-mean noise with different variances: Akaike's
information criterion picker (Maeda 1985; standard for seismic first arrivals),

    AIC(k) = k log var(x[:k]) + (N - k) log var(x[k:]),

minimised over the samples where the variance steps *up*. It needs no threshold and no
knowledge of the click's shape, so its bias does not change as the bounces fade.

Inside a roll the "noise" before a bounce is mostly the previous bounces still ringing:
modes and buzz that are predictable from their own past. So the window is first whitened
by a linear predictor fitted to the stretch before the search region (the AR-AIC picker of
Sleeman & van Eck 1999): the ring is predicted away, the new impact is not, and the AIC
split is taken on the prediction error.

A lossy transform codec (AAC, Opus, MP3, Vorbis) spreads the quantisation noise of the block
that holds an impact over the whole block, so the noise arrives before the impact does
(pre-echo): a stretch of noise, up to one short transform window long, at the codec's
signal-to-noise ratio under the sound that caused it. Where it stands above what was there
before, the change point above is its start, 1-3 ms before the impact, and the impact's own
first stage, if fainter than the noise, is hidden under it. In a lossy file
(``codec_block`` > 0) :func:`out_of_codec_noise` therefore asks whether the stretch after the
change point is such noise: a third segment, the sound stepping out of it within a codec
block, as likely as Akaike's charge for the two extra parameters and strong evidence
(:data:`STRONG`) require, and the stretch at least :data:`CODEC_SNR_DB` under the sound. If so,
the impact began somewhere under the noise, where the data cannot say, but not long before it
steps out: an impact's sound rises to :data:`CODEC_SNR_DB` under its peak within
:data:`IMPACT_RISE_S` of its start, so it is hidden under noise that far under it for no
longer than that. Its start is uniform over the stretch's last :data:`IMPACT_RISE_S` (all of
it when shorter), and the onset is the middle of that, with its sd in the uncertainty.
Lossless audio has no such noise and is timed as before.

The uncertainty has three parts, added in quadrature: the spread of the change point's
likelihood ``exp(-AIC / 2)`` over the searched samples (tempered by how much more irregular
the noise before the onset is than white Gaussian noise, :func:`dispersion`); the level-
dependent lag of the split behind the true start of a smooth rise, about the click's rise
time times its noise-to-peak ratio as recorded; and one-sample quantisation.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from drumroll.stats import student_t_logpdf_fixed


@dataclass(frozen=True)
class Refined:
    """One refined onset.

    Attributes
    ----------
    sample
        Onset sample index within the array that was passed in.
    amplitude
        Peak absolute value of the high-passed click in the window after the onset.
    snr_db
        The impact's own sound against what was already there: the whitened energy in the
        ``post`` samples after the onset, less the energy per sample before it, over the
        latter, dB (0 dB: the impact is as loud as the ring and noise it lands in).
    sigma_s
        Timing uncertainty (one standard deviation), seconds.
    rise_s
        Time from the onset to the click first reaching half its peak, seconds.
    level
        Peak absolute value of the high-passed sound over a longer window after the onset
        (the loudness the tracker compares; NaN when not measured).
    raw_snr_db
        As ``snr_db``, on the sound as recorded (not whitened): where each impact excites
        the same resonance as the ring it lands in (a wood block, a ball's shell), the ring's
        prediction also predicts much of the new impact away, and this is the truer margin.
    """

    sample: int
    amplitude: float
    snr_db: float
    sigma_s: float
    rise_s: float
    level: float = float("nan")
    raw_snr_db: float = float("nan")


#: Splits whose tempered AIC is within this of the best are statistically equivalent
#: (a likelihood ratio of e: Akaike's usual "substantial support" band).
EQUIVALENT = 2.0

#: Log Bayes factor of "strong" evidence on Kass & Raftery's scale (odds of about 20): the
#: bar for moving an onset away from its change point.
STRONG = 3.0

#: Least level (dB) by which a lossy codec's noise before an impact lies under the impact's
#: sound: the quantisation noise of a transform codec at the rates phones and messaging apps
#: write (64-128 kb/s) is kept under the signal by a signal-to-noise ratio of 15-30 dB in the
#: bands that carry an impact's click (AAC and Opus at 64 kb/s and up; lower rates give
#: more). A stretch louder than this relative to what follows it is the sound's own first
#: stage, not the codec's noise.
CODEC_SNR_DB = 15.0

#: Longest time (seconds) an impact's sound takes from its start to rise to
#: :data:`CODEC_SNR_DB` under its peak, so the longest it can stay hidden under a lossy
#: codec's noise that far under it. Measured on the onsets of lossless recordings of real
#: impacts (the 197 of the shared corpus's drum, stick and claves rolls and the 55 of the
#: real ping-pong: from each onset, the first 0.125 ms bin of the high-passed sound within
#: 15 dB of its peak over the next 5 ms): median 0.12 ms for the drums, 0.95 ms for the
#: claves (a faint first stage 35 dB under the click), 0.54 ms for the ping-pong; 99 % within
#: 1.5 ms, the longest 1.9 ms. A codec's pre-echo reaches up to a short transform window
#: ahead of the impact (:data:`drumroll.audio.timing.PRE_ECHO_SAMPLES`, 5-9 ms), longer than
#: this: what lies further ahead of the sound than this is the codec's noise, not its start.
IMPACT_RISE_S = 2e-3


@dataclass(frozen=True)
class Prior:
    """Where an onset is expected before its sound is looked at: a Student t about ``mean``
    with scale ``sd`` (samples) and ``dof`` degrees of freedom (the predictive of a scatter
    estimated from that many residuals), mixed with probability ``outlier`` with a uniform
    density over the ``width`` samples searched, so that a clear onset away from the
    expectation is still found where it is (a robust prior)."""

    mean: float
    sd: float
    outlier: float
    width: float
    dof: float = np.inf

    def shifted(self, by: float) -> Prior:
        """The same prior on an index ``by`` samples further on."""
        return Prior(self.mean + by, self.sd, self.outlier, self.width, self.dof)

    def log_density(self, k: np.ndarray) -> np.ndarray:
        """Log prior density at sample indices ``k``."""
        sd = max(self.sd, 1.0)
        z = (k - self.mean) / sd
        if np.isfinite(self.dof):
            core = student_t_logpdf_fixed(z * z, max(self.dof, 1.0))
        else:
            core = -0.5 * z * z - 0.5 * np.log(2.0 * np.pi)
        return np.logaddexp(np.log1p(-self.outlier) + core - np.log(sd),
                            np.log(self.outlier / max(self.width, 1.0)))


def aic_onset(x: np.ndarray, lo: int, hi: int, dispersion: float = 1.0,
              prior: Prior | None = None) -> tuple[int, float]:
    """Index in ``[lo, hi)`` of ``x`` minimising the two-variance AIC (variance stepping up),
    and the standard deviation (samples) of the change point's likelihood.

    ``AIC(k)`` is, up to a constant, minus twice the log-likelihood of "zero-mean Gaussian
    noise whose variance changes at k"; ``exp(-AIC / 2)`` over the searched splits is the
    change point's likelihood, and its spread about the best split is the timing uncertainty
    the data support: narrow for a sharp step out of quiet, wide where the noise before and
    the sound after are hard to tell apart. ``dispersion`` (>= 1) tempers that likelihood
    when the noise is less regular than Gaussian white noise (see :func:`dispersion`). Falls
    back to the unrestricted minimum when no split in range has the variance rising. With a
    ``prior`` on where the onset is (:class:`Prior`, in samples of ``x``), the split and its
    spread are those of the posterior, likelihood times prior.
    """
    n = x.size
    e = np.concatenate(([0.0], np.cumsum(x * x)))
    k = np.arange(max(lo, 2), min(hi, n - 2))
    if k.size == 0:
        return int(np.clip((lo + hi) // 2, 0, n - 1)), float(max(hi - lo, 1)) / np.sqrt(12.0)
    tiny = 1e-300
    v1 = e[k] / k + tiny
    v2 = (e[n] - e[k]) / (n - k) + tiny
    aic = k * np.log(v1) + (n - k) * np.log(v2)
    rising = v2 > v1
    if rising.any():
        aic = np.where(rising, aic, np.inf)
    # Minus twice the log posterior (up to a constant): the tempered AIC, less twice the
    # log prior.
    cost = aic / max(dispersion, 1.0)
    if prior is not None:
        cost = cost - 2.0 * prior.log_density(k)
    best = int(np.argmin(cost))
    delta = cost - cost[best]
    # The sound starts at the first split as good as the best: later steps of similar weight
    # are the same impact building up (drum modes, snare wires), not its start.
    best = int(np.flatnonzero(delta <= EQUIVALENT)[0])
    weight = np.exp(-0.5 * (cost - cost[best]))
    spread = float(np.sqrt(np.sum(weight * (k - k[best]) ** 2) / np.sum(weight)))
    return int(k[best]), spread


def out_of_codec_noise(x: np.ndarray, k: int, block: int, post: int,
                       dispersion: float = 1.0) -> tuple[int, int]:
    """Where the sound starting at change point ``k`` of ``x`` (zero-mean, whitened) steps out
    of a lossy codec's pre-echo, if the stretch after ``k`` is that noise (module docstring).

    Two models of ``x[k:]`` are compared: one variance from ``k`` on (the change point's own
    model), or a stretch of noise from ``k`` to ``m`` (at most ``block`` samples: the codec
    spreads its noise over one transform window) and the sound from ``m`` on, at least
    :data:`CODEC_SNR_DB` louder over the ``post`` samples after ``m``, with the stretch
    louder than what was there before ``k``. The second must beat the first by Akaike's
    charge for its two extra parameters and by :data:`STRONG` (as log likelihoods, tempered
    by ``dispersion`` as in :func:`aic_onset`).

    Returns
    -------
    tuple[int, int]
        ``(k, m)``: the start of the codec's noise and where the sound steps out of it;
        ``(k, k)`` when the stretch after ``k`` is the sound itself.
    """
    n = x.size
    m = np.arange(k + 2, min(k + block, n - post) + 1)
    if k < 4 or m.size == 0:
        return k, k
    e = np.concatenate(([0.0], np.cumsum(x * x)))
    tiny = 1e-300
    v0 = e[k] / k + tiny
    vp = (e[m] - e[k]) / (m - k) + tiny
    v_after = (e[n] - e[m]) / (n - m) + tiny
    v_one = (e[n] - e[k]) / (n - k) + tiny
    v_sound = (e[m + post] - e[m]) / post + tiny
    # Twice the log-likelihood ratio of "noise, then the sound" over "the sound from k on".
    gain = ((n - k) * np.log(v_one) - (m - k) * np.log(vp) - (n - m) * np.log(v_after))
    gain = gain / max(dispersion, 1.0)
    noise = (vp > v0) & (vp * 10.0 ** (CODEC_SNR_DB / 10.0) <= v_sound)
    gain = np.where(noise, gain, -np.inf)
    best = int(np.argmax(gain))
    if not gain[best] > 2.0 * 2.0 + 2.0 * STRONG:
        return k, k
    return k, int(m[best])


def dispersion(x: np.ndarray, block: int = 16) -> float:
    """How much more the short-time power of ``x`` fluctuates than white Gaussian noise's.

    The mean square of ``block`` independent Gaussian samples has relative variance
    ``2 / block``; noise that is modulated (snare wires buzzing at the head's frequency) or
    still correlated after whitening fluctuates more, and a likelihood that assumed
    independent samples is overconfident by about this ratio (a quasi-likelihood dispersion).
    Returns at least 1.
    """
    n = x.size // block
    if n < 4:
        return 1.0
    ms = np.mean(x[: n * block].reshape(n, block) ** 2, axis=1)
    mean = float(ms.mean())
    if mean <= 0:
        return 1.0
    return max(float(ms.var(ddof=1)) / mean**2 / (2.0 / block), 1.0)


def whiten(x: np.ndarray, fit: np.ndarray, order: int) -> np.ndarray:
    """Prediction error of ``x`` under an order-``order`` linear predictor fitted to ``fit``.

    Returns ``x`` unchanged when ``fit`` is too short or too quiet to fit a predictor.
    """
    order = min(order, fit.size // 4)
    if order < 2:
        return x
    r = np.correlate(fit, fit, mode="full")[fit.size - 1: fit.size + order] / fit.size
    if r[0] <= 0:
        return x
    r = r.copy()
    r[0] *= 1.0 + 1e-6  # a touch of diagonal loading: keeps pure tones solvable
    lags = np.abs(np.arange(order)[:, None] - np.arange(order)[None, :])
    try:
        a = np.linalg.solve(r[lags], r[1:order + 1])
    except np.linalg.LinAlgError:
        return x
    if not np.all(np.isfinite(a)):
        return x
    return np.convolve(x, np.concatenate(([1.0], -a)))[: x.size]


def refine_onset(y: np.ndarray, guess: int, sample_rate: int, *, pre: int, post: int,
                 search: int, search_after: int | None = None, order: int = 16,
                 prior: Prior | None = None, codec_block: int = 0,
                 within: tuple[int, int] | None = None) -> Refined:
    """Refine an onset near ``y[guess]`` on the high-passed signal ``y``.

    Parameters
    ----------
    y
        High-passed signal; must extend ``pre`` samples before and ``post`` after ``guess``
        (zeros are assumed where it does not).
    guess
        Onset estimate from the detection function (sample index into ``y``).
    pre, post
        Window before and after ``guess`` used for the AIC split and the statistics.
    search, search_after
        The onset is looked for from ``guess - search`` to ``guess + search_after``
        (default: ``search`` both ways). The detection function peaks at or after an onset,
        never much before it (its filters are causal), so the search may lean back.
    order
        Order of the whitening predictor fitted to the ``pre - search`` samples before the
        search region (0: no whitening).
    prior
        Optional prior on the onset (sample indices into ``y``), e.g. where the bounce
        sequence puts it.
    codec_block
        For a lossy file, the longest stretch (samples) over which its codec spreads noise
        ahead of an impact (:func:`out_of_codec_noise`; ``y`` should extend that far past
        ``guess + post``); 0 for lossless audio.
    within
        The first and last sample (indices into ``y``) the onset may be placed at, inside
        the searched stretch (default: all of it). The window, its whitening and every
        split's likelihood stay those of the whole search; only where the onset may land
        is narrowed.
    """
    start = guess - pre
    lo_pad = max(0, -start)
    # Past the window, the stretch a codec's noise may precede the sound by (the whitening
    # is causal, so the window's samples are whitened alike with or without it).
    ahead = y[max(start, 0): guess + post + codec_block]
    if lo_pad:
        ahead = np.concatenate((np.zeros(lo_pad), ahead))
    if order:
        ahead = whiten(ahead, ahead[: max(pre - search, 0)], order)
        ahead[:order] = 0.0  # no full predictor history yet
    x = ahead[: pre + post]
    raw = y[max(start, 0): guess + post + codec_block]
    if lo_pad:
        raw = np.concatenate((np.zeros(lo_pad), raw))
    after = search if search_after is None else search_after
    fit_end = max(pre - search, order + 2)
    disp = dispersion(x[order:fit_end])
    first, last = fit_end, pre + after + 1
    if within is not None:
        first, last = max(first, within[0] - start), min(last, within[1] - start + 1)
    k, spread = aic_onset(x, first, last, disp,
                          None if prior is None else prior.shifted(-start))
    noise_from = k
    if codec_block > 0:
        # The sound began somewhere under the codec's noise, where the data cannot say, but
        # no further ahead of where it steps out than an impact takes to rise out of noise
        # that far under it: uniformly over that, so its middle, with that uniform's sd.
        noise_from, out_of = out_of_codec_noise(ahead, k, codec_block, post, disp)
        if out_of > k:
            hidden_from = max(noise_from, out_of - round(IMPACT_RISE_S * sample_rate))
            k = (hidden_from + out_of) // 2
            spread = float(np.hypot(spread, (out_of - hidden_from) / np.sqrt(12.0)))
    # Timing precision is set by the whitened signal (what the split saw); the amplitude a
    # user reads is the click's own. What was there before is measured before the codec's
    # noise, if any (``noise_from`` is ``k`` otherwise), and the sound after an onset moved
    # out of it may reach past the window (into ``ahead``).
    x = ahead
    before = x[order:noise_from] if noise_from > order + 1 else x[:noise_from]
    after = x[k: k + post]
    amplitude = float(np.abs(raw[k: k + post]).max()) if k < raw.size else 0.0
    peak_abs = float(np.abs(after).max()) if after.size else 0.0
    noise = max(float(np.sqrt(np.mean(before * before))) if before.size else 0.0,
                peak_abs * 1e-6, 1e-12)
    if after.size:
        half = np.flatnonzero(np.abs(after) >= 0.5 * peak_abs)
        rise = (int(half[0]) + 1) / sample_rate if half.size else post / sample_rate
    else:
        rise = 1.0 / sample_rate
    # Where a smooth rise first stands out of the noise depends on how loud it is: a lag of
    # about (rise time) x (noise / peak) on the click as recorded, which varies from impact
    # to impact as the levels do.
    raw_after = np.abs(raw[k: k + post])
    raw_peak = float(raw_after.max()) if raw_after.size else 0.0
    raw_before = raw[max(noise_from - post, 0): noise_from]
    raw_noise = float(np.sqrt(np.mean(raw_before**2))) if raw_before.size else 0.0
    if raw_peak > 0:
        half_raw = np.flatnonzero(raw_after >= 0.5 * raw_peak)
        rise_raw = (int(half_raw[0]) + 1) if half_raw.size else post
        lag = rise_raw * min(raw_noise / raw_peak, 1.0)
    else:
        lag = float(post)
    sigma = float(np.sqrt(spread**2 + lag**2 + 1.0 / 12.0) / sample_rate)
    # The impact's own sound against what was already there, as energies over the window
    # after the onset (the whitened sound before it is the reference); and the same on the
    # sound as recorded.
    e_after = float(np.mean(after * after)) if after.size else 0.0
    own = max(e_after / (noise * noise) - 1.0, 1e-6)
    raw_e_after = float(np.mean(raw[k: k + post] ** 2)) if k < raw.size else 0.0
    raw_e_before = (float(np.mean(raw[order:noise_from] ** 2)) if noise_from > order + 1
                    else raw_noise**2)
    raw_own = max(raw_e_after / max(raw_e_before, 1e-300) - 1.0, 1e-6)
    return Refined(sample=start + k, amplitude=amplitude,
                   snr_db=float(10.0 * np.log10(own)), sigma_s=sigma, rise_s=rise,
                   raw_snr_db=float(10.0 * np.log10(raw_own)))
