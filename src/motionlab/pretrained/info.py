"""Where a loaded pretrained module came from: :class:`PretrainedInfo`, attached as ``module.provenance``."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from types import MappingProxyType
from typing import Any

from torch import nn

from ..representation import Normalizer

KINDS = ("momask_rvq", "t2mgpt_vq", "discord_decoder")


def _plain(value: Any) -> Any:
    """A JSON-friendly copy: mappings to dicts, tuples to lists, paths and other objects to strings."""
    if isinstance(value, Mapping):
        return {str(k): _plain(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_plain(v) for v in value]
    if value is None or isinstance(value, (bool, int, float, str)):
        return value
    return str(value)


@dataclass(frozen=True)
class PretrainedInfo:
    """Provenance of a loaded checkpoint.

    ``kind``: one of :data:`KINDS`; ``layout``: the folder layout it was read from (``"momask"``,
    ``"discord-momask"`` for DisCoRD's copy of the MoMask tokenizer, ``"t2mgpt"``, ``"discord"``, or
    ``"converted"``); ``files``: what was read; ``epoch`` / ``iteration`` when the checkpoint records them;
    ``config``: the settings as read (``opt.txt``, YAML, or sizes read off the state dict); ``notes``: choices
    the loader made (published defaults used, the decoder's parameterisation, ...).
    """

    kind: str
    layout: str
    files: tuple[str, ...]
    epoch: int | None = None
    iteration: int | None = None
    config: Mapping[str, Any] = field(default_factory=dict)
    notes: tuple[str, ...] = ()

    def __post_init__(self) -> None:
        if self.kind not in KINDS:
            raise ValueError(f"kind must be one of {KINDS}, got {self.kind!r}")
        object.__setattr__(self, "files", tuple(str(f) for f in self.files))
        object.__setattr__(self, "notes", tuple(self.notes))
        object.__setattr__(self, "config", MappingProxyType(_plain(dict(self.config))))

    def to_dict(self) -> dict[str, Any]:
        return {
            "kind": self.kind,
            "layout": self.layout,
            "files": list(self.files),
            "epoch": self.epoch,
            "iteration": self.iteration,
            "config": _plain(self.config),
            "notes": list(self.notes),
        }

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> PretrainedInfo:
        return cls(
            kind=data["kind"],
            layout=data["layout"],
            files=tuple(data.get("files", ())),
            epoch=data.get("epoch"),
            iteration=data.get("iteration"),
            config=data.get("config", {}),
            notes=tuple(data.get("notes", ())),
        )


def finish(module: nn.Module, normalizer: Normalizer, info: PretrainedInfo, device: Any) -> nn.Module:
    """Attach ``module.normalizer`` and ``module.provenance``; move to ``device``; eval mode."""
    module.normalizer = normalizer
    module.provenance = info
    return module.to(device).eval()


def epoch_and_iteration(checkpoint: Any) -> tuple[int | None, int | None]:
    """MoMask's ``ep`` / ``total_it`` (or ``epoch`` / ``iter``) when a checkpoint dict has them as integers."""
    if not isinstance(checkpoint, Mapping):
        return None, None

    def first(*keys: str) -> int | None:
        for key in keys:
            value = checkpoint.get(key)
            if isinstance(value, int) and not isinstance(value, bool):
                return value
        return None

    return first("ep", "epoch"), first("total_it", "iter", "iteration")
