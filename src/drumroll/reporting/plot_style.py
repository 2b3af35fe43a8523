"""What every ``drumroll estimate`` figure shares: palette, fonts, labels, draws and saving.

One look for all figures: the Okabe–Ito colour-blind-safe palette with one fixed colour per
model (the same model is the same colour in every figure), data in black, 90 % bands as light
fills under the points, sans-serif fonts large enough to read at the report's width.
Figures are built as :class:`matplotlib.figure.Figure` objects (no pyplot state, no GUI
backend needed) and written atomically with :func:`drumroll.fileio.write_with`.
"""

from __future__ import annotations

import contextlib
import io
import os
import re
import warnings
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from drumroll import fileio
from drumroll.errors import DrumrollWarning
from drumroll.physics.models import MODELS
from drumroll.quantities import DERIVED, DRAW_DERIVED, quantity

#: Okabe & Ito (2008) colour-blind-safe palette.
OKABE_ITO: dict[str, str] = {
    "blue": "#0072B2", "vermillion": "#D55E00", "green": "#009E73", "orange": "#E69F00",
    "sky": "#56B4E9", "purple": "#CC79A7", "yellow": "#F0E442", "black": "#000000",
}
_SPARE_COLORS = (OKABE_ITO["orange"], OKABE_ITO["purple"], OKABE_ITO["sky"])
DATA_COLOR = "black"
#: Resolution of every PNG.
DPI = 150
#: zlib level of the PNGs: 1 (Pillow's fastest) encodes the trace figure in half the time of
#: the default 6, and these plots come out no larger (within 20 %).
PNG_COMPRESSION = 1
#: Central posterior interval drawn as bands (and quoted in titles).
BAND = 0.90

#: Matplotlib settings applied while a figure is drawn and saved.
STYLE: dict[str, Any] = {
    "font.family": "sans-serif",
    "font.size": 10,
    "axes.titlesize": 10.5,
    "axes.labelsize": 10,
    "xtick.labelsize": 9,
    "ytick.labelsize": 9,
    "legend.fontsize": 9,
    "legend.frameon": False,
    "axes.spines.top": False,
    "axes.spines.right": False,
    "axes.grid": False,
    "axes.formatter.useoffset": False,
    "axes.formatter.limits": (-4, 5),
    "savefig.dpi": DPI,
    "figure.dpi": DPI,
}

@contextlib.contextmanager
def style() -> Iterator[None]:
    """Apply :data:`STYLE` (and the Agg-safe defaults) inside a ``with`` block."""
    import matplotlib

    with matplotlib.rc_context(STYLE):
        yield


def new_figure(figsize: tuple[float, float], **kwargs: Any):
    """A :class:`matplotlib.figure.Figure` detached from pyplot (so nothing leaks)."""
    from matplotlib.figure import Figure

    return Figure(figsize=figsize, **kwargs)


def save_figure(fig, path: str | os.PathLike[str], *, overwrite: bool = False) -> Path:
    """Write ``fig`` as a PNG at :data:`DPI`, atomically.

    The figure is not cleared afterwards: it belongs to no pyplot manager, so it is freed with
    its last reference, and clearing a figure rebuilds every axis's ticks (a third of the
    corner plot's time).

    Raises
    ------
    drumroll.errors.DrumrollError
        If ``path`` exists and ``overwrite`` is false, or its folder does not exist.
    """
    with style():
        return fileio.write_with(
            path, lambda tmp: write_png(fig, tmp, dpi=DPI, facecolor="white",
                                        pil_kwargs={"compress_level": PNG_COMPRESSION}),
            overwrite=overwrite)


def png_bytes(fig) -> bytes:
    """``fig`` as the PNG :func:`save_figure` writes, in memory (a report or a notebook
    embeds it)."""
    buffer = io.BytesIO()
    with style():
        write_png(fig, buffer, dpi=DPI, facecolor="white",
                  pil_kwargs={"compress_level": PNG_COMPRESSION})
    return buffer.getvalue()


#: Matplotlib's warning of a character its font cannot draw (one warning per character).
_MISSING_GLYPH = re.compile(r"^Glyph (\d+) .*missing from font")


@contextlib.contextmanager
def missing_glyphs_said_once(figure: str) -> Iterator[None]:
    """Draw and save inside this block: matplotlib's warnings of characters its font has no
    glyph for (a file name or a run label in a script it lacks, an emoji), one per
    character in its own words, become one warning naming the figure and the characters.
    Other warnings pass through as they were."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        yield
    missing = []
    for warning in caught:
        match = _MISSING_GLYPH.match(str(warning.message))
        if match:
            missing.append(chr(int(match.group(1))))
        else:
            warnings.warn_explicit(warning.message, warning.category, warning.filename,
                                   warning.lineno, source=warning.source)
    if missing:
        warnings.warn(f"{figure}: the figure's font cannot draw {''.join(dict.fromkeys(missing))} "
                      "(from a file name or label); they show as empty boxes",
                      DrumrollWarning, stacklevel=3)


def write_png(fig, target: Any, *, dpi: float, facecolor: str | None = None,
              pil_kwargs: dict[str, Any] | None = None) -> None:
    """Write ``fig`` as a PNG, as ``fig.savefig(target, format="png", dpi=dpi,
    facecolor=facecolor, pil_kwargs=pil_kwargs)`` writes it, drawing it once.

    ``savefig`` draws a figure with a layout engine (``layout="constrained"``) twice: once
    without output, which runs the layout, and once more to render. Rendering on the Agg
    canvas runs the layout within the draw that renders, on the same figure in the same
    state, so the pixels (and the file) are the same (tests/unit/reporting compares), for
    half the drawing: 0.3 of the trace figure's 0.8 CPU-s.
    """
    import matplotlib.image
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    canvas = FigureCanvasAgg(fig)
    fig.set_dpi(dpi)
    if facecolor is not None:
        fig.set_facecolor(facecolor)
    canvas.draw()
    matplotlib.image.imsave(target, canvas.buffer_rgba(), format="png", origin="upper",
                            dpi=dpi, pil_kwargs=pil_kwargs)


def model_color(model: str, index: int = 0) -> str:
    """The fixed colour of ``model`` (its registry entry; a spare colour for other names)."""
    return MODELS[model].colour if model in MODELS else _SPARE_COLORS[index % len(_SPARE_COLORS)]


def model_linestyle(model: str) -> object:
    """The fixed line style of ``model`` (dash-dot for names not in the registry)."""
    return MODELS[model].linestyle if model in MODELS else "-."


def model_name(model: str) -> str:
    """A model's name in words, as legends show it."""
    return MODELS[model].title if model in MODELS else model


def ordered_models(models: list[str] | tuple[str, ...] | Any, main: str | None = None
                   ) -> list[str]:
    """Models in the registry's order, richest first, the main model first of all."""
    models = list(models)
    registry = list(MODELS)[::-1]
    ordered = [m for m in registry if m in models] + [m for m in models if m not in registry]
    if main in ordered:
        ordered.remove(main)
        ordered.insert(0, main)
    return ordered


def parameter_label(key: str) -> str:
    """Axis label with its unit, e.g. ``$d$ (mm)``, for any posterior variable."""
    try:
        return quantity(key).label()
    except KeyError:
        return key.replace("_", " ")


def parameter_symbol(key: str) -> str:
    """The bare symbol of a posterior variable (no unit), e.g. ``$\\alpha$``."""
    try:
        return quantity(key).symbol
    except KeyError:
        return key.replace("_", " ")


def sampled_parameters(idata) -> list[str]:
    """Names of the posterior variables the sampler moved (not derived, not constant).

    Uses the sampler's own list (``sample_stats.attrs["tau_parameters"]``) when present,
    otherwise every posterior variable that is not a known derived quantity. Variables with
    no spread (held fixed) are left out.
    """
    posterior = idata.posterior
    names = None
    if "sample_stats" in idata.groups():
        listed = idata.sample_stats.attrs.get("tau_parameters")
        if listed is not None:
            names = [str(n) for n in np.atleast_1d(listed) if str(n) in posterior]
    if not names:
        names = [str(n) for n in posterior.data_vars if str(n) not in DERIVED
                 and str(n) not in DRAW_DERIVED and str(n) != "t0_s"]
    return [n for n in names if posterior[n].ndim == 2 and np.ptp(posterior[n].values) > 0]


def flat_draws(idata, group: str, name: str) -> NDArray[np.float64]:
    """``idata[group][name]`` as (chain × draw, …) floats."""
    values = np.asarray(getattr(idata, group)[name].values, dtype=float)
    return values.reshape((-1, *values.shape[2:]))









