"""The determinism and compile run settings: resolved from options or the environment, exported, applied."""

from __future__ import annotations

import pytest
import torch

from motionlab.settings import RunSettings, apply_settings, resolve_settings, running_tasks
from motionlab.train.compiling import (
    GRAPHED,
    GRAPHED_ON_CUDA,
    LAUNCH_BOUND,
    compile_for_training,
    compile_mode,
    should_compile,
    uses_cuda_graphs,
)


def test_the_settings_come_from_options_then_the_environment(monkeypatch):
    monkeypatch.delenv("MOTIONLAB_DETERMINISTIC", raising=False)
    monkeypatch.delenv("MOTIONLAB_COMPILE", raising=False)
    plain = resolve_settings("smoke")
    assert (plain.deterministic, plain.compile) == (False, "auto")
    monkeypatch.setenv("MOTIONLAB_DETERMINISTIC", "1")
    monkeypatch.setenv("MOTIONLAB_COMPILE", "off")
    assert (resolve_settings("smoke").deterministic, resolve_settings("smoke").compile) == (True, "off")
    assert resolve_settings("smoke", deterministic=False, compile="on").compile == "on"
    monkeypatch.setenv("MOTIONLAB_DETERMINISTIC", "maybe")
    with pytest.raises(ValueError, match="MOTIONLAB_DETERMINISTIC"):
        resolve_settings("smoke")
    with pytest.raises(ValueError, match="compile"):
        RunSettings("smoke", compile="sometimes")


def test_applying_exports_them_and_switches_torch_to_deterministic_kernels(monkeypatch):
    monkeypatch.delenv("MOTIONLAB_THREADS", raising=False)  # a caller's thread count would be read back as the run's
    settings = apply_settings(RunSettings("smoke", "fp32", deterministic=True, compile="off"))
    assert torch.are_deterministic_algorithms_enabled() and torch.backends.cudnn.deterministic
    assert resolve_settings() == settings  # what a worker process reads back from the environment
    assert "deterministic kernels" in settings.describe() and "compile off" in settings.describe()
    apply_settings(RunSettings("smoke", "fp32"))
    assert not torch.are_deterministic_algorithms_enabled()


def test_compiling_is_cuda_only_under_auto_and_never_when_off(monkeypatch):
    assert not should_compile("discord", "cpu", "auto")  # never measured to pay on these CPUs
    assert should_compile("discord", "cuda", "auto") and not should_compile("denoiser", "cuda", "auto")
    assert should_compile("tokenizer", "cpu", "on") and not should_compile("discord", "cuda", "off")
    with pytest.raises(ValueError, match="part"):
        should_compile("vocoder", "cpu", "auto")
    monkeypatch.setenv("MOTIONLAB_COMPILE", "auto")
    layer = torch.nn.Linear(2, 2)
    assert not compile_for_training([layer], "discord", torch.device("cpu"))
    assert layer._compiled_call_impl is None  # left as it was


def test_cuda_graphs_only_for_the_launch_bound_networks_and_only_on_cuda():
    assert LAUNCH_BOUND == {"denoiser"} and GRAPHED_ON_CUDA <= LAUNCH_BOUND
    assert compile_mode("denoiser", "cuda", "graphs") == GRAPHED and uses_cuda_graphs("denoiser", "cuda:0", "graphs")
    assert compile_mode("discord", "cuda", "graphs") == "default"  # compiled, not graphed: it is not launch-bound
    assert compile_mode("denoiser", "cpu", "graphs") == "default"  # CUDA graphs need CUDA
    assert compile_mode("denoiser", "cuda", "on") == "default" and compile_mode("denoiser", "cuda", "off") is None
    # auto graphs nothing until bench_gpu.py shows that graphs pay; whoever changes that changes this line too
    assert GRAPHED_ON_CUDA == frozenset() and not uses_cuda_graphs("denoiser", "cuda", "auto")
    assert not uses_cuda_graphs("denoiser", "cpu", "auto") and compile_mode("tokenizer", "cuda", "auto") is None
    with pytest.raises(ValueError, match="compile setting"):
        compile_mode("denoiser", "cuda", "always")
    assert resolve_settings("smoke", compile="graphs").compile == "graphs"


@pytest.mark.filterwarnings("ignore::DeprecationWarning")  # importing torch's compiler stack warns about torch.jit
def test_a_trained_model_is_handed_back_uncompiled():
    from motionlab.train.compiling import release_compiled

    model = torch.nn.Sequential(torch.nn.Linear(2, 2), torch.nn.Linear(2, 1))
    model[0].compile()  # compiles lazily, at the first call: nothing is built here
    assert model[0]._compiled_call_impl is not None
    release_compiled(model)
    assert all(m._compiled_call_impl is None for m in model.modules())


def test_the_load_is_what_wants_a_core_now_not_the_last_minute(monkeypatch, tmp_path):
    import os

    from motionlab import settings
    from motionlab.build.plan import load_slowdown

    loadavg = tmp_path / "loadavg"
    loadavg.write_text("1.21 0.80 0.41 3/129 3941\n")  # the minute remembers a finished install; 3 runnable now
    assert running_tasks(seconds=0.05, every=0.01, source=str(loadavg))[:2] == [3, 3]
    assert running_tasks(source=str(tmp_path / "absent")) == []

    monkeypatch.setattr(os, "cpu_count", lambda: 2)
    monkeypatch.setattr(os, "getloadavg", lambda: (1.2, 0.8, 0.4))
    monkeypatch.setattr(settings, "running_tasks", lambda: [1, 1, 2, 1])  # this process, and a short task once
    assert settings.cpu_load() == 0.25  # the samples' mean less the reader itself, not the minute's 1.2
    assert settings.threads_for_load(settings.cpu_load()) is None and load_slowdown(2)[0] == 1.125
    monkeypatch.setattr(settings, "running_tasks", lambda: [3, 3, 3, 3])  # two busy programs beside the reader
    assert settings.cpu_load() == 2.0 and settings.threads_for_load(2.0) == 1 and load_slowdown(2) == (2.0, 2.0, 2)
    monkeypatch.setattr(settings, "running_tasks", lambda: [])  # no /proc (macOS): the minute's average
    assert settings.cpu_load() == 1.2
