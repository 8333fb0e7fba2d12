"""``motionlab evaluate multi`` computes chapter 09's table: the CLI, run in-process, prints the numbers the chapter's
own expressions compute (smoke models, 3 instances, 2 repeats), with the ground-truth Jerks on the whole test set and
the per-boundary samples that the chapter's paired differences use.

Also the options behind that: the method specs, :func:`paper_config` from a chapter's sizes, and its command line.
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
from motionlab.evaluation import MultiMotionConfig, evaluate_multi
from motionlab.evaluation.multi import PAPER_METHODS, method_rows, paper_config, parse_method
from motionlab.multimotion import GROUND_TRUTH_CONCAT, GROUND_TRUTH_SINGLE
from motionlab.sizes import chapter_sizes

REPO = Path(__file__).resolve().parents[2]
CHAPTER_09 = REPO / "notebooks" / "09_two_phase_sampling.ipynb"
# The statements of chapter 09 that compute its tables (the test evaluates exactly these).
CONFIG = "evaluation.multi.paper_config(design, seed=seed)"
TABLE = "evaluation.evaluate_multi(dataset, config, generated=generated, tokens=tokens)"
FLOW = "evaluation.evaluate_multi(dataset, flow_config, tokens=tokens)"
UNIFORM = 'evaluation.multi.paper_config(design, seed=seed, model="t2m/uniform", methods=("independent", "tps"))'
TPS, INDEPENDENT = "TPS (T_s = 90)", "Independent (tokens concatenated)"


def test_chapter_09_computes_its_tables_with_these_expressions(chapter_code):
    code = chapter_code(CHAPTER_09)
    assert f"config = {CONFIG}" in code and f"table = {TABLE}" in code and f"flow = {FLOW}" in code
    assert "uniform = evaluation.evaluate_multi(" in code and f"    dataset, {UNIFORM}\n)" in code


@pytest.fixture(scope="module")
def chapter():
    """The tables as chapter 09 computes them (its statements, evaluated as written), in the smoke profile."""
    from motionlab.data import load_dataset

    design = replace(chapter_sizes("smoke").tps, instances=3, repeats=2, num_steps=3)
    with pytest.MonkeyPatch.context() as mp:
        mp.setenv("MOTIONLAB_PROFILE", "smoke")
        mp.setenv("MOTIONLAB_PRECISION", "fp32")
        dataset = load_dataset(profile="smoke", seed=0)
        names = {"evaluation": motionlab.evaluation, "design": design, "seed": 0}
        config = eval(CONFIG, names)
        generated: dict = {}
        tokens: dict = {}
        scope = {"evaluation": motionlab.evaluation, "dataset": dataset, "config": config, "generated": generated}
        table = eval(TABLE, {**scope, "tokens": tokens})
        uniform = evaluate_multi(dataset, eval(UNIFORM, names), tokens=tokens)
    return SimpleNamespace(config=config, table=table, generated=generated, uniform=uniform, tokens=tokens)


def test_the_cli_prints_the_numbers_chapter_09_computes(chapter, run_command_line):
    config, table = chapter.config, chapter.table
    argv, printed, result = run_command_line(config)
    assert argv[:4] == ["evaluate", "multi", "--profile", "smoke"] and "--segment-jerk" in argv
    assert table.to_markdown() in printed  # every row, every number, the notes (the ground-truth Jerks among them)
    expected = json.loads(json.dumps(table.to_json_dict()))
    assert result["rows"] == expected["rows"] and result["config"] == expected["config"]
    assert list(result["rows"]) == [GROUND_TRUTH_SINGLE, GROUND_TRUTH_CONCAT, *method_rows(PAPER_METHODS, 90)]


def test_the_ground_truth_jerks_cover_the_whole_test_set(chapter):
    table = chapter.table
    assert table.counts["instances"] == 3 and table.counts["instances for the ground-truth Jerk"] > 3
    cuts = table.samples[GROUND_TRUTH_CONCAT]["jerk"]
    assert len(cuts) == 3 * table.counts["instances for the ground-truth Jerk"]  # 3 cuts between 4 actions
    finite = np.asarray(cuts)[np.isfinite(cuts)]
    assert table.estimate(GROUND_TRUTH_CONCAT, "jerk") == mean_ci(finite)
    assert table.estimate(GROUND_TRUTH_CONCAT, "cut_minus_inside").n > 1
    # inside real clips the Jerk is the Ground Truth (Single) Jerk itself
    single = table.rows[GROUND_TRUTH_SINGLE]
    assert single["segment_jerk"] == single["jerk"] and single["jerk"].n > table.repeats


def test_rows_pair_boundary_by_boundary_within_and_across_tables(chapter):
    table, uniform = chapter.table, chapter.uniform
    boundaries = 3 * 3 * table.repeats  # instances x boundaries x repeats
    tps, ind = (np.asarray(table.samples[row]["jerk"]) for row in (TPS, INDEPENDENT))
    assert tps.shape == ind.shape == (boundaries,)
    d = tps - ind
    assert table.paired(TPS, INDEPENDENT, "jerk") == mean_ci(d[np.isfinite(d)])
    assert len(table.samples[TPS]["fid"]) == table.repeats  # the other metrics: per repeat
    # each generated row keeps its motions, repeat by repeat, for the chapter's figures
    assert set(chapter.generated) == set(method_rows(PAPER_METHODS, 90))
    assert all(len(runs) == table.repeats and len(runs[0]) == 3 for runs in chapter.generated.values())
    # another model on the same instances and seeds: its rows join the table and pair with the chapter's
    arms = table.select(GROUND_TRUTH_SINGLE, TPS).joined(uniform.select(TPS), prefix="uniform: ")
    assert list(arms.rows) == [GROUND_TRUTH_SINGLE, TPS, "uniform: " + TPS]
    assert arms.paired(TPS, "uniform: " + TPS, "jerk").n == boundaries
    assert uniform.rows[GROUND_TRUTH_CONCAT] == table.rows[GROUND_TRUTH_CONCAT]  # real data: the same numbers
    assert not np.allclose(uniform.samples[TPS]["jerk"], table.samples[TPS]["jerk"])  # a different model


def test_a_second_evaluation_decodes_the_tokens_the_first_drew(chapter):
    """Chapter 09's DisCoRD rows take the main table's draws (``tokens=``): here the same decoder, so the rows must
    come back number for number, and without a single new draw."""
    from motionlab.data import load_dataset

    by_model = chapter.tokens
    assert len(by_model) == 2  # the chapter's model and t2m/uniform keep their draws apart
    drawn = by_model[next(key for key in by_model if key[0] == chapter.config.model)]
    # 8 methods x 2 repeats, less the draws "separate" shares with "independent"
    assert len(drawn) == (len(PAPER_METHODS) - 1) * chapter.table.repeats
    before = dict(drawn)
    with pytest.MonkeyPatch.context() as mp:
        mp.setenv("MOTIONLAB_PROFILE", "smoke")
        mp.setenv("MOTIONLAB_PRECISION", "fp32")
        again = evaluate_multi(
            load_dataset(profile="smoke", seed=0),
            replace(chapter.config, methods=("independent", "tps")),
            tokens=chapter.tokens,
        )
    assert drawn == before and all(drawn[key] is before[key] for key in before)
    for row in (INDEPENDENT, TPS):
        assert again.rows[row] == chapter.table.rows[row]


# --------------------------------------------------------------------------------- the config, without models


def test_paper_config_takes_a_chapters_sizes():
    laptop = chapter_sizes("laptop").tps
    config = paper_config(laptop, seed=3)
    assert (config.instances, config.repeats, config.num_steps, config.seed) == (32, 3, 25, 3)
    assert config.methods == PAPER_METHODS and config.model == "t2m/multi-eta0.25" and config.segment_jerk
    assert paper_config(laptop, model="t2m/uniform").model == "t2m/uniform"
    assert list(method_rows(PAPER_METHODS, 90)) == [
        INDEPENDENT,
        "Separate (motions concatenated)",
        TPS,
        "TPS (T_s = 90, compound condition)",
        "TPS (T_s = 50)",
        "TPS (T_s = 0)",
        "Handshake (40 frames)",
        "SLERP (40 frames)",
    ]


@pytest.mark.parametrize("profile", ["smoke", "laptop", "full"])
def test_the_command_line_parses_back_into_the_config(profile):
    config = paper_config(chapter_sizes(profile).tps, seed=1)
    args = cli.build_parser().parse_args(shlex.split(config.command_line(profile))[1:])
    assert args.profile == profile and cli._evaluation_config(args, args.repeats) == config
    flow = replace(config, decoder="discord", methods=("independent", "tps"), steps=4, solver="midpoint")
    args = cli.build_parser().parse_args(shlex.split(flow.command_line(profile))[1:])
    assert cli._evaluation_config(args, args.repeats) == flow


def test_method_specs():
    assert parse_method("tps:T_s=50:joint_text=all") == ("tps", {"T_s": 50, "joint_text": "all"})
    assert parse_method("handshake:transition=24") == ("handshake", {"transition": 24})
    assert method_rows(["tps", "slerp"], 80) == {
        "TPS (T_s = 80)": {"method": "tps", "T_s": 80},
        "SLERP (40 frames)": {"method": "slerp"},
    }


@pytest.mark.parametrize(
    "spec, message",
    [
        ("tpz", "unknown method"),
        ("tps:transition=40", "not an option of tps"),
        ("tps:T_s=x", "T_s must be an int"),
        ("tps:T_s=-1", "T_s"),
        ("tps:joint_text=some", "joint_text must be one of"),
        ("slerp:transition=30", "positive multiple of 8"),
        ("tps:T_s=50:T_s=40", "sets T_s twice"),
        ("", "non-empty string"),
    ],
)
def test_bad_method_specs_are_refused(spec, message):
    with pytest.raises(ValueError, match=message):
        parse_method(spec)


@pytest.mark.parametrize(
    "options, message",
    [
        ({"methods": ("tps", "tps")}, "without repeats"),
        ({"methods": ("tps:T_s=90", "tps")}, None),  # the same row twice is refused when the rows are named
        ({"model": "discord/vq"}, "text-to-motion model"),
        ({"segment_jerk": 1}, "True or False"),
        ({"decoder": "flow"}, "'vq' or 'discord'"),
    ],
)
def test_bad_configs_are_refused(options, message):
    if message is None:
        with pytest.raises(ValueError, match="twice"):
            method_rows(MultiMotionConfig(**options).methods, 90)
        return
    with pytest.raises(ValueError, match=message):
        MultiMotionConfig(**options)
