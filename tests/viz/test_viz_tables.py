"""Tables for reading: cell formats, alignment, comparisons, and chapter 01's two tables."""

import numpy as np
import pytest

from motionlab.estimate import Estimate
from motionlab.representation import T2M, feature_slices
from motionlab.viz import Table, feature_differences, skeleton_table
from motionlab.viz.tables import format_cell


def test_cells_print_as_estimates_numbers_and_text():
    assert format_cell(Estimate(52.345, 3.14, n=10, unit="mm")) == "52.3 ± 3.1 mm"
    assert format_cell(Estimate(0.5)) == "0.500"  # one value: no interval to show
    assert format_cell(300000) == "300,000" and format_cell(np.int64(7)) == "7"
    assert format_cell(0.012345) == "0.0123" and format_cell(np.float32(2.5)) == "2.50"
    assert format_cell(None) == "–" and format_cell(True) == "yes"
    assert format_cell("a|b") == "a\\|b"  # a bar inside a cell must not end it
    assert format_cell(0.00031, ".1e") == "3.1e-04" and format_cell(0.5, ".0%") == "50%"
    assert format_cell(Estimate(1.23456, 0.01, n=5), ".3f") == "1.235 ± 0.010"
    assert format_cell("text", ".3f") == "text"  # a spec formats numbers only


def test_table_renders_markdown_with_numeric_columns_right_aligned():
    table = Table(
        "model",
        {"a": {"score": Estimate(1.0, 0.1, n=3), "note": "fast"}, "b": {"score": 2.0}},
        notes=("± = 95% interval.",),
    )
    assert table.columns == ("score", "note") and table.labels == ["a", "b"]
    assert table.to_markdown().splitlines() == [
        "| model | score | note |",
        "|---|---:|---|",
        "| a | 1.00 ± 0.10 | fast |",
        "| b | 2.00 | – |",
        "",
        "± = 95% interval.",
    ]
    assert table._repr_markdown_() == str(table) == table.to_markdown()
    assert table.column("score") == [Estimate(1.0, 0.1, n=3), 2.0] and table.column("note") == ["fast"]


def test_table_formats_columns_and_checks_its_arguments():
    table = Table("NFE", {1: {"x": 0.123456, "y": None}, 2: {"x": 0.5, "y": 0.25}}, formats={"x": ".4f"})
    assert "| 1 | 0.1235 | – |" in table.to_markdown() and "| 2 | 0.5000 | 0.250 |" in table.to_markdown()
    assert table.to_markdown().splitlines()[1] == "|---|---:|---:|"
    with pytest.raises(ValueError, match="empty"):
        Table("x", {})
    with pytest.raises(ValueError, match="formats"):
        Table("x", {"a": {"b": 1}}, formats={"c": ".1f"})
    with pytest.raises(KeyError, match="no row"):
        table.cell(3, "x")
    with pytest.raises(KeyError, match="no column"):
        table.cell(1, "z")
    with pytest.raises(KeyError, match="no column"):
        table.column("z")


def test_compare_judges_two_rows_by_the_one_rule():
    table = Table("run", {"a": {"loss": Estimate(1.0, 0.1, n=5)}, "b": {"loss": Estimate(2.0, 0.1, n=5)}})
    c = table.compare("a", "b", "loss")
    assert c.verdict == "lower" and c.names == ("a", "b") and c.quantity == "loss"
    close = Table("run", {"a": {"loss": Estimate(1.0, 0.5, n=5)}, "b": {"loss": Estimate(1.2, 0.5, n=5)}})
    assert close.compare("a", "b", "loss", "mine", "theirs").verdict == "not distinguishable"
    assert "mine 1.00 ± 0.50 and theirs 1.20 ± 0.50 are not distinguishable" in str(
        close.compare("a", "b", "loss", "mine", "theirs")
    )


def test_skeleton_table_lists_every_joint_with_its_parent_and_bone():
    table = skeleton_table("t2m")
    assert table.labels == list(range(22)) and table.columns == ("name", "parent", "bone length (m)")
    assert table.cell(0, "parent") is None and table.cell(0, "bone length (m)") is None  # the root
    wrist = T2M.index("left_wrist")
    assert table.cell(wrist, "parent") == "left_elbow"
    assert table.cell(wrist, "bone length (m)") == pytest.approx(float(T2M.bone_lengths[wrist]))
    assert f"| {wrist} | left_wrist | left_elbow | {T2M.bone_lengths[wrist]:.4f} |" in table.to_markdown()
    assert skeleton_table(T2M).to_markdown() == table.to_markdown()


def test_feature_differences_are_the_largest_per_group():
    rng = np.random.default_rng(0)
    ours = rng.normal(size=(10, 263))
    shipped = np.concatenate([ours, rng.normal(size=(1, 263))])  # one frame longer: only the first 10 count
    ric = feature_slices("t2m")["ric"]
    shipped[3, ric.start + 5] += 0.25
    table = feature_differences(ours, shipped)
    assert table.labels == list(feature_slices("t2m"))
    assert table.cell("ric", "max abs difference") == pytest.approx(0.25)
    assert table.cell("rot", "max abs difference") == 0.0
    assert "| ric | 2.5e-01 |" in table.to_markdown()
    with pytest.raises(ValueError, match="reference"):
        feature_differences(ours, shipped[:5])
    with pytest.raises(ValueError, match="features"):
        feature_differences(ours[:, :200], shipped)
