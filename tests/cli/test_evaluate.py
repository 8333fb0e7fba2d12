"""``motionlab evaluate``: the three paper tables on a tiny embedded dataset with smoke models.

One 240-clip dataset (42 test clips: enough for R-precision's batches of 32) and one model cache serve the
whole module, so every smoke model is trained once, by whichever test needs it first.
"""

import json
import math

import numpy as np
import pytest

from motionlab.cli import main
from motionlab.evaluation import EvaluationTable, repeat_seed, write_json
from motionlab.metrics import Estimate


@pytest.fixture(scope="module")
def data(tmp_path_factory):
    root = tmp_path_factory.mktemp("evaluate")
    with pytest.MonkeyPatch.context() as mp:
        mp.setenv("MOTIONLAB_HOME", str(root / "motionlab-home"))
        assert main(["data", "make-embedded", "--out", str(root / "data"), "--clips", "240"]) == 0
        yield root / "data"


def evaluate(task: str, data, *options: str) -> int:
    return main(["evaluate", task, "--profile", "smoke", "--data", str(data), "--device", "cpu", *options])


def read(path) -> dict:
    return json.loads(path.read_text())


def test_help_for_evaluate_and_every_task(capsys):
    for argv in (["evaluate"], ["evaluate", "reconstruction"], ["evaluate", "t2m"], ["evaluate", "multi"]):
        with pytest.raises(SystemExit) as exit_info:
            main([*argv, "--help"])
        assert exit_info.value.code == 0
        out = capsys.readouterr().out
        assert out.startswith(f"usage: motionlab {' '.join(argv)}")
    assert "discord:FOLDER[,TOKENIZER]" in main_help(["evaluate", "reconstruction"], capsys)
    assert "--multimodality" in main_help(["evaluate", "t2m"], capsys)
    assert "--methods" in main_help(["evaluate", "multi"], capsys)
    assert "reconstruction" in main_help(["evaluate"], capsys)


def main_help(argv, capsys) -> str:
    with pytest.raises(SystemExit):
        main([*argv, "--help"])
    return capsys.readouterr().out


def test_reconstruction_vq_json_equals_the_library_scores(data, tmp_path, capsys):
    from motionlab.data import load_dataset
    from motionlab.evaluation.reconstruction import lost_travel
    from motionlab.flow.reconstruction import decode_clips, reconstruction_scores
    from motionlab.metrics import ClipJoints
    from motionlab.metrics.evaluator_training import load_or_train_evaluator
    from motionlab.tokenizers import tokenizer_for_dataset

    out = tmp_path / "vq.json"
    assert evaluate("reconstruction", data, "--decoder", "vq", "--limit", "12", "--json", str(out)) == 0
    stdout = capsys.readouterr().out.splitlines()
    dataset = load_dataset(data)
    assert stdout[0] == (
        f"evaluate reconstruction: profile smoke, fp32, data {dataset.key}, split test, 12 clips, 2 repeats, seed 0"
    )
    assert "| VQ-VAE decoder (deterministic) |" in "\n".join(stdout)

    # the same numbers, straight from the building blocks
    clips = dataset.split("test")[:12]
    tokenizer = tokenizer_for_dataset("vq", dataset, "smoke", device="cpu")
    evaluator = load_or_train_evaluator(dataset, "smoke", device="cpu")
    q = tokenizer.downsample
    gt = [c.features[: len(c.features) // q * q] for c in clips]
    recon = decode_clips([dataset.normalizer.normalize(c.features) for c in clips], tokenizer)
    expected = reconstruction_scores([dataset.normalizer.denormalize(r) for r in recon], gt, evaluator.embed_motions)
    # the lost-travel note sits under the table exactly when the building blocks find the pattern
    _, travel_note = lost_travel(
        ClipJoints.from_features(gt), ClipJoints.from_features([dataset.normalizer.denormalize(r) for r in recon])
    )
    printed = "\n".join(stdout)
    assert (travel_note in printed) if travel_note else ("Travel lost" not in printed)

    result = read(out)
    header = {k: result[k] for k in ("task", "profile", "data", "split", "repeats", "seed")}
    assert header == dict(task="reconstruction", profile="smoke", data=dataset.key, split="test", repeats=2, seed=0)
    assert result["config"]["decoder"] == "vq" and result["config"]["limit"] == 12
    assert list(result["rows"]) == ["VQ-VAE decoder"] and result["deterministic"] == ["VQ-VAE decoder"]
    row = result["rows"]["VQ-VAE decoder"]
    assert set(row) == {
        "fid",
        "mpjpe_mm",
        "sjpe",
        "noise_sjpe",
        "static_sjpe",
        "sjpe_ratio",
        "noise_sjpe_ratio",
        "static_sjpe_ratio",
        "joint_jerk",
    }
    for metric, value in expected.as_dict().items():
        assert row[metric] == {"mean": pytest.approx(value, rel=1e-9, abs=1e-12), "ci95": 0.0, "n": 1}
    assert not [p for p in tmp_path.iterdir() if p.name != "vq.json"]  # no temporary file left behind


def test_reconstruction_discord_repeats_spread_and_are_seeded(data, tmp_path, capsys):
    args = ["--decoder", "discord", "--limit", "10", "--repeats", "2", "--steps", "2"]
    a, b, c = tmp_path / "a.json", tmp_path / "b.json", tmp_path / "c.json"
    assert evaluate("reconstruction", data, *args, "--seed", "3", "--json", str(a)) == 0
    assert evaluate("reconstruction", data, *args, "--seed", "3", "--json", str(b)) == 0
    assert evaluate("reconstruction", data, *args, "--seed", "4", "--json", str(c)) == 0
    rows = read(a)["rows"]
    flow = "RVQ-VAE tokens + DisCoRD (2 euler steps)"
    assert list(rows) == ["RVQ-VAE decoder", flow]
    assert all(rows[flow][m]["n"] == 2 for m in rows[flow])
    assert rows[flow]["fid"]["ci95"] > 0 and rows[flow]["mpjpe_mm"]["ci95"] > 0  # two seeds, two decodes
    assert read(b)["rows"] == rows  # the same seed, the same numbers
    assert read(c)["rows"][flow]["mpjpe_mm"] != rows[flow]["mpjpe_mm"]
    assert read(c)["rows"]["RVQ-VAE decoder"] == rows["RVQ-VAE decoder"]  # deterministic: the seed is unused
    assert f"| {flow} |" in capsys.readouterr().out


def test_reconstruction_chooses_the_flow_decoders_parameterisation_and_sampling(data, tmp_path, capsys):
    base = ["--decoder", "discord", "--limit", "10", "--repeats", "2", "--steps", "2"]
    x, cold = tmp_path / "x.json", tmp_path / "cold.json"
    assert evaluate("reconstruction", data, *base, "--predict", "x", "--final-prediction", "--json", str(x)) == 0
    assert (
        evaluate(
            "reconstruction",
            data,
            *base,
            "--predict",
            "x",
            "--final-prediction",
            "--temperature",
            "0",
            "--json",
            str(cold),
        )
        == 0
    )
    flow_x = "RVQ-VAE tokens + DisCoRD (2 euler steps, x-prediction, last step x̂1)"
    assert list(read(x)["rows"])[1] == flow_x
    assert read(x)["config"]["prediction"] == "x" and read(x)["config"]["temperature"] is None
    cold_row = read(cold)["rows"]["RVQ-VAE tokens + DisCoRD (2 euler steps, x-prediction, temperature 0, last step x̂1)"]
    assert cold_row["mpjpe_mm"]["ci95"] == 0.0 and cold_row["mpjpe_mm"]["n"] == 1  # no start noise: decoded once
    assert "temperature 0 decodes every seed to the same motion" in " ".join(read(cold)["notes"])
    capsys.readouterr()


@pytest.mark.parametrize(
    "options,message",
    [
        (["--decoder", "rvq", "--temperature", "0.5"], "need decoder='discord'"),
        (["--decoder", "vq", "--predict", "x"], "need decoder='discord'"),
        (["--decoder", "discord", "--final-prediction"], "prediction='x'"),
        (["--decoder", "discord", "--temperature", "-1"], "temperature"),
    ],
)
def test_reconstruction_rejects_flow_options_that_cannot_apply(data, capsys, options, message):
    assert evaluate("reconstruction", data, *options) == 2
    assert message in capsys.readouterr().err


def test_train_refuses_flow_options_for_other_models(data, capsys):
    args = ["train", "vq", "--profile", "smoke", "--data", str(data), "--predict", "x"]
    assert main(args) == 2
    assert "need the model 'discord'" in capsys.readouterr().err


def test_t2m_prints_the_ground_truth_row_and_every_metric(data, capsys):
    options = [
        "--limit",
        "32",
        "--repeats",
        "2",
        "--num-steps",
        "5",
        "--multimodality",
        "--mm-texts",
        "3",
        "--mm-repeats",
        "10",
    ]
    assert evaluate("t2m", data, *options) == 0
    captured = capsys.readouterr()
    lines = captured.out.splitlines()
    # stderr is not a terminal here: one line per phase reaches the log, with an honest MultiModality estimate
    phases = [line for line in captured.err.splitlines() if line.startswith("evaluate ")]
    assert any("generating 32 motions (repeat 2 of 2)" in line for line in phases)
    assert any("MultiModality: 2 × 30 motions (3 texts × 10), about" in line for line in phases)
    assert any("MultiModality repeat 2 of 2" in line for line in phases)
    assert lines[0].startswith("evaluate t2m: profile smoke") and "32 clips" in lines[0] and "2 repeats" in lines[0]
    header = lines[1]
    for column in ("R-Top1", "R-Top2", "R-Top3", "FID", "MM-Dist", "Diversity", "MModality"):
        assert column in header
    truth = next(line for line in lines if line.startswith("| Ground Truth |"))
    model = next(line for line in lines if line.startswith("| Discrete diffusion + VQ decoder |"))
    assert truth.count("±") == 6 and truth.rstrip(" |").endswith("–")  # no MultiModality for real motions
    assert model.count("±") == 7
    fid_truth = float(truth.split("|")[5].split("±")[0])
    fid_model = float(model.split("|")[5].split("±")[0])
    assert abs(fid_truth) < 1e-3 < fid_model  # the real motions against themselves


def test_multi_tps_and_independent(data, tmp_path, capsys):
    out = tmp_path / "multi.json"
    options = ["--methods", "tps,independent", "--instances", "3", "--repeats", "2", "--num-steps", "5"]
    assert evaluate("multi", data, *options, "--json", str(out)) == 0
    captured = capsys.readouterr()
    stdout = captured.out
    assert "multi-motion generation 4 of 4" in captured.err  # one line per generation phase in a log
    assert "3 instances, 4 actions each" in stdout.splitlines()[0]
    result = read(out)
    assert list(result["rows"]) == [
        "Ground Truth (Single)",
        "Ground Truth (Concat)",
        "TPS (T_s = 90)",
        "Independent (tokens concatenated)",
    ]
    assert result["config"]["methods"] == ["tps", "independent"] and result["counts"]["instances"] == 3
    for label in ("TPS (T_s = 90)", "Independent (tokens concatenated)", "Ground Truth (Single)"):
        row = result["rows"][label]
        assert list(row) == result["metrics"]
        assert all(math.isfinite(row[m]["mean"]) for m in row)
        assert all(row[m]["n"] == 2 for m in row if (label, m) != ("Ground Truth (Single)", "jerk"))  # jerk: windows
    concat = result["rows"]["Ground Truth (Concat)"]  # the Jerk at every cut of the split's instances, with an interval
    assert list(concat) == ["jerk", "cut_minus_inside"] and concat["jerk"]["ci95"] > 0 and concat["jerk"]["n"] >= 9
    assert math.isfinite(concat["jerk"]["mean"])
    assert "| Ground Truth (Concat) | – |" in stdout


@pytest.mark.parametrize(
    "task, options, message",
    [
        ("reconstruction", ["--repeats", "0"], "repeats must be an int >= 1"),
        ("reconstruction", ["--limit", "1"], "limit must be an int >= 2"),
        ("reconstruction", ["--decoder", "vq", "--tokenizer", "rvq"], "is that tokenizer's own decoder"),
        ("reconstruction", ["--tokenizer", "momask:/nowhere"], "the book's decoder, trained on the book's tokens"),
        ("reconstruction", ["--decoder", "discord:/nowhere", "--tokenizer", "rvq"], "codes of the tokenizer"),
        ("reconstruction", ["--decoder", "discord:/nowhere", "--predict", "x"], "a released decoder is what"),
        ("reconstruction", ["--tokenizer", "vqgan:/x", "--decoder", "feed-forward"], "a released tokenizer is one of"),
        ("reconstruction", ["--evaluator", "mine"], "'official:FOLDER'"),
        ("reconstruction", ["--glove", "/g"], "it needs evaluator='official:FOLDER'"),
        ("reconstruction", ["--window", "198"], "multiple of 4"),
        ("reconstruction", ["--decoder", "rvq", "--steps", "4"], "need decoder='discord'"),
        ("reconstruction", ["--solver", "rk4"], "solver must be one of"),
        ("t2m", ["--limit", "8"], "batches of 32"),
        ("multi", ["--methods", "tps,warp"], "unknown method(s) ['warp']"),
        ("multi", ["--actions", "1"], "actions must be an int >= 2"),
    ],
)
def test_bad_options_exit_2_before_any_work(task, options, message, tmp_path, capsys):
    # the data folder does not exist: an option error must be reported before the data is even opened
    assert evaluate(task, tmp_path / "missing", *options) == 2
    assert message in capsys.readouterr().err


def test_existing_json_is_never_overwritten_without_force(data, tmp_path, capsys):
    out = tmp_path / "table.json"
    out.write_text("{}")
    assert evaluate("reconstruction", tmp_path / "missing", "--decoder", "vq", "--json", str(out)) == 2
    err = capsys.readouterr().err
    assert f"--json {out} exists; pass --force" in err and "force=True" not in err and out.read_text() == "{}"
    assert evaluate("reconstruction", data, "--decoder", "vq", "--limit", "4", "--json", str(out), "--force") == 0
    assert read(out)["rows"]["VQ-VAE decoder"]["fid"]["n"] == 1
    assert evaluate("reconstruction", data, "--json", str(tmp_path / "nowhere" / "t.json")) == 2
    assert "does not exist" in capsys.readouterr().err


def test_failures_leave_nothing_behind(data, tmp_path, capsys):
    out = tmp_path / "multi.json"
    # 20 distinct action families do not exist in the tiny test split: fails after the data is loaded
    assert evaluate("multi", data, "--actions", "20", "--json", str(out)) == 2
    assert "distinct families" in capsys.readouterr().err
    assert list(tmp_path.iterdir()) == []
    assert evaluate("reconstruction", tmp_path / "missing") == 2
    assert "does not exist" in capsys.readouterr().err


def test_decoder_choices_are_checked_per_task(capsys):
    with pytest.raises(SystemExit) as exit_info:
        main(["evaluate", "t2m", "--decoder", "rvq"])  # the diffusion model samples VQ tokens
    assert exit_info.value.code == 2 and "invalid choice: 'rvq'" in capsys.readouterr().err


def test_table_json_and_markdown(tmp_path):
    rows = {
        "a": {"fid": Estimate(1.0, 0.5, 3), "jerk": Estimate(float("nan"), float("nan"), 3)},
        "b": {"fid": Estimate(2.0, 0.0, 1)},
    }
    table = EvaluationTable(
        "multi", "smoke", "data-123", "test", 3, 7, {"x": 1}, {"clips": 5}, ("fid", "jerk"), rows, deterministic=("b",)
    )
    md = table.to_markdown(digits=2).splitlines()
    assert md[0] == "| | FID ↓ | Jerk → |"
    assert md[2] == "| a | 1.00 ± 0.50 | nan ± nan |" and md[3] == "| b (deterministic) | 2.00 | – |"
    path = write_json(table, tmp_path / "t.json")
    back = read(path)
    assert back["rows"]["a"]["jerk"] == {"mean": None, "ci95": None, "n": 3}  # JSON has no NaN
    assert back["rows"]["b"]["fid"] == {"mean": 2.0, "ci95": 0.0, "n": 1} and back["seed"] == 7
    with pytest.raises(ValueError, match="exists"):
        write_json(table, path)
    with pytest.raises(ValueError, match=".json"):
        write_json(table, tmp_path / "t.txt")
    one_run = EvaluationTable(
        "t2m", "smoke", "d", "test", 1, 0, {}, {"clips": 32}, ("fid",), {"model": {"fid": Estimate(3.0, 0.0, 1)}}
    )
    assert one_run.to_markdown(digits=1).splitlines()[2] == "| model | 3.0 |"  # no "± 0" from a single run
    assert "32 clips, 1 repeat, seed 0" in one_run.header()
    seeds = {repeat_seed(0, r, s) for r in range(50) for s in range(2)}
    assert len(seeds) == 100 and all(0 <= x < 2**32 for x in seeds) and repeat_seed(5, 1) == repeat_seed(5, 1)
    assert np.isfinite(list(seeds)).all()


def test_configs_validate_and_name_their_tokens():
    from motionlab.evaluation import (
        MultiMotionConfig,
        ReconstructionConfig,
        TextToMotionConfig,
        evaluate_multi,
        evaluate_reconstruction,
    )

    assert ReconstructionConfig().tokenizer_kind == "rvq"  # DisCoRD on MoMask-style residual tokens
    assert ReconstructionConfig(decoder="discord", tokenizer="vq").tokenizer_kind == "vq"  # T2M-GPT + DisCoRD
    assert ReconstructionConfig(decoder="vq").tokenizer_kind == "vq"
    with pytest.raises(ValueError, match="config must be a ReconstructionConfig"):
        evaluate_reconstruction(None, TextToMotionConfig())
    with pytest.raises(ValueError, match="fewer than the 2 transitions"):
        MultiMotionConfig(instances=1, actions=2)
    with pytest.raises(ValueError, match="dataset must be a MotionDataset"):
        evaluate_multi(object(), MultiMotionConfig())
    with pytest.raises(ValueError, match="mm_repeats must be an int >= 10"):
        TextToMotionConfig(mm_repeats=5)
    with pytest.raises(ValueError, match="guidance_on must be one of"):
        MultiMotionConfig(guidance_on="x_t")
    posterior = MultiMotionConfig(guidance_on="posterior", guidance_scale=2.0)
    assert "--guidance-scale 2 --guidance-on posterior" in posterior.command_line()


def test_reconstruction_xpred_decodes_with_the_laptop_lever(monkeypatch):
    """``xpred=True`` (``--xpred``) is chapter 05's x-prediction variant: its own book model, its own config (the
    levers of sizes.DISCORD_XPRED on top of the paper's decoder), refused where no such decoder exists."""
    from types import SimpleNamespace

    from motionlab.evaluation import ReconstructionConfig
    from motionlab.evaluation import reconstruction as recon

    config = ReconstructionConfig(xpred=True, limit=8)
    assert config.book_models() == ["tokenizer/rvq", "evaluator", "discord/rvq-xpred"]
    assert "--xpred" in config.command_line("laptop").split()
    for bad in (
        dict(decoder="vq"),
        dict(tokenizer="vq"),
        dict(training_seed=1),
        dict(decoder="discord:some/folder"),
    ):
        with pytest.raises(ValueError, match="xpred"):
            ReconstructionConfig(xpred=True, **bad)
    seen = []
    monkeypatch.setattr("motionlab.flow.train_or_load_discord", lambda *a, config, **kw: seen.append(config))
    shape = SimpleNamespace(feature_dim=263, code_dim=64, downsample=4)
    dataset = SimpleNamespace(normalizer=None)
    recon._book_decoder(config, dataset, shape, "laptop", None, False)
    recon._book_decoder(ReconstructionConfig(), dataset, shape, "laptop", None, False)
    lever, paper = seen
    assert (lever.prediction, lever.temperature, lever.sample_steps) == ("x", 0.0, 8)
    assert (paper.prediction, paper.temperature, paper.sample_steps) == ("v", 1.0, 15)


def test_reconstruction_training_seed_names_the_replicate_chain():
    from motionlab.evaluation import ReconstructionConfig

    config = ReconstructionConfig(training_seed=2)
    assert config.book_models() == ["tokenizer/rvq-seed2", "evaluator", "discord/rvq-seed2"]
    assert ReconstructionConfig(decoder="vq", training_seed=1).book_models() == ["tokenizer/vq-seed1", "evaluator"]
    assert ReconstructionConfig().book_models() == ["tokenizer/rvq", "evaluator", "discord/rvq"]
    assert "--training-seed 2" in config.command_line("smoke")
    assert "--training-seed" not in ReconstructionConfig().command_line("smoke")
    with pytest.raises(ValueError, match="training_seed"):
        ReconstructionConfig(training_seed=-1)
    with pytest.raises(ValueError, match="released checkpoints have one"):
        ReconstructionConfig(decoder="feed-forward", tokenizer="momask:/nowhere", training_seed=1)


def test_claim_cells_name_the_cells_the_claims_judge():
    from motionlab.estimate import Estimate
    from motionlab.evaluation import EvaluationTable, ReconstructionConfig
    from motionlab.evaluation import reconstruction_claim_cells as claim_cells
    from motionlab.evaluation.reconstruction import GROUND_TRUTH

    config = ReconstructionConfig(grid=(("midpoint", 1), ("midpoint", 15), ("euler", 2)))
    two, sixteen = config.grid_row("midpoint", 1), config.grid_row("midpoint", 15)
    cell = {m: Estimate(1.0) for m in ("fid", "sjpe", "noise_sjpe", "static_sjpe", "mpjpe_mm", "seconds")}
    rows = {"RVQ-VAE": cell, "DisCoRD": cell, two: cell, sixteen: cell, GROUND_TRUTH: {"joint_jerk": Estimate(9.0)}}
    table = EvaluationTable("reconstruction", "smoke", "d", "test", 1, 0, {}, {"clips": 2}, tuple(cell), rows)
    cells = claim_cells(table, config)
    assert cells["sjpe_rf"] == ("DisCoRD", "sjpe") and cells["sjpe_ff"] == ("RVQ-VAE", "sjpe")
    assert cells["mpjpe_rf"] == ("DisCoRD", "mpjpe_mm") and cells["time_ff"] == ("RVQ-VAE", "seconds")
    assert cells["fid_steps2"] == (two, "fid") and cells["time_steps16"] == (sixteen, "seconds")
    assert cells["joint_jerk_gt"] == (GROUND_TRUTH, "joint_jerk")
    assert "joint_jerk_rf" not in cells  # no such column in this table
    no_grid = claim_cells(table, ReconstructionConfig())
    assert "fid_steps2" not in no_grid and no_grid["fid_rf"] == ("DisCoRD", "fid")
    with pytest.raises(ValueError, match="decoder='discord'"):
        claim_cells(table, ReconstructionConfig(decoder="vq"))


def test_multi_claim_cells_name_chapter_09s_rows():
    from motionlab.estimate import Estimate
    from motionlab.evaluation import EvaluationTable, multi_claim_cells
    from motionlab.evaluation.multi import PAPER_METHODS, method_rows
    from motionlab.multimotion import GROUND_TRUTH_CONCAT, GROUND_TRUTH_SINGLE

    cell = {m: Estimate(1.0) for m in ("jerk", "fid", "r_top3", "segment_jerk")}
    rows = {label: cell for label in method_rows(PAPER_METHODS, 90)}
    rows |= {GROUND_TRUTH_SINGLE: {"jerk": Estimate(1.2)}, GROUND_TRUTH_CONCAT: {"jerk": Estimate(1.4)}}
    table = EvaluationTable("multi", "smoke", "d", "test", 1, 0, {}, {"instances": 2}, tuple(cell), rows)
    cells = multi_claim_cells(table)
    assert cells["jerk_tps"] == ("TPS (T_s = 90)", "jerk") and cells["fid_ts50"] == ("TPS (T_s = 50)", "fid")
    assert cells["fid_ts100"] == ("Independent (tokens concatenated)", "fid")
    assert cells["jerk_handshake"] == ("Handshake (40 frames)", "jerk")
    assert cells["r_top3_tps_compound"] == ("TPS (T_s = 90, compound condition)", "r_top3")
    assert cells["jerk_gt_concat"] == (GROUND_TRUTH_CONCAT, "jerk")
    assert "jerk_concat_minus_inside" not in cells  # the table has no such column
    only_two = EvaluationTable("multi", "smoke", "d", "test", 1, 0, {}, {}, ("jerk",), {"TPS (T_s = 90)": cell})
    assert set(multi_claim_cells(only_two)) == {"jerk_tps", "segment_jerk_tps", "fid_ts90", "r_top3_tps"}
