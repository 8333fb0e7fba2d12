"""Drawing primitives for method diagrams: labelled boxes, arrows between them, token strips and brackets.

A :class:`Canvas` is a matplotlib axes in data units (``width`` × ``height``, origin bottom left, y up) with the
frame and ticks hidden, so a diagram is laid out like a sketch on squared paper: ``canvas.box(x, y, w, h, "U-Net")``
and ``canvas.arrow(a, b)`` from one box to another. Colours come from :data:`PALETTE` so every diagram of the book
uses the same colour for the same kind of thing (data, a network, noise, a condition, an operation).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import matplotlib.pyplot as plt
from matplotlib.patches import FancyArrowPatch, FancyBboxPatch, Rectangle

# One colour per kind of thing, the same on every page (colour-blind safe: the Okabe-Ito set, lightened for fills).
PALETTE = {
    "data": "#cfe3f5",  # motions, features, ground truth
    "token": "#f7d9a8",  # discrete ids and code vectors
    "network": "#d5ecd4",  # a trained module (U-Net, transformer, decoder)
    "noise": "#e8e0f0",  # Gaussian noise, [MASK], random replacements
    "condition": "#fbe0e6",  # text, frame-wise conditions
    "operation": "#eeeeee",  # a fixed computation (repeat, sum, ODE step)
    "edge": "#333333",
    "accent": "#d55e00",
}


@dataclass(frozen=True)
class Box:
    """A drawn box: its lower-left corner, size and centre, for arrows and labels placed relative to it."""

    x: float
    y: float
    w: float
    h: float

    @property
    def center(self) -> tuple[float, float]:
        return self.x + self.w / 2, self.y + self.h / 2

    def side(self, where: str) -> tuple[float, float]:
        """The middle of one side: ``"left"``, ``"right"``, ``"top"`` or ``"bottom"``."""
        cx, cy = self.center
        points = {
            "left": (self.x, cy),
            "right": (self.x + self.w, cy),
            "top": (cx, self.y + self.h),
            "bottom": (cx, self.y),
        }
        if where not in points:
            raise ValueError(f"where must be one of {sorted(points)}, got {where!r}")
        return points[where]


class Canvas:
    """An axes laid out in data units ``[0, width] × [0, height]`` with nothing but what is drawn on it."""

    def __init__(self, width: float, height: float, *, inches_per_unit: float = 0.75, ax=None) -> None:
        if width <= 0 or height <= 0:
            raise ValueError(f"width and height must be positive, got {width} × {height}")
        if ax is None:
            _, ax = plt.subplots(figsize=(width * inches_per_unit, height * inches_per_unit))
        self.ax, self.figure = ax, ax.figure
        ax.set_xlim(0, width)
        ax.set_ylim(0, height)
        ax.set_aspect("equal")
        ax.axis("off")

    def box(
        self,
        x: float,
        y: float,
        w: float,
        h: float,
        text: str = "",
        kind: str = "operation",
        *,
        fontsize: float = 9,
        rounded: bool = True,
        dashed: bool = False,
    ) -> Box:
        """A filled box of one :data:`PALETTE` kind with centred text (``$...$`` is mathtext); returns its geometry."""
        if kind not in PALETTE:
            raise ValueError(f"kind must be one of {sorted(PALETTE)}, got {kind!r}")
        style = "round,pad=0.02,rounding_size=0.12" if rounded else "square,pad=0.0"
        self.ax.add_patch(
            FancyBboxPatch(
                (x, y),
                w,
                h,
                boxstyle=style,
                facecolor=PALETTE[kind],
                edgecolor=PALETTE["edge"],
                linewidth=0.9,
                linestyle="--" if dashed else "-",
            )
        )
        if text:
            self.ax.text(x + w / 2, y + h / 2, text, ha="center", va="center", fontsize=fontsize)
        return Box(x, y, w, h)

    def arrow(
        self,
        start: Box | tuple[float, float],
        end: Box | tuple[float, float],
        text: str = "",
        *,
        start_side: str = "right",
        end_side: str = "left",
        curve: float = 0.0,
        fontsize: float = 8,
        color: str | None = None,
        dashed: bool = False,
        text_offset: tuple[float, float] = (0.0, 0.15),
    ) -> None:
        """An arrow between two boxes (from ``start_side`` of one to ``end_side`` of the other) or two points;
        ``curve`` bends it (the radius of a ``arc3`` connection), ``text`` labels its middle."""
        a = start.side(start_side) if isinstance(start, Box) else start
        b = end.side(end_side) if isinstance(end, Box) else end
        self.ax.add_patch(
            FancyArrowPatch(
                a,
                b,
                arrowstyle="-|>",
                mutation_scale=10,
                connectionstyle=f"arc3,rad={curve}",
                color=color or PALETTE["edge"],
                linewidth=1.0,
                linestyle="--" if dashed else "-",
                shrinkA=2,
                shrinkB=2,
            )
        )
        if text:
            mx, my = (a[0] + b[0]) / 2 + text_offset[0], (a[1] + b[1]) / 2 + text_offset[1]
            self.ax.text(mx, my, text, ha="center", va="bottom", fontsize=fontsize)

    def text(self, x: float, y: float, text: str, *, fontsize: float = 9, **kwargs) -> None:
        """Free text at ``(x, y)``; keyword arguments go to ``Axes.text`` (``ha``, ``va``, ``color``, ``style``)."""
        kwargs.setdefault("ha", "center")
        kwargs.setdefault("va", "center")
        self.ax.text(x, y, text, fontsize=fontsize, **kwargs)

    def strip(
        self,
        x: float,
        y: float,
        labels: Sequence[str],
        *,
        cell: float = 0.5,
        height: float | None = None,
        kinds: Sequence[str] | str = "token",
        fontsize: float = 8,
    ) -> list[Box]:
        """A row of square cells (a token sequence, a motion's frames), one label per cell; ``kinds`` colours them
        one kind for all or one per cell. Returns the cells' boxes, left to right."""
        if isinstance(kinds, str):
            kinds = [kinds] * len(labels)
        if len(kinds) != len(labels):
            raise ValueError(f"got {len(kinds)} kinds for {len(labels)} cells")
        h = cell if height is None else height
        cells = []
        for i, (label, kind) in enumerate(zip(labels, kinds)):
            if kind not in PALETTE:
                raise ValueError(f"kind must be one of {sorted(PALETTE)}, got {kind!r}")
            self.ax.add_patch(
                Rectangle((x + i * cell, y), cell, h, facecolor=PALETTE[kind], edgecolor=PALETTE["edge"], linewidth=0.7)
            )
            if label:
                self.ax.text(x + (i + 0.5) * cell, y + h / 2, label, ha="center", va="center", fontsize=fontsize)
            cells.append(Box(x + i * cell, y, cell, h))
        return cells

    def bracket(self, x0: float, x1: float, y: float, text: str = "", *, below: bool = True, fontsize: float = 8):
        """A square bracket under (or over) the span ``[x0, x1]`` at height ``y``, labelled in its middle."""
        tick = -0.12 if below else 0.12
        self.ax.plot([x0, x0, x1, x1], [y - tick, y, y, y - tick], color=PALETTE["edge"], lw=0.8)
        if text:
            self.ax.text(
                (x0 + x1) / 2, y + 2 * tick, text, ha="center", va="top" if below else "bottom", fontsize=fontsize
            )

    def finish(self):
        """The figure, laid out tight (call last, then show or return it)."""
        self.figure.tight_layout(pad=0.2)
        return self.figure
