"""Where classifier-free guidance acts, measured: the guidance-space records as results the claims' rules read.

``experiments/guidance_space.py`` scores the book's seed-0 text-to-motion models twice, on the same machine and in
the same precision: with guidance on p_θ(x_0 | x_t) (``"x0"``: the book's sampler, after VQ-Diffusion's code) and on
p_θ(x_{t-1} | x_t) (``"posterior"``: M2D2M's Eq. 9), each into
``book/data/guidance_space/embedded-v<N>/<profile>-<precision>-<space>.json``. :func:`load_guidance_study` reads
the two spaces of one precision, setting aside a record whose configs are no longer the code's
(:func:`motionlab.evaluation.studies.guidance_changes`), so that a departure row compares two runs that differ in
the guidance space only.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from .scale import record_results
from .store import Result

FOLDER = ("book", "data", "guidance_space")
SPACES = ("x0", "posterior")  # motionlab.diffusion.GUIDANCE_SPACES, in the order a row names them


@dataclass(frozen=True)
class GuidanceStudy:
    """Both guidance spaces' records of one precision: ``records[space]`` is one file's JSON."""

    profile: str
    records: dict[str, dict]
    set_aside: tuple[str, ...] = ()

    @property
    def where(self) -> str:
        """The machine and precision both spaces were scored on: ``AMD EPYC (avx512_bf16), bf16``."""
        record = self.records[SPACES[0]]
        return f"{record.get('cpu', record.get('device', '?'))}, {record.get('precision', '?')}"

    def results(self, space: str) -> dict[str, Result]:
        """Every claim number of ``space``'s record, as results the rules read."""
        if space not in self.records:
            raise KeyError(f"no {space!r} record; this study has {sorted(self.records)}")
        note = f"guidance-space study, guidance on {space}, the book's seed-0 models ({self.where})"
        return record_results(self.records[space], self.profile, note)


def read_guidance_records(folder: Path, profile: str) -> tuple[list[dict], list[str]]:
    """The guidance-space files of ``profile`` in ``folder`` that measured the code's models and evaluations, and a
    line per file set aside."""
    from motionlab.evaluation.studies import guidance_changes

    from .spread import read_current

    return read_current(folder, profile, guidance_changes, study="guidance_space")


def load_guidance_study(profile: str, folder: str | Path | None = None) -> GuidanceStudy | None:
    """The guidance-space study of ``profile``: both spaces scored in one precision (None where no precision has
    both). Read from the repository's ``book/data/guidance_space/embedded-v<N>`` of the current embedded data unless
    ``folder`` is given; where several precisions have both, the last by file name (fp32 after bf16)."""
    from .spread import study_folder

    folder = study_folder(FOLDER, folder)
    if folder is None or not folder.is_dir():
        return None
    found, set_aside = read_guidance_records(folder, profile)
    by_precision: dict[str, dict[str, dict]] = {}
    for record in found:
        by_precision.setdefault(record.get("precision", "?"), {})[record["guidance_on"]] = record
    complete = [records for records in by_precision.values() if set(SPACES) <= set(records)]
    if not complete:
        return None
    return GuidanceStudy(profile, complete[-1], tuple(set_aside))


__all__ = ["FOLDER", "SPACES", "GuidanceStudy", "load_guidance_study", "read_guidance_records"]
