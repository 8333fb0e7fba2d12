"""papermill drives a chapter through its ``parameters`` cell: the injected profile is the one used."""

from __future__ import annotations

from pathlib import Path

import nbformat
import pytest

pm = pytest.importorskip("papermill")

REPO = Path(__file__).resolve().parents[2]
CHAPTER = REPO / "notebooks" / "99_what_reproduces.ipynb"


def test_papermill_injects_the_profile(tmp_path, monkeypatch):
    # The environment says "full"; the injected parameter must win over it.
    monkeypatch.setenv("MOTIONLAB_PROFILE", "full")
    monkeypatch.setenv("MOTIONLAB_RESULTS", str(tmp_path / "results"))
    out = tmp_path / "out.ipynb"
    pm.execute_notebook(
        str(CHAPTER),
        str(out),
        parameters={"profile": "smoke"},
        kernel_name="python3",
        cwd=str(REPO),
        progress_bar=False,
        execution_timeout=300,
    )

    nb = nbformat.read(out, as_version=4)
    assert nb.metadata.papermill.parameters == {"profile": "smoke"}
    tags = [c.metadata.get("tags", []) for c in nb.cells]
    params = next(i for i, t in enumerate(tags) if "parameters" in t)
    assert "injected-parameters" in tags[params + 1], "papermill did not inject right after `parameters`"
    assert 'profile = "smoke"' in nb.cells[params + 1].source
    printed = "".join(o.get("text", "") for c in nb.cells if c.cell_type == "code" for o in c.outputs)
    assert "profile: smoke" in printed
    assert (tmp_path / "results" / "smoke").is_dir() and not (tmp_path / "results" / "full").exists()
