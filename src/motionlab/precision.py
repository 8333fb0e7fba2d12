"""Numeric precision: bfloat16 where a CPU or GPU has matrix units for it, float32 wherever numbers must be exact.

One choice per run, ``auto`` | ``fp32`` | ``bf16`` (``--precision``, ``$MOTIONLAB_PRECISION``, ``book.setup``),
resolved here into what actually runs, ``fp32`` or ``bf16``:

- ``auto`` is ``bf16`` where the hardware multiplies bf16 matrices fast, else ``fp32``. On a CPU that means
  Intel AMX tiles (``amx_bf16`` + ``amx_tile``), or an AMD CPU with AVX512-BF16 (Zen 4 and later; measured on a
  Zen 5 EPYC: a bf16 matmul at 4× fp32's throughput, training steps 1.2-1.4× faster). AVX512-BF16 on an Intel CPU
  without AMX does *not* count: there
  oneDNN's bf16 kernels were measured slower than fp32 (a bf16 step 1.23× slower with AMX switched off by
  ``ONEDNN_MAX_CPU_ISA=AVX512_CORE_BF16``). A cap set through ``ONEDNN_MAX_CPU_ISA`` is honoured: units oneDNN
  is told not to use do not count. On CUDA, ``auto`` is ``bf16`` where the GPU supports it.
- ``bf16`` runs the networks under :func:`torch.autocast` with bfloat16: matrix products and convolutions in
  bf16, everything else in fp32. Parameters, optimizer state, EMA weights, losses, the ODE state, diffusion
  posteriors, log-probabilities, Gumbel draws, nearest-code searches and every metric stay fp32
  (:func:`in_fp32` marks the places inside a network's forward pass that must not be cast).
- ``fp32`` runs exactly the code path the library had before precision existed: :func:`autocast` is then a
  no-op context, so every result is bit-identical to it.

The resolved precision is part of every trained model's cache key (:mod:`motionlab.train.cache`), is written
beside every recorded result, and the first-run plan line names it.
"""

from __future__ import annotations

import contextlib
import functools
import os
from collections.abc import Callable
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path
from typing import TypeVar

import torch

T = TypeVar("T")

PRECISIONS = ("auto", "fp32", "bf16")
RESOLVED = ("fp32", "bf16")
DEFAULT_PRECISION = "auto"

# oneDNN's CPU ISA levels in increasing order (``ONEDNN_MAX_CPU_ISA`` / ``DNNL_MAX_CPU_ISA`` values); a cap below
# a level switches its kernels off. ``ALL`` and ``DEFAULT`` mean no cap.
_ONEDNN_ISA_ORDER = (
    "SSE41",
    "AVX",
    "AVX2",
    "AVX2_VNNI",
    "AVX2_VNNI_2",
    "AVX512_CORE",
    "AVX512_CORE_VNNI",
    "AVX512_CORE_BF16",
    "AVX10_1_512",
    "AVX512_CORE_FP16",
    "AVX512_CORE_AMX",
    "AVX10_1_512_AMX",
    "AVX512_CORE_AMX_FP16",
    "AVX10_1_512_AMX_FP16",
    "AVX10_2_512",
    "AVX10_2_512_AMX_2",
)


@dataclass(frozen=True)
class CPUInfo:
    """What :func:`cpu_bf16_units` needs to know about a CPU: its vendor, model name and feature flags."""

    vendor: str  # "GenuineIntel", "AuthenticAMD", ... ("" when unknown)
    model: str
    flags: frozenset[str]

    @property
    def summary(self) -> str:
        """The model and the flags that matter here, e.g. ``"AMD EPYC (avx512_bf16)"``."""
        wanted = ("amx_bf16", "amx_tile", "avx512_bf16")
        present = [f for f in wanted if f in self.flags] or ["no bf16 flags"]
        return f"{self.model or 'unknown CPU'} ({', '.join(present)})"


def read_cpu_info(path: str | os.PathLike = "/proc/cpuinfo") -> CPUInfo:
    """Vendor, model name and flags of the first processor in ``/proc/cpuinfo``.

    Where that file does not exist (macOS, Windows), torch's own probes stand in for the flags.
    """
    fields: dict[str, str] = {}
    try:
        for line in Path(path).read_text(errors="replace").splitlines():
            if not line.strip():
                if fields:
                    break  # the first processor is enough: the cores of one machine share their flags
                continue
            key, _, value = line.partition(":")
            fields.setdefault(key.strip(), value.strip())
    except OSError:
        return CPUInfo("", "", _torch_flags())
    flags = frozenset(fields.get("flags", "").split())
    return CPUInfo(fields.get("vendor_id", ""), fields.get("model name", ""), flags)


def _torch_flags() -> frozenset[str]:
    probes = {"amx_tile": "_is_amx_tile_supported", "avx512_bf16": "_is_avx512_bf16_supported"}
    flags = {flag for flag, probe in probes.items() if getattr(torch.cpu, probe, lambda: False)()}
    if "amx_tile" in flags:
        flags.add("amx_bf16")  # every CPU with AMX tiles so far has the bf16 tile instructions
    return frozenset(flags)


def onednn_isa_cap(environ: dict[str, str] | None = None) -> str | None:
    """The ISA cap oneDNN was given (``ONEDNN_MAX_CPU_ISA``, else ``DNNL_MAX_CPU_ISA``), upper-case; None: no cap."""
    env = os.environ if environ is None else environ
    value = (env.get("ONEDNN_MAX_CPU_ISA") or env.get("DNNL_MAX_CPU_ISA") or "").strip().upper()
    return None if value in ("", "ALL", "DEFAULT") else value


def _allows(cap: str | None, level: str) -> bool:
    if cap is None:
        return True
    if cap not in _ONEDNN_ISA_ORDER:  # a value this table does not know: assume it caps nothing we use
        return True
    return _ONEDNN_ISA_ORDER.index(cap) >= _ONEDNN_ISA_ORDER.index(level)


def cpu_bf16_units(info: CPUInfo, isa_cap: str | None = None) -> tuple[bool, str]:
    """Whether bf16 matrix products beat fp32 on this CPU, and why (a short phrase for the plan line).

    A pure function of the CPU's flags and oneDNN's ISA cap, so that the rule can be tested without the hardware.
    """
    flags = info.flags
    if {"amx_bf16", "amx_tile"} <= flags:
        if _allows(isa_cap, "AVX512_CORE_AMX"):
            return True, "AMX tiles"
        return False, f"AMX tiles switched off (ONEDNN_MAX_CPU_ISA={isa_cap})"
    if "avx512_bf16" in flags and info.vendor == "AuthenticAMD":
        if _allows(isa_cap, "AVX512_CORE_BF16"):
            return True, "AVX512-BF16 on AMD"
        return False, f"AVX512-BF16 switched off (ONEDNN_MAX_CPU_ISA={isa_cap})"
    if "avx512_bf16" in flags:
        return False, "AVX512-BF16 without AMX (slower than fp32 on Intel)"
    return False, "no bf16 matrix units"


# Measured on an AMD EPYC Zen 3 (AVX2 and FMA, no AVX-512), one thread: oneDNN without bf16 instructions falls back to
# reference code, and a bf16 matmul ran at 0.27 GFLOP/s against fp32's 75.
BF16_WITHOUT_UNITS_SLOWDOWN = 275


def bf16_refusal(info: CPUInfo, isa_cap: str | None = None) -> str | None:
    """Why ``bf16`` cannot run at a usable speed on this CPU (one line), or None where it can.

    It can wherever the CPU has bf16 instructions oneDNN may use (AMX tiles or AVX512-BF16), even where ``auto``
    prefers fp32 (AVX512-BF16 on Intel without AMX: 1.23x slower, not hundreds). A pure function of the flags
    :func:`cpu_bf16_units` reads."""
    flags = info.flags
    if not ({"amx_bf16", "amx_tile"} <= flags or "avx512_bf16" in flags):
        why = "has neither AMX nor AVX512-BF16"
    elif not _allows(isa_cap, "AVX512_CORE_BF16"):
        why = f"has its bf16 instructions switched off (ONEDNN_MAX_CPU_ISA={isa_cap})"
    else:
        return None
    return (
        f"precision bf16 refused on {info.summary}: this CPU {why}, so its bf16 matrix products run in reference code "
        f"(measured {BF16_WITHOUT_UNITS_SLOWDOWN}x slower than fp32 on an AVX2-only AMD EPYC); use fp32 (what auto "
        "picks here), or insist with --force-precision (MOTIONLAB_FORCE_PRECISION=1)"
    )


def precision_forced(environ: dict[str, str] | None = None) -> bool:
    """Whether ``$MOTIONLAB_FORCE_PRECISION`` (``--force-precision``) insists on the requested precision."""
    env = os.environ if environ is None else environ
    return env.get("MOTIONLAB_FORCE_PRECISION", "").strip().lower() in ("1", "true", "yes")


@lru_cache(maxsize=8)
def _cpu_bf16_refusal(isa_cap: str | None) -> str | None:
    return bf16_refusal(read_cpu_info(), isa_cap)


def check_precision(value: object) -> str:
    """``value`` as one of :data:`PRECISIONS` (case-insensitive), or a ``ValueError`` naming the choices."""
    text = str(value).strip().lower()
    if text not in PRECISIONS:
        raise ValueError(f"unknown precision {value!r}; expected one of {', '.join(PRECISIONS)}")
    return text


def requested_precision(precision: str | None = None) -> str:
    """``precision`` if given, else ``$MOTIONLAB_PRECISION``, else ``auto``: validated, not yet resolved."""
    if precision is None:
        precision = os.environ.get("MOTIONLAB_PRECISION", "") or DEFAULT_PRECISION
    return check_precision(precision)


@lru_cache(maxsize=8)
def _auto(device_type: str, isa_cap: str | None) -> tuple[str, str]:
    if device_type == "cuda":
        supported = torch.cuda.is_available() and torch.cuda.is_bf16_supported()
        return ("bf16", "CUDA bf16") if supported else ("fp32", "CUDA without bf16")
    if device_type != "cpu":
        return "fp32", f"{device_type} device"
    fast, why = cpu_bf16_units(read_cpu_info(), isa_cap)
    return ("bf16" if fast else "fp32"), why


def resolve_precision(precision: str | None = None, device: str | torch.device = "cpu") -> str:
    """What runs, ``"fp32"`` or ``"bf16"``, for a requested precision (None: ``$MOTIONLAB_PRECISION``) on ``device``."""
    return explain_precision(precision, device)[0]


def explain_precision(precision: str | None = None, device: str | torch.device = "cpu") -> tuple[str, str]:
    """``(resolved, reason)``: e.g. ``("bf16", "auto: AMX tiles")`` or ``("fp32", "asked for")``.

    ``bf16`` on a CPU without bf16 instructions is refused (:func:`bf16_refusal`) unless :func:`precision_forced`."""
    requested = requested_precision(precision)
    if requested == "bf16" and torch.device(device).type == "cpu" and not precision_forced():
        refusal = _cpu_bf16_refusal(onednn_isa_cap())
        if refusal is not None:
            raise ValueError(refusal)
    if requested != "auto":
        return requested, "asked for"
    resolved, why = _auto(torch.device(device).type, onednn_isa_cap())
    return resolved, f"auto: {why}"


def autocast(precision: str, device: str | torch.device = "cpu") -> contextlib.AbstractContextManager:
    """The context a network's forward (and backward) pass runs in: bf16 autocast, or nothing at all for fp32."""
    if precision not in RESOLVED:
        raise ValueError(f"autocast needs a resolved precision ({', '.join(RESOLVED)}), got {precision!r}")
    if precision == "fp32":
        return contextlib.nullcontext()
    return torch.autocast(torch.device(device).type, dtype=torch.bfloat16)


def network_precision(device: str | torch.device = "cpu") -> str:
    """The resolved precision a network runs in on ``device`` for this run (``$MOTIONLAB_PRECISION``, else auto)."""
    return resolve_precision(None, device)


def in_precision(
    network: Callable[..., torch.Tensor], precision: str, device: str | torch.device = "cpu"
) -> Callable[..., torch.Tensor]:
    """``network`` called under :func:`autocast` with its output returned in fp32 (``network`` itself for fp32).

    What samplers wrap around a network: the state they integrate or sample (an ODE's ``x``, log-probabilities)
    stays fp32 between the network's evaluations.
    """
    if precision == "fp32":
        return network

    def run(*args, **kwargs) -> torch.Tensor:
        with autocast(precision, device):
            return network(*args, **kwargs).float()

    return run


def network_autocast(device: str | torch.device = "cpu") -> contextlib.AbstractContextManager:
    """:func:`autocast` in the run's precision, around a whole sampling loop: the networks' weights are cast to
    bf16 once for the loop instead of at every call (measured: with a cast per call, Two-Phase Sampling's many
    small network calls ran slower in bf16 than in fp32). Keep fp32 work inside it behind :func:`in_fp32`."""
    return autocast(network_precision(device), device)


def attention_kernel(device: str | torch.device = "cpu") -> contextlib.AbstractContextManager:
    """The attention kernel for this moment (wrap ``scaled_dot_product_attention`` calls in it).

    When training under CPU bf16 autocast: plain matmuls + softmax. At the book's lengths (≤ 50 motion tokens, ≤ 33
    text tokens) that is faster than the fused CPU kernel, whose bf16 backward was 37% of a denoiser training step
    (the step went from 1.74× to 2.33× fp32's speed). Sampling (no gradients) keeps the fused kernel, whose forward is
    fine; fp32 keeps torch's default choice, bit for bit.
    """
    from torch.nn.attention import SDPBackend, sdpa_kernel

    if torch.device(device).type == "cpu" and torch.is_grad_enabled() and torch.is_autocast_enabled("cpu"):
        return sdpa_kernel([SDPBackend.MATH])
    return contextlib.nullcontext()


def _autocasting() -> list[str]:
    return [kind for kind in ("cpu", "cuda") if torch.is_autocast_enabled(kind)]


def in_fp32(fn: Callable[..., T]) -> Callable[..., T]:
    """Run ``fn`` in float32 even when called inside an autocast region: autocast is switched off for the call and
    its bf16/fp16 tensor arguments are cast to float32. Outside autocast it is ``fn`` itself, untouched.

    For the parts of a forward pass whose numbers must be exact: nearest-code searches and codebook updates,
    diffusion posteriors, contrastive losses.
    """

    @functools.wraps(fn)
    def wrapper(*args, **kwargs):
        kinds = _autocasting()
        if not kinds:
            return fn(*args, **kwargs)
        with contextlib.ExitStack() as stack:
            for kind in kinds:
                stack.enter_context(torch.autocast(kind, enabled=False))
            return fn(*(_to_fp32(a) for a in args), **{k: _to_fp32(v) for k, v in kwargs.items()})

    return wrapper


def _to_fp32(value):
    if torch.is_tensor(value) and value.dtype in (torch.bfloat16, torch.float16):
        return value.float()
    return value


__all__ = [
    "BF16_WITHOUT_UNITS_SLOWDOWN",
    "DEFAULT_PRECISION",
    "PRECISIONS",
    "RESOLVED",
    "CPUInfo",
    "attention_kernel",
    "autocast",
    "bf16_refusal",
    "check_precision",
    "cpu_bf16_units",
    "explain_precision",
    "in_fp32",
    "in_precision",
    "network_autocast",
    "network_precision",
    "onednn_isa_cap",
    "precision_forced",
    "read_cpu_info",
    "requested_precision",
    "resolve_precision",
]
