"""The run-wide settings, resolved once at the top of a run and handed down: profile, precision, threads,
determinism and compilation.

The way nanoGPT resolves one config before anything runs: a command (:mod:`motionlab.cli`) or a chapter
(:func:`motionlab.book.setup`) builds one :class:`RunSettings` from its options and the environment, and
:func:`apply_settings` makes it the run's. Applying exports the settings as ``MOTIONLAB_PROFILE``,
``MOTIONLAB_PRECISION``, ``MOTIONLAB_DETERMINISTIC``, ``MOTIONLAB_COMPILE`` (and ``MOTIONLAB_THREADS`` when set),
so that every process the run starts (the
training workers of ``train book``, the chapters' kernels) inherits the same run, and library code that was
given no profile or precision (``get_profile(None)``, :func:`motionlab.precision.resolve_precision`) reads the
same values.

    settings = resolve_settings(profile="laptop", precision="auto")
    apply_settings(settings)
    settings.describe()        # "profile laptop, precision bf16 (auto: AMX tiles)"
"""

from __future__ import annotations

import os
import time
from dataclasses import dataclass

import torch

from .precision import explain_precision, requested_precision
from .profiles import env_threads, get_profile


@dataclass(frozen=True)
class RunSettings:
    """What every part of a run agrees on. ``precision`` is what was asked for (``auto`` | ``fp32`` | ``bf16``);
    :meth:`resolved_precision` says what runs on a device."""

    profile: str
    precision: str = "auto"
    threads: int | None = None  # torch CPU threads; None: leave torch's choice
    # Bit-identical results on CUDA too (resume, batch order): deterministic kernels only. The CPU's are already.
    deterministic: bool = False
    # torch.compile: "auto" (where measured to pay, CUDA only) | "on" | "graphs" (on, CUDA graphs where launch-bound)
    # | "off" (motionlab.train.compiling)
    compile: str = "auto"

    def __post_init__(self) -> None:
        object.__setattr__(self, "profile", get_profile(self.profile))
        object.__setattr__(self, "precision", requested_precision(self.precision))
        if not isinstance(self.deterministic, bool):
            raise ValueError(f"deterministic must be True or False, got {self.deterministic!r}")
        if self.compile not in COMPILE_CHOICES:
            raise ValueError(f"compile must be one of {COMPILE_CHOICES}, got {self.compile!r}")
        if self.threads is not None and (
            isinstance(self.threads, bool) or not isinstance(self.threads, int) or not 1 <= self.threads <= MAX_THREADS
        ):  # far above any core count: torch's thread pools crash at 32,767
            raise ValueError(f"threads must be an int in [1, {MAX_THREADS}] or None, got {self.threads!r}")

    @property
    def sizes(self):
        """How large each chapter's experiments are in this profile (:mod:`motionlab.sizes`)."""
        from .sizes import chapter_sizes

        return chapter_sizes(self.profile)

    def resolved_precision(self, device: str | torch.device = "cpu") -> str:
        """``"fp32"`` or ``"bf16"``: what runs on ``device``."""
        return explain_precision(self.precision, device)[0]

    def describe(self, device: str | torch.device = "cpu") -> str:
        """One phrase for plan lines and logs, e.g. ``"profile laptop, precision bf16 (auto: AMX tiles)"``; the
        determinism and compile settings are named when they are not the defaults."""
        resolved, why = explain_precision(self.precision, device)
        extra = (", deterministic kernels" if self.deterministic else "") + (
            f", compile {self.compile}" if self.compile != "auto" else ""
        )
        return f"profile {self.profile}, precision {resolved} ({why}){extra}"


COMPILE_CHOICES = ("auto", "on", "graphs", "off")
MAX_THREADS = 4096  # threads per process; more is a typo, not a machine


def env_deterministic() -> bool:
    """``$MOTIONLAB_DETERMINISTIC`` as a bool (unset: False)."""
    value = os.environ.get("MOTIONLAB_DETERMINISTIC", "").strip().lower()
    if value in ("", "0", "false", "no"):
        return False
    if value in ("1", "true", "yes"):
        return True
    raise ValueError(f"MOTIONLAB_DETERMINISTIC must be 1 or 0, got {value!r}")


def env_compile() -> str:
    """``$MOTIONLAB_COMPILE`` (unset: ``auto``), validated."""
    value = os.environ.get("MOTIONLAB_COMPILE", "auto").strip().lower() or "auto"
    if value not in COMPILE_CHOICES:
        raise ValueError(f"MOTIONLAB_COMPILE must be one of {COMPILE_CHOICES}, got {value!r}")
    return value


def resolve_settings(
    profile: str | None = None,
    precision: str | None = None,
    threads: int | None = None,
    deterministic: bool | None = None,
    compile: str | None = None,
) -> RunSettings:
    """The settings from explicit values, else ``$MOTIONLAB_PROFILE`` / ``$MOTIONLAB_PRECISION`` /
    ``$MOTIONLAB_THREADS`` / ``$MOTIONLAB_DETERMINISTIC`` / ``$MOTIONLAB_COMPILE``, else the defaults (``laptop``,
    ``auto``, torch's threads, not deterministic, ``auto``); validated."""
    return RunSettings(
        get_profile(profile),
        requested_precision(precision),
        threads if threads is not None else env_threads(),
        deterministic if deterministic is not None else env_deterministic(),
        compile if compile is not None else env_compile(),
    )


def running_tasks(seconds: float = 0.25, every: float = 0.025, source: str = "/proc/loadavg") -> list[int]:
    """The tasks the kernel counts as runnable (waiting for a core or on one, this one included), read from
    Linux's ``/proc/loadavg`` every ``every`` seconds for ``seconds``; ``[]`` where that file cannot be read."""
    samples = []
    deadline = time.monotonic() + seconds
    while True:
        try:
            with open(source) as f:
                samples.append(int(f.read().split()[3].split("/")[0]))  # "0.52 0.58 0.59 3/129 3941": 3 runnable
        except (OSError, IndexError, ValueError):
            return []
        if time.monotonic() >= deadline:
            return samples
        time.sleep(every)


def cpu_load() -> float | None:
    """How many other tasks want a core now: the runnable tasks of :func:`running_tasks`, averaged over a quarter of
    a second, less this one; where that cannot be read, the 1-minute load average; None where neither can.

    Why not the 1-minute average alone: it remembers tasks that have ended. In a cold ``make book`` on a 2-core AMD
    EPYC (Zen 4), the set-up's ``pip install`` had just finished, the average read 1.2, and ``train book`` said other
    programs were using the CPU and promised "up to 49.8 min" for a training that took 21-23 min in the builds
    recorded on that CPU.
    """
    samples = running_tasks()
    if samples:
        return max(0.0, sum(samples) / len(samples) - 1)
    try:
        return os.getloadavg()[0]
    except (AttributeError, OSError):  # not on every platform
        return None


def threads_for_load(load: float | None) -> int | None:
    """Torch threads for a command given no ``--threads``, at ``load`` (:func:`cpu_load`): None (torch's choice, a
    thread per core) on an idle machine or where the load is unknown, else the cores other tasks leave free, at
    least 1.

    Why: torch's threads wait for one another at every operation, so one of them that shares a core with another
    program slows them all. Measured on a 2-core AMD EPYC at load 3.9: a smoke ``generate`` trained its two models in
    4 min 8 s on torch's 2 threads and in 17 s on 1.
    """
    if load is None:
        return None
    cores = os.cpu_count() or 1
    free = cores - load
    if free >= cores - 0.5:  # idle, give or take a short task
        return None
    return max(1, int(free))


def use_deterministic_kernels(on: bool) -> None:
    """Make torch pick deterministic kernels (cuDNN and cuBLAS included) or lift that; a no-op change on the CPU.

    An operation with no deterministic kernel warns (once) instead of stopping the run; the warning names it.
    """
    if on:
        # cuBLAS needs a fixed workspace to reduce in a fixed order; must be set before its first call
        os.environ.setdefault("CUBLAS_WORKSPACE_CONFIG", ":4096:8")
    torch.use_deterministic_algorithms(on, warn_only=True)
    torch.backends.cudnn.deterministic = on
    if on:
        torch.backends.cudnn.benchmark = False


def apply_settings(settings: RunSettings) -> RunSettings:
    """Make ``settings`` this run's: export them to the environment (child processes inherit them) and set
    torch's thread count. Returns ``settings``."""
    os.environ["MOTIONLAB_PROFILE"] = settings.profile
    os.environ["MOTIONLAB_PRECISION"] = settings.precision
    os.environ["MOTIONLAB_DETERMINISTIC"] = "1" if settings.deterministic else "0"
    os.environ["MOTIONLAB_COMPILE"] = settings.compile
    use_deterministic_kernels(settings.deterministic)
    if settings.threads is not None:
        os.environ["MOTIONLAB_THREADS"] = str(settings.threads)
        torch.set_num_threads(settings.threads)
    return settings


__all__ = [
    "cpu_load",
    "running_tasks",
    "threads_for_load",
    "COMPILE_CHOICES",
    "RunSettings",
    "apply_settings",
    "env_compile",
    "env_deterministic",
    "resolve_settings",
    "use_deterministic_kernels",
]
