"""Shared test fixtures: the real-data folder beside the project, an isolated cache root, the official evaluator's
downloaded layout."""

from __future__ import annotations

import os
import pickle
from pathlib import Path

import numpy as np
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


@pytest.fixture(scope="session")
def bench_gpu():
    """``benchmarks/bench_gpu.py`` as a module (with its sibling ``_timing`` importable): the benchmark's builders of
    the library's trainers are what the tests of those trainers' steps use too."""
    import sys

    benchmarks = str(REPO / "benchmarks")
    sys.path.insert(0, benchmarks)
    try:
        import bench_gpu

        yield bench_gpu
    finally:
        sys.path.remove(benchmarks)
        sys.modules.pop("bench_gpu", None)


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


RUN_SETTINGS = (
    "MOTIONLAB_PROFILE",
    "MOTIONLAB_PRECISION",
    "MOTIONLAB_THREADS",
    "MOTIONLAB_FORCE_PRECISION",
    "MOTIONLAB_DETERMINISTIC",
    "MOTIONLAB_COMPILE",
)


@pytest.fixture(autouse=True)
def idle_machine(monkeypatch):
    """Time estimates as on an idle machine: the plan line adds what the load seen now makes of an estimate
    (:func:`motionlab.build.plan.load_slowdown`), and a test's text must not depend on what else the CI machine
    runs. The load is read as the 1-minute average here (no /proc sample); tests of the load's effect set their
    own average."""
    from motionlab import settings

    monkeypatch.setattr(settings, "running_tasks", lambda *args, **kwargs: [])
    monkeypatch.setattr(os, "getloadavg", lambda: (0.0, 0.0, 0.0))


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
    deterministic = torch.are_deterministic_algorithms_enabled(), torch.is_deterministic_algorithms_warn_only_enabled()
    cudnn = torch.backends.cudnn.deterministic, torch.backends.cudnn.benchmark
    yield
    for name, value in saved.items():
        if value is None:
            os.environ.pop(name, None)
        else:
            os.environ[name] = value
    torch.use_deterministic_algorithms(deterministic[0], warn_only=deterministic[1])  # a run setting may set them
    torch.backends.cudnn.deterministic, torch.backends.cudnn.benchmark = cudnn


def pytest_configure(config):
    config.addinivalue_line("markers", "cpu_only(reason): holds on the CPU by nature; skipped on another device")


def pytest_collection_modifyitems(config, items):
    """Skip the ``cpu_only`` tests when ``$MOTIONLAB_DEVICE`` sends the library to another device."""
    device = os.environ.get("MOTIONLAB_DEVICE", "").strip()
    if not device or device.startswith("cpu"):
        return
    for item in items:
        marker = item.get_closest_marker("cpu_only")
        if marker is not None:
            reason = marker.args[0] if marker.args else "holds on the CPU only"
            item.add_marker(pytest.mark.skip(reason=f"CPU only ({device} requested): {reason}"))


GLOVE_WORDS = ["sos", "eos", "unk", "a", "person", "walk", "left"]


def _write_official_evaluator(root: Path, model, dataset: str = "t2m") -> None:
    """The official T2M evaluator's downloaded layout under ``root`` (``checkpoints/<dataset>/text_mot_match/model/
    finest.tar`` with ``model``'s weights under the official keys, ``Comp_v6_KLD005/meta``, ``glove/`` of 7 words)."""
    ckpt_dir = root / "checkpoints" / dataset / "text_mot_match" / "model"
    meta = root / "checkpoints" / dataset / "Comp_v6_KLD005" / "meta"
    glove = root / "glove"
    for d in (ckpt_dir, meta, glove):
        d.mkdir(parents=True)
    torch.save({**model.official_state(), "epoch": 7}, ckpt_dir / "finest.tar")
    rng = np.random.default_rng(0)
    dim = model.config.dim_pose
    np.save(meta / "mean.npy", rng.normal(size=dim).astype(np.float32))
    np.save(meta / "std.npy", rng.uniform(0.5, 2, size=dim).astype(np.float32))
    np.save(glove / "our_vab_data.npy", rng.normal(size=(len(GLOVE_WORDS), 300)).astype(np.float32))
    with open(glove / "our_vab_words.pkl", "wb") as f:
        pickle.dump(GLOVE_WORDS, f)
    with open(glove / "our_vab_idx.pkl", "wb") as f:
        pickle.dump({w: i for i, w in enumerate(GLOVE_WORDS)}, f)


@pytest.fixture
def official_evaluator_layout():
    """``write(root, model, dataset="t2m")``: the official evaluator's files under ``root``, as its download script
    leaves them, holding ``model``'s (a :class:`~motionlab.metrics.TextMotionEvaluator`) weights."""
    return _write_official_evaluator
