"""Chapter 08's diffusion diagnostic as the reader sees it: the distance between M2D2M's and VQ-Diffusion's forward
processes per η, with the sentence that reads it.

The measurement is :func:`motionlab.diffusion.diagnostics.dynamic_uniform_tv`'s.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

from torch import Tensor

from motionlab.comparison import Sentence
from motionlab.diffusion.diagnostics import dynamic_uniform_tv
from motionlab.diffusion.schedule import Schedule


class MarkdownTable(str):
    """A Markdown table as a ``str`` that Jupyter renders (a cell's last line, or ``display(table)``)."""

    @classmethod
    def of(cls, header: Sequence[str], rows: Sequence[Sequence[object]], align: str = "right") -> MarkdownTable:
        """``header`` and ``rows`` of cells (each ``str()``-ed; an :class:`~motionlab.estimate.Estimate` prints as
        ``mean ± half-width``); the first column is left-aligned, the others ``align``-ed."""
        rule = "---:" if align == "right" else "---"

        def line(cells) -> str:  # a "|" inside a cell ("p(x0 | x_t)") would split it: escape it
            return "| " + " | ".join(str(c).replace("|", r"\|") for c in cells) + " |"

        lines = [line(header), "|---|" + f"{rule}|" * (len(header) - 1), *map(line, rows)]
        return cls("\n".join(lines))

    def _repr_markdown_(self) -> str:
        return str(self)


@dataclass(frozen=True)
class EtaDistances:
    """How far M2D2M's forward process is from VQ-Diffusion's, per η: the TV between the rows of the dynamic and
    the uniform Q̄_t (:func:`dynamic_uniform_tv`), and the cap K·β̄_t that no η can exceed.

    ``largest`` (η, T+1) is the largest over codes, ``mean`` (η, T+1) the mean weighted by code use; ``columns``
    are further per-η columns of the table (:meth:`with_column`, e.g. the FID of a model trained at each η), whose
    η's are then the table's rows. The table renders as Markdown (a cell's last line).
    """

    etas: tuple[float, ...]
    largest: Tensor
    mean: Tensor
    cap: Tensor  # (T+1,) K·β̄_t
    columns: tuple[tuple[str, dict[float, object]], ...] = ()

    def at(self, eta: float) -> float:
        """The largest TV over t and codes at ``eta`` (0 at η = 0: the processes are the same)."""
        if float(eta) == 0.0:
            return 0.0
        if float(eta) not in self.etas:
            raise KeyError(f"η = {eta} was not measured; measured: {list(self.etas)}")
        return float(self.largest[self.etas.index(float(eta))].max())

    @property
    def cap_T(self) -> float:
        """K·β̄_T: the most mass the replacement moves, the TV's ceiling."""
        return float(self.cap[-1])

    def half_cap(self) -> float | None:
        """The smallest measured η whose largest TV reaches half the cap (None: none does)."""
        return next((eta for eta in self.etas if self.at(eta) >= 0.5 * self.cap_T), None)

    def with_column(self, name: str, values: dict[float, object]) -> EtaDistances:
        """The table with a column ``name`` of ``values`` per η; its rows become the η's of ``values``."""
        return EtaDistances(self.etas, self.largest, self.mean, self.cap, (*self.columns, (name, dict(values))))

    def to_markdown(self) -> str:
        rows_etas = list(self.columns[0][1]) if self.columns else list(self.etas)
        header = ["η", "largest TV over t and codes", "share of the cap K·β̄_T", *(name for name, _ in self.columns)]
        rows = [
            [f"{eta:g}", f"{self.at(eta):.4f}", f"{100 * self.at(eta) / self.cap_T:.1f} %"]
            + [values.get(eta, "–") for _, values in self.columns]
            for eta in rows_etas
        ]
        return str(MarkdownTable.of(header, rows))

    def _repr_markdown_(self) -> str:
        return self.to_markdown()

    def describe(self, eta: float, others: Sequence[float] = ()) -> str:
        """A sentence: how much of a token's probability the dynamic process moves at ``eta`` (and at ``others``),
        against the cap, and where the TV reaches half of it."""
        tv = self.at(eta)
        also = "".join(f"; η = {e:g}: {self.at(e):.4f}" for e in others)
        half = self.half_cap()
        reach = (
            f"reaches half the cap only at η ≈ {half:g}"
            if half is not None
            else f"stays below half the cap even at η = {self.etas[-1]:g}"
        )
        return Sentence(
            f"At η = {eta:g} the dynamic forward process moves at most {tv:.4f} of a token's probability "
            f"({100 * tv:.2f} %{also}; the cap is K·β̄_T = {self.cap_T:.2f}), and {reach}."
        )


def eta_distances(
    schedule: Schedule,
    codebook: Tensor,
    etas: Sequence[float],
    weights: Tensor | None = None,
    distance: str = "l2_rank",
) -> EtaDistances:
    """:class:`EtaDistances` over ``etas``: the largest and the ``weights``-weighted mean (e.g. by code use) TV
    between the dynamic and the uniform forward process at every step (:func:`dynamic_uniform_tv`)."""
    etas = tuple(float(e) for e in etas)
    if any(e <= 0 for e in etas):
        raise ValueError(f"etas must be positive (η = 0 is the uniform process itself), got {list(etas)}")
    largest = dynamic_uniform_tv(schedule, codebook, etas, distance)
    mean = dynamic_uniform_tv(schedule, codebook, etas, distance, reduce="mean", weights=weights)
    return EtaDistances(etas, largest, mean, schedule.kbeta_bar.double().cpu())
