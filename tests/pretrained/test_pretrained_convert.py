"""check() reports, convert() → safetensors round trips without pickle, the CLI subcommands and model specs."""

from __future__ import annotations

import argparse
import json
import pickle

import pytest
import torch
from released_layouts import write_discord, write_momask, write_t2mgpt

from motionlab.cli import examples_epilog
from motionlab.pretrained import (
    CheckpointError,
    add_subcommands,
    check,
    convert,
    detect_layout,
    load,
    parse_model_spec,
)


def _same_state(a: torch.nn.Module, b: torch.nn.Module) -> None:
    sa, sb = a.state_dict(), b.state_dict()
    assert sa.keys() == sb.keys()
    assert all(torch.equal(sa[k], sb[k]) for k in sa)


def test_detect_layout(tmp_path):
    assert detect_layout(write_momask(tmp_path / "rvq").folder) == "momask"
    assert detect_layout(write_momask(tmp_path / "Momask", layout="discord").folder) == "discord-momask"
    t2m = write_t2mgpt(tmp_path / "t2m")
    assert detect_layout(t2m.checkpoint) == detect_layout(t2m.folder) == "t2mgpt"
    assert detect_layout(write_discord(tmp_path / "DisCoRD").folder) == "discord"
    assert detect_layout(tmp_path / "nothing") is None


def test_check_reports_each_layout(tmp_path):
    report = check(write_momask(tmp_path / "rvq").folder)
    text = str(report)
    assert report.loads and report.layout == "momask" and report.parameters and not report.missing
    assert "MoMask residual VQ-VAE" in text and "num_quantizers=2" in text and "loads: yes" in text

    t2m = write_t2mgpt(tmp_path / "t2m")
    report = check(t2m.folder, meta=t2m.extra["meta"])
    assert report.loads and report.config["width"] == 32 and "net_last.pth" in report.found

    report = check(write_discord(tmp_path / "DisCoRD").folder)
    assert report.loads and report.config["up_conv_c"] == "Repeat_and_stack_and_linear"
    assert any(note.startswith("tokenizer: ") for note in report.notes)


def test_check_reports_problems_instead_of_raising(tmp_path):
    released = write_momask(tmp_path / "rvq")
    (released.folder / "meta" / "std.npy").unlink()
    report = check(released.folder)
    assert not report.loads and report.missing == ["meta/std.npy"] and "meta/std.npy" in report.error
    assert "loads: no" in str(report)

    released = write_momask(tmp_path / "bad", vq_act="gelu")
    report = check(released.folder)
    assert not report.loads and "vq_act='gelu'" in report.error and report.config["vq_act"] == "gelu"

    t2m = write_t2mgpt(tmp_path / "t2m")
    t2m.checkpoint.write_bytes(t2m.checkpoint.read_bytes()[:200])
    report = check(t2m.checkpoint, meta=t2m.extra["meta"])
    assert not report.loads and "damaged or truncated" in report.error

    report = check(tmp_path / "nothing")
    assert report.layout is None and not report.loads and "not a pretrained checkpoint" in report.error

    alone = write_discord(tmp_path / "alone", with_tokenizer=None)
    report = check(alone.folder)
    assert report.loads and any("tokenizer not found" in note for note in report.notes)


def _convert_then_load(monkeypatch, source, out, **kwargs):
    original = load(source, **{k: v for k, v in kwargs.items() if k in ("meta", "tokenizer")})
    convert(source, out, **kwargs)
    with monkeypatch.context() as mp:
        for target, name in ((torch, "load"), (pickle, "load"), (pickle, "loads")):
            mp.setattr(target, name, _no_pickle)
        converted = load(out)
    return original, converted


def _no_pickle(*args, **kwargs):
    raise AssertionError("a converted folder must load without pickle")


def test_convert_round_trips(tmp_path, monkeypatch):
    rvq = write_momask(tmp_path / "rvq")
    original, converted = _convert_then_load(monkeypatch, rvq.folder, tmp_path / "out_rvq")
    _same_state(original, converted)
    assert converted.provenance.layout == "converted" and converted.provenance.epoch == 7
    assert (tmp_path / "out_rvq" / "model.safetensors").is_file()
    assert json.loads((tmp_path / "out_rvq" / "config.json").read_text())["kind"] == "momask_rvq"
    x = torch.randn(1, 16, 263)
    assert torch.equal(original.encode(x), converted.encode(x))

    t2m = write_t2mgpt(tmp_path / "t2m")
    original, converted = _convert_then_load(monkeypatch, t2m.checkpoint, tmp_path / "out_vq", meta=t2m.extra["meta"])
    _same_state(original, converted)
    assert (converted.normalizer.mean == original.normalizer.mean).all()

    dis = write_discord(tmp_path / "DisCoRD")
    original, converted = _convert_then_load(monkeypatch, dis.folder, tmp_path / "out_dis")
    _same_state(original, converted)
    _same_state(original.tokenizer, converted.tokenizer)
    assert converted.config == original.config
    ids = original.tokenizer.encode(torch.randn(1, 16, 263))
    assert torch.equal(original.decode(ids, seed=1), converted.decode(ids, seed=1))
    assert check(tmp_path / "out_dis").loads


def test_convert_refuses_a_non_empty_out_and_damaged_safetensors(tmp_path):
    released = write_momask(tmp_path / "rvq")
    out = convert(released.folder, tmp_path / "out")
    with pytest.raises(FileExistsError):
        convert(released.folder, out)
    (out / "model.safetensors").write_bytes(b"\x00" * 10)
    with pytest.raises(CheckpointError, match="model.safetensors: not a readable safetensors"):
        load(out)


def test_cli_subcommands(tmp_path, capsys):
    parser = argparse.ArgumentParser(prog="motionlab")
    add_subcommands(parser.add_subparsers(dest="command", required=True), examples_epilog)
    released = write_momask(tmp_path / "rvq")
    args = parser.parse_args(["pretrained", "check", str(released.folder)])
    assert args.func(args) == 0 and "loads: yes" in capsys.readouterr().out
    args = parser.parse_args(["pretrained", "check", str(tmp_path / "nothing")])
    assert args.func(args) == 1
    args = parser.parse_args(["pretrained", "convert", str(released.folder), "--out", str(tmp_path / "out")])
    assert args.func(args) == 0 and (tmp_path / "out" / "config.json").is_file()


def test_model_specs(tmp_path):
    rvq = write_momask(tmp_path / "rvq")
    t2m = write_t2mgpt(tmp_path / "t2m")
    dis = write_discord(tmp_path / "DisCoRD")
    assert parse_model_spec(f"momask:{rvq.folder}").provenance.kind == "momask_rvq"
    assert parse_model_spec(f"momask:{rvq.folder},net_best_fid.tar").num_layers == 2
    assert parse_model_spec(f"t2mgpt:{t2m.checkpoint},{t2m.extra['meta']}").provenance.kind == "t2mgpt_vq"
    decoder = parse_model_spec(f"discord:{dis.folder}")
    assert decoder.tokenizer.provenance.layout == "discord-momask"
    tokenizer_folder = dis.extra["tokenizer"].folder
    assert parse_model_spec(f"discord:{dis.folder},{tokenizer_folder}").tokenizer.provenance.layout == "discord-momask"
    assert parse_model_spec(f"auto:{rvq.folder}").provenance.layout == "momask"
    for bad in ("momask", f"vqvae:{rvq.folder}", "momask:", f"auto:{rvq.folder},x"):
        with pytest.raises(ValueError):
            parse_model_spec(bad)
