"""Shared test fixtures: the real-data folder beside the project, and an isolated cache root."""

from __future__ import annotations

import os
from pathlib import Path

import pytest
import torch

REPO = Path(__file__).resolve().parents[1]
SHARED_DATA = Path(os.environ.get("MOTIONLAB_SHARED", REPO.parent / "shared")) / "data"


@pytest.fixture
def shared_data() -> Path:
    """``../shared/data`` (real clips, test fixtures only); skips the test where it is absent."""
    if not SHARED_DATA.is_dir():
        pytest.skip(f"real-data fixtures not found at {SHARED_DATA}")
    return SHARED_DATA


@pytest.fixture
def isolated_cache(tmp_path, monkeypatch) -> Path:
    """Point motionlab's cache root at a temporary folder."""
    root = tmp_path / "motionlab-home"
    monkeypatch.setenv("MOTIONLAB_HOME", str(root))
    return root


@pytest.fixture(autouse=True, scope="session")
def one_torch_thread():
    """Unit tests use tiny models: a second torch thread only adds hand-offs (and on a busy 2-core machine,
    spinning threads make a one-second test take a minute)."""
    previous = torch.get_num_threads()
    torch.set_num_threads(1)
    yield
    torch.set_num_threads(previous)
