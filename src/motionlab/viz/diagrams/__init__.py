"""Diagrams of the methods: the picture a chapter opens with, drawn by code so it cannot drift from the text.

One module per part of the book; each function returns a matplotlib ``Figure`` (shown by a notebook cell, captioned
by the cell's ``mystnb.figure.caption`` metadata). The drawing primitives live in :mod:`._draw`.

- :mod:`.foundations`: motion as data, vector and residual quantization (chapters 01-02);
- :mod:`.flow`: rectified-flow paths, the condition projection and sJPE's two halves (chapters 03, 04, 06);
- :mod:`.discord`: the DisCoRD decoder from tokens to motion (chapter 05);
- :mod:`.m2d2m`: mask-and-replace, the transition matrix and β(t, d) (chapters 07-08);
- :mod:`.tps`: Two-Phase Sampling, one joint sequence then one per action (chapter 09).

Submodules are imported on first use, so that importing ``motionlab.viz`` does not start matplotlib.
"""

from importlib import import_module
from types import ModuleType

_PARTS = ("foundations", "flow", "discord", "m2d2m", "tps")

__all__ = list(_PARTS)


def __getattr__(name: str) -> ModuleType:
    if name in _PARTS:
        return import_module(f"{__name__}.{name}")
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted([*globals(), *__all__])
