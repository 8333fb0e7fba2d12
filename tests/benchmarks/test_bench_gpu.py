"""The GPU benchmark runs end to end at the smoke sizes on the CPU, so a GPU run only has to be started."""

from __future__ import annotations

import json

import pytest

from motionlab.report.gpu import decode_table, projection_table, read_gpu_run, step_table


def gpu_tables(run) -> str:
    return "\n".join([step_table(run), projection_table(run, precision="fp32"), decode_table(run)])


def test_the_smoke_run_records_every_section(bench_gpu, tmp_path, capsys):
    out = tmp_path / "gpu.json"
    argv = ["--smoke", "--precisions", "fp32", "--repeats", "1", "--steps", "1", "--decode-repeats", "1"]
    bench_gpu.main([*argv, "--json", str(out)])
    records = json.loads(out.read_text())
    machine = [r for r in records if r["section"] == "machine"]
    assert len(machine) == 1 and machine[0]["profile"] == "smoke" and machine[0]["matmul_tflops"]["bf16"] > 0

    train = {(r["model"], r["variant"]): r for r in records if r["section"] == "train"}
    assert set(train) == {(m, v) for m in ("rvq", "discord", "t2m") for v in ("library train_step", "module")}
    for r in train.values():
        assert r["step_ms_min"] <= r["step_ms_median"] <= r["step_ms_max"]
        assert r["tflop_per_step"] > 0 and 0 < r["share_of_bf16_peak"] < 1
        assert r["batch"] >= 1
    assert all(train[m, "module"]["ratio_to_module"] == 1.0 for m in ("rvq", "discord", "t2m"))

    decode = {(r["decoder"], r["batch"], r["points"]) for r in records if r["section"] == "decode"}
    assert decode == {("feed-forward", b, 0) for b in (1, 32)} | {("motionlab", b, p) for b in (1, 32) for p in (2, 16)}
    assert "train discord" in capsys.readouterr().out

    run = read_gpu_run(out)  # what chapter 98 reads
    assert "smoke" not in gpu_tables(run) and "| DisCoRD decoder | fp32 | module |" in gpu_tables(run)


def test_the_laptop_profile_times_the_books_models(bench_gpu, tmp_path):
    from motionlab.sizes import DISCORD_DECODER

    out = tmp_path / "gpu.json"
    argv = ["--device", "cpu", "--profile", "laptop", "--sections", "train", "--models", "discord"]
    bench_gpu.main([*argv, "--precisions", "fp32", "--repeats", "1", "--steps", "1", "--json", str(out)])
    records = json.loads(out.read_text())
    assert [r["profile"] for r in records if r["section"] == "machine"] == ["laptop"]
    train = [r for r in records if r["section"] == "train"]
    assert {r["batch"] for r in train} == {DISCORD_DECODER["laptop"]["batch_size"]}


def test_smoke_and_another_profile_do_not_mix(bench_gpu, capsys):
    with pytest.raises(SystemExit):
        bench_gpu.main(["--smoke", "--profile", "laptop", "--sections", "peak"])
    assert "leave out --profile laptop" in capsys.readouterr().err


def test_official_modules_need_their_repositories(bench_gpu, tmp_path):
    with pytest.raises(FileNotFoundError):
        bench_gpu.official_discord_unet(tmp_path, None)


def test_a_wrong_official_path_stops_the_run_before_timing(bench_gpu, tmp_path, capsys):
    with pytest.raises(SystemExit):
        bench_gpu.main(["--smoke", "--official-momask", str(tmp_path), "--sections", "peak"])
    printed = capsys.readouterr()
    assert f"--official-momask {tmp_path}: no models/vq/model.py there" in printed.err
    assert "matmul peak" not in printed.out


def test_the_official_modules_packages_are_named(bench_gpu, tmp_path, monkeypatch):
    (tmp_path / "models" / "vq").mkdir(parents=True)
    (tmp_path / "models" / "vq" / "model.py").write_text("")
    monkeypatch.setattr(bench_gpu.importlib.util, "find_spec", lambda name: None)
    args = bench_gpu.argparse.Namespace(official_discord=None, official_momask=tmp_path, sections=["decode"])
    assert bench_gpu.official_problems(args) == ["--official-momask needs einops: pip install einops"]
    source = tmp_path / bench_gpu.OFFICIAL_SOURCES["official_discord"][0]
    source.parent.mkdir(parents=True)
    source.write_text("")
    args = bench_gpu.argparse.Namespace(official_discord=tmp_path, official_momask=None, sections=["decode"])
    assert bench_gpu.official_problems(args) == [
        "--official-discord needs einops, torchdiffeq: pip install einops torchdiffeq"
    ]
    args.sections = ["train"]  # torchdiffeq drives only the official decoding
    assert bench_gpu.official_problems(args) == ["--official-discord needs einops: pip install einops"]


def test_the_denoiser_is_also_timed_compiled_with_cuda_graphs(bench_gpu, tmp_path, monkeypatch):
    modes = []

    def compile_lazily(module, *args, mode="default", **kwargs):  # records what was asked; compiling takes a minute
        modes.append((type(module).__name__, mode))

    monkeypatch.setattr(bench_gpu.torch.nn.Module, "compile", compile_lazily)
    marks = []
    monkeypatch.setattr(bench_gpu.torch.compiler, "cudagraph_mark_step_begin", lambda: marks.append(1))
    out = tmp_path / "gpu.json"
    argv = ["--smoke", "--sections", "train", "--models", "t2m", "--precisions", "fp32", "--repeats", "1"]
    bench_gpu.main([*argv, "--steps", "2", "--compile", "--graphs", "t2m", "--json", str(out)])
    train = {r["variant"]: r for r in json.loads(out.read_text()) if r["section"] == "train"}
    assert set(train) == {"library train_step", "module", "module, compiled", "module, compiled, CUDA graphs"}
    assert modes == [("DenoisingTransformer", "default"), ("DenoisingTransformer", "reduce-overhead")]
    assert len(marks) == 1 + 2 * 2  # every step of the graphed variant begins an iteration: first call, warm-up, round
    compile_s = train["module, compiled, CUDA graphs"]["compile_s"]  # the first call's time; compiling is stubbed
    assert isinstance(compile_s, float) and compile_s >= 0  # here, so only that it is recorded is checked
    assert train["library train_step"]["compile_mode"] == "off"  # the run's auto compiles nothing on a CPU
    (machine,) = [r for r in json.loads(out.read_text()) if r["section"] == "machine"]
    assert machine["compile_setting"] == "auto"


def test_cuda_graphs_are_timed_on_cuda_only_unless_asked(bench_gpu, monkeypatch):
    seen = {}
    monkeypatch.setattr(bench_gpu, "train_section", lambda args, *rest: seen.update(graphs=args.graphs))
    bench_gpu.main(["--smoke", "--sections", "train"])
    assert seen["graphs"] == []
