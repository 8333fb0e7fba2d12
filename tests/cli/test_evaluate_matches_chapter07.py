"""``motionlab evaluate t2m`` computes chapter 07's table: the CLI, run in-process, prints the numbers the chapter's own
expression computes (smoke models, 32 test clips), and chapter 08's design is rows of the same kind of table.

Also the options behind that: :class:`TextToMotionConfig` built from a chapter's sizes, its row names, its command
line, and the model names of chapter 08's design.
"""

from __future__ import annotations

import json
import shlex
from dataclasses import replace
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

import motionlab.evaluation
from motionlab import cli
from motionlab.estimate import mean_ci
from motionlab.evaluation import TextToMotionConfig, evaluate_t2m
from motionlab.evaluation.t2m import _load_model, _sampling_note, eta_model, seed_replica
from motionlab.sizes import DiffusionSizes, TransitionsSizes, chapter_sizes

REPO = Path(__file__).resolve().parents[2]
CHAPTER_07 = REPO / "notebooks" / "07_discrete_diffusion.ipynb"
# The two statements of chapter 07 that compute its Table 3 and guidance sweep (the test evaluates exactly these).
CONFIG = "evaluation.TextToMotionConfig.from_sizes(sizes.diffusion, seed=seed)"
TABLE = "evaluation.evaluate_t2m(dataset, config)"


def test_chapter_07_computes_its_table_with_these_expressions(chapter_code):
    code = chapter_code(CHAPTER_07)
    assert f"config = {CONFIG}" in code and f"table = {TABLE}" in code


@pytest.fixture(scope="module")
def small_sizes() -> DiffusionSizes:
    """Chapter 07's smoke sizes, smaller: 32 clips (one R-precision batch), 2 repeats, 3 sampling steps."""
    return replace(chapter_sizes("smoke").diffusion, eval_clips=32, repeats=2, num_steps=3, mm_texts=2)


@pytest.fixture(scope="module")
def chapter_table(small_sizes):
    """The table as chapter 07 computes it (its two statements, evaluated as written), in the smoke profile."""
    from motionlab.data import load_dataset

    with pytest.MonkeyPatch.context() as mp:
        mp.setenv("MOTIONLAB_PROFILE", "smoke")
        mp.setenv("MOTIONLAB_PRECISION", "fp32")
        dataset = load_dataset(profile="smoke", seed=0)
        config = eval(
            CONFIG, {"evaluation": motionlab.evaluation, "sizes": SimpleNamespace(diffusion=small_sizes), "seed": 0}
        )
        table = eval(TABLE, {"evaluation": motionlab.evaluation, "dataset": dataset, "config": config})
    return config, table


def test_the_cli_prints_the_numbers_chapter_07_computes(chapter_table, run_command_line):
    config, table = chapter_table
    argv, printed, result = run_command_line(config)
    assert argv[:4] == ["evaluate", "t2m", "--profile", "smoke"] and "--token-stats" in argv
    assert table.to_markdown() in printed  # every row, every number, the notes
    expected = json.loads(json.dumps(table.to_json_dict()))  # JSON's lists for the config's tuples
    assert result["rows"] == expected["rows"] and result["config"] == expected["config"]
    assert list(result["rows"]) == [
        "Ground Truth",
        "VQ-VAE (reconstruction)",
        "Real tokens (train vs test)",
        "s = 0",
        "s = 1",
        "s = 2",
        "s = 4",
    ]


def test_every_row_keeps_its_repeats_and_pairs_with_the_others(chapter_table):
    config, table = chapter_table
    assert table.deterministic == ("Real tokens (train vs test)",)
    for row in table.rows:
        if row in table.deterministic:
            continue
        assert all(len(values) == config.repeats for values in table.samples[row].values())
        for metric, values in table.samples[row].items():
            assert table.estimate(row, metric).mean == pytest.approx(np.mean(values))
    s4, s0 = (np.array(table.samples[row]["fid"]) for row in ("s = 4", "s = 0"))
    assert table.paired("s = 4", "s = 0", "fid") == mean_ci(s4 - s0)
    assert "multimodality" in table.samples["s = 0"] and "multimodality" not in table.samples["Ground Truth"]
    tokens = table.rows["Real tokens (train vs test)"]
    assert set(tokens) == {"hist_tv", "repeat_rate"} and 0 < tokens["hist_tv"].mean < 1
    for row in ("s = 0", "s = 4"):
        assert 0 <= table.estimate(row, "hist_tv").mean <= 1 and 0 <= table.estimate(row, "repeat_rate").mean <= 1


def test_a_row_does_not_depend_on_the_other_rows_of_its_table(chapter_table):
    # Chapter 08's design: several models in one table, at one guidance scale. Every row draws the same captions and
    # sampling seeds, so the dynamic model at s = 4 scores what chapter 07's s = 4 row scored.
    config, table = chapter_table
    two = replace(config, models=("t2m/uniform", "t2m/dynamic"), guidance_scales=(), guidance_scale=4.0)
    two = replace(two, multimodality=False, reconstruction=False, token_stats=False)
    with pytest.MonkeyPatch.context() as mp:
        mp.setenv("MOTIONLAB_PROFILE", "smoke")
        from motionlab.data import load_dataset

        arms = evaluate_t2m(load_dataset(profile="smoke", seed=0), two)
    assert list(arms.rows) == ["Ground Truth", "t2m/uniform", "t2m/dynamic"]
    for metric in ("top1", "top3", "fid", "mm_dist", "diversity"):
        assert arms.samples["t2m/dynamic"][metric] == table.samples["s = 4"][metric]
        assert arms.samples["Ground Truth"][metric] == table.samples["Ground Truth"][metric]
    d = arms.paired("t2m/dynamic", "t2m/uniform", "fid")
    assert d.n == config.repeats and "Generated by t2m/uniform, t2m/dynamic: s = 4" in arms.notes[0]


# --------------------------------------------------------------------------------- the config, without models


def test_from_sizes_builds_each_chapters_design():
    diffusion = chapter_sizes("laptop").diffusion
    config = TextToMotionConfig.from_sizes(diffusion, seed=3)
    assert (config.limit, config.repeats, config.num_steps, config.seed) == (256, 3, 25, 3)
    assert config.guidance_scales == (0.0, 1.0, 2.0, 4.0) and config.models == ("t2m/dynamic",)
    assert config.multimodality and config.reconstruction and config.token_stats
    assert (config.mm_texts, config.mm_repeats) == (diffusion.mm_texts, diffusion.mm_repeats)
    assert [config.row("t2m/dynamic", s) for s in config.guidance_scales] == ["s = 0", "s = 1", "s = 2", "s = 4"]

    transitions = chapter_sizes("smoke").transitions
    config = TextToMotionConfig.from_sizes(transitions)
    assert config.guidance_scale == 4.0 and not config.guidance_scales and not config.multimodality
    assert config.models == (
        "t2m/uniform",
        "t2m/uniform-seed1",
        "t2m/uniform-seed2",
        "t2m/dynamic",
        "t2m/dynamic-seed1",
        "t2m/dynamic-seed2",
        "t2m/multi-eta0.25",  # the η sweep's models, once each (η = 0 and 0.5 are the seed-0 arms)
    )
    assert config.row("t2m/uniform-seed1") == "t2m/uniform-seed1"
    full = TextToMotionConfig.from_sizes(chapter_sizes("full").transitions)
    assert full.models[-5:] == (
        "t2m/eta2",
        "t2m/eta8",
        "t2m/distance-l2",
        "t2m/distance-cosine",
        "t2m/distance-cosine_rank",
    )
    with pytest.raises(ValueError, match="unknown TextToMotionConfig option"):
        TextToMotionConfig.from_sizes(diffusion, guidance=2)
    with pytest.raises(ValueError, match="DiffusionSizes or TransitionsSizes"):
        TextToMotionConfig.from_sizes(chapter_sizes("smoke").tps)


@pytest.mark.parametrize("profile", ["smoke", "laptop", "full"])
@pytest.mark.parametrize("chapter", ["diffusion", "transitions"])
def test_the_command_line_parses_back_into_the_config(profile, chapter):
    config = TextToMotionConfig.from_sizes(getattr(chapter_sizes(profile), chapter), seed=1)
    args = cli.build_parser().parse_args(shlex.split(config.command_line(profile))[1:])
    assert args.profile == profile and cli._evaluation_config(args, args.repeats) == config


def test_every_option_survives_the_command_line():
    config = TextToMotionConfig(
        models=("t2m/uniform", "t2m/eta1.5"),
        guidance_scales=(0.1 + 0.2, 4),  # a float whose short form would read back differently
        top_p=0.85,
        mm_texts=7,  # kept even without MultiModality: the config is the same either way
        token_stats=True,
        split="val",
        seed=2,
        limit=40,
        repeats=3,
        num_steps=5,
        guidance_on="posterior",
    )
    args = cli.build_parser().parse_args(shlex.split(config.command_line())[1:])
    assert cli._evaluation_config(args, args.repeats) == config
    assert "--guidance-on posterior" in config.command_line()


def test_the_default_row_and_the_row_names_of_each_option():
    default = TextToMotionConfig()
    assert default.row("t2m/dynamic") == "Discrete diffusion + VQ decoder"  # as the command always printed it
    assert default.command_line() == "motionlab evaluate t2m --repeats 1"
    top_p = TextToMotionConfig(guidance_scales=(0, 4), top_p=0.85)
    assert top_p.row("t2m/dynamic", 0.0) == "s = 0, top-p 0.85" and top_p.guidance_scales == (0.0, 4.0)
    several = TextToMotionConfig(models=["t2m/uniform", "t2m/dynamic"], guidance_scales=(0, 4))
    assert several.models == ("t2m/uniform", "t2m/dynamic") and several.row("t2m/uniform", 4.0) == "t2m/uniform, s = 4"
    assert TextToMotionConfig(split="train").real_tokens_row() == "Real tokens (test vs train)"
    notes = [_sampling_note(c, "VQ decoder") for c in (default, top_p, TextToMotionConfig(guidance_scale=2))]
    assert notes == [
        "Generated by t2m/dynamic: the model's guidance scale (s = 4), all T sampling steps, decoded by the VQ "
        "decoder.",
        "Generated by t2m/dynamic: s as in each row, all T sampling steps, top-p 0.85, decoded by the VQ decoder.",
        "Generated by t2m/dynamic: s = 2, all T sampling steps, decoded by the VQ decoder.",
    ]
    posterior = _sampling_note(TextToMotionConfig(guidance_scale=2, guidance_on="posterior"), "VQ decoder")
    assert posterior.startswith("Generated by t2m/dynamic: s = 2, guidance on p_θ(x_{t-1} | x_t) (Eq. 9), all T")


@pytest.mark.parametrize(
    "options, message",
    [
        ({"models": ()}, "one or more distinct model names"),
        ({"models": ("t2m/dynamic", "t2m/dynamic")}, "one or more distinct model names"),
        ({"models": ("discord/rvq",)}, "unknown text-to-motion model"),
        ({"models": ("t2m/eta-2",)}, "unknown text-to-motion model"),
        ({"guidance_scales": (0, 0)}, "distinct"),
        ({"guidance_scales": (-1,)}, "finite number >= 0"),
        ({"guidance_scales": (1,), "guidance_scale": 4.0}, "not both"),
        ({"guidance_scale": float("nan")}, "finite number >= 0"),
        ({"top_p": 0.0}, "top_p must be in"),
        ({"top_p": "0.5"}, "top_p must be in"),
        ({"token_stats": 1}, "True or False"),
        ({"num_steps": 0}, "num_steps must be an int >= 1"),
        ({"guidance_on": "x_t"}, "guidance_on must be one of"),
    ],
)
def test_bad_options_are_refused(options, message):
    with pytest.raises(ValueError, match=message):
        TextToMotionConfig(**options)


def test_bad_cli_options_exit_2_before_any_work(tmp_path, capsys):
    missing = str(tmp_path / "missing")
    for options, message in (
        (["--guidance-scales", "0,x"], "--guidance-scales must be comma-separated numbers"),
        (["--models", "t2m/dynamic,t2m/nope"], "unknown text-to-motion model 't2m/nope'"),
    ):
        assert cli.main(["evaluate", "t2m", "--profile", "smoke", "--data", missing, *options]) == 2
        assert message in capsys.readouterr().err


def test_chapter_08_model_names():
    assert [seed_replica(arm, s) for arm in ("uniform", "dynamic") for s in (0, 2)] == [
        "t2m/uniform",
        "t2m/uniform-seed2",
        "t2m/dynamic",
        "t2m/dynamic-seed2",
    ]
    assert [eta_model(e) for e in (0, 0.25, 0.5, 2.0, 1.5)] == [
        "t2m/uniform",
        "t2m/multi-eta0.25",
        "t2m/dynamic",
        "t2m/eta2",
        "t2m/eta1.5",
    ]
    with pytest.raises(ValueError, match="arm"):
        seed_replica("local", 1)
    with pytest.raises(ValueError, match="eta"):
        eta_model(-1.0)


def test_an_eta_name_trains_or_loads_seed_0_at_that_eta(monkeypatch):
    calls = []

    def fake(dataset, profile, **kw):
        calls.append(kw)
        return "pipe"

    monkeypatch.setattr("motionlab.diffusion.text_to_motion_for_dataset", fake)  # what models.load calls
    assert _load_model("t2m/eta2", "data", "smoke", None) == "pipe" and calls == [{"eta": 2.0, "device": None}]


def test_chapter_08_sizes_take_its_parameters():
    sizes = chapter_sizes("smoke").transitions
    assert sizes.override(training_seeds=None, distance_ablation=None) == sizes
    chosen = sizes.override(training_seeds=[0, 3], distance_ablation=True)  # papermill passes a list
    assert chosen.training_seeds == (0, 3) and chosen.distance_ablation and chosen.sweep_etas == sizes.sweep_etas
    with pytest.raises(ValueError, match="start with 0"):
        sizes.override(training_seeds=(1, 2))
    assert isinstance(sizes, TransitionsSizes)
