"""Public functions that run a module take tensors from anywhere (issue 46): a model the trainer moved to a GPU
works with ids, text features, masks and motions built on the CPU, and each result lives where its docstring says.

A move needs two devices. Where a function does no host work its result stays on the module's device, and torch's
``meta`` device stands in for a GPU on a CPU-only machine. The others run a sampler or a loss (host reads, CPU
generators), so their module goes to :func:`~motionlab.train.get_device`: under ``MOTIONLAB_DEVICE=cuda`` (a GPU
lease's test run) the module is on the GPU and the inputs on the CPU; on a CPU-only machine both share the CPU and
these tests check the documented result device and valid output only.
"""

from __future__ import annotations

import pytest
import torch
from torch import nn

from motionlab.diffusion import (
    DenoisingTransformer,
    build_transitions,
    denoise_step,
    diffusion_loss,
    get_schedule,
    transformer_config,
)
from motionlab.diffusion.diagnostics import x0_entropy
from motionlab.flow import DisCoRDConfig, DisCoRDDecoder
from motionlab.metrics.evaluator_training import EvaluatorNetworks, evaluator_config
from motionlab.tokenizers import build_tokenizer, rvq_config, vq_config
from motionlab.train import EMA, get_device, model_device

META = torch.device("meta")
K, D_TEXT, T = 8, 12, 10


def small_decoder(feature_dim: int = 6) -> DisCoRDDecoder:
    config = DisCoRDConfig(feature_dim=feature_dim, code_dim=8, cond_dim=8, width=8, sample_steps=3, solver="euler")
    return DisCoRDDecoder(config)


def denoiser(device: torch.device) -> tuple[DenoisingTransformer, object]:
    cfg = transformer_config("smoke", num_codes=K, text_dim=D_TEXT, timesteps=T)
    codebook = torch.randn(K, 3, generator=torch.Generator().manual_seed(1))
    return DenoisingTransformer(cfg, seed=0).eval().to(device), build_transitions(get_schedule(T=T), codebook=codebook)


def cpu_text(batch: int = 3) -> tuple[torch.Tensor, torch.Tensor]:
    text = torch.randn(batch, 4, D_TEXT, generator=torch.Generator().manual_seed(2))
    return text, torch.tensor([[False, False, True, True]] * batch)


# ------------------------------------------------------------------------- results on the module's device (meta)


def test_condition_projection_takes_code_vectors_from_anywhere():
    decoder = small_decoder().to(META)
    cond = decoder.condition(torch.randn(2, 5, 8))  # (B, N, d) on the CPU
    assert cond.device == META and cond.shape == (2, 5 * decoder.config.q, decoder.config.cond_dim)


def test_tokenizer_lookups_and_decoding_run_on_the_codebooks_device():
    vq = build_tokenizer(vq_config("smoke")).to(META)
    assert vq.quantizer.quantize(torch.randn(2, 3, vq.code_dim)).device == META
    assert vq.quantizer.lookup(torch.tensor([[0, 1]])).device == META
    assert vq.decode_latent(torch.randn(1, 4, vq.code_dim)).device == META
    rvq = build_tokenizer(rvq_config("smoke")).to(META)
    ids = rvq.quantizer.quantize(torch.randn(2, 3, rvq.code_dim))
    assert ids.device == META and ids.shape == (2, 3, rvq.quantizer.num_layers)
    codes = rvq.quantizer.get_codes_from_indices(torch.zeros(2, 3, 2, dtype=torch.long))
    assert codes.device == META and codes.shape == (2, 2, 3, rvq.code_dim)


def test_the_averages_follow_a_model_moved_after_its_ema_was_made():
    model = nn.Linear(3, 2)
    ema = EMA(model)
    model.to(META)  # as Trainer users do when they build the EMA first
    ema.update(model)
    assert {t.device for t in ema.shadow.values()} == {META}


# ------------------------------------------------------------------ samplers and losses (the GPU under cuda runs)


def test_a_denoising_step_runs_where_the_model_lives_and_answers_on_the_callers_device():
    model, transitions = denoiser(get_device())
    text, text_padding = cpu_text()
    x = torch.full((3, 6), K)  # all-mask, on the CPU
    padding = torch.tensor([[False] * 6, [False] * 4 + [True] * 2, [False] * 2 + [True] * 4])
    out = denoise_step(
        model, transitions, x, T, 0, text, text_padding,
        generator=torch.Generator().manual_seed(0), guidance_scale=2.0, padding_mask=padding,
    )  # fmt: skip
    assert out.device == x.device
    assert ((out >= 0) & (out < K))[~padding].all() and (out[padding] == K).all()


def test_a_denoising_step_hands_the_network_its_inputs_on_the_models_device(monkeypatch):
    """On a CPU-only machine the step above shares one device with its inputs, so it cannot see a missing move. Here
    the model lives on ``meta`` and the network call is intercepted: every tensor it is given must be there."""
    from motionlab.diffusion import sampling

    class Moved(Exception):
        pass

    seen = {}

    def network(model, x_t, t, text, guided, **masks):
        seen.update(x_t=x_t.device, text=text.device, **{k: v.device for k, v in masks.items() if v is not None})
        raise Moved

    monkeypatch.setattr(sampling, "_model_log_p_x0", network)
    model, transitions = denoiser(META)
    text, text_padding = cpu_text()
    x = torch.full((3, 6), K)
    padding = torch.zeros(3, 6, dtype=torch.bool)
    with pytest.raises(Moved):
        denoise_step(model, transitions, x, T, 0, text, text_padding, generator=torch.Generator(), padding_mask=padding)
    assert set(seen) == {"x_t", "text", "text_padding_mask", "padding_mask"}
    assert set(seen.values()) == {META}


def test_the_diffusion_loss_takes_a_batch_built_on_the_cpu():
    model, transitions = denoiser(get_device())
    text, text_padding = cpu_text()
    x0 = torch.randint(0, K, (3, 6), generator=torch.Generator().manual_seed(3))
    loss = diffusion_loss(
        model, transitions, x0, text, text_padding, torch.zeros(3, 6, dtype=torch.bool),
        generator=torch.Generator().manual_seed(0),
    )  # fmt: skip
    assert loss.loss.device == model_device(model, x0.device) and torch.isfinite(loss.loss)


def test_the_entropy_diagnostic_takes_text_features_from_the_cpu():
    model, transitions = denoiser(get_device())
    text, text_padding = cpu_text()
    x0 = torch.randint(0, K, (3, 6), generator=torch.Generator().manual_seed(3))
    curve = x0_entropy(
        model, transitions, x0, text, text_padding, timesteps=[T, T // 2], generator=torch.Generator().manual_seed(0)
    )
    assert curve.entropy.shape == (2,) and torch.isfinite(curve.entropy).all() and (curve.entropy >= 0).all()
    assert curve.entropy.device == curve.nll.device == torch.device("cpu")  # one host number per step, as documented


def test_model_space_scaling_answers_on_the_motions_device():
    decoder = small_decoder(feature_dim=263).to(get_device())
    motion = torch.ones(1, 4, 263)
    scaled = decoder.to_model_space(motion)
    assert scaled.device == motion.device and scaled[0, 0, 0] == 25 and scaled[0, 0, 4] == 1
    torch.testing.assert_close(decoder.from_model_space(scaled), motion)


def test_the_learned_evaluator_encodes_word_ids_built_on_the_cpu():
    config = evaluator_config("smoke").evaluator
    networks = EvaluatorNetworks(config, vocab_size=20, generator=torch.Generator().manual_seed(0)).to(get_device())
    ids = torch.randint(0, 20, (2, 5), generator=torch.Generator().manual_seed(1))
    pos = torch.zeros(2, 5, config.dim_pos_ohot)
    out = networks.encode_text(ids, pos, torch.tensor([5, 3]))
    assert out.shape == (2, config.dim_coemb) and out.device == model_device(networks, ids.device)
