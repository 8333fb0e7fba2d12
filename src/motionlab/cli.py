"""The ``motionlab`` command line. Thin: it parses arguments, then calls the library.

Only subcommands whose component exists are listed; more arrive with their components.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path


def _data_check(args: argparse.Namespace) -> int:
    from .data import check_dataset

    problems = check_dataset(args.path)
    if problems:
        print(f"{args.path}: {len(problems)} problem(s)", file=sys.stderr)
        for line in problems:
            print(f"  - {line}", file=sys.stderr)
        return 1
    print(f"{args.path}: looks like a complete HumanML3D-layout dataset")
    return 0


def _data_make_embedded(args: argparse.Namespace) -> int:
    from .data.embedded import EMBEDDED_SIZES, ensure_embedded, write_embedded_dataset
    from .profiles import get_profile

    if args.out is None:
        path = ensure_embedded(profile=args.profile, seed=args.seed)
    else:
        out = Path(args.out)
        if out.exists():
            print(f"error: {out} already exists; choose a new folder", file=sys.stderr)
            return 2
        n = args.clips or EMBEDDED_SIZES[get_profile(args.profile)]
        path = write_embedded_dataset(out, n_clips=n, seed=args.seed)
    print(path)
    return 0


def _train(args: argparse.Namespace) -> int:
    from .data import load_dataset
    from .profiles import get_profile
    from .tokenizers import tokenizer_for_dataset
    from .train.distributed import init_distributed

    ctx = init_distributed()  # a no-op unless launched by torchrun
    profile = get_profile(args.profile)
    dataset = load_dataset(args.data, profile=profile)
    trainers = {"vq": tokenizer_for_dataset, "rvq": tokenizer_for_dataset}
    model = trainers[args.model](args.model, dataset, profile, device=args.device)
    n_params = sum(p.numel() for p in model.parameters())
    if ctx.is_main:
        print(f"{args.model} ({profile}, data {dataset.key}): {n_params / 1e6:.2f} M parameters, trained and cached")
    return 0


def _convert(args: argparse.Namespace) -> int:
    from .io import convert_motion

    if args.dst.exists() and not args.force:
        print(f"error: {args.dst} exists; pass --force to replace it", file=sys.stderr)
        return 2
    path = convert_motion(args.src, args.dst, mapping=args.mapping, scale=args.scale, up=args.up,
                          start=args.start, end=args.end)  # fmt: skip
    print(path)
    return 0


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="motionlab", description=__doc__.splitlines()[0])
    sub = parser.add_subparsers(dest="command", required=True)

    data = sub.add_parser("data", help="datasets: generate the embedded one, check a folder")
    data_sub = data.add_subparsers(dest="data_command", required=True)

    check = data_sub.add_parser("check", help="validate a HumanML3D/KIT-ML folder and list what is missing")
    check.add_argument("path", type=Path)
    check.set_defaults(func=_data_check)

    make = data_sub.add_parser("make-embedded", help="generate the embedded procedural dataset")
    make.add_argument("--profile", choices=["smoke", "laptop", "full"], default=None,
                      help="dataset size (default: $MOTIONLAB_PROFILE or laptop)")  # fmt: skip
    make.add_argument("--seed", type=int, default=0)
    make.add_argument("--out", type=Path, default=None, help="write here instead of the cache (must not exist)")
    make.add_argument("--clips", type=int, default=None, help="number of clips (with --out)")
    make.set_defaults(func=_data_make_embedded)

    train = sub.add_parser("train", help="train a model of the book (or load it if already trained); resumable")
    train.add_argument("model", choices=["vq", "rvq"], help="which model")
    train.add_argument("--profile", choices=["smoke", "laptop", "full"], default=None,
                       help="model size (default: $MOTIONLAB_PROFILE or laptop)")  # fmt: skip
    train.add_argument("--data", default=None, help="a HumanML3D/KIT-ML folder (default: the embedded dataset)")
    train.add_argument("--device", default=None, help="cpu, cuda, cuda:1 ... (default: CUDA when present)")
    train.set_defaults(func=_train)

    convert = sub.add_parser("convert", help="convert motion between .bvh, .npy (HumanML3D features) and .html",
                             description="Mocap (BVH) becomes HumanML3D features on the t2m skeleton at 20 fps; "
                                         "features or joints become BVH or a standalone HTML animation.")  # fmt: skip
    convert.add_argument("src", type=Path, help="input .bvh or .npy (features (T, 263) or joints (T, 22, 3))")
    convert.add_argument("dst", type=Path, help="output .npy, .bvh or .html")
    convert.add_argument("--mapping", default="cmu", choices=["cmu", "t2m"], help="joint-name mapping of a BVH input")
    convert.add_argument("--scale", type=float, default=None, help="BVH units to metres (default: the rig's)")
    convert.add_argument("--up", choices=["y", "z"], default=None, help="up axis of the BVH (default: y)")
    convert.add_argument("--start", type=int, default=0, help="first frame to keep, at 20 fps")
    convert.add_argument("--end", type=int, default=None, help="frame to stop before, at 20 fps")
    convert.add_argument("--force", action="store_true", help="replace an existing output file")
    convert.set_defaults(func=_convert)
    return parser


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    try:
        return args.func(args)
    except (ValueError, FileNotFoundError) as err:
        print(f"error: {err}", file=sys.stderr)
        return 2


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
