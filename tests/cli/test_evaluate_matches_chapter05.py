"""``motionlab evaluate reconstruction`` computes chapter 05's tables: the CLI, run in-process, prints the numbers the
chapter's own expression computes (smoke models, 12 test clips), Table 1 and Table E alike.

Also the options behind that: :class:`ReconstructionConfig` built from the chapter's sizes, its command line, its grid
rows, and the columns that the options add.
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
from motionlab.evaluation import ReconstructionConfig, repeat_seed
from motionlab.evaluation.reconstruction import GROUND_TRUTH, PAPER_TABLE_1
from motionlab.sizes import DiscordSizes, chapter_sizes

REPO = Path(__file__).resolve().parents[2]
CHAPTER_05 = REPO / "notebooks" / "05_discord.ipynb"
# The two statements of chapter 05 that compute its Table 1 and Table E (the test evaluates exactly these).
CONFIG = "evaluation.ReconstructionConfig.from_sizes(sizes.discord, seed=seed)"
TABLE = "evaluation.evaluate_reconstruction(dataset, eval_config, profile)"
TIMED = "seconds"  # wall-clock times differ from run to run; every other number must agree exactly


def test_chapter_05_computes_its_tables_with_these_expressions(chapter_code):
    code = chapter_code(CHAPTER_05)
    assert f"eval_config = {CONFIG}" in code and f"table = {TABLE}" in code
    assert "eval_config.command_line(profile)" in code  # the page prints the command that gives its numbers


@pytest.fixture(scope="module")
def small_sizes() -> DiscordSizes:
    """Chapter 05's smoke sizes, smaller: 12 clips, 2 seeds, one timed call, three grid rows (one at the smoke
    decoder's own 4 Euler steps)."""
    return replace(
        chapter_sizes("smoke").discord,
        test_clips=12,
        seeds=2,
        timing_repeats=1,
        euler_steps=(1, 4),
        midpoint_steps=(1,),
    )


@pytest.fixture(scope="module")
def chapter_table(small_sizes):
    """The table as chapter 05 computes it (its two statements, evaluated as written), in the smoke profile."""
    from motionlab.data import load_dataset

    with pytest.MonkeyPatch.context() as mp:
        mp.setenv("MOTIONLAB_PROFILE", "smoke")
        mp.setenv("MOTIONLAB_PRECISION", "fp32")
        dataset = load_dataset(profile="smoke", seed=0)
        config = eval(
            CONFIG, {"evaluation": motionlab.evaluation, "sizes": SimpleNamespace(discord=small_sizes), "seed": 0}
        )
        names = {"evaluation": motionlab.evaluation, "dataset": dataset, "eval_config": config}
        table = eval(TABLE, {**names, "profile": "smoke"})
    return config, table


def _untimed(rows: dict) -> dict:
    return {row: {m: cell for m, cell in cells.items() if m != TIMED} for row, cells in rows.items()}


def test_the_cli_prints_the_numbers_chapter_05_computes(chapter_table, run_command_line):
    evaluation, table = chapter_table
    argv, printed, result = run_command_line(evaluation)
    assert argv[:4] == ["evaluate", "reconstruction", "--profile", "smoke"] and "--token-phases" in argv
    assert printed.startswith(table.header())
    expected = json.loads(json.dumps(table.to_json_dict()))  # JSON's lists for the config's tuples
    assert result["config"] == expected["config"] and result["counts"] == {"clips": 12}
    assert result["metrics"] == expected["metrics"] and result["notes"] == expected["notes"]
    assert _untimed(result["rows"]) == _untimed(expected["rows"])  # every number but the wall-clock times
    timed = [row for row, cells in result["rows"].items() if TIMED in cells]
    assert timed == [row for row in expected["rows"] if row != GROUND_TRUTH]
    assert all(result["rows"][row][TIMED]["mean"] > 0 for row in timed)
    for row in expected["rows"]:
        assert f"| {row}" in printed  # the CLI prints every row the chapter reads
    assert list(result["rows"]) == [
        "RVQ-VAE decoder",
        "RVQ-VAE tokens + DisCoRD (4 euler steps)",
        "DisCoRD, 1 euler step (1 evaluation)",
        "DisCoRD, 4 euler steps (4 evaluations)",
        "DisCoRD, 1 midpoint step (2 evaluations)",
        GROUND_TRUTH,
    ]


def test_the_options_rows_and_columns_hold_what_the_chapter_reads(chapter_table):
    evaluation, table = chapter_table
    ff, rf = list(table.rows)[:2]
    assert table.deterministic == (ff, GROUND_TRUTH)
    # the repeats: repeat r from repeat_seed(seed, r), the grid rows from the first grid_seeds of them
    assert all(len(values) == 2 for m, values in table.samples[rf].items() if m != TIMED)
    at_default = evaluation.grid_row("euler", 4)  # the smoke decoder's own steps: its first repeat, not decoded again
    for metric in ("fid", "sjpe", "noise_sjpe", "mpjpe_mm"):
        assert table.samples[at_default][metric] == table.samples[rf][metric][:1]
        assert table.estimate(rf, metric).mean == pytest.approx(np.mean(table.samples[rf][metric]))
    assert table.estimate(evaluation.grid_row("euler", 1), "fid").mean != table.estimate(at_default, "fid").mean
    # Noise sJPE by token phase sums to Noise sJPE, run by run; the share is phase 0's part
    phases = [f"noise_sjpe_phase{p}" for p in range(4)]
    for row in (ff, rf):
        runs = table.samples[row]
        total = np.sum([runs[m] for m in phases], axis=0)
        np.testing.assert_allclose(total, runs["noise_sjpe"], rtol=1e-9)
        np.testing.assert_allclose(runs["noise_sjpe_boundary_share"], np.array(runs[phases[0]]) / total, rtol=1e-9)
    # the ground truth's own jerk, the time and the arithmetic of each decoder
    assert set(table.rows[GROUND_TRUTH]) == {"joint_jerk"} and table.rows[GROUND_TRUTH]["joint_jerk"].mean > 0
    flops = {row: table.estimate(row, "gflops").mean for row in table.rows if row != GROUND_TRUTH}
    one, two, four = (flops[evaluation.grid_row(m, s)] for m, s in (("euler", 1), ("midpoint", 1), ("euler", 4)))
    assert four - one == pytest.approx(3 * (two - one)) and two > one  # a U-Net call per evaluation, a projection
    assert table.estimate(ff, "seconds").n == evaluation.timing_repeats
    assert "12 longest clips" in table.notes[0]  # fewer clips than a batch of 32: all of them
    # each clip's values, averaged over a row's seeds, pair the decoders clip by clip (the claims' test-set interval)
    from motionlab.evaluation import reconstruction_clip_cells

    assert len(table.clip_values[rf]["sjpe"]) == 12 and len(table.clip_weights["mpjpe_mm"]) == 12
    for metric in ("sjpe", "noise_sjpe", "static_sjpe", "mpjpe_mm"):
        difference = table.paired_clips(rf, ff, metric)
        assert difference.mean == pytest.approx(table.estimate(rf, metric).mean - table.estimate(ff, metric).mean)
        assert difference.half_width > 0 and difference.n == 12
    cells = reconstruction_clip_cells(table, evaluation)
    assert cells["sjpe_rf_minus_ff"] == (rf, ff, "sjpe") and cells["mpjpe_rf_minus_ff"] == (rf, ff, "mpjpe_mm")
    # the paper's rows sit beside ours in Table 1
    shown = table.with_rows(PAPER_TABLE_1).select(ff, rf, *PAPER_TABLE_1)
    assert shown.estimate("paper, HumanML3D: MoMask + DisCoRD", "sjpe_ratio").mean == 0.385


def test_the_chapters_example_decodes_are_table_1s_first_seed(chapter_table):
    from motionlab import models
    from motionlab.data import load_dataset
    from motionlab.metrics import sjpe_dataset
    from motionlab.studies.reconstruction import ground_truth_joints, reconstructed_joints

    evaluation, table = chapter_table
    with pytest.MonkeyPatch.context() as mp:
        mp.setenv("MOTIONLAB_PROFILE", "smoke")
        dataset = load_dataset(profile="smoke", seed=0)
        tokenizer, decoder = models.load("tokenizer/rvq", dataset), models.load("discord/rvq", dataset)
        gt = ground_truth_joints(dataset, tokenizer, limit=evaluation.limit)
        rf = reconstructed_joints(dataset, tokenizer, decoder, limit=evaluation.limit, seed=repeat_seed(0, 0))
    rf_row = list(table.rows)[1]
    assert len(gt) == len(rf) == 12
    assert sjpe_dataset(rf, gt).sjpe == pytest.approx(table.samples[rf_row]["sjpe"][0], rel=1e-6)


# --------------------------------------------------------------------------------- the config, without models


@pytest.mark.parametrize("profile", ["smoke", "laptop", "full"])
def test_from_sizes_builds_the_chapter_and_its_command_line_parses_back(profile):
    sizes = chapter_sizes(profile).discord
    config = ReconstructionConfig.from_sizes(sizes, seed=3)
    assert (config.limit, config.repeats, config.timing_repeats, config.seed) == (
        sizes.test_clips,
        sizes.seeds,
        sizes.timing_repeats,
        3,
    )
    assert config.grid[:5] == tuple(("euler", s) for s in sizes.euler_steps) and config.grid[-1] == ("midpoint", 15)
    assert config.grid_repeats == sizes.grid_seeds and config.jerk and config.token_phases
    args = cli.build_parser().parse_args(shlex.split(config.command_line(profile))[1:])
    assert args.profile == profile and cli._evaluation_config(args, args.repeats) == config


def test_every_option_survives_the_command_line():
    config = ReconstructionConfig(
        tokenizer="vq",
        split="val",
        limit=40,
        repeats=3,
        seed=2,
        steps=5,
        solver="midpoint",
        prediction="x",
        temperature=0.1 + 0.2,  # a float whose short form would read back differently
        spacing="data_dense",
        final_prediction=True,
        grid="euler:2, midpoint:3",
        grid_repeats=2,
        timing_repeats=4,
        jerk=True,
    )
    assert config.grid == (("euler", 2), ("midpoint", 3))  # the CLI's text, read into pairs
    args = cli.build_parser().parse_args(shlex.split(config.command_line())[1:])
    assert cli._evaluation_config(args, args.repeats) == config
    assert ReconstructionConfig().command_line() == "motionlab evaluate reconstruction --repeats 1"


def test_grid_row_names_and_bad_options():
    config = ReconstructionConfig(grid=[("euler", 1), "midpoint:15"])
    assert config.grid_row("euler", 1) == "DisCoRD, 1 euler step (1 evaluation)"
    assert config.grid_row("midpoint", 15) == "DisCoRD, 15 midpoint steps (30 evaluations)"
    with pytest.raises(KeyError, match="not in this config's grid"):
        config.grid_row("euler", 2)
    for options, message in (
        ({"grid": "rk4:2"}, "grid solver must be one of"),
        ({"grid": "euler:two"}, "look like 'midpoint:15'"),
        ({"grid": "euler:0"}, "grid steps must be an int >= 1"),
        ({"grid": "euler:2,euler:2"}, "distinct"),
        ({"grid": [("euler", 1, 2)]}, "pairs"),
        ({"decoder": "rvq", "grid": "euler:1"}, "needs decoder='discord'"),
        ({"grid_repeats": 2}, "needs a grid"),
        ({"grid": "euler:1", "grid_repeats": 0}, "grid_repeats must be an int >= 1"),
        ({"timing_repeats": -1}, "timing_repeats must be an int >= 0"),
        ({"jerk": 1}, "True or False"),
        ({"token_phases": "yes"}, "True or False"),
    ):
        with pytest.raises(ValueError, match=message):
            ReconstructionConfig(**options)
    with pytest.raises(ValueError, match="DiscordSizes"):
        ReconstructionConfig.from_sizes(chapter_sizes("smoke").tps)
    with pytest.raises(ValueError, match="unknown ReconstructionConfig option"):
        ReconstructionConfig.from_sizes(chapter_sizes("smoke").discord, steps_grid=())


def test_bad_cli_options_exit_2_before_any_work(tmp_path, capsys):
    missing = str(tmp_path / "missing")
    for options, message in (
        (["--grid", "euler:x"], "look like 'midpoint:15'"),
        (["--grid-repeats", "2"], "needs a grid"),
        (["--decoder", "vq", "--grid", "euler:1"], "needs decoder='discord'"),
    ):
        assert cli.main(["evaluate", "reconstruction", "--profile", "smoke", "--data", missing, *options]) == 2
        assert message in capsys.readouterr().err
