"""``motionlab evaluate reconstruction`` on released checkpoints: a folder in the HumanML3D layout, a DisCoRD folder
with its MoMask tokenizer, a T2M-GPT VQ and the official evaluator, all in their released layouts (random weights)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import torch
from released_layouts import UNetSize, VQSize, write_discord, write_t2mgpt

from motionlab.cli import main
from motionlab.data import load_dataset
from motionlab.evaluation import EvaluationTable, ReconstructionConfig, evaluate_reconstruction
from motionlab.flow.reconstruction import decode_clips, reconstruction_scores
from motionlab.metrics import TextMotionEvaluator, load_official_evaluator
from motionlab.metrics.evaluator import EvaluatorConfig
from motionlab.pretrained import load_discord_decoder

SMALL_EVALUATOR = EvaluatorConfig(
    dim_text_hidden=8, dim_motion_hidden=12, dim_coemb=6, dim_movement_hidden=10, dim_movement_latent=10
)


@pytest.fixture(scope="module")
def released(tmp_path_factory):
    """The embedded data (HumanML3D's layout, 263-d), DisCoRD + MoMask and T2M-GPT folders, the official evaluator."""
    root = tmp_path_factory.mktemp("released")
    with pytest.MonkeyPatch.context() as mp:
        mp.setenv("MOTIONLAB_HOME", str(root / "home"))
        assert main(["data", "make-embedded", "--out", str(root / "HumanML3D"), "--clips", "120"]) == 0
    write_discord(root / "DisCoRD", UNetSize(dim=16, c_in=16, c_proj=8), with_tokenizer=VQSize(width=32))
    write_t2mgpt(root / "T2M-GPT", VQSize(quantizers=1, width=32))
    model = TextMotionEvaluator(SMALL_EVALUATOR, generator=torch.Generator().manual_seed(3)).eval()
    return root, model


def test_the_cli_prints_table_1_of_the_released_models_with_the_paper_beside(
    released, official_evaluator_layout, tmp_path, capsys, monkeypatch
):
    root, model = released
    official_evaluator_layout(tmp_path / "evaluator", model)
    monkeypatch.setenv("MOTIONLAB_HOME", str(tmp_path / "home"))  # nothing of the book's is trained or loaded
    argv = ["evaluate", "reconstruction", "--data", str(root / "HumanML3D"), "--decoder", f"discord:{root / 'DisCoRD'}"]
    argv += ["--evaluator", f"official:{tmp_path / 'evaluator'}", "--limit", "8", "--repeats", "2", "--steps", "2"]
    assert main([*argv, "--json", str(tmp_path / "t1.json")]) == 0
    out, err = capsys.readouterr()
    assert "MoMask RVQ-VAE (released) decoder" in out and "MoMask RVQ-VAE (released) tokens + DisCoRD (released)" in out
    assert "paper, HumanML3D: MoMask + DisCoRD" in out and "zero-padded to 196 frames" in out
    assert "reconstruction cost:" in err and "GFLOP per clip" in err and "models first" not in err
    assert not (tmp_path / "home" / "models").exists()
    table = json.loads((tmp_path / "t1.json").read_text())
    assert table["config"]["decoder"].startswith("discord:") and table["counts"]["clips"] == 8


def test_the_numbers_are_the_released_modules_decoding_the_official_window(
    released, official_evaluator_layout, tmp_path
):
    root, model = released
    official_evaluator_layout(tmp_path / "evaluator", model)
    dataset = load_dataset(root / "HumanML3D")
    config = ReconstructionConfig(
        decoder=f"discord:{root / 'DisCoRD'}",
        evaluator=f"official:{tmp_path / 'evaluator'}",
        limit=6,
        repeats=1,
        steps=2,
    )
    table = evaluate_reconstruction(dataset, config, device="cpu")  # where the expected numbers are computed
    decoder = load_discord_decoder(root / "DisCoRD")
    tokenizer, evaluator = decoder.tokenizer, load_official_evaluator(tmp_path / "evaluator", tmp_path / "evaluator")
    clips = [c.features[:196] for c in dataset.split("test")[:6]]
    gt = [c[: len(c) // 4 * 4] for c in clips]
    normalized = [tokenizer.normalizer.normalize(c) for c in clips]
    recon = decode_clips(normalized, tokenizer, pad_to=196)  # the official loader's zero-padded 196-frame windows
    expected = reconstruction_scores([tokenizer.normalizer.denormalize(r) for r in recon], gt, evaluator.embed_motions)
    row = table.rows["MoMask RVQ-VAE (released) decoder"]
    assert row["mpjpe_mm"].mean == pytest.approx(expected.mpjpe_mm, rel=1e-5)
    assert row["sjpe"].mean == pytest.approx(expected.sjpe, rel=1e-5)
    assert row["fid"].mean == pytest.approx(expected.fid, rel=1e-4, abs=1e-6)
    unpadded = decode_clips(normalized, tokenizer)
    assert any(
        not np.allclose(a, b, atol=1e-6) for a, b in zip(recon, unpadded)
    )  # the window changes the tokens' context


def test_a_t2mgpt_tokenizer_gives_its_feed_forward_row(released, official_evaluator_layout, tmp_path, capsys):
    root, model = released
    official_evaluator_layout(tmp_path / "evaluator", model)
    argv = ["evaluate", "reconstruction", "--data", str(root / "HumanML3D"), "--decoder", "feed-forward"]
    argv += ["--tokenizer", f"t2mgpt:{root / 'T2M-GPT' / 'VQVAE' / 'net_last.pth'},{root / 'T2M-GPT' / 'meta'}"]
    argv += ["--evaluator", f"official:{tmp_path / 'evaluator'}", "--limit", "4", "--repeats", "1"]
    assert main([*argv, "--json", str(tmp_path / "table.json")]) == 0
    assert "T2M-GPT VQ-VAE (released) decoder" in capsys.readouterr().out
    table = EvaluationTable.from_json_dict(json.loads((tmp_path / "table.json").read_text()))
    assert list(table.rows) == ["T2M-GPT VQ-VAE (released) decoder"]  # the feed-forward row alone, no DisCoRD row


def test_a_damaged_released_checkpoint_is_one_line_naming_the_file(released, tmp_path, capsys):
    root, _ = released
    broken = tmp_path / "DisCoRD"
    write_discord(broken, UNetSize(dim=16, c_in=16, c_proj=8), with_tokenizer=VQSize(width=32))
    ckpt = next((broken / "checkpoints").glob("*.pth"))
    ckpt.write_bytes(ckpt.read_bytes()[:200])  # truncated
    argv = ["evaluate", "reconstruction", "--data", str(root / "HumanML3D"), "--decoder", f"discord:{broken}"]
    assert main([*argv, "--limit", "4", "--repeats", "1"]) == 2
    err = capsys.readouterr().err
    assert "error:" in err and ckpt.name in err and "Traceback" not in err


CHAPTER_98 = Path(__file__).resolve().parents[2] / "notebooks" / "98_full_scale.ipynb"


def test_chapter_98_runs_table_1_on_the_folder_motionlab_pretrained_names(
    released, official_evaluator_layout, tmp_path, monkeypatch, capsys
):
    root, model = released
    folder = tmp_path / "pretrained"  # the layout the chapter describes
    folder.mkdir()
    (folder / "HumanML3D").symlink_to(root / "HumanML3D")
    decoder = folder / "DisCoRD" / "checkpoints" / "Momask"
    write_discord(decoder, UNetSize(dim=16, c_in=16, c_proj=8), with_tokenizer=VQSize(width=32))
    official_evaluator_layout(folder, model)
    monkeypatch.setenv("MOTIONLAB_PRETRAINED", str(folder))
    monkeypatch.setenv("MOTIONLAB_PROFILE", "smoke")
    monkeypatch.setenv("MOTIONLAB_HOME", str(tmp_path / "home"))
    nbformat = pytest.importorskip("nbformat")  # the book's tooling; absent on a GPU image
    cells = [c for c in nbformat.read(CHAPTER_98, as_version=4).cells if c.cell_type == "code"]
    run = [c for c in cells if "MOTIONLAB_PRETRAINED" in c.source]
    assert len(run) == 1
    namespace: dict = {}
    for cell in cells[:2]:  # the parameters, the imports and book.setup
        exec(compile(cell.source, str(CHAPTER_98), "exec"), namespace)
    namespace["display"] = lambda shown: print(shown.data)  # what the page would render
    exec(compile(run[0].source, str(CHAPTER_98), "exec"), namespace)
    out = capsys.readouterr().out
    assert f"motionlab evaluate reconstruction --profile smoke --decoder discord:{decoder}" in out
    assert "MoMask RVQ-VAE (released) tokens + DisCoRD (released)" in out and "Skipped" not in out
    assert not (tmp_path / "home" / "models").exists()  # nothing of the book's was trained
