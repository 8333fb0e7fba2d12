"""``motionlab.models.load``: the plan's recipes and ``motionlab train <model>`` go through it, on the cache entries
they used before (a changed key would silently retrain every reader's models)."""

from __future__ import annotations

import importlib
import inspect
from dataclasses import replace
from functools import partial
from types import SimpleNamespace

import pytest

from motionlab import models
from motionlab.build.book_models import book_jobs
from motionlab.cli import _trained_model
from motionlab.diffusion.training import PAPER_ETA
from motionlab.models import book_dataset, projection_config
from motionlab.multimotion import MULTI_MOTION_ETA
from motionlab.sizes import DISCORD_ABLATION, DISCORD_VQ, DISCORD_XPRED, XPRED_LEVERS
from motionlab.train import cache

# The functions models.load is built on, where models.py imports them from (at call time).
VERBS = (
    "motionlab.tokenizers.tokenizer_for_dataset",
    "motionlab.flow.train_or_load_discord",
    "motionlab.diffusion.text_to_motion_for_dataset",
    "motionlab.metrics.evaluator_training.load_or_train_evaluator",
    "motionlab.flow.toy.train_or_load_toy_flow",
)

# (eta, training seed, distance) of each text-to-motion job, as the plan passed them before models.load
OLD_T2M = {
    "dynamic": (None, None, "l2_rank"),
    "uniform": (0.0, None, "l2_rank"),
    "multi-eta0.25": (MULTI_MOTION_ETA, None, "l2_rank"),
    **{f"dynamic-seed{k}": (PAPER_ETA, k, "l2_rank") for k in (1, 2)},
    **{f"uniform-seed{k}": (0.0, k, "l2_rank") for k in (1, 2)},
    **{f"distance-{d}": (None, None, d) for d in models.DISTANCES},
}


def _old_recipe(name: str, profile: str, seed: int, flow: dict | None) -> None:
    """The calls the plan's recipes made before they went through models.load: the cache keys to keep."""
    from motionlab import diffusion, tokenizers
    from motionlab import flow as flows
    from motionlab.flow import toy
    from motionlab.metrics import evaluator_training

    dataset = book_dataset(profile, seed)
    kind, _, variant = name.partition("/")
    if kind == "tokenizer":
        tokenizers.tokenizer_for_dataset(variant, dataset, profile)
    elif kind == "discord":
        tokens, _, projection = variant.partition("-")
        tokenizer = tokenizers.tokenizer_for_dataset(tokens, dataset, profile)
        if projection == "xpred":  # the laptop's former decoder, now a lever: its old key (tests/test_sizes.py)
            levers = {**DISCORD_XPRED.get(profile, XPRED_LEVERS), **(flow or {})}
            config = flows.discord_config(profile, tokenizer=tokenizer, seed=seed, **levers)
        elif projection:
            config = projection_config(profile, tokenizer, projection, seed)
        else:  # discord/vq's laptop key changed on purpose: it trains its own, smaller decoder (sizes.DISCORD_VQ)
            budget = DISCORD_VQ.get(profile, {}) if tokens == "vq" else {}
            config = flows.discord_config(profile, tokenizer=tokenizer, seed=seed, **{**budget, **(flow or {})})
        flows.train_or_load_discord(dataset, tokenizer, profile, config=config)
    elif kind == "t2m":
        eta, training_seed, distance = OLD_T2M[variant]
        diffusion.text_to_motion_for_dataset(dataset, profile, eta=eta, seed=training_seed, distance=distance)
    elif kind == "evaluator":
        evaluator_training.load_or_train_evaluator(dataset, profile)
    else:
        conditional = variant.endswith("conditional")
        config = toy.toy_flow_config(profile, distribution="ring", conditional=conditional, seed=seed)
        toy.train_or_load_toy_flow(config, profile=profile)


class _Verbs:
    """Stand-ins for :data:`VERBS` that record each call's arguments, defaults filled in (what the key is made of)."""

    def __init__(self, monkeypatch):
        self.calls: list[tuple[str, dict]] = []
        self.tokenizers = {
            k: SimpleNamespace(kind=k, feature_dim=263, code_dim=32, downsample=4) for k in ("vq", "rvq")
        }
        for path in VERBS:
            module, name = path.rsplit(".", 1)
            monkeypatch.setattr(importlib.import_module(module), name, self._stub(path))

    def _stub(self, path: str):
        module, name = path.rsplit(".", 1)
        signature = inspect.signature(getattr(importlib.import_module(module), name))

        def stub(*args, **kwargs):
            bound = signature.bind(*args, **kwargs)
            bound.apply_defaults()
            self.calls.append((name, dict(bound.arguments)))
            return self.tokenizers[bound.arguments["kind"]] if name == "tokenizer_for_dataset" else None

        return stub

    def of(self, run) -> list[tuple[str, dict]]:
        self.calls.clear()
        run()
        return list(self.calls)


@pytest.mark.parametrize(
    ("profile", "seed", "flow"),
    [("smoke", 0, None), ("laptop", 0, None), ("full", 0, None), ("smoke", 1, {"prediction": "x"})],
)
def test_every_plan_job_makes_the_calls_it_made_before_models_load(monkeypatch, profile, seed, flow):
    datasets = {}
    monkeypatch.setattr(models, "_dataset", lambda *key: datasets.setdefault(key, SimpleNamespace(key=key)))
    verbs = _Verbs(monkeypatch)
    jobs = [job for job in book_jobs(profile, seed, flow_options=flow) if job.name != "data"]
    assert len(jobs) == len(book_jobs(profile)) - 1
    for job in jobs:
        new = verbs.of(job.run)
        assert new, job.name
        assert new == verbs.of(partial(_old_recipe, job.name, profile, seed, flow)), job.name


def test_plan_recipes_go_through_models_load(monkeypatch):
    seen = []
    monkeypatch.setattr(models, "_dataset", lambda *key: SimpleNamespace(key=key))
    monkeypatch.setattr(models, "load", lambda name, dataset, profile, **kw: seen.append((name, dataset, kw)))
    jobs = {job.name: job for job in book_jobs("smoke", flow_options={"prediction": "x"})}
    for job in jobs.values():
        job.run()
    assert [name for name, _, _ in seen] == [name for name in jobs if name != "data"]
    by_name = {name: (dataset, kw) for name, dataset, kw in seen}
    assert by_name["discord/vq"][1] == {"seed": 0, "prediction": "x"}
    assert by_name["discord/rvq-stacked"][1] == {"seed": 0}  # the ablation keeps the profile's decoder options
    assert by_name["toy_flow/ring"][0] is None  # the toy flows never load the motion data


@pytest.mark.parametrize("profile", ["smoke", "laptop", "full"])
def test_the_vq_tokens_decoder_trains_its_own_budget_and_the_rvq_one_the_profiles(monkeypatch, profile):
    from motionlab.flow import discord_config

    verbs = _Verbs(monkeypatch)
    dataset = SimpleNamespace(key="data")

    def steps(name: str, **overrides) -> int:
        (call,) = [
            args
            for verb, args in verbs.of(lambda: models.load(name, dataset, profile, **overrides))
            if verb == "train_or_load_discord"
        ]
        return call["config"].train_steps

    full_budget = discord_config(profile).train_steps
    assert steps("discord/rvq") == steps("discord/rvq-seed1") == full_budget  # chapter 05's claims and their study
    assert (
        steps("discord/vq") == steps("discord/vq-seed1") == DISCORD_VQ.get(profile, {}).get("train_steps", full_budget)
    )
    assert steps("discord/vq", train_steps=77) == 77  # an explicit override still wins
    if profile == "laptop":  # chapter 09's decoder costs what one of chapter 04's ablation decoders costs
        assert DISCORD_VQ["laptop"] == DISCORD_ABLATION["laptop"] and steps("discord/vq") < full_budget


def test_the_multi_motion_evaluation_decodes_with_the_books_vq_decoder_by_name(monkeypatch):
    from motionlab.evaluation import multi
    from motionlab.metrics import evaluator_training

    seen = []
    flow = SimpleNamespace(sample_steps=8, solver="midpoint")
    monkeypatch.setattr(
        models, "load", lambda name, *a, **kw: seen.append(name) or SimpleNamespace(name=name, config=flow)
    )
    monkeypatch.setattr(evaluator_training, "load_or_train_evaluator", lambda *a, **kw: "evaluator")
    config = multi.MultiMotionConfig(decoder="discord", model="t2m/uniform")
    _, _, decoder, _ = multi._models("dataset", config, "smoke", None, False)
    assert seen == ["t2m/uniform", "discord/vq"]  # chapter 09's decoder, not a second one of the default config
    assert decoder.decoder.name == "discord/vq"


def _folders(run, monkeypatch) -> list[str]:
    """The cache folders ``run`` asks for, under a probe (nothing trains; a missing model stops it there)."""
    asked, original = [], cache.artefact_dir

    def recording(*args, **kwargs):
        folder = original(*args, **kwargs)
        asked.append(str(folder))
        return folder

    monkeypatch.setattr(cache, "artefact_dir", recording)
    with cache.cache_probe():
        try:
            run()
        except cache.NotCached:
            pass
    monkeypatch.setattr(cache, "artefact_dir", original)
    return asked


def test_smoke_plan_jobs_ask_for_the_cache_folders_they_asked_for_before(monkeypatch):
    book_dataset("smoke", 0)  # outside the probe: made once if it is missing
    for job in book_jobs("smoke"):
        if job.name == "data":
            continue
        new = _folders(job.run, monkeypatch)
        assert new, job.name
        assert new == _folders(partial(_old_recipe, job.name, "smoke", 0, None), monkeypatch), job.name


# -- motionlab train <model> ------------------------------------------------------------------------------------
@pytest.fixture
def loads(monkeypatch) -> list[tuple[str, dict]]:
    """models.load replaced by a recorder returning a stand-in with the wrappers' fields."""
    seen: list[tuple[str, dict]] = []

    def load(name, dataset, profile, **kwargs):
        seen.append((name, kwargs))
        return SimpleNamespace(name=name, networks=f"{name} networks", model=f"{name} denoiser")

    monkeypatch.setattr(models, "load", load)
    return seen


@pytest.mark.parametrize(
    ("model", "name", "returned"),
    [
        ("vq", "tokenizer/vq", None),
        ("rvq", "tokenizer/rvq", None),
        ("evaluator", "evaluator", "evaluator networks"),
        ("diffusion", "t2m/dynamic", "t2m/dynamic denoiser"),
    ],
)
def test_trained_model_loads_the_plan_name(loads, model, name, returned):
    out = _trained_model(model, "ds", "smoke", "cpu")
    assert loads == [(name, {"device": "cpu"})]
    assert out == (returned or SimpleNamespace(name=name, networks=f"{name} networks", model=f"{name} denoiser"))


def test_trained_discord_passes_its_tokenizer_and_options(loads):
    _trained_model("discord", "ds", "smoke", None, {"prediction": "x"}, "vq")
    _trained_model("discord", "ds", "smoke", None)
    assert loads == [("discord/vq", {"device": None, "prediction": "x"}), ("discord/rvq", {"device": None})]


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (("flow", None), "unknown model 'flow'; use one of diffusion, discord, evaluator, rvq, vq"),
        (("discord", None, "fsq"), "reads 'rvq' or 'vq' tokens, got 'fsq'"),
        (("vq", {"prediction": "x"}), "prediction configure the DisCoRD decoder"),
    ],
)
def test_trained_model_refuses_clearly(loads, args, message):
    name, *rest = args
    with pytest.raises(ValueError, match=message):
        _trained_model(name, "ds", "smoke", None, *rest)
    assert loads == []


@pytest.mark.parametrize(
    ("name", "message"),
    [
        ("tokenizer/fsq", "unknown tokenizer 'tokenizer/fsq'"),
        ("discord/rvq-bogus", "unknown DisCoRD decoder 'discord/rvq-bogus'"),
        ("t2m/dynamic-seedx", "unknown text-to-motion model 't2m/dynamic-seedx'"),
        ("flow/rvq", "unknown model 'flow/rvq'"),
        ("rvq", "model names look like 'discord/rvq'"),
    ],
)
def test_models_load_names_an_unknown_model(name, message):
    with pytest.raises(ValueError, match=message):
        models.load(name, SimpleNamespace(key="unused"), "smoke")


def test_a_budget_name_is_the_arm_s_model_trained_for_that_many_steps(monkeypatch):
    from motionlab.diffusion import training

    monkeypatch.setattr(models, "_tokenizer", lambda kind, dataset, profile, device: SimpleNamespace(codebook_size=256))
    calls = []
    monkeypatch.setattr(
        "motionlab.diffusion.text_to_motion_for_dataset", lambda dataset, profile, **kw: calls.append(kw) or kw
    )
    own = training.diffusion_training_config("laptop", num_codes=256)
    assert models.load("t2m/dynamic-steps800", "data", "laptop")["config"] == own  # the laptop model's own key
    assert models.load("t2m/uniform-steps800", "data", "laptop")["config"] == training.diffusion_training_config(
        "laptop", num_codes=256, eta=0.0
    )
    longer = models.load("t2m/dynamic-seed2-steps8000", "data", "laptop")
    assert longer["config"].transformer.train_steps == 8000 and longer["seed"] == 2
    assert longer["config"].transformer == replace(own.transformer, train_steps=8000)
    with pytest.raises(ValueError, match="at least 1 step"):
        models.load("t2m/dynamic-steps0", "data", "laptop")


def test_a_seeded_chain_trains_its_tokenizer_and_decoder_with_that_seed(monkeypatch):
    verbs = _Verbs(monkeypatch)
    calls = verbs.of(lambda: models.load("discord/rvq-seed2", "ds", "smoke"))
    (tok_name, tok), (flow_name, flow) = calls
    assert (tok_name, tok["kind"], tok["seed"]) == ("tokenizer_for_dataset", "rvq", 2)
    assert flow_name == "train_or_load_discord" and flow["config"].seed == 2
    assert flow["tokenizer"] is verbs.tokenizers["rvq"]
    (_, tok), *_ = verbs.of(lambda: models.load("tokenizer/vq-seed3", "ds", "smoke"))
    assert (tok["kind"], tok["seed"]) == ("vq", 3)
    # seed 0 of the chain is the book's pair, on the cache entries it always had
    assert verbs.of(lambda: models.load("discord/rvq-seed0", "ds", "smoke")) == verbs.of(
        lambda: models.load("discord/rvq", "ds", "smoke")
    )
    assert verbs.of(lambda: models.load("tokenizer/rvq-seed0", "ds", "smoke")) == verbs.of(
        lambda: models.load("tokenizer/rvq", "ds", "smoke")
    )
    with pytest.raises(ValueError, match="names its training seed"):
        models.load("discord/rvq-seed1", "ds", "smoke", seed=4)
    with pytest.raises(ValueError, match="unknown DisCoRD decoder 'discord/rvq-seed1-stacked'"):
        models.load("discord/rvq-seed1-stacked", "ds", "smoke")


def test_tokenizer_seed_changes_weights_codebook_and_batch_order_only(monkeypatch):
    from motionlab import tokenizers

    seen = []
    monkeypatch.setattr(tokenizers.training, "train_or_load_tokenizer", lambda *a, config, **kw: seen.append(config))
    dataset = SimpleNamespace(
        kind=SimpleNamespace(feature_dim=263), skeleton=SimpleNamespace(n_joints=22), key="k", normalized=None
    )
    for seed in (0, 5):
        tokenizers.tokenizer_for_dataset("rvq", dataset, "smoke", seed=seed)
    book, other = seen
    assert book == tokenizers.rvq_config("smoke", feature_dim=263, n_joints=22)  # seed 0: the book's cache key
    assert (other.seed, other.train.seed) == (5, 5)
    assert replace(other, seed=0, train=replace(other.train, seed=0)) == book
    with pytest.raises(ValueError, match="seed must be an integer >= 0"):
        tokenizers.tokenizer_for_dataset("rvq", dataset, "smoke", seed=-1)


def test_a_multi_motion_replicate_is_the_multi_motion_model_with_another_training_seed(monkeypatch):
    verbs = _Verbs(monkeypatch)
    (_, book), *_ = verbs.of(lambda: models.load("t2m/multi-eta0.25", "ds", "smoke"))
    (_, again), *_ = verbs.of(lambda: models.load("t2m/multi-eta0.25-seed0", "ds", "smoke"))
    (_, other), *_ = verbs.of(lambda: models.load("t2m/multi-eta0.25-seed2", "ds", "smoke"))
    assert book == again and (book["eta"], book["seed"]) == (MULTI_MOTION_ETA, None)
    assert (other["eta"], other["seed"]) == (MULTI_MOTION_ETA, 2)


def test_an_eta_name_is_the_dynamic_model_at_that_eta(monkeypatch):
    verbs = _Verbs(monkeypatch)
    (_, kw), *_ = verbs.of(lambda: models.load("t2m/eta2", "ds", "smoke"))
    assert kw["eta"] == 2.0 and kw["seed"] is None
    (_, kw), *_ = verbs.of(lambda: models.load("t2m/eta0.125", "ds", "smoke"))
    assert kw["eta"] == 0.125
    with pytest.raises(ValueError, match="unknown text-to-motion model 't2m/eta-1'"):
        models.load("t2m/eta-1", "ds", "smoke")


def test_the_studies_record_the_configs_models_load_trains(monkeypatch):
    """``evaluation.studies`` states the configs of the studied models without training them. Its statement must be
    what ``models.load`` hands to training: the DisCoRD decoder's whole config, and the text-to-motion models' η,
    distance, schedule and seed (from which ``text_to_motion_for_dataset`` builds theirs), and the default evaluator."""
    from motionlab.evaluation.studies import study_configs
    from motionlab.tokenizers import rvq_config

    verbs = _Verbs(monkeypatch)
    rvq = rvq_config("laptop")
    verbs.tokenizers["rvq"] = SimpleNamespace(
        kind="rvq", feature_dim=rvq.feature_dim, code_dim=rvq.code_dim, downsample=4
    )
    stated = {**study_configs("discord", "laptop")["models"], **study_configs("m2d2m", "laptop")["models"]}

    ((_, decoder),) = [
        c for c in verbs.of(lambda: models.load("discord/rvq", "ds", "laptop")) if c[0] != "tokenizer_for_dataset"
    ]
    assert cache.config_dict(decoder["config"]) == stated["discord/rvq"]
    for name in ("t2m/dynamic", "t2m/uniform", "t2m/multi-eta0.25"):
        ((_, call),) = verbs.of(lambda n=name: models.load(n, "ds", "laptop"))
        transformer = stated[name]["transformer"]
        assert (call["eta"] if call["eta"] is not None else PAPER_ETA) == transformer["eta"], name
        assert (call["distance"], call["schedule"], call["config"], call["seed"]) == ("l2_rank", None, None, None), name
        assert transformer["distance"] == "l2_rank" and stated[name]["seed"] == 0
    ((_, evaluator),) = verbs.of(lambda: models.load("evaluator", "ds", "laptop"))
    assert evaluator["config"] is None  # load_or_train_evaluator then trains evaluator_config(profile): the stated one
