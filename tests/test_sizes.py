"""``motionlab.sizes``: one table per profile for the chapters, the run and every model, applied in one idiom.

The model tables feed the cache keys of the book's models, so their configs are pinned here by hash: a change to a
size is a deliberate act that retrains those models for every reader (update the digest with the change)."""

from __future__ import annotations

from dataclasses import dataclass, field, fields
from types import SimpleNamespace

import pytest

from motionlab import sizes
from motionlab.diffusion.training import DiffusionTrainingConfig, diffusion_training_config
from motionlab.diffusion.transformer import TransformerConfig, transformer_config
from motionlab.flow.config import DisCoRDConfig, discord_config
from motionlab.flow.toy import ToyFlowConfig, toy_flow_config
from motionlab.metrics.evaluator_training import EvaluatorTrainingConfig, evaluator_config
from motionlab.profiles import PROFILES
from motionlab.tokenizers.config import RVQConfig, VQConfig, rvq_config, vq_config
from motionlab.train.cache import config_hash


@dataclass(frozen=True)
class _Inner:
    a: int = 1
    b: int = 2


@dataclass(frozen=True)
class _Outer:
    width: int = 512
    inner: _Inner = field(default_factory=_Inner)


def test_resized_changes_only_the_named_fields_and_merges_nested_configs():
    table = {"smoke": {"width": 8, "inner": {"b": 5}}, "laptop": {}}
    assert sizes.resized(_Outer(), table, "smoke") == _Outer(8, _Inner(1, 5))
    assert sizes.resized(_Outer(), table, "laptop") == _Outer()
    assert sizes.resized(_Outer(), table, "full") == _Outer()  # full is the defaults
    with pytest.raises(ValueError, match="'depth', not a field of _Outer"):
        sizes.resized(_Outer(), {"smoke": {"depth": 3}}, "smoke")
    with pytest.raises(ValueError, match="unknown profile"):
        sizes.resized(_Outer(), table, "huge")


@pytest.mark.parametrize("table", sorted(sizes.MODEL_TABLES))
def test_model_tables_name_only_profiles_and_never_restate_full(table):
    assert set(sizes.MODEL_TABLES[table]) <= set(PROFILES) - {"full"}


def test_the_full_profile_is_each_config_class_s_defaults():
    assert vq_config("full") == VQConfig() and rvq_config("full") == RVQConfig()
    assert discord_config("full") == DisCoRDConfig() and toy_flow_config("full") == ToyFlowConfig()
    assert transformer_config("full") == TransformerConfig()
    assert evaluator_config("full") == EvaluatorTrainingConfig()
    full = diffusion_training_config("full", num_codes=512)
    assert full.transformer == TransformerConfig() and full == DiffusionTrainingConfig(TransformerConfig())


def test_the_denoiser_a_profile_names_is_the_one_its_models_train():
    for profile in PROFILES:
        trained = diffusion_training_config(profile, num_codes=512).transformer
        assert trained == transformer_config(profile, text_dim=trained.text_dim)


def test_run_sizes_are_ordered_and_reach_the_chapters():
    runs = [sizes.run_sizes(p) for p in PROFILES]
    assert [r.embedded_clips for r in runs] == sorted({r.embedded_clips for r in runs})
    assert runs[-1].evaluation_repeats == 20  # the papers'
    assert sizes.chapter_sizes("laptop").run == runs[1]


# config_hash of each profile's configs: the cache keys of the book's models (smoke and laptop) and the full run.
PINNED = {
    "smoke": {
        "vq": "1ec6c04bc3f6",
        "rvq": "3addfcde3562",
        "discord": "62d9691877b5",
        "diffusion": "f44574490524",
        "evaluator": "28dabfecb608",
        "toy_flow": "bd11d118bb11",
    },
    "laptop": {
        "vq": "6464ca563870",
        "rvq": "220e09b35557",
        "discord": "9aac8ed3f035",  # the paper's protocol since issue 62 (2b665d595297: the lever discord/rvq-xpred)
        "diffusion": "71c0bd368ad7",
        "evaluator": "f6a6687a85e4",
        "toy_flow": "ae0d2c8ebaba",
    },
    "full": {
        "vq": "fc25213cc124",
        "rvq": "432a5892e23b",
        "discord": "40dcb8b25c80",
        "diffusion": "5c9fc889c6ed",
        "evaluator": "2091ff343c68",
        "toy_flow": "2ffabec9d039",
    },
}


def _configs(profile: str) -> dict[str, object]:
    return {
        "vq": vq_config(profile),
        "rvq": rvq_config(profile),
        "discord": discord_config(profile),
        "diffusion": diffusion_training_config(profile, num_codes=vq_config(profile).codebook_size),
        "evaluator": evaluator_config(profile),
        "toy_flow": toy_flow_config(profile),
    }


@pytest.mark.parametrize("profile", PROFILES)
def test_model_configs_keep_their_cache_keys(profile):
    assert {name: config_hash(c) for name, c in _configs(profile).items()} == PINNED[profile]


def test_the_x_prediction_lever_is_the_laptop_decoder_it_replaced():
    """Until issue 62 the laptop's DisCoRD decoder predicted x from zero noise (key 2b665d595297); that decoder is now
    the lever ``discord/rvq-xpred``, and it must keep the cache entry (and the measurements) it had."""
    from motionlab.models import xpred_config

    shape = SimpleNamespace(feature_dim=263, code_dim=64, downsample=4)
    variant = xpred_config("laptop", shape)
    assert config_hash(variant) == "2b665d595297"
    paper = discord_config("laptop", tokenizer=shape)
    assert (paper.prediction, paper.temperature, paper.sample_steps, paper.solver) == ("v", 1.0, 15, "midpoint")
    differs = {f.name for f in fields(paper) if getattr(paper, f.name) != getattr(variant, f.name)}
    assert differs == {"prediction", "temperature", "sample_steps"}  # the levers, and nothing else
