"""Training DisCoRD on a frozen tokenizer's codes: the loss falls, the cache trains once, decoding shapes."""

from __future__ import annotations

import numpy as np
import pytest
import torch

import motionlab.flow.training as flow_training
from motionlab.data import load_dataset
from motionlab.data.embedded import write_embedded_dataset
from motionlab.flow import DisCoRDDecoder, discord_config, discord_training_log, train_or_load_discord
from motionlab.flow.training import code_vectors, loss_at_time, noise_floor, token_window_batches, tokenizer_key
from motionlab.tokenizers import build_tokenizer, rvq_config, train_tokenizer
from motionlab.train import TrainConfig, WindowDataset, artefact_dir

STEPS = 40


@pytest.fixture(scope="module")
def dataset(tmp_path_factory):
    """A tiny embedded dataset (42 clips: 14 train / 14 val / 14 test), written once for the module."""
    return load_dataset(write_embedded_dataset(tmp_path_factory.mktemp("data") / "tiny", n_clips=42, progress=False))


@pytest.fixture(scope="module")
def tokenizer(dataset):
    """A smoke-sized residual tokenizer, briefly trained (it only has to produce codes)."""
    config = rvq_config("smoke", train=TrainConfig(steps=15, lr=2e-3, log_every=5))
    model = build_tokenizer(config)
    train_tokenizer(model, dataset.normalized("train"), progress=False)
    return model.eval()


def tiny_config(tokenizer, **kw):
    settings = dict(train_steps=STEPS, warmup_steps=4, batch_size=16, lr=5e-3)
    return discord_config("smoke", tokenizer=tokenizer, **{**settings, **kw})


def test_train_once_then_load(dataset, tokenizer, isolated_cache, monkeypatch):
    config = tiny_config(tokenizer)
    decoder = train_or_load_discord(dataset, tokenizer, "smoke", config=config, progress=False)
    assert isinstance(decoder, DisCoRDDecoder) and not decoder.training and decoder.tokenizer is tokenizer

    log = discord_training_log(dataset, tokenizer, "smoke", config=config)
    losses = np.array([row["loss"] for row in log["history"] if "loss" in row])
    assert log["steps"] == STEPS and len(losses) == STEPS  # one row per step at this length
    assert losses[-10:].mean() < 0.95 * losses[:10].mean(), losses  # measured: 2.52 -> 2.13
    val = np.array([row["val_loss"] for row in log["history"] if "val_loss" in row])  # fixed held-out windows
    assert len(val) == 10 and (np.diff(val) < 0).all() and val[-1] < 0.95 * val[0], val  # measured: 2.56 -> 2.21
    assert log["cpu_seconds"] > 0 and log["seconds"] > 0

    # the second call loads: training would raise
    def no_training(*args, **kwargs):
        raise AssertionError("the cached decoder should have been loaded")

    monkeypatch.setattr(flow_training, "train_discord", no_training)
    again = train_or_load_discord(dataset, tokenizer, "smoke", config=config, progress=False)
    for (name, a), (_, b) in zip(decoder.state_dict().items(), again.state_dict().items()):
        assert torch.equal(a, b), name

    # another tokenizer (config) means another decoder: not in the cache
    other = build_tokenizer(rvq_config("smoke", seed=1))
    assert tokenizer_key(other, dataset.key) != tokenizer_key(tokenizer, dataset.key)
    with pytest.raises(AssertionError, match="cached decoder"):
        train_or_load_discord(dataset, other, "smoke", config=tiny_config(other), progress=False)


def test_cached_weights_are_the_ema_average(dataset, tokenizer, isolated_cache):
    config = tiny_config(tokenizer, train_steps=6, warmup_steps=1)
    trained = train_or_load_discord(dataset, tokenizer, "smoke", config=config, progress=False)
    cached = {name: tensor.cpu() for name, tensor in trained.state_dict().items()}
    model, clips = DisCoRDDecoder(config), dataset.normalized("train")
    trainer = flow_training.discord_trainer(model, tokenizer, clips, progress=False)
    trainer.fit()  # the same seeds: the same run (the cached one's validation does not perturb it)
    raw = {name: tensor.cpu() for name, tensor in trainer.model.state_dict().items()}
    assert trainer.ema is not None and trainer.ema.shadow
    for name, average in trainer.ema.shadow.items():
        assert torch.allclose(cached[name], average.cpu(), atol=1e-6), name
    assert any(not torch.allclose(cached[n], raw[n], atol=1e-6) for n in trainer.ema.shadow)  # not the last step's


def test_decoding_shapes_after_training(dataset, tokenizer, isolated_cache):
    decoder = train_or_load_discord(
        dataset, tokenizer, "smoke", config=tiny_config(tokenizer, train_steps=4), progress=False
    )
    clip = torch.as_tensor(dataset.normalized("test")[0][:44])[None]  # (1, 44, 263): 11 tokens
    ids = tokenizer.encode(clip)  # (1, 11, R)
    assert ids.shape == (1, 11, tokenizer.num_layers)
    motion = decoder.decode(ids, steps=2, seed=3)
    assert motion.shape == (1, 44, 263) and torch.isfinite(motion).all()
    assert torch.equal(motion, decoder.decode(ids, steps=2, seed=3))  # a seed fixes the decode


def test_batches_pair_windows_with_their_codes(dataset, tokenizer):
    windows = WindowDataset(dataset.normalized("train"), 16)
    motion, codes = token_window_batches(windows, tokenizer, 5)(0, torch.Generator().manual_seed(0))
    assert motion.shape == (5, 16, 263) and codes.shape == (5, 4, tokenizer.code_dim)
    assert torch.equal(codes, code_vectors(tokenizer, motion))
    assert not codes.requires_grad


def test_tokenizer_key_is_the_tokenizers_cache_folder(dataset, tokenizer):
    expected = artefact_dir("rvq", tokenizer.config, "smoke", {"data": dataset.key}).name
    assert tokenizer_key(tokenizer, dataset.key) == expected


def test_input_checks(dataset, tokenizer):
    with pytest.raises(ValueError, match="MotionDataset"):
        train_or_load_discord(object(), tokenizer, "smoke")
    with pytest.raises(ValueError, match="DisCoRDConfig"):
        train_or_load_discord(dataset, tokenizer, "smoke", config={"width": 8})
    with pytest.raises(ValueError, match="config"):
        tokenizer_key(object(), dataset.key)
    with pytest.raises(ValueError, match="batch_size"):
        token_window_batches(WindowDataset(dataset.normalized("train"), 16), tokenizer, 0)
    mismatched = discord_config("smoke", code_dim=tokenizer.code_dim + 1)
    with pytest.raises(ValueError, match="code_dim"):
        flow_training.train_discord(DisCoRDDecoder(mismatched), tokenizer, dataset.normalized("train"))


def test_a_narrow_unet_cannot_beat_the_noise_floor_at_t0(dataset, tokenizer):
    config = tiny_config(tokenizer)  # width 16 < 263 features
    assert noise_floor(config) == pytest.approx((263 - 16) / 263)
    assert noise_floor(discord_config("full")) == 0.0  # width 512 >= 263
    model = DisCoRDDecoder(config)
    flow_training.train_discord(model, tokenizer, dataset.normalized("train"), progress=False)
    motion = WindowDataset(dataset.normalized("val"), config.window).sample(32, torch.Generator().manual_seed(0))
    codes = code_vectors(tokenizer, motion)
    at0 = loss_at_time(model, motion, codes, 0.0, torch.Generator().manual_seed(1))
    assert at0 > 0.95 * noise_floor(config)  # a bound on the expectation; 32 × 16 × 263 draws keep it tight
    at1 = loss_at_time(model, motion, codes, 1.0, torch.Generator().manual_seed(1))
    assert at1 > 0.95  # at t = 1 the input is x1 alone: the x0 in the target (variance 1) is unpredictable
    with pytest.raises(ValueError, match="t must"):
        loss_at_time(model, motion, codes, 1.5, torch.Generator())


def test_an_interrupted_decoder_training_resumes_bit_identically(dataset, tokenizer, tmp_path, monkeypatch):
    """Ctrl-C (or a lease's end) mid-training leaves a checkpoint every tenth of the steps; a new trainer on the same
    folder resumes from the newest and ends where an uninterrupted run ends."""
    monkeypatch.setenv("MOTIONLAB_DETERMINISTIC", "1")  # on a GPU, bit-identical needs deterministic kernels
    config = tiny_config(tokenizer, train_steps=20, warmup_steps=2)
    clips = dataset.normalized("train")

    def trainer(workdir=None):
        model = DisCoRDDecoder(config)
        return flow_training.discord_trainer(model, tokenizer, clips, workdir=workdir, device="cpu", progress=False)

    straight = trainer()
    straight.fit()
    interrupted = trainer(tmp_path)
    assert interrupted.config.ckpt_every == 2
    step = interrupted.train_step

    def stop_at_step_7():
        if interrupted.step == 7:
            raise KeyboardInterrupt
        return step()

    interrupted.train_step = stop_at_step_7
    with pytest.raises(KeyboardInterrupt):
        interrupted.fit()
    resumed = trainer(tmp_path)
    assert resumed.step == 6  # the newest checkpoint before the interruption
    resumed.fit()
    for name, value in straight.model.state_dict().items():
        assert torch.equal(value, resumed.model.state_dict()[name]), name
    assert resumed.history == straight.history
