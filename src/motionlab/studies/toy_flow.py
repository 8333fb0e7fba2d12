"""Chapter 03's sampler study on the toy flow: the energy distance to the data after each budget of network
evaluations, per field and solver, as a table (the measurements are :func:`motionlab.flow.toy.energy_by_budget`'s).
"""

from __future__ import annotations

from collections.abc import Mapping

from motionlab.viz.tables import Table

SOLVER_LABELS = {"euler": "Euler", "midpoint": "midpoint"}


def energy_table(quality: Mapping[tuple[str, str, int], float], floor: float | None = None, points: int = 0) -> Table:
    """:func:`~motionlab.flow.toy.energy_by_budget`'s grid as a :class:`~motionlab.viz.tables.Table`: one row per budget
    (NFE), one column per field and solver ("–" where the solver cannot spend that budget); under it the noise ``floor``
    (the energy distance between two samples of the data, ``points`` each), when given."""
    if not quality:
        raise ValueError("quality is empty")
    columns = {(name, solver): f"{name}, {SOLVER_LABELS.get(solver, solver)}" for name, solver, _ in quality}
    rows = {
        nfe: {label: quality.get((*key, nfe)) for key, label in columns.items()}
        for nfe in sorted({nfe for *_, nfe in quality})
    }
    notes = () if floor is None else (f"noise floor (two samples of the data, {points} points each): {floor:.4f}",)
    labels = tuple(columns.values())
    return Table("NFE", rows, columns=labels, notes=notes, formats=dict.fromkeys(labels, ".4f"))


__all__ = ["SOLVER_LABELS", "energy_table"]
