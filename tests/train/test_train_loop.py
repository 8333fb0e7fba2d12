"""The shared training loop: learning, schedules, EMA, checkpoints and bit-identical resume."""

import json
import math
import os
import signal
import subprocess
import sys

import pytest
import torch
from torch import nn

from motionlab.train import (
    EMA,
    TrainConfig,
    Trainer,
    latest_checkpoint,
    list_checkpoints,
    load_checkpoint,
    lr_multiplier,
    save_checkpoint,
    seeded,
)

TRUE_W = torch.tensor([[1.5, -2.0, 0.5]])


def regression_batch(step, generator):
    x = torch.randn(16, 3, generator=generator)
    return x, x @ TRUE_W.t()


def noisy_mse(model, batch, generator):
    """MSE with input noise from the trainer's noise generator, so resume must restore it too."""
    x, y = batch
    x = x + 0.01 * torch.randn(x.shape, generator=generator, device=generator.device).to(x.device)
    loss = ((model(x) - y) ** 2).mean()
    return {"loss": loss, "abs_err": (model(x) - y).abs().mean()}


def make_model():
    with seeded(0):
        return nn.Sequential(nn.Linear(3, 8), nn.Dropout(0.1), nn.Linear(8, 1))


def assert_same_run(resumed, straight):
    """Weights, EMA weights and logged history equal bit for bit."""
    for k, v in straight.model.state_dict().items():
        assert torch.equal(v, resumed.model.state_dict()[k]), k
    for k, v in straight.ema.shadow.items():
        assert torch.equal(v, resumed.ema.shadow[k]), k
    assert resumed.history == straight.history


def config(**kw):
    base = dict(steps=20, lr=1e-2, schedule="cosine", warmup_steps=3, log_every=2, ema_decay=0.9, grad_clip=1.0)
    return TrainConfig(**{**base, **kw})


def test_loss_decreases_on_linear_regression():
    with seeded(0):
        model = nn.Linear(3, 1)
    history = Trainer(model, noisy_mse, regression_batch, config(steps=150, lr=3e-2), progress=False).fit()
    losses = [r["loss"] for r in history if "loss" in r]
    assert losses[-1] < 0.01 * losses[0]
    assert torch.allclose(model.weight.cpu(), TRUE_W, atol=0.05)
    assert "grad_norm" in history[-1] and "abs_err" in history[-1]


def test_loss_fn_must_return_loss_and_finite():
    model = make_model()
    with pytest.raises(ValueError, match="'loss'"):
        Trainer(model, lambda m, b, g: {"mse": torch.tensor(1.0)}, regression_batch, config(), progress=False).fit()
    nan_loss = lambda m, b, g: {"loss": m(b[0]).sum() * float("nan")}  # noqa: E731
    with pytest.raises(FloatingPointError):
        Trainer(make_model(), nan_loss, regression_batch, config(), progress=False).fit()


def test_schedules_warm_up_then_decay():
    cos = [lr_multiplier(s, schedule="cosine", warmup_steps=10, total_steps=100, min_lr_ratio=0.1) for s in range(120)]
    assert cos[:10] == pytest.approx([(s + 1) / 10 for s in range(10)])  # linear warm-up to the peak
    assert max(cos) == pytest.approx(1.0) and cos[10] == pytest.approx(1.0)
    assert all(a >= b for a, b in zip(cos[10:], cos[11:]))  # then non-increasing
    assert cos[100] == pytest.approx(0.1) and cos[119] == pytest.approx(0.1)  # floor after the end
    assert cos[55] == pytest.approx(0.1 + 0.45 * (1 + math.cos(math.pi * 0.5)))

    ms = [lr_multiplier(s, schedule="multistep", warmup_steps=5, milestones=(20, 40), gamma=0.05) for s in range(50)]
    assert ms[:5] == pytest.approx([0.2, 0.4, 0.6, 0.8, 1.0])
    assert ms[19] == 1.0 and ms[20] == pytest.approx(0.05) and ms[40] == pytest.approx(0.0025)
    with pytest.raises(ValueError, match="schedule"):
        lr_multiplier(0, schedule="linear")


def test_trainer_applies_the_schedule():
    model = make_model()
    cfg = config(steps=10, schedule="multistep", warmup_steps=2, milestones=(5,), gamma=0.1)
    trainer = Trainer(model, noisy_mse, regression_batch, cfg, progress=False)
    seen = []
    for _ in range(10):
        trainer.train_step()
        seen.append(trainer.optimizer.param_groups[0]["lr"])
    assert seen == pytest.approx([5e-3, 1e-2, 1e-2, 1e-2, 1e-2] + [1e-3] * 5)


def test_ema_update_and_apply():
    model = nn.Linear(2, 1)
    ema = EMA(model, decay=0.75)
    before = model.weight.detach().clone()
    with torch.no_grad():
        model.weight.add_(4.0)
    ema.update(model)
    assert torch.allclose(ema.shadow["weight"], 0.75 * before + 0.25 * (before + 4.0))
    trained = model.weight.detach().clone()
    with ema.apply_to(model):
        assert torch.allclose(model.weight, ema.shadow["weight"])
    assert torch.equal(model.weight, trained)  # training weights are back
    with pytest.raises(ValueError):
        EMA(model, decay=1.0)


def test_checkpoint_round_trip(tmp_path):
    model = make_model()
    opt = torch.optim.AdamW(model.parameters(), lr=1e-3)
    model(torch.randn(4, 3)).sum().backward()
    opt.step()
    ema, gen = EMA(model, 0.9), torch.Generator().manual_seed(7)
    path = save_checkpoint(tmp_path, 3, model, opt, ema, {"data": gen}, {"note": "hi"})
    expected_next = torch.rand(3, generator=gen)

    other = nn.Sequential(nn.Linear(3, 8), nn.Dropout(0.1), nn.Linear(8, 1))
    other_opt = torch.optim.AdamW(other.parameters(), lr=1e-3)
    other_ema, other_gen = EMA(other, 0.9), torch.Generator().manual_seed(0)
    meta = load_checkpoint(path, other, other_opt, other_ema, {"data": other_gen})
    assert meta == {"step": 3, "note": "hi"}
    for a, b in zip(model.state_dict().values(), other.state_dict().values()):
        assert torch.equal(a, b)
    assert torch.equal(other_opt.state_dict()["state"][0]["exp_avg"], opt.state_dict()["state"][0]["exp_avg"])
    assert torch.equal(torch.rand(3, generator=other_gen), expected_next)
    with pytest.raises(ValueError, match="do not fit"):
        load_checkpoint(path, nn.Linear(3, 1))


def test_failed_save_leaves_nothing(tmp_path, monkeypatch):
    model = make_model()
    save_checkpoint(tmp_path, 1, model)

    def boom(*args, **kwargs):
        raise OSError("disk full")

    monkeypatch.setattr(torch, "save", boom)
    with pytest.raises(OSError):
        save_checkpoint(tmp_path, 2, model)
    assert [p.name for p in tmp_path.iterdir()] == ["step_00000001"]  # no half-written folder
    assert latest_checkpoint(tmp_path).name == "step_00000001"


def test_resume_is_bit_identical(tmp_path):
    cfg = config(steps=20, ckpt_every=0)
    straight = Trainer(make_model(), noisy_mse, regression_batch, cfg, progress=False)
    straight.fit()

    first = Trainer(make_model(), noisy_mse, regression_batch, cfg, workdir=tmp_path, progress=False)
    first.fit(until=9)  # an odd split: the log interval (2) is cut in the middle
    assert latest_checkpoint(tmp_path).name == "step_00000009"
    resumed = Trainer(make_model(), noisy_mse, regression_batch, cfg, workdir=tmp_path, progress=False)
    assert resumed.step == 9
    resumed.fit()

    assert_same_run(resumed, straight)
    # a different schedule cannot silently continue an old run
    with pytest.raises(ValueError, match="lr"):
        Trainer(make_model(), noisy_mse, regression_batch, config(steps=20, lr=0.5), workdir=tmp_path, progress=False)


def ctrl_c_at(steps, signals=1, signum=signal.SIGINT):
    """``noisy_mse`` that sends this process ``signals`` of ``signum`` (SIGINT: Ctrl-C) during each step in ``steps``
    (counted from 1)."""
    seen = []

    def loss_fn(model, batch, generator):
        seen.append(None)
        if len(seen) in steps:
            for _ in range(signals):
                os.kill(os.getpid(), signum)
        return noisy_mse(model, batch, generator)

    return loss_fn


class Terminated(Exception):
    """What the SIGTERM handler of these tests raises (a scheduler's job, a lease's script: they clean up)."""


@pytest.fixture
def sigterm_handler():
    """A Python SIGTERM handler for the test, so a SIGTERM cannot end pytest; its calls are counted."""
    calls = []

    def handler(signum, frame):
        calls.append(signum)
        raise Terminated

    previous = signal.signal(signal.SIGTERM, handler)
    yield handler, calls
    signal.signal(signal.SIGTERM, previous)


def test_ctrl_c_checkpoints_the_step_it_arrives_in_and_the_run_resumes_bit_identically(tmp_path):
    cfg = config(steps=20, ckpt_every=5)
    straight = Trainer(make_model(), noisy_mse, regression_batch, cfg, progress=False)
    straight.fit()

    handler = signal.getsignal(signal.SIGINT)
    interrupted = Trainer(make_model(), ctrl_c_at({7}), regression_batch, cfg, workdir=tmp_path, progress=False)
    with pytest.raises(KeyboardInterrupt, match="step 7"):
        interrupted.fit()
    assert signal.getsignal(signal.SIGINT) is handler  # the caller's handler is back
    assert interrupted.step == 7  # the step under way finished; no later one started
    assert latest_checkpoint(tmp_path).name == "step_00000007"  # not the periodic one of step 5

    resumed = Trainer(make_model(), noisy_mse, regression_batch, cfg, workdir=tmp_path, progress=False)
    assert resumed.step == 7
    resumed.fit()
    assert_same_run(resumed, straight)


def test_a_sigterm_checkpoints_its_step_before_the_handler_that_was_there_runs(tmp_path, sigterm_handler):
    handler, calls = sigterm_handler
    cfg = config(steps=20, ckpt_every=5)
    straight = Trainer(make_model(), noisy_mse, regression_batch, cfg, progress=False)
    straight.fit()

    cut = Trainer(make_model(), ctrl_c_at({7}, signum=signal.SIGTERM), regression_batch, cfg, workdir=tmp_path)
    with pytest.raises(Terminated):
        cut.fit()
    assert calls == [signal.SIGTERM]  # the caller's handler ran once, after the step and its checkpoint
    assert signal.getsignal(signal.SIGTERM) is handler
    assert cut.step == 7 and latest_checkpoint(tmp_path).name == "step_00000007"

    resumed = Trainer(make_model(), noisy_mse, regression_batch, cfg, workdir=tmp_path, progress=False)
    resumed.fit()
    assert_same_run(resumed, straight)


def test_a_sigterm_handler_that_returns_still_stops_the_training(tmp_path):
    previous = signal.signal(signal.SIGTERM, lambda signum, frame: None)  # a process that goes on after SIGTERM
    try:
        cut = Trainer(make_model(), ctrl_c_at({4}, signum=signal.SIGTERM), regression_batch, config(), workdir=tmp_path)
        with pytest.raises(KeyboardInterrupt, match="step 4"):  # never a silent early return
            cut.fit()
    finally:
        signal.signal(signal.SIGTERM, previous)
    assert latest_checkpoint(tmp_path).name == "step_00000004"


def test_a_second_sigterm_acts_at_once(tmp_path, sigterm_handler):
    cut = Trainer(make_model(), ctrl_c_at({7}, 2, signal.SIGTERM), regression_batch, config(), workdir=tmp_path)
    with pytest.raises(Terminated):
        cut.fit()
    assert sigterm_handler[1] == [signal.SIGTERM]
    assert cut.step == 6 and latest_checkpoint(tmp_path) is None  # raised inside step 7: nothing saved


def test_without_a_workdir_a_sigterm_acts_at_once(sigterm_handler):
    trainer = Trainer(make_model(), ctrl_c_at({3}, signum=signal.SIGTERM), regression_batch, config(), progress=False)
    with pytest.raises(Terminated):
        trainer.fit()
    assert trainer.step == 2


@pytest.mark.skipif(not hasattr(signal, "SIGKILL"), reason="POSIX signals")
def test_a_process_ended_by_sigterm_leaves_the_checkpoint_of_its_last_step(tmp_path):
    """By default a SIGTERM ends the process, as before, but one step later, with that step checkpointed."""
    script = f"""
import os, signal, torch
from torch import nn
from motionlab.train import TrainConfig, Trainer

def batch(step, generator):
    x = torch.randn(8, 3, generator=generator)
    return x, x.sum(1, keepdim=True)

def loss(model, b, generator):
    if model.calls == 5:
        os.kill(os.getpid(), signal.SIGTERM)
    model.calls += 1
    return {{"loss": ((model(b[0]) - b[1]) ** 2).mean()}}

model = nn.Linear(3, 1)
model.calls = 0
Trainer(model, loss, batch, TrainConfig(steps=50, ckpt_every=0), workdir={str(tmp_path)!r}, progress=False).fit()
print("not reached")
"""
    done = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=300)
    assert done.returncode == -signal.SIGTERM, done.stderr
    assert "not reached" not in done.stdout
    assert latest_checkpoint(tmp_path).name == "step_00000006"  # the step the signal came in


def test_each_process_that_trains_a_model_is_one_sitting_of_its_checkpoints(tmp_path):
    cfg = config(steps=20, ckpt_every=0)
    Trainer(make_model(), noisy_mse, regression_batch, cfg, workdir=tmp_path, progress=False).fit(until=12)
    resumed = Trainer(make_model(), noisy_mse, regression_batch, cfg, workdir=tmp_path, progress=False)
    assert [s["steps"] for s in resumed.sittings] == [[0, 12]]  # read back from the checkpoint
    resumed.fit()
    resumed.fit()  # nothing left to train: no sitting
    first, second = resumed.sittings
    assert second["steps"] == [12, 20] and first["seconds"] > 0 and second["seconds"] > 0
    assert second["device"] == "cpu" and second["threads"] == torch.get_num_threads() and second["ranks"] == 1
    meta = json.loads((latest_checkpoint(tmp_path) / "meta.json").read_text())
    assert [s["steps"] for s in meta["sittings"]] == [[0, 12], [12, 20]]  # the last checkpoint lists both


def test_a_checkpoint_from_before_sittings_resumes_with_its_time_unknown(tmp_path):
    cfg = config(steps=20, ckpt_every=0)
    Trainer(make_model(), noisy_mse, regression_batch, cfg, workdir=tmp_path, progress=False).fit(until=5)
    meta_path = latest_checkpoint(tmp_path) / "meta.json"
    meta = json.loads(meta_path.read_text())
    del meta["sittings"]
    meta_path.write_text(json.dumps(meta))
    resumed = Trainer(make_model(), noisy_mse, regression_batch, cfg, workdir=tmp_path, progress=False)
    resumed.fit()
    assert [(s["steps"], s["seconds"] is None) for s in resumed.sittings] == [([0, 5], True), ([5, 20], False)]


def test_a_second_ctrl_c_interrupts_at_once(tmp_path):
    trainer = Trainer(make_model(), ctrl_c_at({7}, signals=2), regression_batch, config(), workdir=tmp_path)
    with pytest.raises(KeyboardInterrupt) as raised:
        trainer.fit()
    assert "step" not in str(raised.value)  # raised inside the step, not after its checkpoint
    assert trainer.step == 6
    assert latest_checkpoint(tmp_path) is None


def test_without_a_workdir_ctrl_c_interrupts_at_once():
    trainer = Trainer(make_model(), ctrl_c_at({3}), regression_batch, config(), progress=False)
    with pytest.raises(KeyboardInterrupt):
        trainer.fit()
    assert trainer.step == 2  # nothing to save, so nothing to wait for


def test_a_process_that_ignores_ctrl_c_goes_on_ignoring_it(tmp_path):
    previous = signal.signal(signal.SIGINT, signal.SIG_IGN)  # as in a non-interactive shell's background job
    try:
        trainer = Trainer(make_model(), ctrl_c_at({3}), regression_batch, config(), workdir=tmp_path, progress=False)
        trainer.fit()
        assert trainer.step == 20
        assert signal.getsignal(signal.SIGINT) is signal.SIG_IGN
    finally:
        signal.signal(signal.SIGINT, previous)


def test_periodic_checkpoints_and_validation(tmp_path):
    cfg = config(steps=12, ckpt_every=4, keep_checkpoints=2, val_every=6)
    calls = []

    def val_fn(model):
        calls.append(model.training)
        return {"mse": 1.0}

    history = Trainer(
        make_model(), noisy_mse, regression_batch, cfg, val_fn=val_fn, workdir=tmp_path, progress=False
    ).fit()
    assert [p.name for p in list_checkpoints(tmp_path)] == ["step_00000008", "step_00000012"]
    assert calls == [False, False]  # validated twice, in eval mode
    assert [r["step"] for r in history if "val_mse" in r] == [6, 12]


def test_a_non_finite_loss_stops_training_at_the_next_log_line_naming_its_step(tmp_path):
    def nan_from_step_3(model, batch, generator):
        loss = noisy_mse(model, batch, generator)["loss"]
        return {"loss": loss * float("nan") if trainer.step >= 3 else loss}

    trainer = Trainer(make_model(), nan_from_step_3, regression_batch, config(log_every=5), workdir=tmp_path)
    with pytest.raises(FloatingPointError, match="at step 3"):
        trainer.fit()
    assert trainer.step == 5  # found when the step-5 log line reads the sums
    assert latest_checkpoint(tmp_path) is None  # nothing a NaN has touched is saved


def test_a_train_step_returns_its_logged_terms_as_tensors_without_graphs():
    trainer = Trainer(make_model(), noisy_mse, regression_batch, config(), progress=False)
    logged = trainer.train_step()
    assert set(logged) == {"loss", "abs_err", "grad_norm"}
    assert all(torch.is_tensor(v) and v.ndim == 0 and not v.requires_grad for v in logged.values())


def test_fit_reads_the_device_once_per_log_line_not_once_per_step(monkeypatch):
    """On a GPU every read of a tensor's value waits for the queue to drain: ``fit`` may read its logged sums at a log
    line, never in the steps between. Count every read of a value over runs of 10, 20 and 30 steps, a log line every
    10: each window of steps adds the same reads, and at most two (a read per step would add ten). torch's AdamW
    reads its step counters, CPU tensors, on the CPU path and none on CUDA's fused one: its reads are not counted."""
    reads = {"n": 0, "optimizing": False}
    for name in ("item", "tolist", "__float__", "__int__", "__bool__"):
        original = getattr(torch.Tensor, name)

        def counted(self, *args, _original=original, **kwargs):
            reads["n"] += not reads["optimizing"]
            return _original(self, *args, **kwargs)

        monkeypatch.setattr(torch.Tensor, name, counted)
    adamw_step = torch.optim.AdamW.step

    def uncounted_step(self, *args, **kwargs):
        reads["optimizing"] = True
        try:
            return adamw_step(self, *args, **kwargs)
        finally:
            reads["optimizing"] = False

    monkeypatch.setattr(torch.optim.AdamW, "step", uncounted_step)

    def reads_in_fit(steps: int) -> int:
        trainer = Trainer(make_model(), noisy_mse, regression_batch, config(steps=steps, log_every=10), progress=False)
        reads["n"] = 0
        trainer.fit()
        return reads["n"]

    counts = [reads_in_fit(steps) for steps in (10, 20, 30)]
    per_window = {b - a for a, b in zip(counts, counts[1:])}
    assert len(per_window) == 1 and per_window.pop() <= 2, counts


def test_a_batch_source_with_to_is_moved_to_the_training_device_once():
    moved = []

    class Source:
        def to(self, device):
            moved.append(torch.device(device))
            return self

        def __call__(self, step, generator):
            return regression_batch(step, generator)

    Trainer(make_model(), noisy_mse, Source(), config(steps=3), progress=False, device="cpu").fit()
    assert moved == [torch.device("cpu")]


def test_the_trainer_takes_torchs_adamw_per_tensor_in_fp32_and_fused_in_bf16_on_the_cpu():
    """fp32 on the CPU keeps the per-tensor update the cached models were trained with; bf16 takes the fused kernel."""
    for precision, fused, foreach in (("fp32", None, False), ("bf16", True, None)):
        trainer = Trainer(
            make_model(), noisy_mse, regression_batch, config(), progress=False, device="cpu", precision=precision
        )
        assert type(trainer.optimizer) is torch.optim.AdamW
        assert (trainer.optimizer.defaults["fused"], trainer.optimizer.defaults["foreach"]) == (fused, foreach)


def test_the_ema_update_is_the_per_tensor_lerp_bit_for_bit():
    model = make_model()
    model.register_buffer("count", torch.tensor(3))
    ema = EMA(model, decay=0.97)
    expected = {k: v.clone() for k, v in ema.shadow.items()}
    generator = torch.Generator().manual_seed(0)
    for _ in range(5):
        with torch.no_grad():
            for p in model.parameters():
                p.add_(torch.randn(p.shape, generator=generator))
            model.count += 1
        ema.update(model)
        for name, value in model.state_dict().items():
            if value.is_floating_point():
                expected[name].lerp_(value, 1.0 - 0.97)
            else:
                expected[name].copy_(value)
    assert all(torch.equal(ema.shadow[k], expected[k]) for k in expected)
