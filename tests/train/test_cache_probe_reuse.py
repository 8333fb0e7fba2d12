"""reuse_probed_models: a command that probes its plan and then runs it loads each cached model once."""

from __future__ import annotations

import os
from dataclasses import dataclass

import pytest
from torch import nn

from motionlab.train import train_or_load
from motionlab.train.cache import NotCached, artefact_dir, cache_probe, reuse_probed_models


@dataclass
class Config:
    hidden: int = 3


class Builds:
    """A build_fn that counts its calls (each load builds the model once)."""

    def __init__(self):
        self.calls = 0

    def __call__(self, config: Config) -> nn.Module:
        self.calls += 1
        return nn.Linear(2, config.hidden)


def no_training(model, workdir):
    return {}


@pytest.fixture(autouse=True)
def home(tmp_path, monkeypatch):
    monkeypatch.setenv("MOTIONLAB_HOME", str(tmp_path))
    train_or_load("toy", Config(), Builds(), no_training, "smoke", device="cpu")  # the cached artefact
    return tmp_path


def load(build: Builds, config: Config | None = None, **kwargs) -> nn.Module:
    return train_or_load("toy", config or Config(), build, no_training, "smoke", device="cpu", **kwargs)


def test_the_probe_s_model_is_handed_to_the_command_once():
    build = Builds()
    with reuse_probed_models():
        with cache_probe():
            probed = load(build)
        assert load(build) is probed and build.calls == 1  # not read and verified again
        again = load(build)  # handed over once: a second load is a load of its own
        assert again is not probed and build.calls == 2


def test_without_the_block_nothing_is_kept():
    build = Builds()
    with cache_probe():
        probed = load(build)
    assert load(build) is not probed and build.calls == 2
    with reuse_probed_models():
        with cache_probe():
            load(build)
    assert load(build) is not probed and build.calls == 4  # dropped when the block ended


def test_a_rewritten_weights_file_or_retrain_is_loaded_anew(home):
    build = Builds()
    with reuse_probed_models():
        with cache_probe():
            probed = load(build)
        weights = artefact_dir("toy", Config(), "smoke") / "model.safetensors"
        stat = weights.stat()
        os.utime(weights, ns=(stat.st_atime_ns, stat.st_mtime_ns + 1_000_000))
        assert load(build) is not probed and build.calls == 2
        with cache_probe():
            probed = load(build)
        retrained = load(build, retrain=True)
        assert retrained is not probed


def test_a_missing_model_is_still_reported_by_the_probe():
    with reuse_probed_models(), cache_probe(), pytest.raises(NotCached):
        load(Builds(), Config(hidden=5))
