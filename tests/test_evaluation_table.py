"""EvaluationTable.select: a chosen part of a table, with or without the notes under it."""

from motionlab.estimate import Estimate
from motionlab.evaluation import EvaluationTable


def test_select_keeps_the_cells_and_drops_the_notes_when_asked():
    rows = {"a": {"fid": Estimate(1.0, 0.1, 3), "jerk": Estimate(2.0, 0.2, 3)}, "b": {"fid": Estimate(3.0, 0.3, 3)}}
    table = EvaluationTable("multi", "smoke", "d", "test", 3, 0, {}, {}, ("fid", "jerk"), rows, notes=["a note"])
    with_notes, without = (
        table.select("b", "a", metrics=("fid",)),
        table.select("b", "a", metrics=("fid",), notes=False),
    )
    assert "a note" in with_notes.to_markdown() and "a note" not in without.to_markdown()
    assert without.rows == with_notes.rows and list(without.rows) == ["b", "a"] and without.metrics == ("fid",)
    assert table.notes == ["a note"]  # the table it came from keeps its notes
