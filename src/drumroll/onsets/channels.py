"""Which channel of a recording hears the impacts first.

A stereo recording may come from two microphones: one close to the drum, one farther away
(a phone on a table, a camera across the room). Sound reaches the far one later, after more
of the room, and averaging the two smears every onset over their delay. The impacts are
timed on the channel that hears them first: the loudest candidates are timed on every
channel, and the channel whose onsets come earliest (the median over the candidates of its
lead over the others) is the one. Channels that agree to within a sample are averaged, as a
mono recording is. Only the channels that hear a fair share (a quarter) of the loudest
impacts (their sound above what was there) take part: a dead input or a muted side, exact
zeros or hiss, would otherwise place its "onsets" anywhere in each search, often first, and
have the roll timed on nothing.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from drumroll.onsets.candidates import Candidates, refine_window, settle_samples
from drumroll.onsets.odf import OdfParams, wide_filter

#: Candidates (the most significant) the channels are compared on.
_LOUDEST = 8

#: Share of the loudest candidates a channel must hear to take part (a dead or hissing
#: channel heard none of them in every case tried; a live one at least a quarter).
_LIVE_SHARE = 0.25

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
    times = np.empty((loudest.size, channels))
    heard = np.zeros((loudest.size, channels), dtype=bool)
    for i, k in enumerate(loudest):
        guess = round(c.time_s[k] * rate)
        lo, hi = guess - pre - search - settle, guess + search + post
        for ch in range(channels):
            r = refine_window(excerpt(lo, hi, ch), lo, guess, rate, wide.filter, settle,
                              pre=pre + search, post=post, search=search)
            times[i, ch] = r.sample
            heard[i, ch] = r.amplitude > 0.0 and r.snr_db > 0.0
    # A channel that hears a fair share of the loudest impacts is a microphone of the roll;
    # one that hears almost none (a dead input, a side muted in an editor: exact zeros or
    # hiss, which heard none of the 8 in every case tried) would put its "onsets" anywhere
    # in each search, often first, and have the roll timed on nothing. A live channel does
    # not hear every one stand out: in a reverberant hall, through AGC and AAC at 64 kb/s,
    # the far microphone of the corpus's stereo roll heard fewer than half.
    live = np.flatnonzero(heard.mean(axis=0) >= _LIVE_SHARE)
    if live.size < 2:
        return int(live[0]) if live.size == 1 else None
    times = times[:, live]
    lead = np.median(times - times.min(axis=1, keepdims=True), axis=0)
    if float(lead.max()) < 1.0 and live.size == channels:
        return None
    return int(live[np.argmin(lead)])
