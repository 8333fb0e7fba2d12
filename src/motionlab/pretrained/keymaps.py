"""Parameter names: the official repositories' state-dict keys ↔ motionlab's module names.

Each map is written out from the two architectures side by side (official ``nn.Sequential`` indices on the
left, motionlab's on the right), for a given config. ``KeyMap.to_motionlab`` renames (and reshapes) an official
state dict; ``KeyMap.to_official`` is its inverse (tests, export).

**Tokenizer conv stacks** (MoMask ``models/vq/encdec.py``, T2M-GPT ``models/encdec.py``; two stride-2 stages)::

    official encoder.model.0               conv3 in        -> encoder.net.0
             encoder.model.{2+i}.0         conv4/s2        -> encoder.net.{2+2i}
             encoder.model.{2+i}.1.model.j residual block  -> encoder.net.{3+2i}.j       (conv1, conv2)
             encoder.model.4               conv3 out       -> encoder.net.6
             decoder.model.0               conv3 in        -> decoder.net.0
             decoder.model.{2+i}.0.model.j residual block  -> decoder.net.{2+3i}.j
             decoder.model.{2+i}.2         conv3 after ×2  -> decoder.net.{4+3i}
             decoder.model.4, .6           conv3, conv3    -> decoder.net.8, .10

ReLU, upsampling and the identity norms have no parameters. T2M-GPT nests all of it under ``vqvae.``.

**DisCoRD U-Net** (``MotionPriors/models/rf_decoder/Unet1Dflow_decoder.py``, no attention): ``downs.i`` /
``ups.i`` are lists ``[ResnetBlock × k, resample]``; a ResnetBlock's ``mlp.1`` / ``block{1,2}.proj`` /
``block{1,2}.norm.g`` / ``res_conv`` are motionlab's ``to_scale_shift.1`` / ``block{1,2}.conv`` /
``block{1,2}.norm.gain`` / ``residual``. The condition projection's 1×1 convolutions are motionlab Linears
(same numbers, ``(out, in, 1)`` → ``(out, in)``).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path

import torch
from torch import Tensor

from .files import match_state_dict

PARAMS = ("weight", "bias")

# DisCoRD's up_conv_c values whose modules motionlab has, and motionlab's projection kind for each.
DISCORD_PROJECTIONS = {
    "Repeat_and_stack_and_linear": "stacked",  # repeat ×4, stack, 1×1 conv 4d→4d, unstack, 1×1 conv d→c
    "Repeat_and_linear": "repeat",  # repeat ×4, 1×1 conv d→c
    "Nearest_and_linear": "repeat",  # nearest upsample ×4 (= repeat), 1×1 conv d→c
}


@dataclass(frozen=True)
class KeyMap:
    """``names``: official key → motionlab key. ``squeeze``: official keys stored as ``(out, in, 1)`` conv
    weights that motionlab keeps as ``(out, in)`` Linear weights."""

    names: dict[str, str]
    squeeze: frozenset[str] = field(default_factory=frozenset)

    def to_motionlab(self, official: Mapping[str, Tensor]) -> dict[str, Tensor]:
        """Rename (and reshape) every mapped key; unmapped keys are an error for the caller's strict check."""
        return {
            ml: _squeezed(official[off]) if off in self.squeeze else official[off] for off, ml in self.names.items()
        }

    def to_official(self, motionlab: Mapping[str, Tensor]) -> dict[str, Tensor]:
        """The inverse: motionlab tensors under the official names (motionlab-only entries are left out)."""
        return {
            off: motionlab[ml].unsqueeze(-1) if off in self.squeeze else motionlab[ml] for off, ml in self.names.items()
        }

    def official_shapes(self, motionlab: Mapping[str, Tensor]) -> dict[str, tuple[int, ...]]:
        """The shape each official key must have for a motionlab module with state dict ``motionlab``."""
        shapes = {}
        for off, ml in self.names.items():
            shape = tuple(motionlab[ml].shape)
            shapes[off] = (*shape, 1) if off in self.squeeze else shape
        return shapes


def _squeezed(t: Tensor) -> Tensor:
    return t.squeeze(-1) if t.dim() == 3 and t.shape[-1] == 1 else t  # a wrong shape is reported before this


def _layer(official: str, motionlab: str, params: tuple[str, ...] = PARAMS) -> dict[str, str]:
    return {f"{official}.{p}": f"{motionlab}.{p}" for p in params}


# ----------------------------------------------------------------------------- tokenizers


def _resnet1d(official: str, motionlab: str, depth: int) -> dict[str, str]:
    """``depth`` pre-activation blocks (dilations largest first in both codes): conv1 (k3, dilated), conv2 (k1)."""
    names = {}
    for j in range(depth):
        for conv in ("conv1", "conv2"):
            names.update(_layer(f"{official}.{j}.{conv}", f"{motionlab}.{j}.{conv}"))
    return names


def conv_stack_keys(depth: int, official_prefix: str = "") -> dict[str, str]:
    """Encoder and decoder of a T2M-GPT / MoMask tokenizer with two stride-2 stages (``down_t = 2``)."""
    enc, dec = f"{official_prefix}encoder.model", f"{official_prefix}decoder.model"
    names = _layer(f"{enc}.0", "encoder.net.0")
    for i in range(2):
        names.update(_layer(f"{enc}.{2 + i}.0", f"encoder.net.{2 + 2 * i}"))
        names.update(_resnet1d(f"{enc}.{2 + i}.1.model", f"encoder.net.{3 + 2 * i}", depth))
    names.update(_layer(f"{enc}.4", "encoder.net.6"))
    names.update(_layer(f"{dec}.0", "decoder.net.0"))
    for i in range(2):
        names.update(_resnet1d(f"{dec}.{2 + i}.0.model", f"decoder.net.{2 + 3 * i}", depth))
        names.update(_layer(f"{dec}.{2 + i}.2", f"decoder.net.{4 + 3 * i}"))
    names.update(_layer(f"{dec}.4", "decoder.net.8"))
    names.update(_layer(f"{dec}.6", "decoder.net.10"))
    return names


def momask_rvq_keymap(depth: int, num_quantizers: int) -> KeyMap:
    """MoMask ``RVQVAE``: conv stacks plus one ``codebook`` buffer per residual layer.

    The official ``QuantizeEMAReset`` registers only ``codebook``; its ``code_sum`` / ``code_count`` are plain
    attributes, absent from the state dict (see :func:`fill_motionlab_only` for motionlab's counterparts).
    """
    names = conv_stack_keys(depth)
    for k in range(num_quantizers):
        names[f"quantizer.layers.{k}.codebook"] = f"quantizer.layers.{k}.codebook"
    return KeyMap(names)


def t2mgpt_vq_keymap(depth: int) -> KeyMap:
    """T2M-GPT ``HumanVQVAE``: everything under ``vqvae.``; one ``codebook`` buffer."""
    names = conv_stack_keys(depth, official_prefix="vqvae.")
    names["vqvae.quantizer.codebook"] = "quantizer.codebook"
    return KeyMap(names)


# ----------------------------------------------------------------------------- DisCoRD


def _resnet_block(official: str, motionlab: str, residual: bool) -> dict[str, str]:
    names = _layer(f"{official}.mlp.1", f"{motionlab}.to_scale_shift.1")
    for block in ("block1", "block2"):
        names.update(_layer(f"{official}.{block}.proj", f"{motionlab}.{block}.conv"))
        names[f"{official}.{block}.norm.g"] = f"{motionlab}.{block}.norm.gain"
    if residual:  # a 1×1 conv where the widths differ, identity otherwise
        names.update(_layer(f"{official}.res_conv", f"{motionlab}.residual"))
    return names


def discord_keymap(levels: int, resnets_per_level: int, up_conv_c: str) -> KeyMap:
    """``RectifiedFlowDecoder`` (every key under ``net.``) → motionlab ``DisCoRDDecoder`` (``projection``, ``unet``).

    ``levels`` = ``len(dim_mults)``; ``resnets_per_level`` = ``resnet_per_block``; ``up_conv_c`` one of
    :data:`DISCORD_PROJECTIONS`.
    """
    k = resnets_per_level
    names: dict[str, str] = {}
    if up_conv_c == "Repeat_and_stack_and_linear":  # Sequential(stack, conv, unstack, conv)
        names.update(_layer("net.condition_projection.1", "projection.stacked"))
        names.update(_layer("net.condition_projection.3", "projection.frame"))
    elif up_conv_c == "Repeat_and_linear":  # a single conv after repeat_interleave in forward
        names.update(_layer("net.condition_projection", "projection.frame"))
    elif up_conv_c == "Nearest_and_linear":  # Sequential(Upsample ×4, conv)
        names.update(_layer("net.condition_projection.1", "projection.frame"))
    else:
        raise ValueError(f"up_conv_c must be one of {sorted(DISCORD_PROJECTIONS)}, got {up_conv_c!r}")
    squeeze = frozenset(key for key in names if key.endswith(".weight"))

    names.update(_layer("net.init_proj", "unet.init_proj"))
    names.update(_layer("net.time_mlp.1", "unet.time_mlp.1"))  # time_mlp.0 is the (parameter-free) sinusoid
    names.update(_layer("net.time_mlp.3", "unet.time_mlp.3"))
    for i in range(levels):
        for j in range(k):  # down blocks keep their width: no residual conv
            names.update(_resnet_block(f"net.downs.{i}.{j}", f"unet.downs.{i}.blocks.{j}", residual=False))
        names.update(_layer(f"net.downs.{i}.{k}", f"unet.downs.{i}.resample"))  # conv4/s2, or conv3 at the last
    names.update(_resnet_block("net.mid_block1", "unet.mid.0", residual=False))
    names.update(_resnet_block("net.mid_block2", "unet.mid.1", residual=False))
    for i in range(levels):
        for j in range(k):  # up blocks take the skip concatenated: a residual conv
            names.update(_resnet_block(f"net.ups.{i}.{j}", f"unet.ups.{i}.blocks.{j}", residual=True))
        if i < levels - 1:  # Sequential(Upsample, conv3)
            names.update(_layer(f"net.ups.{i}.{k}.1", f"unet.ups.{i}.resample.1"))
        else:  # conv3 at the last level
            names.update(_layer(f"net.ups.{i}.{k}", f"unet.ups.{i}.resample"))
    names.update(_resnet_block("net.final_res_block", "unet.final_block", residual=True))
    names.update(_layer("net.final_conv", "unet.final_conv"))
    return KeyMap(names, squeeze)


# ----------------------------------------------------------------------------- motionlab-only state


def fill_motionlab_only(model: torch.nn.Module, state: dict[str, Tensor]) -> dict[str, Tensor]:
    """Complete a renamed official state dict with the entries only motionlab's modules have.

    - ``*.code_sum``, ``*.code_count``, ``*.initialized`` of each :class:`~motionlab.tokenizers.QuantizerEMAReset`:
      the EMA statistics. The official quantizer keeps them as plain attributes (not saved), so they are set to
      the state its ``init_codebook`` leaves: ``code_sum = codebook``, ``code_count = 1``, initialised.
    - ``_extra_state`` of a :class:`~motionlab.flow.DisCoRDDecoder`: its record of what the weights predict, which
      the loader has decided from the released config.

    Any other key motionlab expects and the official file lacks stays missing (the strict load reports it).
    """
    out = dict(state)
    for key in model.state_dict():
        if key in out:
            continue
        if key.endswith(".code_sum") and key.replace(".code_sum", ".codebook") in out:
            out[key] = out[key.replace(".code_sum", ".codebook")].clone()
        elif key.endswith(".code_count") and key.replace(".code_count", ".codebook") in out:
            out[key] = torch.ones(out[key.replace(".code_count", ".codebook")].shape[0])
        elif key.endswith(".initialized"):
            out[key] = torch.tensor(True)
        elif key == "_extra_state" and hasattr(model, "get_extra_state"):
            out[key] = model.get_extra_state()
    return out


def load_official(
    model: torch.nn.Module, official: Mapping[str, Tensor], keymap: KeyMap, path: Path, what: str, hint: str
):
    """Strictly check ``official`` against the shapes ``model`` needs (:func:`~.files.match_state_dict`), rename it,
    complete it with :func:`fill_motionlab_only`, and load it with ``strict=True``."""
    match_state_dict(official, keymap.official_shapes(model.state_dict()), path, what, hint)
    model.load_state_dict(fill_motionlab_only(model, keymap.to_motionlab(official)), strict=True)
