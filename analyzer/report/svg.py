"""Matplotlib figures as inline SVG: no files, no external references, safe to embed.

Figures are built with the object-oriented API on an Agg canvas (no pyplot, so no global
figure registry to leak into and nothing to close but the figure itself). The SVG is
cleaned for inlining in an HTML page:

* the XML prolog, DOCTYPE and metadata (which carry ``http://`` URLs) are dropped;
* every ``id`` is prefixed with a per-figure key, so two figures never share an id
  (matplotlib derives ids from content hashes, and a page holds many figures);
* the root's fixed ``width``/``height`` go, the ``viewBox`` stays: the page's CSS sizes
  the figure (responsive, printable);
* text stays text (``svg.fonttype = none``: smaller and selectable); matplotlib escapes
  it as XML, so a channel name like ``<script>`` cannot become markup.
"""

from __future__ import annotations

import io
import re
import warnings
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from typing import Any

import matplotlib as mpl
import numpy as np
import numpy.typing as npt
from markupsafe import Markup
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from matplotlib.font_manager import FontProperties
from matplotlib.textpath import TextToPath

from analyzer.report.format import shorten, visible_controls

RC: dict[str, Any] = {
    "svg.fonttype": "none",
    "svg.hashsalt": "analyzer-report",
    "font.family": "sans-serif",
    "font.sans-serif": ["DejaVu Sans"],
    "font.size": 9.0,
    "axes.titlesize": 9.5,
    "axes.labelsize": 9.0,
    "xtick.labelsize": 8.0,
    "ytick.labelsize": 8.0,
    "legend.fontsize": 8.0,
    "axes.grid": True,
    "grid.color": "#d9d9d9",
    "grid.linewidth": 0.6,
    "axes.spines.top": False,
    "axes.spines.right": False,
    "axes.axisbelow": True,
    "path.simplify": True,
    "path.simplify_threshold": 0.5,
    "agg.path.chunksize": 10000,
}
"""Style of every report figure (applied in a context, never globally)."""

_PROLOG = re.compile(r"\A.*?(?=<svg\b)", re.S)
_METADATA = re.compile(r"<metadata>.*?</metadata>\s*", re.S)
_PATH_DATA = re.compile(r'\bd="([^"]*)"')
_DECIMALS = re.compile(r"(?<=\d\.\d)\d+")
"""The digits after a number's first decimal (dropped with a literal, empty replacement:
the substitution then runs in C, without a Python template expansion per number)."""
_XY = re.compile(r'\b(x|y)="(-?\d+\.\d)\d*"')
_TAG = re.compile(r"<[^>]*>")
_ROOT_SIZE = re.compile(r'(<svg\b[^>]*?)\s(?:width|height)="[^"]*"')


@contextmanager
def style() -> Iterator[None]:
    """The report's matplotlib style for the duration of a block, without matplotlib's
    missing-glyph warnings (a character of a channel name the font lacks is drawn as a
    box in the figure and shown whole in the tables: nothing for the user's terminal)."""
    rc = mpl.rc_context(RC)  # type: ignore[arg-type]  # keys are checked by matplotlib
    with rc, warnings.catch_warnings():
        warnings.filterwarnings("ignore", r"Glyph \d+ .*missing from", UserWarning)
        yield


def new_figure(width_in: float, height_in: float, constrained: bool = True) -> Figure:
    """A figure on an Agg canvas (no pyplot state). ``constrained`` layout fits labels of
    any length but measures every text twice; figures with a known structure use
    :func:`grid` instead (about half the drawing time)."""
    fig = Figure(figsize=(width_in, height_in), layout="constrained" if constrained else None)
    FigureCanvasAgg(fig)
    return fig


def grid(
    fig: Figure,
    rows: int,
    cols: int = 1,
    *,
    left: float = 0.8,
    right: float = 0.35,
    top: float = 0.4,
    bottom: float = 0.45,
    hgap: float = 0.65,
    wgap: float = 0.75,
    width_ratios: Sequence[float] | None = None,
) -> npt.NDArray[np.object_]:
    """A ``rows x cols`` array of axes with fixed margins and gaps in inches (room for
    tick labels, axis labels and a title or legend line above each axes)."""
    w_in, h_in = fig.get_size_inches()
    # the axes keep at least half the width, whatever the labels claim
    left = min(left, max(0.0, 0.5 * w_in - right))
    ax_h = (h_in - top - bottom - (rows - 1) * hgap) / rows
    ax_w = (w_in - left - right - (cols - 1) * wgap) / cols
    fig.subplots_adjust(
        left=left / w_in,
        right=1.0 - right / w_in,
        bottom=bottom / h_in,
        top=1.0 - top / h_in,
        hspace=hgap / max(ax_h, 1e-3),
        wspace=wgap / max(ax_w, 1e-3),
    )
    return fig.subplots(rows, cols, squeeze=False, width_ratios=width_ratios)


NAME_CHARS = 48
"""Longest channel or detector name drawn in a figure (longer ones lose their middle to
an ellipsis; the tables show them whole): a deep ROS path must not squeeze the axes out
of the figure."""


def label(text: str) -> str:
    """``text`` safe for a matplotlib label: a ``$`` would start mathtext, and control or
    bidi formatting characters are shown as escapes (line breaks stay line breaks)."""
    return "\n".join(visible_controls(line) for line in text.split("\n")).replace("$", r"\$")


def shown_name(text: str) -> str:
    """A channel or detector name as a figure shows it: controls (line breaks too) made
    visible, then cut to :data:`NAME_CHARS` in the middle; pass the result to
    :func:`label` (or embed it in a text that is)."""
    return shorten(visible_controls(text), NAME_CHARS)


def shown_names(texts: Sequence[str]) -> list[str]:
    """Names drawn side by side (a figure's rows), as :func:`shown_name` shows each,
    unless two of them then read alike (deep paths that differ in the middle: three
    wings' ``.../floor_accelerometer_raw_x`` all read ``building_A/structural_h...``):
    then whole, controls made visible (the grid keeps the axes at half the width
    whatever the labels' length)."""
    shown = [shown_name(t) for t in texts]
    if len(set(shown)) == len(set(texts)):
        return shown
    return [visible_controls(t) for t in texts]


_TEXT = TextToPath()


def text_width_in(text: str, size_pt: float) -> float:
    """Width in inches of a one-line ``text`` in the report's font at ``size_pt``, as
    matplotlib lays it out (call it within :func:`style`): lets a figure with a known
    structure reserve room for its labels without a constrained-layout pass."""
    width_pt, _, _ = _TEXT.get_text_width_height_descent(text, FontProperties(size=size_pt), False)
    return float(width_pt) / 72.0


def to_svg(fig: Figure, key: str) -> Markup:
    """The cleaned inline SVG of ``fig`` (see the module doc).

    The figure is left as it is, not cleared: nothing else refers to it (no pyplot
    registry), so it goes with its last reference, and ``Figure.clear`` would reset every
    axes once more (as costly as creating it) only to throw the result away."""
    buf = io.StringIO()
    fig.savefig(
        buf,
        format="svg",
        metadata={"Date": None, "Creator": None, "Format": None, "Type": None},
    )
    return Markup(clean_svg(buf.getvalue(), key))


def clean_svg(svg: str, key: str) -> str:
    """Matplotlib's SVG text made inlinable (see the module doc)."""
    prefix = re.sub(r"[^A-Za-z0-9_-]", "-", key) + "-"
    out = _PROLOG.sub("", svg, count=1)
    out = _METADATA.sub("", out)
    for _ in range(2):
        out = _ROOT_SIZE.sub(r"\1", out, count=1)

    def tag(m: re.Match[str]) -> str:
        t = _PATH_DATA.sub(_compact_path, m.group())
        t = _XY.sub(r'\1="\2"', t)
        t = t.replace(' id="', f' id="{prefix}')
        return t.replace('href="#', f'href="#{prefix}').replace("url(#", f"url(#{prefix}")

    # inside tags only: a text node (a channel name drawn in a figure) may hold the same
    # characters, and matplotlib escapes only & < > there, so no tag ends inside one
    return _TAG.sub(tag, out).strip()


def _compact_path(m: re.Match[str]) -> str:
    """Path data with coordinates to 0.1 pt (a tenth of a printer's point is below what
    any screen or printer resolves) and single spaces: about half the bytes."""
    d = _DECIMALS.sub("", m.group(1))
    return 'd="' + " ".join(d.split()) + '"'


__all__ = [
    "NAME_CHARS",
    "RC",
    "clean_svg",
    "grid",
    "label",
    "shown_name",
    "shown_names",
    "new_figure",
    "style",
    "text_width_in",
    "to_svg",
]
