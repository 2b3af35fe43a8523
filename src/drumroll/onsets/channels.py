"""Which channel of a recording hears the impacts first.

A stereo recording may come from two microphones: one close to the drum, one farther away
(a phone on a table, a camera across the room). Sound reaches the far one later, after more
of the room, and averaging the two smears every onset over their delay. The impacts are
timed on the channel that hears them first: the loudest candidates are timed on every
channel, and the channel whose onsets come earliest (the median over the candidates of its
lead over the others) is the one. Channels that agree to within a sample are averaged, as a
mono recording is. A channel votes only on the impacts it hears (its peak there within 60 dB
of the loudest channel's): a dead input or a muted side, exact zeros or hiss, would otherwise
place its "onset" anywhere in the search, often first, and have the roll timed on nothing.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from drumroll.onsets.candidates import Candidates, refine_window, settle_samples
from drumroll.onsets.odf import OdfParams, wide_filter

#: Candidates (the most significant) the channels are compared on.
_LOUDEST = 8

#: A channel whose peak at an impact is under this fraction (-60 dB) of the loudest
#: channel's there does not hear it.
_DEAF_BELOW = 1e-3

#: Refinement windows (seconds): the stretch before an onset the whitening is fitted on,
#: and the search either side of the first pass's time.
_PRE_S, _SEARCH_S, _POST_S = 0.008, 0.002, 0.002


def earliest_channel(c: Candidates, channels: int, rate: int, odf: OdfParams,
                     excerpt: Callable[[int, int, int], np.ndarray]) -> int | None:
    """The channel (0-based) that hears the most significant candidates first, or None when
    the channels agree to within a sample (or there is one channel).

    Parameters
    ----------
    c
        Candidates found on the mean of the channels.
    channels
        Number of channels.
    rate
        Sample rate.
    odf
        The detection settings (the wide high-pass the onsets are refined on).
    excerpt
        ``excerpt(start, stop, channel)``: one channel's samples ``[start, stop)``.
    """
    if channels < 2 or len(c) == 0:
        return None
    wide = wide_filter(odf, rate)
    settle = settle_samples(wide.sos, rate)
    pre, search, post = (round(v * rate) for v in (_PRE_S, _SEARCH_S, _POST_S))
    loudest = np.argsort(-c.z)[:_LOUDEST]
    times = np.full((loudest.size, channels), np.nan)
    level = np.zeros((loudest.size, channels))
    for i, k in enumerate(loudest):
        guess = round(c.time_s[k] * rate)
        lo, hi = guess - pre - search - settle, guess + search + post
        for ch in range(channels):
            r = refine_window(excerpt(lo, hi, ch), lo, guess, rate, wide.filter, settle,
                              pre=pre + search, post=post, search=search)
            times[i, ch], level[i, ch] = r.sample, r.amplitude
    # A channel times only an impact it hears: one that is silent there (a dead input, a side
    # muted in an editor: exact zeros, or hiss 60 dB and more under the channel that hears
    # the impact) puts its "onset" anywhere in the search, often first, and would be chosen
    # to time the roll on nothing. Two microphones of one room differ by tens of dB at most.
    heard = (level > 0.0) & (level >= _DEAF_BELOW * level.max(axis=1, keepdims=True))
    times = np.where(heard, times, np.nan)
    both = heard.sum(axis=1) >= 2  # a lead needs two channels hearing the same impact
    if not both.any():
        deaf = ~heard.any(axis=0)
        # Every channel but one deaf: that one times the roll, alone.
        return int(np.flatnonzero(~deaf)[0]) if deaf.sum() == channels - 1 else None
    rows = times[both]
    behind = rows - np.nanmin(rows, axis=1, keepdims=True)
    # Each channel's median lag behind the first, over the impacts it hears (never heard
    # with another: never first).
    lead = np.array([np.median(col[np.isfinite(col)]) if np.isfinite(col).any() else np.inf
                     for col in behind.T])
    if np.all(np.isfinite(lead)) and float(lead.max()) < 1.0:
        return None
    return int(np.argmin(lead))
