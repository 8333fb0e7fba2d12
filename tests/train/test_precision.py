"""The precision setting: the auto rule, run settings, bf16 where it pays, fp32 bit for bit as before."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import tarfile
from pathlib import Path

import pytest
import torch
from torch import nn

from motionlab import precision as P
from motionlab.settings import RunSettings, apply_settings, resolve_settings

INTEL_AMX = P.CPUInfo("GenuineIntel", "Intel Xeon", frozenset({"avx512f", "avx512_bf16", "amx_bf16", "amx_tile"}))
INTEL_BF16 = P.CPUInfo("GenuineIntel", "Intel Xeon", frozenset({"avx512f", "avx512_bf16"}))
AMD_BF16 = P.CPUInfo("AuthenticAMD", "AMD EPYC", frozenset({"avx512f", "avx512_bf16"}))
AVX2 = P.CPUInfo("AuthenticAMD", "AMD EPYC", frozenset({"avx2"}))


@pytest.mark.parametrize(
    ("info", "cap", "fast"),
    [
        (INTEL_AMX, None, True),
        (INTEL_AMX, "AVX512_CORE_AMX", True),
        (INTEL_AMX, "AVX512_CORE_BF16", False),  # AMX switched off: measured 1.23x slower than fp32
        (INTEL_AMX, "AVX512_CORE", False),
        (INTEL_BF16, None, False),  # AVX512-BF16 alone, on Intel: slower than fp32
        (AMD_BF16, None, True),
        (AMD_BF16, "AVX512_CORE_BF16", True),
        (AMD_BF16, "AVX2", False),
        (AVX2, None, False),
    ],
)
def test_the_auto_rule_reads_the_flags_and_the_onednn_cap(info, cap, fast):
    assert P.cpu_bf16_units(info, cap)[0] is fast


@pytest.mark.parametrize(
    ("info", "cap", "refused"),
    [
        (INTEL_AMX, None, False),
        (INTEL_BF16, None, False),  # slower than fp32 (auto picks fp32), but it has the instructions: allowed
        (AMD_BF16, None, False),
        (AMD_BF16, "AVX512_CORE", True),  # told not to use them
        (AVX2, None, True),  # the Zen 3 case: 275x slower than fp32
    ],
)
def test_bf16_is_refused_where_the_cpu_has_no_bf16_instructions(info, cap, refused):
    message = P.bf16_refusal(info, cap)
    assert (message is not None) is refused
    if refused:
        assert info.model in message and "fp32" in message and "--force-precision" in message
        assert "\n" not in message  # one line


def test_the_refusal_stops_bf16_on_cpu_unless_forced_and_leaves_auto_alone(monkeypatch):
    monkeypatch.setattr(P, "_cpu_bf16_refusal", lambda cap: P.bf16_refusal(AVX2, cap))
    monkeypatch.delenv("MOTIONLAB_FORCE_PRECISION", raising=False)
    with pytest.raises(ValueError, match="precision bf16 refused on AMD EPYC"):
        P.explain_precision("bf16", "cpu")
    assert P.explain_precision("fp32", "cpu") == ("fp32", "asked for")
    assert P.explain_precision("auto", "cpu")[0] in ("fp32", "bf16")  # auto: the flags of this machine, as before
    monkeypatch.setenv("MOTIONLAB_FORCE_PRECISION", "1")
    assert P.explain_precision("bf16", "cpu") == ("bf16", "asked for")


def test_the_cli_refuses_bf16_before_any_work_and_force_precision_insists(monkeypatch, tmp_path, capsys):
    from motionlab.cli import main

    monkeypatch.setattr(P, "_cpu_bf16_refusal", lambda cap: P.bf16_refusal(AVX2, cap))
    monkeypatch.delenv("MOTIONLAB_FORCE_PRECISION", raising=False)
    monkeypatch.setenv("MOTIONLAB_DEVICE", "cpu")  # the refusal is the CPU's, whatever else the machine has
    assert main(["--precision", "bf16", "data", "check", str(tmp_path)]) == 2
    assert "precision bf16 refused" in capsys.readouterr().err
    assert main(["--precision", "bf16", "--force-precision", "data", "check", str(tmp_path)]) == 1  # ran: problems
    assert os.environ["MOTIONLAB_FORCE_PRECISION"] == "1"  # what workers and chapter kernels inherit


def test_onednn_cap_is_read_from_either_variable():
    assert P.onednn_isa_cap({}) is None
    assert P.onednn_isa_cap({"ONEDNN_MAX_CPU_ISA": "avx512_core_bf16"}) == "AVX512_CORE_BF16"
    assert P.onednn_isa_cap({"DNNL_MAX_CPU_ISA": "ALL"}) is None


def test_auto_does_not_pick_bf16_with_amx_switched_off(monkeypatch):
    """On this machine, whatever its CPU: with oneDNN capped below any bf16 unit, auto must be fp32."""
    monkeypatch.setenv("ONEDNN_MAX_CPU_ISA", "AVX512_CORE")
    assert P.resolve_precision("auto") == "fp32"
    monkeypatch.setenv("ONEDNN_MAX_CPU_ISA", "AVX512_CORE_BF16")
    info = P.read_cpu_info()
    if info.vendor != "AuthenticAMD":
        assert P.resolve_precision("auto") == "fp32"


def test_cpu_info_is_parsed_from_proc_cpuinfo(tmp_path):
    text = "processor\t: 0\nvendor_id\t: GenuineIntel\nmodel name\t: Xeon X\nflags\t\t: fpu amx_bf16 amx_tile\n\n"
    (tmp_path / "cpuinfo").write_text(text + text.replace(": 0", ": 1"))
    info = P.read_cpu_info(tmp_path / "cpuinfo")
    assert info.vendor == "GenuineIntel" and info.model == "Xeon X" and {"amx_bf16", "amx_tile"} <= info.flags
    assert "amx_bf16" in info.summary


def test_explicit_precision_wins_and_bad_values_are_refused(monkeypatch):
    monkeypatch.setenv("MOTIONLAB_PRECISION", "bf16")
    assert P.explain_precision() == ("bf16", "asked for")
    assert P.resolve_precision("FP32") == "fp32"
    with pytest.raises(ValueError, match="unknown precision 'fp16'"):
        P.resolve_precision("fp16")
    monkeypatch.setenv("MOTIONLAB_PRECISION", "half")
    with pytest.raises(ValueError, match="auto, fp32, bf16"):
        P.resolve_precision()


def test_run_settings_are_resolved_once_and_exported(monkeypatch):
    monkeypatch.setenv("MOTIONLAB_PROFILE", "laptop")
    monkeypatch.delenv("MOTIONLAB_PRECISION", raising=False)
    settings = resolve_settings(profile="smoke", precision="fp32", threads=1)
    assert settings == RunSettings("smoke", "fp32", 1)
    apply_settings(settings)
    assert os.environ["MOTIONLAB_PROFILE"] == "smoke" and os.environ["MOTIONLAB_PRECISION"] == "fp32"
    assert resolve_settings() == settings  # what a worker process or a chapter kernel reads
    assert settings.describe() == "profile smoke, precision fp32 (asked for)"
    with pytest.raises(ValueError, match="threads"):
        RunSettings("smoke", "auto", 0)


def test_in_fp32_switches_autocast_off_and_casts_inputs():
    calls = []

    @P.in_fp32
    def product(a, b):
        calls.append((a.dtype, torch.is_autocast_enabled("cpu")))
        return a @ b

    a, b = torch.randn(8, 8), torch.randn(8, 8)
    assert product(a, b).dtype == torch.float32 and calls[-1] == (torch.float32, False)
    with torch.autocast("cpu", dtype=torch.bfloat16):
        out = product(a.bfloat16(), b)
    assert out.dtype == torch.float32 and calls[-1] == (torch.float32, False)
    assert torch.equal(out, a.bfloat16().float() @ b)


def test_in_precision_runs_the_network_in_bf16_and_returns_fp32():
    net = nn.Linear(16, 16)
    x = torch.randn(4, 16)
    assert P.in_precision(net, "fp32") is net
    out = P.in_precision(net, "bf16")(x)
    assert out.dtype == torch.float32
    assert not torch.equal(out, net(x))  # the product really ran in bf16 ...
    assert torch.allclose(out, net(x), atol=0.1)  # ... and is close to the fp32 one
    with pytest.raises(ValueError, match="resolved precision"):
        P.autocast("auto")


def test_bf16_training_keeps_weights_and_optimizer_state_fp32():
    from motionlab.train import TrainConfig, Trainer

    def batches(step, generator):
        return torch.randn(16, 32, generator=generator)

    def loss_fn(model, x, generator):
        out = model(x)
        assert out.dtype == torch.bfloat16  # inside the trainer's autocast
        return {"loss": ((out.float() - x) ** 2).mean()}

    model = nn.Sequential(nn.Linear(32, 64), nn.ReLU(), nn.Linear(64, 32))
    trainer = Trainer(
        model, loss_fn, batches, TrainConfig(steps=5, lr=1e-2, ema_decay=0.9), precision="bf16", progress=False
    )
    history = trainer.fit()
    assert trainer.precision == "bf16" and history[-1]["loss"] < history[0]["loss"] * 1.5
    assert all(p.dtype == torch.float32 for p in model.parameters())
    assert all(
        v.dtype == torch.float32
        for s in trainer.optimizer.state.values()
        for v in s.values()
        if torch.is_tensor(v) and v.is_floating_point()
    )


def test_quantizer_picks_codes_in_fp32_under_autocast():
    from motionlab.tokenizers.quantizer import QuantizerEMAReset

    vq = QuantizerEMAReset(codebook_size=64, code_dim=8).eval()
    x = torch.randn(100, 8)
    exact = vq(x).ids
    with torch.autocast("cpu", dtype=torch.bfloat16):
        out = vq(x)
    assert torch.equal(out.ids, exact) and out.quantized.dtype == torch.float32


def test_the_cache_key_includes_the_precision(monkeypatch):
    from motionlab.train import TrainConfig  # any dataclass config will do
    from motionlab.train.cache import artefact_dir

    monkeypatch.setenv("MOTIONLAB_PRECISION", "fp32")
    fp32 = artefact_dir("m", TrainConfig(), "smoke", {"data": "d"})
    monkeypatch.setenv("MOTIONLAB_PRECISION", "bf16")
    bf16 = artefact_dir("m", TrainConfig(), "smoke", {"data": "d"})
    assert fp32 != bf16 and fp32.parent == bf16.parent


# -- fp32 is the code path before precision existed, bit for bit ---------------------------------------------------
# The last commit of main before the precision setting: its library is extracted from git and run beside this one.
BEFORE_PRECISION = "b921bf0a178c78e2da0bdad7e39fd883c0e722e6"
REPO = Path(__file__).resolve().parents[2]


def _extract_library_before(tmp: Path) -> Path | None:
    if shutil.which("git") is None or not (REPO / ".git").exists():
        return None
    archive = tmp / "before.tar"
    done = subprocess.run(
        ["git", "-C", str(REPO), "archive", "-o", str(archive), BEFORE_PRECISION, "src"], capture_output=True
    )
    if done.returncode != 0:  # a shallow clone without that commit
        return None
    with tarfile.open(archive) as tar:
        tar.extractall(tmp / "before", filter="data")
    return tmp / "before" / "src"


def _probe(folder: Path, home: Path, src: Path) -> dict:
    """Train and sample in a fresh process with the library at ``src`` (never an installed copy, which a GPU image
    does not have and an editable install could point elsewhere)."""
    env = {
        **os.environ,
        "MOTIONLAB_HOME": str(home),
        "MOTIONLAB_PRECISION": "fp32",
        "MOTIONLAB_DEVICE": "cpu",  # the bit-for-bit claim is about the CPU's fp32 path
        "MOTIONLAB_THREADS": "1",
        "OMP_NUM_THREADS": "1",
        "PYTHONPATH": str(src),
    }
    done = subprocess.run(
        [sys.executable, str(Path(__file__).with_name("fp32_probe.py")), str(folder)],
        env=env,
        capture_output=True,
        text=True,
        timeout=900,
    )
    assert done.returncode == 0, done.stderr[-3000:]
    return json.loads(done.stdout.strip().splitlines()[-1])


def test_fp32_is_bit_identical_to_the_code_before_precision(tmp_path):
    """A small model of each kind (VQ, RVQ, DisCoRD, evaluator, diffusion, TPS sampling) trained and sampled by
    this checkout with precision fp32 and by the library before precision existed: identical weights and outputs."""
    before = _extract_library_before(tmp_path)
    if before is None:
        pytest.skip(f"needs git and commit {BEFORE_PRECISION[:7]} (a full clone) to extract the earlier library")
    from motionlab.data.embedded import write_embedded_dataset

    data = write_embedded_dataset(tmp_path / "data", n_clips=60, seed=0)
    now, then = _probe(data, tmp_path / "home-now", REPO / "src"), _probe(data, tmp_path / "home-then", before)
    assert then.pop("library").startswith(str(before)) and now.pop("library").startswith(str(REPO / "src"))
    assert now == then


def test_cli_precision_is_a_global_option_handed_to_the_run(tmp_path, capsys):
    from motionlab.cli import main

    assert main(["--precision", "bf16", "data", "check", str(tmp_path)]) == 1  # an empty folder: problems listed
    assert os.environ["MOTIONLAB_PRECISION"] == "bf16"  # what worker processes and chapter kernels inherit
    with pytest.raises(SystemExit):
        main(["--precision", "half", "data", "check", str(tmp_path)])
    assert "invalid choice: 'half'" in capsys.readouterr().err


def test_the_plan_line_says_which_precision_trains(monkeypatch):
    from motionlab.build.plan import Job, plan_line

    monkeypatch.setenv("MOTIONLAB_PRECISION", "bf16")
    line = plan_line([Job("m", lambda: None, (), 60.0, lambda: False)])
    assert line.startswith("training 1 model first: about 1.0 min (bf16, asked for;")


def test_bf16_plans_use_the_slowest_bf16_cpu_measured(monkeypatch):
    from motionlab.build.book_models import (
        BF16_SPEEDUP,
        ESTIMATES_S,
        MEASURED_BF16_S,
        book_jobs,
        training_estimates,
    )
    from motionlab.build.build_times import HISTORY, book_root

    assert training_estimates("laptop", "fp32") == ESTIMATES_S["laptop"]
    bf16 = training_estimates("laptop", "bf16")
    assert bf16 == MEASURED_BF16_S["laptop"]
    monkeypatch.setenv("MOTIONLAB_PRECISION", "bf16")
    jobs = {job.name: job for job in book_jobs("laptop")}
    assert jobs["discord/rvq"].estimate_s == bf16["discord"]
    # no model of a recorded bf16 build ran longer than its estimate: the plan is the slowest CPU's pace
    records = sorted((book_root() / HISTORY).glob("*-bf16-training.json"))
    assert records
    for record in records:
        runs = json.loads(record.read_text())
        slower = {n: run["seconds"] for n, run in runs.items() if n in jobs and run["seconds"] > jobs[n].estimate_s}
        assert not slower, (record.name, slower)
    # profiles no build measured in bf16: the fp32 estimate over the speed-up measured on one CPU
    smoke = training_estimates("smoke", "bf16")
    assert smoke["discord"] == pytest.approx(ESTIMATES_S["smoke"]["discord"] / BF16_SPEEDUP["discord"])


def test_recorded_results_carry_the_precision(isolated_cache, monkeypatch):
    from motionlab import results

    monkeypatch.setenv("MOTIONLAB_PRECISION", "bf16")
    results.record("ch", "value", 1.5, profile="smoke")
    entry = json.loads((results.results_dir("smoke") / "ch.json").read_text())["results"]["value"]
    assert entry["precision"] == "bf16" and entry["value"] == 1.5
