"""A picture to check detected onsets by eye (after the paper's Figure 4).

Three panels: the whole recording with every onset marked; a zoom on the fastest part of the
(longest) roll at full resolution, where mistakes would show; and the flight times against
bounce number on a log scale, where a drumroll is close to a straight line (one line per
roll; no flight is drawn next to a bounce that was not heard, see
:func:`~drumroll.onsets.table.single_flights`).
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from drumroll import fileio
from drumroll.audio.io import iter_blocks, probe, read_excerpt
from drumroll.onsets.table import OnsetTable, single_flights
from drumroll.reporting.plot_style import write_png

#: Points in the overview's min/max envelope (memory stays small for an hour-long file).
_OVERVIEW_BINS = 4000


def _envelope(path: str | os.PathLike[str], frames: int, bins: int) -> tuple[np.ndarray, ...]:
    per_bin = max(1, int(np.ceil(frames / bins)))
    lo, hi = [], []
    carry = np.zeros(0)
    for block in iter_blocks(path, block_frames=max(per_bin, 1 << 16), check=False):
        x = np.concatenate((carry, block))
        n = x.size // per_bin
        if n:
            m = x[: n * per_bin].reshape(n, per_bin)
            lo.append(m.min(axis=1))
            hi.append(m.max(axis=1))
        carry = x[n * per_bin:]
    if carry.size:
        lo.append(carry.min(keepdims=True))
        hi.append(carry.max(keepdims=True))
    lo_a, hi_a = np.concatenate(lo), np.concatenate(hi)
    return np.arange(lo_a.size) * per_bin, lo_a, hi_a


def draw_onset_figure(audio: str | os.PathLike[str], table: OnsetTable):
    """Build the figure (a :class:`matplotlib.figure.Figure`) for ``audio`` and ``table``."""
    from matplotlib.figure import Figure

    info = probe(audio)
    sr = info.sample_rate
    t = table.time_s
    fig = Figure(figsize=(11, 8.5), layout="constrained")
    ax_all, ax_zoom, ax_int = fig.subplots(3, 1, height_ratios=[1.1, 1.1, 0.9])

    start, lo, hi = _envelope(audio, info.frames, _OVERVIEW_BINS)
    ax_all.fill_between(start / sr, lo, hi, color="0.35", lw=0, step="post")
    ax_all.vlines(t, 0, 1, transform=ax_all.get_xaxis_transform(), color="tab:red", lw=0.7,
                  alpha=0.8, label=f"{len(t)} detected impacts")
    ax_all.set_xlim(0, info.duration_s)
    ax_all.set_xlabel("time (s)")
    ax_all.set_ylabel("amplitude")
    ax_all.set_title(f"{Path(audio).name}: waveform and detected impacts")
    ax_all.legend(loc="upper right", fontsize=8)

    # Zoom: the last (fastest) stretch of the (longest) roll, about eight bounces.
    t_roll = t[table.roll == table.longest_roll] if len(t) else t
    k0 = max(0, len(t_roll) - 9)
    span = t_roll[-1] - t_roll[k0] if len(t_roll) > 1 else 0.05
    z_lo, z_hi = t_roll[k0] - 0.25 * span - 0.002, t_roll[-1] + 0.35 * span + 0.002
    ax_all.axvspan(z_lo, z_hi, color="tab:blue", alpha=0.12, lw=0)
    a, b = max(int(z_lo * sr), 0), min(int(np.ceil(z_hi * sr)), info.frames)
    x = read_excerpt(audio, a, b)
    ax_zoom.plot((a + np.arange(x.size)) / sr, x, color="0.3", lw=0.5)
    inside = (t >= z_lo) & (t <= z_hi)
    for ti, si in zip(t[inside], table.sigma_s[inside], strict=True):
        ax_zoom.axvline(ti, color="tab:red", lw=0.9)
        ax_zoom.axvspan(ti - si, ti + si, color="tab:red", alpha=0.25, lw=0)
    if table.rejected_time_s.size:
        rej = table.rejected_time_s[(table.rejected_time_s >= z_lo)
                                    & (table.rejected_time_s <= z_hi)]
        ax_zoom.vlines(rej, 0, 1, transform=ax_zoom.get_xaxis_transform(), color="tab:orange",
                       lw=0.8, ls="--", label="rejected candidates")
        if rej.size:
            ax_zoom.legend(loc="upper right", fontsize=8)
    ax_zoom.set_xlim(z_lo, z_hi)
    ax_zoom.set_xlabel("time (s)")
    ax_zoom.set_ylabel("amplitude")
    ax_zoom.set_title("zoom on the fastest bounces (red: onsets, shaded ±1σ)")

    flight_panel(ax_int, table)
    return fig


def flight_panel(ax, table: OnsetTable) -> None:
    """Each roll's flight times against bounce number on a log axis, where a drumroll is
    close to a straight line (a bounce not heard breaks the line)."""
    t = table.time_s
    ends = single_flights(table.bounce, table.roll)
    colors = ("tab:red", "tab:blue", "tab:green", "tab:orange", "tab:purple", "tab:brown")
    for j, number in enumerate(table.rolls):
        mine = ends[table.roll[ends] == number]
        if not mine.size:
            continue
        k = np.arange(1, int(table.bounce[mine].max()) + 1)
        flights = np.full(k.size, np.nan)  # NaN next to a missing bounce: the line breaks
        flights[table.bounce[mine] - 1] = (t[mine] - t[mine - 1]) * 1e3
        ax.semilogy(k, flights, "o-", color=colors[j % len(colors)], ms=3.5, lw=0.8,
                    label=f"roll {number}" if len(table.rolls) > 1 else None)
    if len(table.rolls) > 1:
        ax.legend(loc="upper right", fontsize=8)
    ax.set_xlabel("bounce number k")
    ax.set_ylabel("flight time T_k (ms)")
    ax.set_title("flight times (a drumroll is close to a straight line here)")
    ax.grid(True, which="both", alpha=0.3)


def draw_flight_times(table: OnsetTable):
    """The flight times of ``table`` alone (no recording needed): a
    :class:`matplotlib.figure.Figure` of :func:`flight_panel`."""
    from matplotlib.figure import Figure

    fig = Figure(figsize=(7, 3.2), layout="constrained")
    flight_panel(fig.subplots(), table)
    return fig


def write_onset_plot(path: str | os.PathLike[str], audio: str | os.PathLike[str],
                     table: OnsetTable, *, overwrite: bool = False) -> Path:
    """Draw the onset figure for ``audio`` and write it to ``path`` atomically."""
    fig = draw_onset_figure(audio, table)
    return fileio.write_with(path, lambda tmp: write_png(fig, tmp, dpi=110),
                             overwrite=overwrite)
