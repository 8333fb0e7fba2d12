"""The run-wide settings, resolved once at the top of a run and handed down: profile, precision, threads.

The way nanoGPT resolves one config before anything runs: a command (:mod:`motionlab.cli`) or a chapter
(:func:`motionlab.book.setup`) builds one :class:`RunSettings` from its options and the environment, and
:func:`apply_settings` makes it the run's. Applying exports the settings as ``MOTIONLAB_PROFILE``,
``MOTIONLAB_PRECISION`` (and ``MOTIONLAB_THREADS`` when set), so that every process the run starts (the
training workers of ``train book``, the chapters' kernels) inherits the same run, and library code that was
given no profile or precision (``get_profile(None)``, :func:`motionlab.precision.resolve_precision`) reads the
same values.

    settings = resolve_settings(profile="laptop", precision="auto")
    apply_settings(settings)
    settings.describe()        # "profile laptop, precision bf16 (auto: AMX tiles)"
"""

from __future__ import annotations

import os
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

    def __post_init__(self) -> None:
        object.__setattr__(self, "profile", get_profile(self.profile))
        object.__setattr__(self, "precision", requested_precision(self.precision))
        if self.threads is not None and (
            isinstance(self.threads, bool) or not isinstance(self.threads, int) or self.threads < 1
        ):
            raise ValueError(f"threads must be a positive int or None, got {self.threads!r}")

    @property
    def sizes(self):
        """How large each chapter's experiments are in this profile (:mod:`motionlab.sizes`)."""
        from .sizes import chapter_sizes

        return chapter_sizes(self.profile)

    def resolved_precision(self, device: str | torch.device = "cpu") -> str:
        """``"fp32"`` or ``"bf16"``: what runs on ``device``."""
        return explain_precision(self.precision, device)[0]

    def describe(self, device: str | torch.device = "cpu") -> str:
        """One phrase for plan lines and logs, e.g. ``"profile laptop, precision bf16 (auto: AMX tiles)"``."""
        resolved, why = explain_precision(self.precision, device)
        return f"profile {self.profile}, precision {resolved} ({why})"


def resolve_settings(
    profile: str | None = None, precision: str | None = None, threads: int | None = None
) -> RunSettings:
    """The settings from explicit values, else ``$MOTIONLAB_PROFILE`` / ``$MOTIONLAB_PRECISION`` /
    ``$MOTIONLAB_THREADS``, else the defaults (``laptop``, ``auto``, torch's threads); validated."""
    return RunSettings(
        get_profile(profile), requested_precision(precision), threads if threads is not None else env_threads()
    )


def apply_settings(settings: RunSettings) -> RunSettings:
    """Make ``settings`` this run's: export them to the environment (child processes inherit them) and set
    torch's thread count. Returns ``settings``."""
    os.environ["MOTIONLAB_PROFILE"] = settings.profile
    os.environ["MOTIONLAB_PRECISION"] = settings.precision
    if settings.threads is not None:
        os.environ["MOTIONLAB_THREADS"] = str(settings.threads)
        torch.set_num_threads(settings.threads)
    return settings


__all__ = ["RunSettings", "apply_settings", "resolve_settings"]
