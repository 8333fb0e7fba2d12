"""DisCoRDDecoder: training loss, seeded decoding of VQ / RVQ ids, input checks, configs."""

from __future__ import annotations

import pytest
import torch
from torch import nn

from motionlab.flow import DisCoRDConfig, DisCoRDDecoder, discord_config, discord_loss_fn, n_evaluations
from motionlab.flow.rectified_flow import sample, sample_noise
from motionlab.flow.training import noise_floor

D, CODE, K, Q = 6, 8, 16, 4


class FakeTokenizer(nn.Module):
    """The tokenizer interface with an nn.Embedding per residual layer (layer −1 ids = absent)."""

    def __init__(self, layers: int = 3, code_dim: int = CODE, feature_dim: int = D) -> None:
        super().__init__()
        torch.manual_seed(123)  # parameter init only
        self.codebooks = nn.ModuleList(nn.Embedding(K, code_dim) for _ in range(layers))
        self.code_dim, self.downsample, self.feature_dim = code_dim, Q, feature_dim

    def embed(self, ids: torch.Tensor) -> torch.Tensor:
        ids = ids[..., None] if ids.dim() == 2 else ids  # (B, N, R)
        out = 0
        for r in range(ids.shape[-1]):
            present = (ids[..., r] >= 0)[..., None]
            out = out + self.codebooks[r](ids[..., r].clamp(min=0)) * present
        return out  # (B, N, d)


def small_config(**kw) -> DisCoRDConfig:
    base = dict(feature_dim=D, code_dim=CODE, cond_dim=8, width=8, sample_steps=3, solver="euler", window=16)
    return DisCoRDConfig(**{**base, **kw})


def decoder(**kw) -> DisCoRDDecoder:
    return DisCoRDDecoder(small_config(**kw))


def ids(B: int = 2, N: int = 5, R: int | None = None, seed: int = 0) -> torch.Tensor:
    shape = (B, N) if R is None else (B, N, R)
    return torch.randint(0, K, shape, generator=torch.Generator().manual_seed(seed))


# ----------------------------------------------------------------------------- decoding


def test_decode_vq_and_rvq_ids_to_motion():
    dec = decoder().attach(FakeTokenizer())
    assert dec.decode(ids(N=5)).shape == (2, 20, D)
    rvq = ids(N=49, R=3)
    rvq[0, :, 2] = -1  # absent top layer for clip 0
    assert dec.decode(rvq).shape == (2, 196, D)


def test_absent_layers_match_fewer_layers():
    dec = decoder().attach(FakeTokenizer())
    full = ids(N=4, R=3)
    dropped = full.clone()
    dropped[..., 1:] = -1
    torch.testing.assert_close(dec.decode(dropped, seed=1), dec.decode(full[..., :1], seed=1))


def test_decode_is_deterministic_under_a_seed_and_varies_across_seeds():
    dec = decoder().attach(FakeTokenizer())
    a, b, c = dec.decode(ids(), seed=5), dec.decode(ids(), seed=5), dec.decode(ids(), seed=6)
    assert torch.equal(a, b)
    assert not torch.allclose(a, c)
    torch.testing.assert_close(dec.decode(ids(), generator=torch.Generator().manual_seed(5)), a)
    assert torch.equal(dec.decode(ids()), dec.decode(ids(), seed=0))  # default seed is 0


def test_decode_equals_the_sampler_on_projected_conditions():
    tok = FakeTokenizer()
    dec = decoder()
    z = tok.embed(ids())
    with torch.no_grad():
        cond = dec.condition(z)
        x0 = sample_noise((2, 20, D), torch.Generator().manual_seed(3))
        expected = sample(dec.unet, x0, 4, "midpoint", cond)
    # the default (feat_bias) decoder samples in its own space, ×25 on the root/contact dims
    scale = torch.ones(D)
    scale[:4], scale[-4:] = 25.0, 25.0
    torch.testing.assert_close(dec.decode(ids(), tokenizer=tok, steps=4, solver="midpoint", seed=3), expected / scale)
    plain = decoder(normalization="std")
    plain.load_state_dict({k: v for k, v in dec.state_dict().items() if k != "_extra_state"}, strict=False)
    with torch.no_grad():
        torch.testing.assert_close(plain.decode(ids(), tokenizer=tok, steps=4, solver="midpoint", seed=3), expected)


def test_sample_is_the_core_integrate_with_the_configs_defaults():
    dec = decoder(dropout=0.5)
    z = FakeTokenizer().embed(ids()).detach()
    cfg = dec.config
    dec.eval()  # what sample does around integrate
    default = dec.integrate(z, torch.Generator().manual_seed(3), cfg.sample_steps, cfg.solver, cfg.temperature)
    warm = dec.integrate(z, torch.Generator().manual_seed(3), 2, "midpoint", temperature=0.5)
    dec.train()
    torch.testing.assert_close(dec.sample(z, seed=3), default)
    torch.testing.assert_close(dec.sample(z, steps=2, solver="midpoint", seed=3, temperature=0.5), warm)
    assert dec.training and not torch.allclose(default, warm)


# ----------------------------------------------------------------------------- parameterisation options


def test_x_prediction_decoder_samples_with_the_implied_velocity():
    from motionlab.flow.rectified_flow import velocity_from_data

    tok = FakeTokenizer()
    dec = decoder(prediction="x", normalization="std")
    z = tok.embed(ids())
    with torch.no_grad():
        cond = dec.condition(z)
        x0 = sample_noise((2, 20, D), torch.Generator().manual_seed(3))
        expected = sample(lambda x, t, c: velocity_from_data(dec.unet(x, t, c), x, t), x0, 3, "euler", cond)
        torch.testing.assert_close(dec.decode(ids(), tokenizer=tok, seed=3), expected)


def test_temperature_scales_the_start_noise():
    tok = FakeTokenizer()
    dec = decoder(normalization="std").attach(tok)
    cold = [dec.decode(ids(), seed=s, temperature=0.0) for s in (1, 2)]
    assert torch.equal(cold[0], cold[1])  # no noise: the seed no longer matters
    assert not torch.equal(dec.decode(ids(), seed=1), dec.decode(ids(), seed=2))
    warm = decoder(normalization="std", temperature=0.0).attach(tok)
    warm.load_state_dict(dec.state_dict())  # temperature is a sampling default, not part of the weights' meaning
    torch.testing.assert_close(warm.decode(ids(), seed=9), cold[0])  # the config's default temperature
    with torch.no_grad():
        cond = dec.condition(tok.embed(ids()))
        x0 = 0.5 * sample_noise((2, 20, D), torch.Generator().manual_seed(4))
        torch.testing.assert_close(dec.decode(ids(), seed=4, temperature=0.5), sample(dec.unet, x0, 3, "euler", cond))
    with pytest.raises(ValueError, match="temperature"):
        dec.decode(ids(), temperature=-1.0)


def test_final_prediction_returns_the_networks_own_estimate():
    tok = FakeTokenizer()
    dec = decoder(prediction="x", normalization="std", final_prediction=True).attach(tok)
    calls = []
    handle = dec.unet.register_forward_hook(lambda *_: calls.append(1))
    dec.decode(ids(), steps=3, solver="midpoint")
    handle.remove()
    assert len(calls) == 2 * 2 + 1  # two midpoint intervals, then one call for x̂1
    with pytest.raises(ValueError, match="prediction='x'"):
        small_config(final_prediction=True)


def test_feature_scale_round_trips_and_weighs_root_and_contacts():
    dec = decoder()
    motion = torch.randn(2, 16, D, generator=torch.Generator().manual_seed(0))
    torch.testing.assert_close(dec.from_model_space(dec.to_model_space(motion)), motion)
    assert torch.equal(decoder(normalization="std").to_model_space(motion), motion)
    scale = decoder(feature_dim=263).to_model_space(torch.ones(263))  # HumanML3D's layout: root first, contacts last
    assert (scale[:4] == 25).all() and (scale[-4:] == 25).all() and (scale[4:-4] == 1).all()


@pytest.mark.parametrize(
    "saved,loaded",
    [
        ({"prediction": "v"}, {"prediction": "x"}),
        ({"prediction": "x"}, {"prediction": "v"}),
        ({"normalization": "std"}, {"normalization": "feat_bias"}),
    ],
)
def test_weights_refuse_to_load_under_another_parameterisation(tmp_path, saved, loaded):
    from motionlab.train.checkpoint import load_weights, save_weights

    save_weights(decoder(**saved).state_dict(), tmp_path / "w.safetensors")
    load_weights(decoder(**saved), tmp_path / "w.safetensors")  # the same interpretation loads
    with pytest.raises(ValueError, match="trained with"):
        load_weights(decoder(**loaded), tmp_path / "w.safetensors")


def test_weights_without_a_parameterisation_record_are_refused(tmp_path):
    from motionlab.train.checkpoint import load_weights, save_weights

    state = {k: v for k, v in decoder().state_dict().items() if k != "_extra_state"}
    save_weights(state, tmp_path / "old.safetensors")
    with pytest.raises(ValueError, match="do not fit"):
        load_weights(decoder(), tmp_path / "old.safetensors")


@pytest.mark.parametrize("steps,solver", [(2, "euler"), (3, "midpoint"), (None, None)])
def test_decode_spends_the_stated_number_of_network_evaluations(steps, solver):
    dec = decoder().attach(FakeTokenizer())
    calls = []
    handle = dec.unet.register_forward_hook(lambda *_: calls.append(1))
    dec.decode(ids(), steps=steps, solver=solver)
    handle.remove()
    cfg = dec.config
    assert len(calls) == n_evaluations(steps or cfg.sample_steps, solver or cfg.solver)


def test_sampling_restores_training_mode_and_never_touches_the_tokenizer():
    tok = FakeTokenizer()
    before = [p.detach().clone() for p in tok.parameters()]
    dec = decoder(dropout=0.5).attach(tok)
    dec.train()
    assert torch.equal(dec.decode(ids(), seed=2), dec.decode(ids(), seed=2))  # dropout is off while sampling
    assert dec.training
    assert not any(k.startswith("_tokenizer") or "codebooks" in k for k in dec.state_dict())
    assert {id(p) for p in dec.parameters()}.isdisjoint(id(p) for p in tok.parameters())
    opt = torch.optim.SGD(dec.parameters(), lr=1.0)
    motion = torch.randn(2, 16, D, generator=torch.Generator().manual_seed(0))
    dec.loss(motion, tok.embed(ids(N=4)).detach(), torch.Generator().manual_seed(0)).backward()
    opt.step()
    assert all(torch.equal(a, b) for a, b in zip(before, tok.parameters()))


# ----------------------------------------------------------------------------- training


def test_loss_is_seeded_and_reaches_every_trainable_part():
    dec = decoder()
    g = torch.Generator().manual_seed(0)
    motion, z = torch.randn(4, 16, D, generator=g), torch.randn(4, 4, CODE, generator=g)
    l1 = dec.loss(motion, z, torch.Generator().manual_seed(1))
    l2 = dec.loss(motion, z, torch.Generator().manual_seed(1))
    assert l1.shape == () and torch.isfinite(l1) and l1.item() == l2.item()
    l1.backward()
    assert dec.projection.stacked.weight.grad.abs().sum() > 0
    assert dec.unet.init_proj.weight.grad.abs().sum() > 0


def test_a_few_steps_fit_a_fixed_batch():
    dec = decoder(width=16, cond_dim=16)
    g = torch.Generator().manual_seed(0)
    z = torch.randn(8, 4, CODE, generator=g)
    motion = z.repeat_interleave(Q, dim=1)[..., :D]  # motion that the codes determine
    opt = torch.optim.Adam(dec.parameters(), lr=3e-3)
    losses = []
    for _ in range(80):
        loss = dec.loss(motion, z, g)
        opt.zero_grad()
        loss.backward()
        opt.step()
        losses.append(loss.item())
    assert sum(losses[-10:]) / 10 < 0.5 * sum(losses[:5]) / 5


# ----------------------------------------------------------------------------- bad inputs


def test_decode_rejects_bad_inputs():
    dec = decoder()
    with pytest.raises(ValueError, match="no tokenizer"):
        dec.decode(ids())
    tok = FakeTokenizer()
    with pytest.raises(ValueError, match="integer tensor"):
        dec.decode(ids().float(), tokenizer=tok)
    with pytest.raises(ValueError, match="integer tensor"):
        dec.decode(ids()[0], tokenizer=tok)
    with pytest.raises(ValueError, match="at least one"):
        dec.decode(ids(N=0), tokenizer=tok)
    with pytest.raises(ValueError, match="code_dim"):
        dec.attach(FakeTokenizer(code_dim=CODE + 1))
    with pytest.raises(ValueError, match="feature_dim"):
        dec.attach(FakeTokenizer(feature_dim=D + 1))
    with pytest.raises(ValueError, match="embed"):
        dec.attach(object())
    with pytest.raises(ValueError, match="either generator or seed"):
        dec.decode(ids(), tokenizer=tok, seed=1, generator=torch.Generator())
    with pytest.raises(ValueError, match="steps"):
        dec.decode(ids(), tokenizer=tok, steps=0)
    with pytest.raises(ValueError, match="solver"):
        dec.decode(ids(), tokenizer=tok, solver="rk45")


def test_loss_and_velocity_reject_bad_shapes():
    dec = decoder()
    g = torch.Generator().manual_seed(0)
    with pytest.raises(ValueError, match="multiple of q=4"):
        dec.loss(torch.zeros(2, 62, D), torch.zeros(2, 15, CODE), g)
    with pytest.raises(ValueError, match=r"code_vectors must have shape \(2, 16, 8\)"):
        dec.loss(torch.zeros(2, 64, D), torch.zeros(2, 15, CODE), g)
    with pytest.raises(ValueError, match=r"motion must have shape \(B, T, 6\)"):
        dec.loss(torch.zeros(2, 64, D + 1), torch.zeros(2, 16, CODE), g)
    with pytest.raises(ValueError, match="x_t"):
        dec.velocity(torch.zeros(64, D), torch.zeros(1), torch.zeros(1, 16, CODE))
    with pytest.raises(ValueError, match="code_vectors"):
        dec.sample(torch.zeros(2, 16, CODE + 1))


# ----------------------------------------------------------------------------- configs


def test_full_config_is_table_a():
    cfg = discord_config("full")
    assert (cfg.width, cfg.width * cfg.width_mults[-1], cfg.cond_dim, cfg.feature_dim) == (512, 1024, 256, 263)
    assert (cfg.window, cfg.batch_size, cfg.lr, cfg.ema_decay, cfg.grad_clip) == (64, 768, 5e-4, 0.999, 1.0)
    assert (cfg.sample_steps + 1, cfg.solver, n_evaluations(cfg.sample_steps, cfg.solver)) == (16, "midpoint", 30)
    assert cfg.tokens_per_window == 16 and cfg.projection == "stacked"
    n_params = sum(p.numel() for p in DisCoRDDecoder(cfg).parameters())
    assert round(n_params / 1e6, 1) == 66.9  # Table A: 66.9 M


@pytest.mark.parametrize("profile", ["smoke", "laptop", "full"])
def test_profiles_and_tokenizer_matching(profile):
    tok = FakeTokenizer()
    cfg = discord_config(profile, tokenizer=tok, projection="repeat")
    assert (cfg.feature_dim, cfg.code_dim, cfg.q, cfg.projection) == (D, CODE, Q, "repeat")
    assert 0 < cfg.warmup_steps < cfg.train_steps and cfg.window % cfg.q == 0
    assert cfg.to_dict()["lr"] == cfg.lr


def test_which_decoders_see_all_of_the_noise():
    """A velocity U-Net narrower than the features leaves part of the noise in every decoded frame (chapter 05): the
    paper's width sees all of it; the laptop's paper decoder cannot (its verdicts say so), its x-prediction lever
    can."""
    from motionlab.models import xpred_config

    full, laptop, lever = discord_config("full"), discord_config("laptop"), xpred_config("laptop", None)
    assert full.prediction == laptop.prediction == "v" and full.width >= full.feature_dim and noise_floor(full) == 0.0
    assert laptop.width < laptop.feature_dim
    assert noise_floor(laptop) == pytest.approx((laptop.feature_dim - laptop.width) / laptop.feature_dim)
    assert lever.prediction == "x" and noise_floor(lever) == 0.0


def test_smoke_decoder_is_tiny():
    n_params = sum(p.numel() for p in DisCoRDDecoder(discord_config("smoke")).parameters())
    assert n_params < 200_000


def test_config_rejects_bad_values():
    with pytest.raises(ValueError, match="unknown DisCoRDConfig fields"):
        discord_config("smoke", widht=3)
    with pytest.raises(ValueError, match="profile"):
        discord_config("huge")
    with pytest.raises(ValueError, match="projection"):
        small_config(projection="bilinear")
    with pytest.raises(ValueError, match="window"):
        small_config(window=18)
    with pytest.raises(ValueError, match="solver"):
        small_config(solver="rk4")
    for field, value in (
        ("prediction", "eps"),
        ("normalization", "minmax"),
        ("time_distribution", "beta"),
        ("spacing", "cosine"),
    ):
        with pytest.raises(ValueError, match=field):
            small_config(**{field: value})
    with pytest.raises(ValueError, match="temperature"):
        small_config(temperature=float("nan"))
    with pytest.raises(ValueError, match="time_scale"):
        small_config(time_scale=0.0)


def test_initial_weights_are_a_function_of_the_config():
    a, b, c = decoder(), decoder(), decoder(seed=1)
    assert all(torch.equal(x, y) for x, y in zip(a.state_dict().values(), b.state_dict().values()))
    assert not torch.equal(a.unet.init_proj.weight, c.unet.init_proj.weight)


def test_train_config_maps_onto_the_shared_trainer():
    cfg = discord_config("full")
    tc = cfg.train_config()
    assert (tc.steps, tc.lr, tc.warmup_steps, tc.ema_decay, tc.grad_clip) == (481_896, 5e-4, 48_190, 0.999, 1.0)
    assert tc.schedule == "cosine" and tc.lr_at(tc.steps) == pytest.approx(cfg.min_lr)
    assert cfg.train_config(steps=10).steps == 10


def test_smoke_profile_trains_with_the_shared_trainer():
    from motionlab.train import Trainer

    tok = FakeTokenizer(code_dim=16)
    dec = DisCoRDDecoder.from_tokenizer(tok, "smoke")
    cfg = dec.config
    g = torch.Generator().manual_seed(0)
    pool_ids = torch.randint(0, K, (64, cfg.tokens_per_window, 3), generator=g)
    pool_z = tok.embed(pool_ids).detach()  # (64, 4, 16)
    pool_motion = pool_z.repeat_interleave(Q, dim=1)[..., :D]  # motion the tokens determine

    def batch_fn(step, generator):
        pick = torch.randint(0, 64, (cfg.batch_size,), generator=generator)
        return pool_motion[pick], pool_z[pick]

    history = Trainer(dec, discord_loss_fn, batch_fn, cfg.train_config(log_every=10), progress=False).fit()
    assert history[-1]["loss"] < 0.8 * history[0]["loss"]
    assert dec.decode(pool_ids[:2]).shape == (2, cfg.window, D)


def test_a_decoder_at_temperature_0_is_deterministic_and_says_so():
    decoder = DisCoRDDecoder(discord_config("smoke", feature_dim=263, code_dim=16, q=4))
    codes = torch.randn(1, 4, 16, generator=torch.Generator().manual_seed(0))  # (B, N, d)
    assert not decoder.deterministic  # the smoke profile samples at temperature 1, like the paper
    assert not torch.equal(decoder.sample(codes, seed=1), decoder.sample(codes, seed=2))
    cold = decoder.with_sampling(temperature=0.0)
    assert cold.deterministic
    assert torch.equal(cold.sample(codes, seed=1), cold.sample(codes, seed=2))
