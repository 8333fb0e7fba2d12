"""``motionlab book stale``: which committed records a change to the code makes stale, before anything runs."""

from __future__ import annotations

import re

from motionlab import sizes
from motionlab.cli import main
from motionlab.report.stale import stale_records


def test_the_committed_records_measure_the_code_as_it_is(capsys):
    assert stale_records("laptop") == []
    assert main(["book", "stale"]) == 0
    assert "every committed laptop record measures the code as it is" in capsys.readouterr().out


def test_a_change_to_a_studied_model_lists_what_it_makes_stale(monkeypatch, capsys):
    """A wider feed-forward layer in the laptop denoiser: every record of a text-to-motion model goes stale (the scale
    points, the training-seed runs of both M2D2M studies, the budget and η models, the guidance spaces); DisCoRD's
    stay."""
    monkeypatch.setitem(sizes.DENOISER, "laptop", {**sizes.DENOISER["laptop"], "d_ff": 512})
    stale = stale_records("laptop")
    folders = {record.path.parent.parent.name for record in stale}
    assert folders == {"scale", "training_seeds", "m2d2m_budget", "m2d2m_eta", "guidance_space"}
    assert not any(record.path.name.startswith("discord") for record in stale)
    assert all("transformer.d_ff" in record.why for record in stale)
    assert all(re.fullmatch(r"\d+ min on .+, (bf16|fp32)", record.cost) for record in stale), [r.cost for r in stale]
    commands = {record.command.split()[2] for record in stale}  # PYTHONPATH=src python <script> ...
    scripts = ("scale", "training_seeds", "m2d2m_budget", "guidance_space")
    assert commands == {f"experiments/{script}.py" for script in scripts}
    assert main(["book", "stale"]) == 1
    out = capsys.readouterr().out
    assert out.startswith(f"{len(stale)} committed laptop record(s)") and "again: PYTHONPATH=src python" in out
