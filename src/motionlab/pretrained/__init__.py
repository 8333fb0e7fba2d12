"""The checkpoints the papers released, loaded into motionlab's own modules (nothing is downloaded).

- :func:`load_momask_rvq`: MoMask's residual VQ-VAE (``<name>/opt.txt``, ``model/*.tar``, ``meta/``; or DisCoRD's
  ``configs/`` copy of it) → :class:`~motionlab.tokenizers.RVQVAE`;
- :func:`load_t2mgpt_vq`: T2M-GPT's VQ-VAE (``net_last.pth`` plus a ``meta`` folder) →
  :class:`~motionlab.tokenizers.VQVAE`;
- :func:`load_discord_decoder`: DisCoRD's rectified-flow decoder (``configs/``, ``checkpoints/*.pth``, ``meta/``) →
  :class:`~motionlab.flow.DisCoRDDecoder` attached to its tokenizer;
- :func:`load`: any of these, or a folder :func:`convert` wrote (``model.safetensors``, no pickle); :func:`check`
  reports what a folder is and whether it loads.

Every loader reads with ``torch.load(weights_only=True)``, checks keys and shapes strictly (:class:`CheckpointError`
names the file and the first mismatches), and returns the module in eval mode with ``.normalizer`` (the released
``meta/mean.npy``, ``std.npy``: the modules take features normalised with it, as the released ones do) and
``.provenance`` (:class:`PretrainedInfo`). Key names are mapped in :mod:`motionlab.pretrained.keymaps`.

    rvq = load_momask_rvq("checkpoints/t2m/rvq_nq6_dc512_nc512_noshare_qdp0.2")
    ids = rvq.encode(rvq.normalizer.normalize(features))          # (B, T/4, 6)
    decoder = load_discord_decoder("DisCoRD", tokenizer=rvq)
    motion = rvq.normalizer.denormalize(decoder.decode(ids))      # (B, T, 263)
"""

from .commands import SPEC_SYNTAX, add_subcommands, parse_model_spec
from .converted import load_converted
from .discord import discord_config, load_discord_decoder
from .files import CheckpointError, UnsupportedSettingError
from .info import PretrainedInfo
from .keymaps import KeyMap, discord_keymap, momask_rvq_keymap, t2mgpt_vq_keymap
from .layouts import convert, detect_layout, load
from .momask import load_momask_rvq, momask_rvq_config
from .report import CheckReport, check
from .t2mgpt import load_t2mgpt_vq

Provenance = PretrainedInfo  # the same class, under the other name

__all__ = [
    "SPEC_SYNTAX",
    "CheckReport",
    "CheckpointError",
    "KeyMap",
    "PretrainedInfo",
    "Provenance",
    "UnsupportedSettingError",
    "add_subcommands",
    "check",
    "convert",
    "detect_layout",
    "discord_config",
    "discord_keymap",
    "load",
    "load_converted",
    "load_discord_decoder",
    "load_momask_rvq",
    "load_t2mgpt_vq",
    "momask_rvq_config",
    "momask_rvq_keymap",
    "parse_model_spec",
    "t2mgpt_vq_keymap",
]
