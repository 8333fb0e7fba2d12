"""The one training loop every model of the book uses.

A model brings two functions and the loop does the rest (AdamW, warm-up schedule, clipping, EMA,
progress bar, validation, checkpoints, resume):

- ``batch_fn(step, generator) -> batch``: draws the batch for ``step`` from the *data* generator (a CPU
  generator, so the draws are the same on every device); a ``batch_fn`` with a ``to(device)`` method is moved to
  the training device once;
- ``loss_fn(model, batch, generator) -> {"loss": tensor, ...}``: any extra scalar terms are logged;
  ``generator`` is the *noise* generator (flow-matching noise, diffusion steps, code resets, ...).

``loss_fn`` runs inside the run's precision (:mod:`motionlab.precision`): under ``bf16`` the network's matrix
products and convolutions run in bfloat16 while parameters, gradients, optimizer moments and EMA stay fp32;
under ``fp32`` nothing is cast.

A step never waits for the device: the logged terms (and the gradient norm) are summed on the device and read
once per ``log_every`` steps, where the finite-loss check is read too (a non-finite loss stops training and names
the step it first appeared at). Inside a step the library's per-call input checks skip reading tensor values
(:func:`motionlab.checks.trusted_values`): batches come from data checked once, when it was loaded.

Both generators are saved in every checkpoint together with the optimizer moments and torch's global
RNG (which ``nn.Dropout`` reads; a fresh run seeds it from ``config.seed``), so training N steps in one
go or N/2 + resume + N/2 produces the same bits. The learning rate is a pure function of the step
(:mod:`.schedules`), so there is no scheduler state to lose.

Ctrl-C (a SIGINT: ``timeout -s INT`` at a job's time limit, a notebook's interrupt) during :meth:`Trainer.fit` of a
single process with a ``workdir`` lets the step under way finish, writes a checkpoint at that step and then raises
``KeyboardInterrupt``, so the next run resumes where this one stopped instead of at the last periodic checkpoint.
A SIGTERM (what a job scheduler sends before it preempts a job, or a machine's time limit) is deferred the same
way; after the checkpoint the process's own SIGTERM handling takes over (by default the process ends, as it would
have a step earlier). A second signal of either kind acts at once.

Each checkpoint also lists the model's *sittings* (:attr:`Trainer.sittings`): every :meth:`Trainer.fit` that
trained it so far, with its steps, wall seconds and hardware. A model trained over several processes (resumed after
a Ctrl-C, or job after job) thus keeps the time its whole training took, and where each part ran.

    trainer = Trainer(model, loss_fn, dataset.batches(64), TrainConfig(steps=2000), workdir=folder)
    history = trainer.fit()          # resumes from folder's latest checkpoint if there is one
"""

from __future__ import annotations

import json
import math
import os
import signal
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import torch
from torch import nn
from tqdm.auto import tqdm

from ..checks import trusted_values
from ..interrupts import DeferredInterrupt
from ..precision import autocast, resolve_precision
from ..settings import env_deterministic, use_deterministic_kernels
from .checkpoint import latest_checkpoint, load_checkpoint, prune_checkpoints, save_checkpoint
from .device import device_name, get_device, to_device
from .distributed import (
    average_gradients,
    average_scalars,
    barrier,
    current_context,
    gather_generator_states,
    rank_device,
    shard_batch,
)
from .ema import EMA
from .progress import bars_enabled
from .progress import report as report_progress
from .schedules import SCHEDULES, lr_multiplier, set_lr

LossFn = Callable[[nn.Module, Any, torch.Generator], dict[str, torch.Tensor]]
BatchFn = Callable[[int, torch.Generator], Any]
ValFn = Callable[[nn.Module], dict[str, float]]

# settings that change what is printed or saved, never the weights: a run may resume with other values
_COSMETIC = {"log_every", "val_every", "ckpt_every", "keep_checkpoints"}


@dataclass
class TrainConfig:
    """Optimisation settings shared by all models (defaults are T2M-GPT's optimiser, not its length)."""

    steps: int = 1000
    lr: float = 2e-4
    betas: tuple[float, float] = (0.9, 0.99)
    weight_decay: float = 0.0
    schedule: str = "cosine"  # "constant" | "cosine" | "multistep"
    warmup_steps: int = 0
    min_lr_ratio: float = 0.1  # cosine floor, as a fraction of lr
    milestones: tuple[int, ...] = ()  # multistep: steps where lr is multiplied by gamma
    gamma: float = 0.1
    grad_clip: float | None = None  # max global gradient norm
    ema_decay: float | None = None  # None: no weight averaging
    seed: int = 0
    log_every: int = 10
    val_every: int = 0  # 0: never validate during training
    ckpt_every: int = 0  # 0: checkpoint only at the end of fit()
    keep_checkpoints: int = 2

    def __post_init__(self):
        if self.steps < 1 or self.lr <= 0:
            raise ValueError(f"steps must be >= 1 and lr > 0, got steps={self.steps}, lr={self.lr}")
        if self.schedule not in SCHEDULES:
            raise ValueError(f"schedule must be one of {SCHEDULES}, got {self.schedule!r}")
        if self.warmup_steps < 0 or self.log_every < 1:
            raise ValueError("warmup_steps must be >= 0 and log_every >= 1")
        self.betas = tuple(self.betas)
        self.milestones = tuple(self.milestones)

    def lr_at(self, step: int) -> float:
        return self.lr * lr_multiplier(
            step,
            schedule=self.schedule,
            warmup_steps=self.warmup_steps,
            total_steps=self.steps,
            min_lr_ratio=self.min_lr_ratio,
            milestones=self.milestones,
            gamma=self.gamma,
        )


class Trainer:
    """Train ``model`` with ``loss_fn`` on batches from ``batch_fn``; resumes from ``workdir``'s latest checkpoint."""

    def __init__(
        self,
        model: nn.Module,
        loss_fn: LossFn,
        batch_fn: BatchFn,
        config: TrainConfig,
        *,
        val_fn: ValFn | None = None,
        workdir: str | os.PathLike | None = None,
        device: str | torch.device | None = None,
        desc: str = "train",
        progress: bool = True,
        precision: str | None = None,
    ):
        self.config = config
        if env_deterministic():  # the run asked for it (a worker process inherits the setting, not torch's flag)
            use_deterministic_kernels(True)
        # Under torchrun every process holds one replica; see motionlab.train.distributed.
        self.dist = current_context()
        self.device = get_device(rank_device(self.dist, device))
        self.model = model.to(self.device)
        # A batch source that can live on a device (WindowDataset.batches, ...) moves there once, so its batches are
        # built where the model trains instead of being copied there at every step.
        if callable(getattr(batch_fn, "to", None)):
            batch_fn.to(self.device)
        self.loss_fn, self.batch_fn, self.val_fn = loss_fn, batch_fn, val_fn
        self.workdir = Path(workdir) if workdir is not None else None
        self.desc, self.progress = desc, progress and self.dist.is_main
        # the run's precision unless given: bf16 autocasts the forward pass; parameters, optimizer state, EMA stay fp32
        self.precision = resolve_precision(precision, self.device)
        params = [p for p in self.model.parameters() if p.requires_grad]
        # fused: one kernel for the whole update (measured faster). fp32 on the CPU keeps the per-tensor update, bit
        # for bit as before (it reads each step counter, a CPU tensor, which waits on nothing); on CUDA every
        # precision takes the fused kernel, which keeps the counters on the device (no per-parameter launches or reads).
        fused = self.device.type == "cuda" or (self.precision == "bf16" and self.device.type == "cpu")
        self.optimizer = torch.optim.AdamW(
            params,
            lr=config.lr,
            betas=config.betas,
            weight_decay=config.weight_decay,
            fused=fused or None,
            foreach=False if not fused else None,
        )
        self.ema = EMA(self.model, config.ema_decay) if config.ema_decay else None
        # Two streams: data order stays the same when a model changes how much noise it draws.
        self.data_generator = torch.Generator().manual_seed(config.seed)
        # Each rank draws its own noise; rank 0's stream is the single-process stream.
        self.noise_generator = torch.Generator(device=self.device).manual_seed(config.seed + 1 + 1000 * self.dist.rank)
        self.step = 0
        # Set by whoever compiles the model with CUDA graphs (motionlab.train.compiling): each step then tells the
        # graphs a new iteration began, so the last step's graph outputs may be overwritten.
        self.marks_graph_steps = False
        self._saved_step: int | None = None
        # every fit() that trained this model, oldest first (checkpointed), and the one under way: (first step, start)
        self.sittings: list[dict[str, Any]] = []
        self._sitting: tuple[int, float, dict[str, Any]] | None = None  # first step, start time, hardware
        self.history: list[dict[str, float]] = []
        # running sums of the logged terms since the last log line, in float64 on the device (read at log steps)
        self._acc: dict[str, torch.Tensor] = {}
        self._acc_n = 0
        self._first_nonfinite = self._no_nonfinite()  # (step, loss) of the first non-finite loss, on the device
        if self.workdir is not None and (ckpt := latest_checkpoint(self.workdir)) is not None:
            self.resume(ckpt)
        else:
            # nn.Dropout and friends read torch's global RNG: seed it so a run is a function of its config
            torch.manual_seed(config.seed)

    # -- one optimisation step ------------------------------------------------------------------------------
    def train_step(self) -> dict[str, torch.Tensor]:
        """One optimiser step. Returns the logged terms as detached 0-d tensors on the training device (reading
        them, e.g. with ``float``, waits for the device: :meth:`fit` sums them there and reads at log steps)."""
        cfg = self.config
        if self.marks_graph_steps:
            torch.compiler.cudagraph_mark_step_begin()
        set_lr(self.optimizer, cfg.lr_at(self.step))
        self.model.train()
        with trusted_values():
            # The global batch is drawn identically on every rank; each keeps its shard.
            batch = to_device(shard_batch(self.batch_fn(self.step, self.data_generator), self.dist), self.device)
            with autocast(self.precision, self.device):
                terms = self.loss_fn(self.model, batch, self.noise_generator)
        if "loss" not in terms:
            raise ValueError(f"loss_fn must return a dict with a 'loss' entry, got keys {sorted(terms)}")
        loss = terms["loss"]
        self._note_nonfinite(loss.detach())
        self.optimizer.zero_grad(set_to_none=True)
        loss.backward()
        average_gradients(self.model.parameters(), self.dist)
        logged = {k: self._as_tensor(v) for k, v in terms.items()}
        if cfg.grad_clip is not None:
            logged["grad_norm"] = nn.utils.clip_grad_norm_(self.model.parameters(), cfg.grad_clip).detach()
        self.optimizer.step()
        if self.ema is not None:
            self.ema.update(self.model)
        self.step += 1
        return logged

    def _as_tensor(self, value) -> torch.Tensor:
        if torch.is_tensor(value):
            return value.detach()
        return torch.full((), float(value), device=self.device)  # a fill kernel: no host-to-device copy

    # -- the finite-loss watch: written on the device every step, read at log steps ----------------------------
    def _no_nonfinite(self) -> torch.Tensor:
        return torch.tensor([-1.0, 0.0], dtype=torch.float64, device=self.device)

    def _note_nonfinite(self, loss: torch.Tensor) -> None:
        seen = self._first_nonfinite
        first = (seen[0] < 0) & ~torch.isfinite(loss)
        step = torch.full((), float(self.step), dtype=torch.float64, device=self.device)  # a fill, not a copy
        here = torch.stack([step, loss.double()])
        self._first_nonfinite = torch.where(first, here, seen)

    def _check_finite(self) -> None:
        step, value = self._first_nonfinite.tolist()
        if step >= 0:
            raise FloatingPointError(f"loss is {value} at step {int(step)}")

    # -- the loop ----------------------------------------------------------------------------------------------
    def _accumulate(self, logged: dict[str, torch.Tensor]) -> None:
        for k, v in logged.items():
            v = v.to(device=self.device, dtype=torch.float64)
            self._acc[k] = self._acc[k] + v if k in self._acc else v
        self._acc_n += 1

    def _read_sums(self) -> dict[str, float]:
        """The logged sums as floats (one read for all of them), averaged over ranks."""
        keys = list(self._acc)
        values = torch.stack([self._acc[k] for k in keys]).tolist() if keys else []
        return average_scalars(dict(zip(keys, values)), self.dist)

    def fit(self, until: int | None = None) -> list[dict[str, float]]:
        """Train up to step ``until`` (default: ``config.steps``); returns the history of logged averages.

        With a ``workdir`` in a single process, Ctrl-C checkpoints the step it arrives in before
        ``KeyboardInterrupt`` is raised, and a SIGTERM checkpoints it before the SIGTERM handler that was there runs
        (see the module's docstring)."""
        # Ranks of a distributed run could see the signal at different steps and then disagree on where to save.
        deferrable = self.workdir is not None and self.dist.world_size == 1
        self._sitting = (self.step, time.perf_counter(), self._hardware())
        try:
            with DeferredInterrupt(enabled=deferrable) as interrupt:
                self._fit(until, interrupt)
        finally:
            self.sittings, self._sitting = self._sittings_so_far(), None
        if interrupt.requested == signal.SIGTERM:
            signal.raise_signal(signal.SIGTERM)  # the handler put back acts now; by default the process ends here
        if interrupt.requested:  # SIGINT, or a SIGTERM handler that returned
            raise KeyboardInterrupt(f"training stopped at step {self.step:,}; its checkpoint resumes it")
        return self.history

    def _fit(self, until: int | None, interrupt: DeferredInterrupt) -> None:
        cfg = self.config
        stop = cfg.steps if until is None else min(until, cfg.steps)
        bar = tqdm(
            total=cfg.steps,
            initial=self.step,
            desc=self.desc,
            disable=not (self.progress and bars_enabled()),
            leave=False,
        )
        try:
            while self.step < stop:
                self._accumulate(self.train_step())
                bar.update(1)
                report_progress(self.desc, self.step, cfg.steps)
                if self.step % cfg.log_every == 0 or self.step == cfg.steps:
                    self._check_finite()
                    row = {"step": self.step, "lr": cfg.lr_at(self.step - 1)}
                    row.update({k: v / self._acc_n for k, v in self._read_sums().items()})
                    self.history.append(row)
                    self._acc, self._acc_n = {}, 0
                    bar.set_postfix(loss=f"{row['loss']:.4f}", lr=f"{row['lr']:.2e}")
                if cfg.val_every and self.step % cfg.val_every == 0:
                    self.history.append({"step": self.step, **self.validate()})
                if self.workdir is not None and cfg.ckpt_every and self.step % cfg.ckpt_every == 0:
                    self.save()
                if interrupt.requested:
                    break
        finally:
            bar.close()
        self._check_finite()
        if self.workdir is not None and self._saved_step != self.step:
            self.save()

    @torch.no_grad()
    def validate(self) -> dict[str, float]:
        """Run ``val_fn`` in eval mode (with EMA weights when an EMA is kept); keys get a ``val_`` prefix."""
        if self.val_fn is None:
            return {}
        self.model.eval()
        if self.ema is not None:
            with self.ema.apply_to(self.model):
                metrics = self.val_fn(self.model)
        else:
            metrics = self.val_fn(self.model)
        self.model.train()
        return {f"val_{k}": float(v) for k, v in metrics.items()}

    def _sittings_so_far(self) -> list[dict[str, Any]]:
        """:attr:`sittings` with the fit() under way as far as it has come (a fit that trained no step adds none)."""
        if self._sitting is None or self.step == self._sitting[0]:
            return list(self.sittings)
        first, start, hardware = self._sitting
        now = {"steps": [first, self.step], "seconds": round(time.perf_counter() - start, 3), **hardware}
        return [*self.sittings, now]

    def _hardware(self) -> dict[str, Any]:
        """What a sitting ran on (read once per fit(), not at every checkpoint)."""
        where = {"device": self.device.type, "name": device_name(self.device), "ranks": self.dist.world_size}
        if self.device.type == "cpu":
            where["threads"] = torch.get_num_threads()
        return where

    # -- checkpoints -------------------------------------------------------------------------------------------
    def _noise_name(self, rank: int) -> str:
        return "noise" if rank == 0 else f"noise_rank{rank}"

    def _generators(self) -> dict[str, torch.Generator]:
        return {"data": self.data_generator, self._noise_name(self.dist.rank): self.noise_generator}

    def save(self) -> Path:
        """Write a checkpoint (rank 0 writes; with several ranks, every rank must call this)."""
        if self.workdir is None:
            raise ValueError("this Trainer has no workdir to save checkpoints in")
        generators = {"data": self.data_generator}
        for rank, state in enumerate(gather_generator_states(self.noise_generator, self.dist)):
            generators[self._noise_name(rank)] = torch.Generator(device=self.noise_generator.device)
            generators[self._noise_name(rank)].set_state(state)
        self._check_finite()  # never checkpoint weights a non-finite loss has touched
        meta = {
            "config": asdict(self.config),
            "history": self.history,
            "acc": {k: float(v) for k, v in self._acc.items()},  # this rank's sums (ranks average at the log line)
            "acc_n": self._acc_n,
            "sittings": self._sittings_so_far(),
        }
        path = self.workdir / f"step_{self.step:08d}"
        if self.dist.is_main:
            path = save_checkpoint(self.workdir, self.step, self.model, self.optimizer, self.ema, generators, meta)
            prune_checkpoints(self.workdir, self.config.keep_checkpoints)
        barrier(self.dist)
        self._saved_step = self.step
        return path

    def resume(self, path: str | os.PathLike) -> None:
        meta = load_checkpoint(path, self.model, self.optimizer, self.ema, self._generators())
        saved, current = meta["config"], json.loads(json.dumps(asdict(self.config)))
        differ = sorted(k for k in current if k not in _COSMETIC and saved.get(k) != current[k])
        if differ:
            raise ValueError(f"checkpoint {path} was written with a different TrainConfig: {', '.join(differ)} differ")
        self.step = self._saved_step = int(meta["step"])
        self.history = list(meta["history"])
        self._acc = {k: torch.tensor(float(v), dtype=torch.float64, device=self.device) for k, v in meta["acc"].items()}
        self._acc_n = int(meta["acc_n"])
        self.sittings = list(meta.get("sittings", []))
        if not self.sittings and self.step > 0:  # a checkpoint from before sittings were kept: time unknown
            self.sittings = [{"steps": [0, self.step], "seconds": None}]


def final_loss(history: list[dict[str, float]]) -> float:
    """The last logged training loss (NaN when nothing was logged)."""
    rows = [r for r in history if "loss" in r]
    return rows[-1]["loss"] if rows else math.nan
