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


RUN_SETTINGS = ("MOTIONLAB_PROFILE", "MOTIONLAB_PRECISION", "MOTIONLAB_THREADS", "MOTIONLAB_FORCE_PRECISION")


@pytest.fixture(autouse=True)
def fp32_run_settings():
    """Unit tests run in fp32, whatever the CPU: the exactness checks against the official code are fp32 checks,
    and the bf16 path has tests of its own that ask for it. A test that applies run settings (every CLI call
    does: they are exported to the environment) must not leak them into the next test. A test that asks for bf16
    gets it on any CPU (its models are tiny): the refusal of bf16 where a CPU has no bf16 instructions has tests of
    its own, which clear ``MOTIONLAB_FORCE_PRECISION``."""
    saved = {name: os.environ.get(name) for name in RUN_SETTINGS}
    os.environ["MOTIONLAB_PRECISION"] = "fp32"
    os.environ["MOTIONLAB_FORCE_PRECISION"] = "1"
    yield
    for name, value in saved.items():
        if value is None:
            os.environ.pop(name, None)
        else:
            os.environ[name] = value
