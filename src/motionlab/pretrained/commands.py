"""Command-line pieces for the released checkpoints: ``pretrained check`` / ``pretrained convert`` subcommands
and :func:`parse_model_spec`, the ``KIND:PATH`` syntax other commands use to name a pretrained model.

Model specs (paths may not contain commas)::

    momask:FOLDER[,CHECKPOINT]     MoMask RVQ folder (opt.txt layout, or DisCoRD's configs/ copy);
                                   CHECKPOINT a file in model/ (default net_best_fid.tar)
    t2mgpt:PATH[,META]             T2M-GPT VQ: PATH the .pth or its folder; META the folder with mean.npy,
                                   std.npy (default: meta/ beside the checkpoint)
    discord:FOLDER[,TOKENIZER]     DisCoRD decoder folder; TOKENIZER a tokenizer folder of any layout
                                   (default: the YAML's vqvae_weight_path)
    auto:PATH                      whatever layout PATH is, converted folders included
"""

from __future__ import annotations

import argparse
from collections.abc import Callable
from pathlib import Path
from typing import Any

import torch

from .discord import load_discord_decoder
from .layouts import convert, default_meta, load
from .momask import load_momask_rvq
from .report import check
from .t2mgpt import load_t2mgpt_vq

SPEC_KINDS = ("momask", "t2mgpt", "discord", "auto")
SPEC_SYNTAX = "momask:FOLDER[,CHECKPOINT] | t2mgpt:PATH[,META] | discord:FOLDER[,TOKENIZER] | auto:PATH"


def parse_model_spec(spec: str, device: str | torch.device = "cpu") -> torch.nn.Module:
    """Load the model a ``KIND:PATH[,EXTRA]`` spec names (see the module docstring); ValueError for a bad spec."""
    kind, sep, rest = str(spec).partition(":")
    if not sep or kind not in SPEC_KINDS or not rest:
        raise ValueError(f"model spec must be {SPEC_SYNTAX}, got {spec!r}")
    path, _, extra = rest.partition(",")
    if not path:
        raise ValueError(f"model spec {spec!r} names no path")
    if kind == "momask":
        return load_momask_rvq(path, device=device, **({"checkpoint": extra} if extra else {}))
    if kind == "t2mgpt":
        return load_t2mgpt_vq(path, extra or default_meta(Path(path)), device=device)
    if kind == "discord":
        tokenizer = load(extra, device=device) if extra else None
        return load_discord_decoder(path, tokenizer=tokenizer, device=device)
    if extra:
        raise ValueError(f"auto:PATH takes no ',' part, got {spec!r}")
    return load(path, device=device)


def _check(args: argparse.Namespace) -> int:
    report = check(args.folder, meta=args.meta)
    print(report)
    return 0 if report.loads else 1


def _convert(args: argparse.Namespace) -> int:
    tokenizer = load(args.tokenizer) if args.tokenizer is not None else None
    out = convert(args.folder, args.out, meta=args.meta, tokenizer=tokenizer, checkpoint=args.checkpoint)
    print(out)
    return 0


def add_subcommands(subparsers: Any, examples_epilog: Callable[..., str]) -> argparse.ArgumentParser:
    """Register ``pretrained check FOLDER`` and ``pretrained convert FOLDER --out DIR`` on an argparse
    subparsers object; each sets ``func`` (``args -> exit code``). ``examples_epilog`` is the command line's
    format of a subcommand's examples (:func:`motionlab.cli.examples_epilog`). Returns the ``pretrained`` parser."""
    parser = subparsers.add_parser(
        "pretrained",
        help="released checkpoints (MoMask RVQ, T2M-GPT VQ, DisCoRD decoder): check a folder, convert it",
        description="Read the checkpoints the papers released, in their released layouts (nothing is downloaded).",
        epilog=examples_epilog(
            ("pretrained check DisCoRD/checkpoints/Momask", "layout, contents, loads?"),
            ("pretrained convert DisCoRD/checkpoints/Momask --out discord-momask", "safetensors + JSON"),
        ),
    )
    sub = parser.add_subparsers(dest="pretrained_command", required=True)
    meta_help = "T2M-GPT only: the folder with mean.npy, std.npy (default: meta/ beside the checkpoint)"

    check_parser = sub.add_parser(
        "check",
        help="say which layout a folder is, what it holds and lacks, and whether it loads",
        description="Say which released layout a folder or file is, what it holds and lacks, and whether it loads "
        "(exit 0 if it does, 1 if not).",
        epilog=examples_epilog(
            ("pretrained check DisCoRD/checkpoints/Momask", "a DisCoRD decoder folder"),
            ("pretrained check pretrained/VQVAE/net_last.pth --meta pretrained/meta", "T2M-GPT's VQ-VAE"),
        ),
    )
    check_parser.add_argument(
        "folder", type=Path, help="a MoMask / DisCoRD folder, a T2M-GPT .pth, or a converted folder"
    )
    check_parser.add_argument("--meta", type=Path, default=None, help=meta_help)
    check_parser.set_defaults(func=_check)

    convert_parser = sub.add_parser(
        "convert",
        help="write a checkpoint as model.safetensors + config.json + meta/ (loads without pickle)",
        description="Write a released checkpoint as model.safetensors + config.json + meta/, which motionlab "
        "loads without unpickling anything (auto:FOLDER in other commands).",
        epilog=examples_epilog(
            ("pretrained convert DisCoRD/checkpoints/Momask --out discord-momask", "and its tokenizer"),
            ("pretrained convert t2m/rvq_nq6_dc512_nc512_noshare_qdp0.2 --out momask-rvq", "a MoMask RVQ"),
        ),
    )
    convert_parser.add_argument("folder", type=Path, help="what to convert (any layout `pretrained check` knows)")
    convert_parser.add_argument("--out", type=Path, required=True, help="the folder to write (must be new or empty)")
    convert_parser.add_argument("--meta", type=Path, default=None, help=meta_help)
    convert_parser.add_argument(
        "--tokenizer", type=Path, default=None, help="DisCoRD only: the tokenizer folder (default: vqvae_weight_path)"
    )
    convert_parser.add_argument(
        "--checkpoint",
        default=None,
        help="a file name inside the folder's checkpoint folder "
        "(default: MoMask's net_best_fid.tar, a DisCoRD folder's only one)",
    )
    convert_parser.set_defaults(func=_convert)
    return parser
