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
    from .train.distributed import init_distributed

    ctx = init_distributed()  # a no-op unless launched by torchrun
    profile = get_profile(args.profile)
    dataset = load_dataset(args.data, profile=profile)
    model = _trained_model(args.model, dataset, profile, args.device)
    n_params = sum(p.numel() for p in model.parameters())
    if ctx.is_main:
        print(f"{args.model} ({profile}, data {dataset.key}): {n_params / 1e6:.2f} M parameters, trained and cached")
    return 0


def _trained_model(name: str, dataset, profile: str, device: str | None):
    """The cached model ``name`` of the book for this dataset and profile (trained on first use)."""
    from .tokenizers import tokenizer_for_dataset

    if name in ("vq", "rvq"):
        return tokenizer_for_dataset(name, dataset, profile, device=device)
    if name == "evaluator":
        from .metrics.evaluator_training import load_or_train_evaluator

        return load_or_train_evaluator(dataset, profile, device=device).networks
    if name == "discord":
        from .flow import train_or_load_discord

        return train_or_load_discord(dataset, tokenizer_for_dataset("rvq", dataset, profile, device=device), profile,
                                     device=device)  # fmt: skip
    from .diffusion.pipeline import text_to_motion_for_dataset

    return text_to_motion_for_dataset(dataset, profile, device=device).model


def _generate(args: argparse.Namespace) -> int:
    from .data import load_dataset
    from .diffusion.pipeline import text_to_motion_for_dataset
    from .io import save_motion
    from .profiles import get_profile

    texts = [t.strip() for t in args.texts]
    if not all(texts):
        raise ValueError("every text must be non-empty")
    lengths = args.length * len(texts) if len(args.length) == 1 else args.length
    if len(lengths) != len(texts):
        raise ValueError(f"give one --length for all texts or one per text; got {len(args.length)} for {len(texts)}")
    profile = get_profile(args.profile)
    dataset = load_dataset(args.data, profile=profile)
    pipe = text_to_motion_for_dataset(dataset, profile, device=args.device)
    decoder = None
    if args.decoder == "discord":
        from .flow import train_or_load_discord

        decoder = train_or_load_discord(dataset, pipe.tokenizer, profile, device=args.device)
    if len(texts) == 1:
        features = pipe.generate(texts, lengths, seed=args.seed, decoder=decoder)[0]
    else:  # several actions: Two-Phase Sampling (M2D2M Algorithm 1)
        from .multimotion import MultiMotionGenerator

        generator = MultiMotionGenerator.from_pipeline(pipe, decoder=decoder)
        features = generator.generate(texts, lengths, method="tps", seed=args.seed, T_s=args.T_s)[0].features
    print(save_motion(features, args.out, title=" / ".join(texts)))
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
    train.add_argument("model", choices=["vq", "rvq", "evaluator", "discord", "diffusion"], help="which model")
    train.add_argument("--profile", choices=["smoke", "laptop", "full"], default=None,
                       help="model size (default: $MOTIONLAB_PROFILE or laptop)")  # fmt: skip
    train.add_argument("--data", default=None, help="a HumanML3D/KIT-ML folder (default: the embedded dataset)")
    train.add_argument("--device", default=None, help="cpu, cuda, cuda:1 ... (default: CUDA when present)")
    train.set_defaults(func=_train)

    gen = sub.add_parser(
        "generate", help="text to motion; several texts make one multi-action motion (TPS)",
        description="Generate a motion from text with the book's discrete-diffusion model (trained on first use). "
                    "Several texts are generated jointly with Two-Phase Sampling.",
    )  # fmt: skip
    gen.add_argument("texts", nargs="+", help='one or more action descriptions, e.g. "a person waves"')
    gen.add_argument("--length", type=int, nargs="+", default=[120],
                     help="frames at 20 fps, a multiple of 4: one for all texts or one per text")  # fmt: skip
    gen.add_argument("--decoder", choices=["vq", "discord"], default="vq", help="token decoder (default: vq)")
    gen.add_argument("--out", type=Path, required=True, help="output .npy (features), .bvh or .html")
    gen.add_argument("--T-s", dest="T_s", type=int, default=None, help="TPS switch step (default: 0.9 T)")
    gen.add_argument("--seed", type=int, default=0)
    gen.add_argument("--profile", choices=["smoke", "laptop", "full"], default=None)
    gen.add_argument("--data", default=None, help="a HumanML3D/KIT-ML folder (default: the embedded dataset)")
    gen.add_argument("--device", default=None)
    gen.set_defaults(func=_generate)

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
