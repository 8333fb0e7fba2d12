"""``book.try_it``: outputs computed once per value, sliders joined to them by links the browser runs."""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import pytest  # noqa: E402

from motionlab import book  # noqa: E402


def links_to(shown, target) -> list:
    """The client-side links (``jslink``) whose target is ``target``'s ``selected_index``."""
    return [link for link in shown.links if link.target == (target, "selected_index")]


def test_one_parameter_precomputes_each_value_and_links_its_slider():
    calls = []

    def draw(steps):
        calls.append(steps)
        return f"<p>{steps} steps</p>"

    shown = book.try_it(draw, steps=[1, 2, 4], initial={"steps": 2}, labels={"steps": "Euler steps"})
    slider, stack = shown.widget.children
    assert calls == [1, 2, 4]  # each value once, when the chapter runs
    assert [c.value for c in stack.children] == ["<p>1 steps</p>", "<p>2 steps</p>", "<p>4 steps</p>"]
    assert slider.description == "Euler steps" and slider.label == "2" and stack.selected_index == 1
    (link,) = links_to(shown, stack)
    assert link.source == (slider, "index")  # the browser's widget manager moves the stack with the slider


def test_two_parameters_nest_one_stack_per_value_of_the_first():
    shown = book.try_it(lambda a, b: f"{a}-{b}", a=["x", "y"], b=[0.5, 1.0, 2.0])
    slider_a, slider_b, outer = shown.widget.children
    assert [[c.value for c in inner.children] for inner in outer.children] == [
        ["x-0.5", "x-1.0", "x-2.0"],
        ["y-0.5", "y-1.0", "y-2.0"],
    ]
    assert links_to(shown, outer)[0].source == (slider_a, "index")
    assert all(links_to(shown, inner)[0].source == (slider_b, "index") for inner in outer.children)
    assert [label for label, _ in slider_b.options] == ["0.5", "1", "2"]


def test_a_figure_becomes_an_inline_png_and_is_closed():
    def draw(k):
        fig, ax = plt.subplots(figsize=(2, 1))
        ax.plot([0, 1], [0, k])
        return fig

    before = len(plt.get_fignums())
    shown = book.try_it(draw, k=[1, 2])
    html = shown.widget.children[1].children[0].value
    assert html.startswith('<img src="data:image/png;base64,') and len(plt.get_fignums()) == before
    assert shown.size_bytes == sum(len(c.value) for c in shown.widget.children[1].children)
    assert shown.widget.children[1].children[0].value != shown.widget.children[1].children[1].value


def test_bad_input_is_refused_before_anything_is_drawn():
    def draw(**_):
        raise AssertionError("drawn")

    with pytest.raises(ValueError, match="one or two parameters"):
        book.try_it(draw)
    with pytest.raises(ValueError, match="one or two parameters"):
        book.try_it(draw, a=[1], b=[1], c=[1])
    with pytest.raises(ValueError, match="no values"):
        book.try_it(draw, a=[])
    with pytest.raises(ValueError, match="repeat"):
        book.try_it(draw, a=[1, 1])
    with pytest.raises(ValueError, match="not among its values"):
        book.try_it(draw, a=[1, 2], initial={"a": 3})
    with pytest.raises(ValueError, match="not given values"):
        book.try_it(draw, a=[1, 2], labels={"b": "B"})
    with pytest.raises(TypeError, match="must return"):
        book.try_it(lambda a: 3, a=[1])


def test_a_caption_goes_under_the_output_and_the_live_version_takes_any_control():
    import ipywidgets as widgets

    shown = book.try_it(lambda k, j=0: f"<p>{k}</p>", k=[1, 2], caption="What <i>k</i> does.")
    *_, caption = shown.widget.children
    assert caption.value == '<p class="ml-caption">What <i>k</i> does.</p>'
    live = shown.live(k=widgets.IntSlider(value=5, min=1, max=9, description="k"))
    assert isinstance(live.children[0], widgets.IntSlider) and live.kwargs == {"k": 5}  # any value, not only 1, 2
    assert shown.live(j=widgets.IntSlider(value=3)).kwargs == {"k": 1, "j": 3}  # one kept at its default above
    with pytest.raises(ValueError, match="does not take"):
        shown.live(z=widgets.IntSlider())


def test_outputs_over_the_page_budget_are_refused():
    with pytest.raises(ValueError, match="over the budget of 100"):
        book.try_it(lambda a: "x" * 80, a=[1, 2], max_bytes=100)
