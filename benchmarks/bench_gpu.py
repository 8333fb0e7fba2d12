"""Training steps and DisCoRD decoding at the papers' sizes on a GPU: the library, its modules, the official modules.

Not a test: prints tables and writes JSON records. What ``../shared/notes/gpu.md`` measured by hand, repeatable in
one GPU run of about five minutes (the machine's start included):

- ``peak``: what an n × n × n matmul reaches in bf16 and in fp32 (TF32 off), TFLOP/s: the yardstick of a step's
  share of the chip;
- ``train``: for the MoMask RVQ tokenizer (batch 256 × 64 frames), the DisCoRD decoder (768 × 64) and M2D2M's text
  encoder + denoiser (64 captions) at the ``full`` sizes: the library's ``Trainer.train_step`` (batches drawn and
  built by the library, clipping, EMA, logging), the module's raw step (forward, backward and a fused AdamW step on
  one device-resident batch) and, on CUDA, the raw step with the network compiled (its compile time recorded) and,
  for the launch-bound denoiser, compiled with CUDA graphs (``mode="reduce-overhead"``), in interleaved rounds;
  FLOPs per step (``torch.utils.flop_counter``) and the share of the measured bf16 peak. The library's step compiles
  what its trainer compiles under the run's setting (``$MOTIONLAB_COMPILE``, recorded with each step):
  ``MOTIONLAB_COMPILE=graphs`` times the library's text-to-motion step with its denoiser replayed as CUDA graphs;
- ``decode``: DisCoRD's Table E grid: 196 frames (49 tokens × 6 layers), batch 1 and 32, 2 and 16 midpoint grid
  points, bf16 and fp32, the tokenizer's feed-forward decoder beside it.

Given the official repositories (never vendored: ``fetch`` them beside the project), their modules join the same
rounds: ``--official-discord PATH`` (whwjdqls/DisCoRD: ``Unet1DforFlowDecoder`` trained on the same batches, and
decoded with ``torchdiffeq.odeint(method="midpoint")`` as its ``sample`` does), ``--official-momask PATH``
(EricGuo5513/momask-codes: ``RVQVAE``). Timing follows ``benchmarks/_timing.py`` with the device synchronised
around every timed call. ``--smoke`` runs everything at the smoke sizes on the CPU in seconds (the test does this);
``--profile laptop`` times the book's laptop models instead of the papers' (a CPU comparison of two settings of one
step, e.g. ``MOTIONLAB_COMPILE=on`` against ``off``, at the sizes the build trains).

    PYTHONPATH=src python benchmarks/bench_gpu.py --json $OUT/gpu.json                        # on a GPU
    PYTHONPATH=src python benchmarks/bench_gpu.py --official-discord ../DisCoRD --official-momask ../momask-codes
    .venv/bin/python benchmarks/bench_gpu.py --smoke --json _build/benchmarks/gpu-smoke.json  # CPU, seconds
    .venv/bin/python benchmarks/bench_gpu.py --device cpu --profile laptop --sections train --models discord
"""

from __future__ import annotations

import argparse
import contextlib
import importlib.util
import json
import math
import os
import platform
import subprocess
import sys
import time
from collections.abc import Callable
from pathlib import Path
from types import SimpleNamespace

import torch
import torch.nn.functional as F
from _timing import add_timing_arguments, apply_threads, interleaved
from _trainers import book_trainer
from torch.utils.flop_counter import FlopCounterMode

from motionlab.data import load_dataset
from motionlab.flow import DisCoRDDecoder, discord_config
from motionlab.models import NETWORKS
from motionlab.precision import autocast
from motionlab.settings import env_compile
from motionlab.tokenizers import build_tokenizer, rvq_config
from motionlab.tokenizers.training import tokenizer_loss_fn
from motionlab.train.compiling import compile_mode

REPO = Path(__file__).resolve().parents[1]
MODELS = ("rvq", "discord", "t2m")
PART_OF_MODEL = {model: part for part, model in NETWORKS.values() if model}  # the network compiling targets
PRECISIONS = ("bf16", "fp32")
TOKENS = 49  # 196 frames: Table E's clip
DECODE_BATCHES = (1, 32)
GRID_POINTS = (2, 16)  # midpoint grid points as the public code counts them: points − 1 intervals


# -- timing on a device ---------------------------------------------------------------------------------------------
def synchronize(device: torch.device) -> None:
    if device.type == "cuda":
        torch.cuda.synchronize(device)


def synced(fn: Callable[[], object], device: torch.device) -> Callable[[], None]:
    """``fn`` followed by a device synchronisation, so wall time covers the work it queued."""

    def run() -> None:
        fn()
        synchronize(device)

    return run


def repeated(step: Callable[[], object], n: int) -> Callable[[], None]:
    """``step`` called ``n`` times: one timed round of training."""

    def run() -> None:
        for _ in range(n):
            step()

    return run


def seconds_of_first_call(fn: Callable[[], object], device: torch.device) -> float:
    synchronize(device)
    start = time.perf_counter()
    fn()
    synchronize(device)
    return time.perf_counter() - start


# -- the yardstick --------------------------------------------------------------------------------------------------
def matmul_peak(device: torch.device, n: int, dtype: torch.dtype, repeats: int) -> float:
    """TFLOP/s of an ``n × n × n`` matmul in ``dtype`` (median of ``repeats`` timed calls; TF32 off for fp32)."""
    generator = torch.Generator(device=device).manual_seed(0)
    a = torch.randn(n, n, device=device, dtype=dtype, generator=generator)
    b = torch.randn(n, n, device=device, dtype=dtype, generator=generator)
    previous = torch.backends.cuda.matmul.allow_tf32
    torch.backends.cuda.matmul.allow_tf32 = False
    try:
        timing = interleaved({"mm": synced(lambda: a @ b, device)}, repeats)["mm"]
    finally:
        torch.backends.cuda.matmul.allow_tf32 = previous
    return 2 * n**3 / float(timing.summary()["wall_median"]) / 1e12


# -- the three trained models: the library's trainer and the bare module ------------------------------------------
def library_trainer(name: str, profile: str, dataset, device: torch.device, precision: str):
    """``(trainer, twin)``: the trainer the library fits ``name`` with, on ``device`` (random initial weights), and
    a function building a second instance of its model (same config and initial weights) for the raw step."""
    return book_trainer(name, profile, dataset, precision, device=device)


def network_of(name: str, model: torch.nn.Module) -> list[torch.nn.Module]:
    """The parts of ``model`` that compiling targets (as :mod:`motionlab.train.compiling` does)."""
    if name == "rvq":
        return [model.encoder, model.decoder]
    return [model.unet] if name == "discord" else [model.denoiser]


def raw_loss_fn(name: str, trainer) -> Callable:
    """The loss the library's trainer of ``name`` runs, as a ``loss_fn(model, batch, generator)``."""
    if name == "rvq":
        return tokenizer_loss_fn
    if name == "discord":
        return lambda model, batch, generator: {"loss": model.loss(*batch, generator)}
    return trainer.loss_fn  # the diffusion loss, with the trainer's transitions on the device


class RawStep:
    """One optimisation step of a module on one fixed, device-resident batch: forward + backward + fused AdamW.

    What a training loop costs when it does nothing but the arithmetic; the library's step is compared with it.
    """

    def __init__(self, model, loss_fn, batch, device: torch.device, precision: str, graphs: bool = False) -> None:
        self.model, self.loss_fn, self.batch = model.to(device).train(), loss_fn, batch
        self.device, self.precision, self.graphs = device, precision, graphs
        params = [p for p in model.parameters() if p.requires_grad]
        self.optimizer = torch.optim.AdamW(params, lr=1e-4, fused=True)
        self.generator = torch.Generator(device=device).manual_seed(1)

    def loss(self) -> torch.Tensor:
        with autocast(self.precision, self.device):
            return self.loss_fn(self.model, self.batch, self.generator)["loss"]

    def __call__(self) -> None:
        if self.graphs:  # a new iteration: the graphs may reuse the memory of the last step's outputs
            torch.compiler.cudagraph_mark_step_begin()
        self.optimizer.zero_grad(set_to_none=True)
        self.loss().backward()
        self.optimizer.step()

    def flops(self) -> int:
        """FLOPs of one forward + backward (the optimizer's few are left out)."""
        counter = FlopCounterMode(display=False)
        with counter:
            self.loss().backward()
        self.optimizer.zero_grad(set_to_none=True)
        return counter.get_total_flops()


# -- the official modules, when their repositories are given --------------------------------------------------------
def load_file_module(path: Path, name: str):
    """Import one source file by path (the official repositories are not packages one can pip install)."""
    spec = importlib.util.spec_from_file_location(name, path)
    if spec is None or spec.loader is None:
        raise FileNotFoundError(f"cannot import {path}")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


# option: (the file its module comes from, the packages that file's import needs, those a section adds)
OFFICIAL_SOURCES = {
    # the public code's torchdiffeq sampler drives its U-Net in the decode section only
    "official_discord": (
        Path("MotionPriors/models/rf_decoder/Unet1Dflow_decoder.py"),
        ("einops",),
        {"decode": ("torchdiffeq",)},
    ),
    "official_momask": (Path("models/vq/model.py"), ("einops",), {}),
}


def official_problems(args) -> list[str]:
    """What keeps a given official repository from joining the rounds, checked before anything is timed."""
    problems = []
    for option, (source, packages, by_section) in OFFICIAL_SOURCES.items():
        root = getattr(args, option)
        if root is None:
            continue
        flag = "--" + option.replace("_", "-")
        if not (root / source).is_file():
            problems.append(f"{flag} {root}: no {source} there (is it a checkout of the right repository?)")
        for section in getattr(args, "sections", ()):
            packages = (*packages, *by_section.get(section, ()))
        missing = [name for name in packages if importlib.util.find_spec(name) is None]
        if missing:
            problems.append(f"{flag} needs {', '.join(missing)}: pip install {' '.join(missing)}")
    return problems


def official_discord_unet(root: Path, config):
    """whwjdqls/DisCoRD's ``Unet1DforFlowDecoder`` at the sizes of ``config`` (its ``configs/config_model.yaml``)."""
    module = load_file_module(root / OFFICIAL_SOURCES["official_discord"][0], "official_discord_unet")
    return module.Unet1DforFlowDecoder(
        dim=config.width,
        dim_mults=tuple(config.width_mults),
        resnet_per_block=config.resnets_per_level,
        c_in_dim=config.code_dim,
        c_proj_dim=config.cond_dim,
        up_conv_c="Repeat_and_stack_and_linear",
        channels=config.feature_dim,
        dropout=config.dropout,
        use_attention=False,
    )


def official_flow_loss(unet, batch, generator):
    """The public code's rectified-flow loss: t ~ U(0, 1), x_t = t·x1 + (1 − t)·x0, MSE to x1 − x0."""
    x1, codes = batch
    t = torch.rand(x1.shape[0], device=x1.device, generator=generator)
    x0 = torch.randn(x1.shape, device=x1.device, generator=generator)
    x_t = t[:, None, None] * x1 + (1 - t[:, None, None]) * x0
    return {"loss": F.mse_loss(unet(x_t, t, codes), x1 - x0)}


@contextlib.contextmanager
def on_path(root: Path):
    sys.path.insert(0, str(root))
    try:
        yield
    finally:
        sys.path.remove(str(root))


def official_momask_rvq(root: Path, config):
    """EricGuo5513/momask-codes' ``RVQVAE`` at the sizes of ``config`` (its released ``rvq_nq6_dc512_nc512``)."""
    with on_path(root):
        from models.vq.model import RVQVAE  # noqa: PLC0415 -- importable only with the repository on the path

    args = SimpleNamespace(
        num_quantizers=config.num_layers,
        shared_codebook=False,
        quantize_dropout_prob=config.quantize_dropout,
        mu=config.ema_decay,
    )
    return RVQVAE(
        args,
        config.feature_dim,
        config.codebook_size,
        config.code_dim,
        config.code_dim,
        2,
        2,
        config.width,
        config.depth,
        config.dilation_growth,
        "relu",
        None,
    )


def official_rvq_loss(model, batch, generator):
    """MoMask's tokenizer loss without its joint terms: smooth L1 reconstruction + 0.02 · commitment."""
    recon, commit, _ = model(batch)
    return {"loss": F.smooth_l1_loss(recon, batch) + 0.02 * commit}


def official_decode(unet, tokenizer, ids, points: int, precision: str, device: torch.device) -> torch.Tensor:
    """Decode as the public code's ``sample`` does: ``torchdiffeq.odeint`` with a fixed midpoint grid of ``points``."""
    from torchdiffeq import odeint  # noqa: PLC0415 -- needed only beside an official repository

    codes = tokenizer.embed(ids)  # (B, N, d)
    x0 = torch.randn(ids.shape[0], ids.shape[1] * 4, unet.channels, device=device)
    grid = torch.linspace(0, 1, points, device=device)
    with torch.no_grad(), autocast(precision, device):
        path = odeint(lambda t, x: unet(x, t.expand(x.shape[0]), codes), x0, grid, method="midpoint")
    return path[-1]


# -- the sections ---------------------------------------------------------------------------------------------------
def train_section(args, device: torch.device, dataset, peak: float, save: Callable[[list[dict]], None]) -> None:
    """Time each model and precision; ``save`` receives each one's records as soon as they are measured (a lease
    that runs out keeps what it measured)."""
    for name in args.models:
        for precision in args.precisions:
            trainer, twin = library_trainer(name, args.profile, dataset, device, precision)
            batch = trainer.batch_fn(0, torch.Generator().manual_seed(0))
            loss_fn = raw_loss_fn(name, trainer)
            raw = RawStep(twin(), loss_fn, batch, device, precision)
            flops = raw.flops()
            steps = args.steps
            variants = {"library train_step": repeated(trainer.train_step, steps), "module": repeated(raw, steps)}
            compile_seconds = {}
            if args.compile and precision == args.precisions[0]:  # one compile per model: each costs tens of seconds
                modes = {"module, compiled": "default"}
                if name in args.graphs:
                    modes["module, compiled, CUDA graphs"] = "reduce-overhead"
                for variant, mode in modes.items():
                    compiled = compiled_step(name, twin(), loss_fn, batch, device, precision, mode)
                    compile_seconds[variant] = seconds_of_first_call(compiled, device)
                    variants[variant] = repeated(compiled, steps)
            official = official_step(args, name, trainer, batch, device, precision)
            if official is not None:
                variants["official module"] = repeated(official, steps)
            timings = interleaved({k: synced(v, device) for k, v in variants.items()}, args.repeats)
            module_ms = 1e3 * timings["module"].summary()["wall_median"] / steps
            records = []
            for variant, timing in timings.items():
                summary = timing.summary()
                ms = {k: 1e3 * summary[f"wall_{k}"] / steps for k in ("median", "min", "max")}
                record = {
                    "section": "train",
                    "model": name,
                    "precision": precision,
                    "variant": variant,
                    "batch": batch_size_of(batch),
                    "step_ms_median": ms["median"],
                    "step_ms_min": ms["min"],
                    "step_ms_max": ms["max"],
                    "tflop_per_step": flops / 1e12,
                    "share_of_bf16_peak": flops / (ms["median"] / 1e3) / (peak * 1e12) if peak else None,
                    "ratio_to_module": ms["median"] / module_ms,
                }
                if variant in compile_seconds:
                    record["compile_s"] = compile_seconds[variant]
                if variant == "library train_step":  # how the trainer compiled it under the run's setting
                    record["compile_mode"] = compile_mode(PART_OF_MODEL[name], device) or "off"
                records.append(record)
            save(records)
            del trainer, raw, variants
            if device.type == "cuda":
                torch.cuda.empty_cache()


def compiled_step(name: str, model, loss_fn, batch, device: torch.device, precision: str, mode: str) -> RawStep:
    """The raw step with the networks of ``model`` compiled in ``mode`` (``"reduce-overhead"``: CUDA graphs too,
    replayed with one launch each, on a CUDA device; on a CPU it compiles as ``"default"`` does)."""
    step = RawStep(model, loss_fn, batch, device, precision, graphs=mode == "reduce-overhead")
    for part in network_of(name, step.model):
        part.compile(mode=mode)
    return step


def official_step(args, name: str, trainer, batch, device: torch.device, precision: str) -> RawStep | None:
    """The official module's raw step on the same batch, when its repository was given."""
    if name == "discord" and args.official_discord:
        unet = official_discord_unet(args.official_discord, trainer.model.config)
        return RawStep(unet, official_flow_loss, batch, device, precision)
    if name == "rvq" and args.official_momask:
        model = official_momask_rvq(args.official_momask, trainer.model.config)
        return RawStep(model, official_rvq_loss, batch, device, precision)
    return None


def batch_size_of(batch) -> int:
    if torch.is_tensor(batch):
        return batch.shape[0]
    if isinstance(batch, dict):
        return batch["ids"].shape[0]
    return batch[0].shape[0]


def decode_section(args, device: torch.device) -> list[dict]:
    tokenizer = build_tokenizer(rvq_config(args.profile)).eval().to(device)
    decoder = DisCoRDDecoder(discord_config(args.profile, tokenizer=tokenizer)).attach(tokenizer).eval().to(device)
    unet = (
        official_discord_unet(args.official_discord, decoder.config).to(device).eval()
        if args.official_discord
        else None
    )
    records = []
    for batch in DECODE_BATCHES:
        ids = torch.randint(
            0,
            tokenizer.codebook_size,
            (batch, TOKENS, tokenizer.num_layers),
            generator=torch.Generator().manual_seed(0),
        ).to(device)
        variants = {("feed-forward", "fp32", 0): lambda ids=ids: tokenizer.decode(ids)}
        for precision in args.precisions:
            for points in GRID_POINTS:

                def ours(ids=ids, precision=precision, points=points):
                    os.environ["MOTIONLAB_PRECISION"] = precision  # the decoder reads the run's precision
                    return decoder.decode(ids, steps=points - 1, solver="midpoint", seed=0)

                variants["motionlab", precision, points] = ours
                if unet is not None:
                    variants["official + torchdiffeq", precision, points] = (
                        lambda ids=ids, precision=precision, points=points: official_decode(
                            unet, tokenizer, ids, points, precision, device
                        )
                    )
        with torch.no_grad():
            timings = interleaved({k: synced(v, device) for k, v in variants.items()}, args.decode_repeats)
        for (decoder_name, precision, points), timing in timings.items():
            summary = timing.summary()
            records.append(
                {
                    "section": "decode",
                    "decoder": decoder_name,
                    "precision": precision,
                    "batch": batch,
                    "points": points,
                    "frames": TOKENS * 4,
                    **{f"seconds_{k}": summary[f"wall_{k}"] for k in ("median", "min", "max")},
                }
            )
    return records


def machine_record(args, device: torch.device, peaks: dict[str, float]) -> dict:
    commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=REPO, capture_output=True, text=True)
    return {
        "section": "machine",
        "device": torch.cuda.get_device_name(device) if device.type == "cuda" else platform.processor() or "cpu",
        "torch": torch.__version__,
        "cuda": torch.version.cuda,
        "commit": commit.stdout.strip() or None,
        "profile": args.profile,
        "date": time.strftime("%Y-%m-%d"),
        "matmul_tflops": peaks,
        "compile_setting": env_compile(),  # what the library's trainers compile (motionlab.train.compiling)
    }


def print_records(records: list[dict]) -> None:
    for r in records:
        if r["section"] == "machine":
            print(f"{r['device']}, torch {r['torch']}, CUDA {r['cuda']}, commit {r['commit']}, profile {r['profile']}")
            print("  matmul peak: " + ", ".join(f"{k} {v:.1f} TFLOP/s" for k, v in r["matmul_tflops"].items()))
        elif r["section"] == "train":
            share = f"{100 * r['share_of_bf16_peak']:5.1f}% of bf16 peak" if r["share_of_bf16_peak"] else ""
            extra = f", compiled in {r['compile_s']:.0f} s" if "compile_s" in r else ""
            print(
                f"  train {r['model']:8s} {r['precision']} {r['variant']:30s} {r['step_ms_median']:8.1f} ms "
                f"({r['step_ms_min']:.1f}–{r['step_ms_max']:.1f}) ×{r['ratio_to_module']:.2f} of the module  "
                f"{r['tflop_per_step']:.2f} TFLOP {share}{extra}"
            )
        else:
            print(
                f"  decode {r['decoder']:24s} {r['precision']} batch {r['batch']:2d}, {r['points']:2d} points: "
                f"{r['seconds_median']:.4f} s ({r['seconds_min']:.4f}–{r['seconds_max']:.4f})"
            )


def main(argv: list[str] | None = None) -> list[dict]:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--smoke", action="store_true", help="smoke sizes on the CPU, a few seconds (the test)")
    parser.add_argument(
        "--profile",
        choices=("laptop", "full"),
        default=None,
        help="the sizes of the models timed (default: full, the papers'); laptop: the book's, to compare variants of "
        "its steps on a CPU",
    )
    parser.add_argument("--device", default=None, help="default: cuda when present, else cpu")
    parser.add_argument(
        "--sections", nargs="+", default=["peak", "train", "decode"], choices=["peak", "train", "decode"]
    )
    parser.add_argument("--models", nargs="+", default=list(MODELS), choices=MODELS)
    parser.add_argument("--precisions", nargs="+", default=list(PRECISIONS), choices=PRECISIONS)
    parser.add_argument("--steps", type=int, default=5, help="training steps per timed round (default 5)")
    parser.add_argument("--decode-repeats", type=int, default=8, help="timed rounds of the decode grid (default 8)")
    parser.add_argument(
        "--compile",
        action=argparse.BooleanOptionalAction,
        default=None,
        help="also time the compiled module (default: on CUDA only)",
    )
    parser.add_argument(
        "--graphs",
        nargs="*",
        choices=MODELS,
        default=None,
        help="with --compile, also time these models' module compiled with CUDA graphs (default: t2m on CUDA, "
        "whose step is launch-bound; none on a CPU, where there are no graphs to replay)",
    )
    parser.add_argument("--official-discord", type=Path, default=None, help="a checkout of whwjdqls/DisCoRD")
    parser.add_argument("--official-momask", type=Path, default=None, help="a checkout of EricGuo5513/momask-codes")
    parser.add_argument("--json", type=Path, default=None, help="write the records here")
    add_timing_arguments(parser, repeats=4)
    args = parser.parse_args(argv)
    if problems := official_problems(args):
        parser.error("; ".join(problems))
    device = torch.device(args.device or ("cuda" if torch.cuda.is_available() and not args.smoke else "cpu"))
    if args.smoke and args.profile:
        parser.error(f"--smoke times the smoke sizes: leave out --profile {args.profile}")
    args.profile = "smoke" if args.smoke else args.profile or "full"
    args.compile = device.type == "cuda" if args.compile is None else args.compile
    args.graphs = (["t2m"] if device.type == "cuda" else []) if args.graphs is None else args.graphs
    if device.type == "cpu":
        apply_threads(args.threads)
    n = 256 if args.smoke else 8192
    peaks = {}
    if "peak" in args.sections:
        peaks = {
            name: matmul_peak(device, n, dtype, max(args.repeats, 3))
            for name, dtype in (("bf16", torch.bfloat16), ("fp32", torch.float32))
        }
    records = [machine_record(args, device, peaks)]

    def save(new: list[dict]) -> None:
        records.extend(new)
        print_records(new)
        if args.json is not None:  # rewritten after every measurement: a run cut short keeps what it measured
            args.json.parent.mkdir(parents=True, exist_ok=True)
            args.json.write_text(json.dumps(records, indent=1) + "\n")

    save([])
    print_records(records[:1])
    if "train" in args.sections:
        dataset = load_dataset(None, profile="smoke")  # the cost of a step does not depend on the data
        train_section(args, device, dataset, peaks.get("bf16", math.nan) if peaks else 0.0, save)
    if "decode" in args.sections:
        save(decode_section(args, device))
    if args.json is not None:
        print(f"wrote {args.json}")
    return records


if __name__ == "__main__":
    main()
