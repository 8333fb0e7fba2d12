"""A "Try it" that answers on the static site: sliders linked, in the browser, to outputs computed at build time.

A chapter's "Try it" is a function of one or two parameters that draws a figure. In a kernel,
``widgets.interact`` would recompute it on every move; on the built site there is no kernel, so such a slider is
frozen. :func:`try_it` calls the function once for every value to show, keeps each result as a small HTML widget
(a figure becomes an inline PNG), stacks them, and joins each slider to its stack with ``jslink``: a link the
page's own widget manager runs, so moving a slider on the site shows another precomputed output, no kernel needed.
The same widget works in Jupyter; :meth:`TryIt.live` gives the kernel version that computes any value.

Pages stay small by choice of values (a handful per slider), resolution (``dpi``) and a size budget
(``max_bytes``): a widget larger than its budget is refused when it is built, with the size it would have had.
"""

from __future__ import annotations

import base64
import io
import itertools
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

DEFAULT_MAX_BYTES = 1_500_000  # one widget's precomputed outputs, as embedded in the page (base64 included)


def _as_html(result: Any, dpi: float) -> str:
    """A function's result as a self-contained HTML fragment: a matplotlib figure as an inline PNG (the figure is
    closed), an object with ``_repr_html_`` as its HTML, a string as it is."""
    if hasattr(result, "savefig"):
        import matplotlib.pyplot as plt

        buffer = io.BytesIO()
        result.savefig(buffer, format="png", dpi=dpi, bbox_inches="tight")
        plt.close(result)
        encoded = base64.b64encode(buffer.getvalue()).decode("ascii")
        return f'<img src="data:image/png;base64,{encoded}" style="max-width:100%" alt="">'
    if hasattr(result, "_repr_html_"):
        return result._repr_html_()
    if isinstance(result, str):
        return result
    raise TypeError(
        f"the function must return a matplotlib Figure, an object with _repr_html_ or an HTML string, got "
        f"{type(result).__name__}"
    )


@dataclass
class TryIt:
    """The precomputed widget (:attr:`widget`, shown when the object is displayed) and how it was made."""

    draw: Callable[..., Any]
    values: dict[str, tuple]
    widget: Any  # an ipywidgets VBox: the sliders over the stack of outputs
    size_bytes: int  # the precomputed outputs' HTML, as the page embeds it
    links: list  # the jslink widgets that join each slider to its stack (run by the browser's widget manager)

    def _repr_mimebundle_(self, **kwargs):
        return self.widget._repr_mimebundle_(**kwargs)

    def live(self, **controls):
        """The kernel version, recomputed on every move (Jupyter only): ``widgets.interactive`` over the same
        function. ``controls`` replace a parameter's slider over the precomputed values by any widget, e.g.
        ``steps=widgets.IntSlider(2, 1, 32)``, so that a reader with a kernel can ask for any value, or add one for
        a parameter the precomputed version keeps at its default."""
        import inspect

        import ipywidgets as widgets

        accepted = inspect.signature(self.draw).parameters
        unknown = set(controls) - set(accepted)
        if unknown:
            raise ValueError(f"controls name parameters the function does not take: {sorted(unknown)}")
        sliders = {name: widgets.SelectionSlider(options=list(v), description=name) for name, v in self.values.items()}
        # the figure is drawn, shown as an image and closed inside the callback, so that the inline backend does
        # not show it a second time
        return widgets.interactive(lambda **kw: _display_result(self.draw(**kw)), **{**sliders, **controls})


def _display_result(result: Any) -> None:
    from IPython.display import HTML, display

    display(HTML(_as_html(result, dpi=100)))


def try_it(
    draw: Callable[..., Any],
    /,
    *,
    caption: str = "",
    labels: dict[str, str] | None = None,
    initial: dict[str, Any] | None = None,
    dpi: float = 80,
    max_bytes: int = DEFAULT_MAX_BYTES,
    **values: Sequence,
) -> TryIt:
    """A "Try it" over ``draw(**params)`` for every combination of ``values`` (one or two parameters, each a
    sequence of the values to show), answering without a kernel.

    ``draw`` returns a matplotlib ``Figure`` (or HTML): the figures are rendered at ``dpi`` and closed. ``caption``
    (HTML) is shown under the output, as a figure's caption is. ``labels``
    names each slider (default: the parameter's name); ``initial`` picks the value shown first (default: each
    parameter's first value). Raises ``ValueError`` for no parameter or more than two, an empty or repeated list of
    values, an initial value not among them, or outputs larger than ``max_bytes`` in all.
    """
    import ipywidgets as widgets

    if not 1 <= len(values) <= 2:
        raise ValueError(f"try_it takes one or two parameters, got {len(values)}: {sorted(values)}")
    values = {name: tuple(v) for name, v in values.items()}
    for name, options in values.items():
        if not options:
            raise ValueError(f"no values given for {name!r}")
        if len(set(map(repr, options))) != len(options):
            raise ValueError(f"values of {name!r} repeat: {options}")
    labels, initial = dict(labels or {}), dict(initial or {})
    unknown = (set(labels) | set(initial)) - set(values)
    if unknown:
        raise ValueError(f"labels/initial name parameters that are not given values: {sorted(unknown)}")
    for name, value in initial.items():
        if value not in values[name]:
            raise ValueError(f"initial {name}={value!r} is not among its values {values[name]}")
    if max_bytes <= 0:
        raise ValueError(f"max_bytes must be positive, got {max_bytes}")

    names = list(values)
    fragments = {combo: _as_html(draw(**dict(zip(names, combo))), dpi) for combo in itertools.product(*values.values())}
    size = sum(len(f) for f in fragments.values())
    if size > max_bytes:
        raise ValueError(
            f"the precomputed outputs take {size:,} bytes, over the budget of {max_bytes:,}: show fewer values, "
            "a lower dpi or a smaller figure"
        )

    sliders = {
        name: widgets.SelectionSlider(
            options=[(_label(v), i) for i, v in enumerate(options)],
            value=options.index(initial[name]) if name in initial else 0,
            description=labels.get(name, name),
            continuous_update=True,
            style={"description_width": "initial"},
            layout=widgets.Layout(width="60%"),
        )
        for name, options in values.items()
    }

    def stack(children):
        return widgets.Stack(children=children)

    links = []

    def join(slider, panel):
        links.append(widgets.jslink((slider, "index"), (panel, "selected_index")))
        panel.selected_index = slider.index  # the saved state already shows the initial value

    if len(names) == 1:
        (first,) = names
        panel = stack([widgets.HTML(fragments[(v,)]) for v in values[first]])
        join(sliders[first], panel)
    else:
        first, second = names
        inner = []
        for v in values[first]:
            column = stack([widgets.HTML(fragments[(v, w)]) for w in values[second]])
            join(sliders[second], column)
            inner.append(column)
        panel = stack(inner)
        join(sliders[first], panel)
    parts = [*sliders.values(), panel]
    if caption:
        parts.append(widgets.HTML(f'<p class="ml-caption">{caption}</p>'))
    box = widgets.VBox(parts)
    box.add_class("ml-try-it")  # how the site's browser test finds it
    return TryIt(draw, values, box, size, links)


def _label(value: Any) -> str:
    return f"{value:g}" if isinstance(value, float) else str(value)


__all__ = ["DEFAULT_MAX_BYTES", "TryIt", "try_it"]
