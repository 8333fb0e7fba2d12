"""Generate motion from text, train and evaluate the models of the motionlab book (DisCoRD and M2D2M).

The first line above is what ``motionlab --help`` shows a user; see :data:`EPILOG` for its examples.
"""

# For developers: this module stays thin. It parses arguments, checks them before any work, then calls the library
# (every number it prints comes from a library function the chapters call too).

from __future__ import annotations

import argparse
import contextlib
import json
import os
import sys
import textwrap
import time
import warnings
from pathlib import Path

EPILOG = """examples:
  motionlab generate "a person waves" --profile smoke --out wave.html   # seconds; then open wave.html
  motionlab generate "a person walks" "a person jumps" --out two.html  # two actions joined (Two-Phase Sampling)
  motionlab train book --jobs 2                                         # every model the book's chapters load
  motionlab evaluate reconstruction --decoder discord                   # DisCoRD's Table 1 on the book's data

In a clone, `make setup` puts motionlab in .venv/bin: `source .venv/bin/activate` first, and the examples run as
written. Every subcommand has its own --help. The book (make book, then _build/html/index.html; or jupyter lab
notebooks/) explains each model and table; its chapter 98 covers the papers' sizes, real datasets and released
checkpoints."""


def examples_epilog(*lines: tuple[str, str]) -> str:
    """A subcommand's ``examples:`` epilog: one ``motionlab ...`` command per line, its comment aligned after it."""
    width = max(len(command) for command, _ in lines)
    return "examples:\n" + "\n".join(f"  motionlab {command:<{width}}  # {comment}" for command, comment in lines)


class _HelpFormatter(argparse.HelpFormatter):
    """Help that states every option's default and keeps indented example lines as written.

    An option whose help does not already say its default gets ``(default: VALUE)`` appended; flags (off unless
    given) and options without a default value are left alone. Paragraphs whose lines start with spaces (the
    examples) are not re-wrapped; the rest wraps to the terminal as usual.
    """

    def _get_help_string(self, action: argparse.Action) -> str:
        text = action.help or ""
        # `is`, not `in`: a default of 0 equals False but is a value worth showing
        quiet = action.default is None or action.default is argparse.SUPPRESS or isinstance(action.default, bool)
        if "default" in text.lower() or quiet or not action.option_strings:
            return text
        value = " ".join(map(str, action.default)) if isinstance(action.default, list) else "%(default)s"
        return f"{text} (default: {value})" if text else f"(default: {value})"

    def _fill_text(self, text: str, width: int, indent: str) -> str:
        paragraphs = text.split("\n\n")
        filled = []
        for paragraph in paragraphs:
            lines = paragraph.splitlines()
            if len(lines) > 1 and all(line.startswith("  ") for line in lines[1:]):
                filled.append("\n".join(indent + line for line in lines))  # a heading and its examples
            else:
                filled.append(
                    textwrap.fill(" ".join(paragraph.split()), width, initial_indent=indent, subsequent_indent=indent)
                )
        return "\n\n".join(filled)


class _Parser(argparse.ArgumentParser):
    """An argument parser with :class:`_HelpFormatter`; ``add_subparsers`` makes every subcommand one too."""

    def __init__(self, *args, **kwargs):
        kwargs.setdefault("formatter_class", _HelpFormatter)
        super().__init__(*args, **kwargs)


def _data_check(args: argparse.Namespace) -> int:
    from .data import check_dataset
    from .data.from_bvh import plural

    if not args.path.is_dir():  # exit 1 as for any other problem of the dataset, said plainly
        where = "does not exist" if not args.path.exists() else "is a file, not the dataset's folder"
        print(f"error: {args.path} {where}", file=sys.stderr)
        return 1
    problems = check_dataset(args.path)
    if problems:
        print(f"{args.path}: {plural(len(problems), 'problem')}", file=sys.stderr)
        for line in problems:
            print(f"  - {line}", file=sys.stderr)
        if any("texts" in line for line in problems):
            for line in _texts_format():
                print(line, file=sys.stderr)
        return 1
    print(f"{args.path}: looks like a complete HumanML3D-layout dataset")
    return 0


def _texts_format() -> list[str]:
    """What a HumanML3D ``texts/<id>.txt`` holds, with an example line the library's own writer formats."""
    from .data.from_bvh import caption_to_line

    return [
        "texts/<id>.txt (one per clip id of the splits) holds one caption per line: "
        "caption#word/POS word/POS ...#start#end, start and end in seconds (0.0#0.0: the whole clip), e.g.",
        f"  {caption_to_line('a person waves with the left hand')}",
        "`motionlab data from-bvh` writes them from file names or a captions CSV",
    ]


def _data_make_embedded(args: argparse.Namespace) -> int:
    from .data.embedded import ensure_embedded, write_embedded_dataset
    from .sizes import run_sizes

    if args.out is None:
        if args.clips is not None:  # the cached dataset's size is the profile's: never ignore --clips silently
            size = run_sizes(args.settings.profile).embedded_clips
            raise ValueError(
                f"--clips needs --out: the cached dataset of a profile has its own size ({size} clips "
                f"for {args.settings.profile}); write a custom size to a folder of your own"
            )
        _check_cache_writable()
        path = ensure_embedded(profile=args.profile, seed=args.seed)
    else:
        out = Path(args.out)
        if out.exists():
            print(f"error: {out} already exists; choose a new folder", file=sys.stderr)
            return 2
        _check_writable_folder(out.parent, "--out")
        n = args.clips if args.clips is not None else run_sizes(args.settings.profile).embedded_clips  # 0 is refused
        path = write_embedded_dataset(out, n_clips=n, seed=args.seed)
    print(path)
    return 0


def _check_mapping(mapping: str) -> None:
    """A ``--mapping FILE.json`` that is not there is refused before any work, naming the option."""
    if mapping.lower().endswith(".json") and not Path(mapping).is_file():
        raise ValueError(f"--mapping {mapping}: the joint map does not exist")


def _data_from_bvh(args: argparse.Namespace) -> int:
    from .data.from_bvh import dataset_from_bvh

    _check_mapping(args.mapping)
    try:
        report = dataset_from_bvh(
            args.folder,
            args.out,
            captions=args.captions,
            mapping=args.mapping,
            scale=args.scale,
            up=args.up,
            seed=args.seed,
            force=args.force,
        )
    except FileExistsError:  # the library's message names its argument; this one the option
        print(
            f"error: --out {args.out} is not empty and holds no earlier from-bvh dataset; pass --force to "
            "convert into it anyway (files the command did not write are kept)",
            file=sys.stderr,
        )
        return 2
    except KeyboardInterrupt:
        print(
            f"\ninterrupted: the clips converted so far are kept in {args.out}; the same command resumes",
            file=sys.stderr,
        )
        return 130
    print(report.summary())
    return 0


def _train(args: argparse.Namespace) -> int:
    from .train.distributed import init_distributed

    flow_options = _flow_overrides(args)
    if args.model == "book":
        return _train_book(args, flow_options)
    if args.jobs is not None:
        raise ValueError("--jobs is for 'train book' (several models at once); one model trains in one process")
    if args.record:
        raise ValueError("--record is for 'train book': it records the book's training times")
    if flow_options and args.model != "discord":  # refused before any data is generated or loaded
        raise ValueError(f"{', '.join(flow_options)} configure the DisCoRD decoder; they need the model 'discord'")
    if args.tokenizer is not None and args.model != "discord":
        raise ValueError("--tokenizer chooses whose tokens the DisCoRD decoder reads; it needs the model 'discord'")
    _check_cache_writable()  # a read-only cache would fail only after the training
    ctx = init_distributed(device=args.device)  # a no-op unless launched by torchrun
    profile = args.settings.profile
    model_job = {
        "vq": "tokenizer/vq",
        "rvq": "tokenizer/rvq",
        "evaluator": "evaluator",
        "diffusion": "t2m/dynamic",
        "discord": f"discord/{args.tokenizer or 'rvq'}",
    }[args.model]
    with _probe_then_run():
        if ctx.is_main:
            _announce_training(profile, [model_job], args.data, flow_options)
        dataset = _command_dataset(args.data, profile)
        model = _trained_model(args.model, dataset, profile, args.device, flow_options, args.tokenizer or "rvq")
    n_params = sum(p.numel() for p in model.parameters())
    if ctx.is_main:
        print(f"{args.model} ({profile}, data {dataset.key}): {n_params / 1e6:.2f} M parameters, trained and cached")
    return 0


def _train_book(args: argparse.Namespace, flow_options: dict) -> int:
    from .build.book_models import book_jobs
    from .build.plan import results_table, run_plan

    given = [f"--{k.replace('_', '-')}" for k in flow_options] + [
        option
        for option, value in (("--data", args.data), ("--device", args.device), ("--tokenizer", args.tokenizer))
        if value
    ]
    if given:  # the book's models are fixed by its chapters
        raise ValueError(f"{', '.join(given)} cannot be used with 'train book': it trains the book's own models")
    jobs = args.jobs if args.jobs is not None else 2
    if jobs < 1:
        raise ValueError(f"--jobs must be >= 1, got {jobs}")
    record = Path("book") / "data" / "build_times"
    if args.record and not (Path("book") / "_toc.yml").is_file():
        raise FileNotFoundError("--record writes into the book's repository: run it from its root (book/_toc.yml)")
    _check_cache_writable()
    profile = args.settings.profile
    plan = book_jobs(profile)
    if profile == "laptop":  # what the whole build costs, from the one record the README and the intro quote
        from .build.build_times import cold_build_line

        if line := cold_build_line():
            print(f"for scale: {line}", flush=True)
    try:
        results = run_plan(plan, workers=jobs)
    except KeyboardInterrupt:
        print("interrupted: finished models are cached; run the same command again to train the rest", file=sys.stderr)
        return 130
    print(results_table(results))
    if (Path("book") / "_toc.yml").is_file():  # in the book's repository: beside the chapters' timings of a build
        _record_training(Path("_build") / "executed" / profile / "training.json", results)
    if args.record:
        _record_training(record / f"{profile}-training.json", results)
    failed = [r.name for r in results if r.status in ("failed", "skipped")]
    if failed:
        print(f"error: not trained: {', '.join(failed)}", file=sys.stderr)
        return 1
    print(f"the book's models ({profile}) are all in the cache")
    return 0


def _record_training(path: Path, results) -> None:
    """Merge the times of the models trained now into ``path``; models loaded from the cache keep their entry."""
    from .build.book_models import job_precision
    from .precision import network_precision
    from .train.device import get_device

    recorded = json.loads(path.read_text()) if path.is_file() else {}
    precision = network_precision(get_device(None))
    for r in results:
        if r.status == "trained":
            recorded[r.name] = {
                "seconds": round(r.seconds, 1),
                "cpu_seconds": round(r.cpu_seconds, 1),
                "precision": job_precision(r.name, precision),
            }
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(dict(sorted(recorded.items())), indent=1) + "\n")
    print(f"training times recorded in {path}")


def _book_stale(args: argparse.Namespace) -> int:
    from .report.stale import stale_records

    profile = args.profile or "laptop"  # the committed records are the laptop profile's
    stale = stale_records(profile)
    if not stale:
        print(f"every committed {profile} record measures the code as it is")
        return 0
    print(f"{len(stale)} committed {profile} record(s) measured other models or evaluations than the code's now:")
    for record in stale:
        print(record.line(Path.cwd()))
    return 1


def _book_execute(args: argparse.Namespace) -> int:
    import os
    import time

    import yaml

    from .build import notebook_runner as runner

    root = Path(args.root).resolve()
    toc = root / "book" / "_toc.yml"
    if not toc.is_file():
        raise FileNotFoundError(f"{toc} not found: run 'book execute' in the book's repository (or pass --root)")
    profile = args.settings.profile
    chapters = [
        root / f"{entry['file']}.ipynb"
        for part in yaml.safe_load(toc.read_text())["parts"]
        for entry in part["chapters"]
        if entry["file"].startswith("notebooks/")
    ]
    if args.chapters:
        unknown = sorted(set(args.chapters) - {c.stem for c in chapters})
        if unknown:
            raise ValueError(f"unknown chapters {unknown}; the book has {[c.stem for c in chapters]}")
        chapters = [c for c in chapters if c.stem in args.chapters]
    if args.jobs < 1:
        raise ValueError(f"--jobs must be >= 1, got {args.jobs}")
    out_dir = root / "_build" / "executed" / profile
    timings_path = out_dir / "timings.json"
    recorded = root / "book" / "data" / "build_times" / f"{profile}.json"
    previous = runner.load_timings(timings_path) or runner.load_timings(recorded)
    # the chapters' kernels inherit the run's settings (exported by _settings) and this: a chapter that would train a
    # model outside `train book`'s plan fails instead of training
    os.environ["MOTIONLAB_NO_TRAIN"] = "1"
    from .data.from_bvh import plural

    print(f"executing {plural(len(chapters), 'chapter')} ({profile}), {args.jobs} at a time -> {out_dir}", flush=True)
    start = time.monotonic()
    last = {c.stem for c in chapters if runner.runs_last(c)}  # summaries that read the others' results
    from .paths import cache_dir

    fingerprint = None if args.force else runner.build_fingerprint(profile, cache_dir())
    runs = runner.execute_chapters(
        chapters,
        out_dir / "notebooks",
        jobs=args.jobs,
        previous=previous,
        last=last,
        stall_s=args.stall_seconds,
        fingerprint=fingerprint,
    )
    record = runner.timings_record(runs, profile, time.monotonic() - start)
    if not args.chapters:
        timings_path.write_text(json.dumps(record, indent=1))
        if args.record:
            recorded.parent.mkdir(parents=True, exist_ok=True)
            recorded.write_text(json.dumps(record, indent=1))
    print(runner.runs_table(runs))
    failed = [r.name for r in runs if r.status != "ok"]
    if failed:
        print(f"error: chapters failed: {', '.join(failed)}", file=sys.stderr)
        return 1
    if not args.chapters:
        stage = runner.stage_site(root, out_dir / "notebooks", root / "_build" / "site-src")
        print(f"executed chapters staged for rendering in {stage}")
    return 0


# The models `motionlab train <model>` trains, by their names in the book's plan (motionlab.models.load).
_TRAINED_MODELS = {"vq": "tokenizer/vq", "rvq": "tokenizer/rvq", "evaluator": "evaluator", "diffusion": "t2m/dynamic"}


def _trained_model(
    name: str, dataset, profile: str, device: str | None, flow_options: dict | None = None, flow_tokenizer: str = "rvq"
):
    """The cached model ``name`` of the book for this dataset and profile (trained on first use).

    ``flow_options`` (DisCoRD only) override the profile's decoder config, e.g. ``{"prediction": "x"}``;
    ``flow_tokenizer`` is whose tokens it decodes: "rvq" (DisCoRD Table 1) or "vq" (the diffusion model's,
    the decoder ``generate``/``evaluate t2m|multi --decoder discord`` use). Returns the network: the evaluator's
    networks and the diffusion model's denoiser, not their wrappers."""
    from . import models

    if name == "discord":
        if flow_tokenizer not in ("rvq", "vq"):
            raise ValueError(f"the DisCoRD decoder reads 'rvq' or 'vq' tokens, got {flow_tokenizer!r}")
        return models.load(f"discord/{flow_tokenizer}", dataset, profile, device=device, **(flow_options or {}))
    if name not in _TRAINED_MODELS:
        raise ValueError(f"unknown model {name!r}; use one of {', '.join(sorted([*_TRAINED_MODELS, 'discord']))}")
    if flow_options:  # models.load refuses them too; this names the command's options
        raise ValueError(f"{', '.join(flow_options)} configure the DisCoRD decoder; they need the model 'discord'")
    model = models.load(_TRAINED_MODELS[name], dataset, profile, device=device)
    if name == "evaluator":
        return model.networks
    return model.model if name == "diffusion" else model


def _generate(args: argparse.Namespace) -> int:
    from .diffusion.pipeline import text_to_motion_for_dataset
    from .io import save_motion
    from .io.provenance import motion_provenance
    from .train.device import get_device

    if args.list_words:
        return _list_words(args)
    texts = [t.strip() for t in args.texts]
    if not texts:
        raise ValueError('give one or more texts, e.g. motionlab generate "a person waves" --out wave.html')
    if not all(texts):
        raise ValueError("every text must be non-empty")
    if args.out is None:
        raise ValueError("--out is required: the file to write, ending in .npy, .bvh or .html")
    lengths = args.length * len(texts) if len(args.length) == 1 else args.length
    if len(lengths) != len(texts):
        raise ValueError(f"give one --length for all texts or one per text; got {len(args.length)} for {len(texts)}")
    if args.T_s is not None and len(texts) == 1:
        raise ValueError("--T-s is the Two-Phase Sampling switch step; it needs two or more texts")
    profile = args.settings.profile
    if args.T_s is not None:  # judged before any training, against the profile's diffusion steps
        from .diffusion.transformer import transformer_config

        T = transformer_config(profile).timesteps
        if not 0 <= args.T_s <= T:
            raise ValueError(f"--T-s must be in [0, T={T}] (the model's diffusion steps), got {args.T_s}")
    _check_generation_lengths(lengths, profile)
    _check_output(args.out, args.force, "--out")  # before any training or sampling
    with _probe_then_run():
        _announce_training(profile, ["t2m/dynamic"] + (["discord/vq"] if args.decoder == "discord" else []), args.data)
        dataset = _command_dataset(args.data, profile)
        _warn_unknown_words(texts, dataset, profile, args.data)  # before any training or sampling
        pipe = text_to_motion_for_dataset(dataset, profile, device=args.device)
        decoder = None
        if args.decoder == "discord":
            from . import models

            decoder = models.load("discord/vq", dataset, profile, device=args.device)
    segments = None
    if len(texts) == 1:
        features = pipe.generate(texts, lengths, seed=args.seed, decoder=decoder)[0]
    else:  # several actions: Two-Phase Sampling (M2D2M Algorithm 1)
        from .multimotion import MultiMotionGenerator

        generator = MultiMotionGenerator.from_pipeline(pipe, decoder=decoder)
        motion = generator.generate(texts, lengths, method="tps", seed=args.seed, T_s=args.T_s)[0]
        features, segments = motion.features, list(zip([0, *motion.boundaries], texts))  # where each action starts
    record = motion_provenance(
        texts,
        profile,
        args.seed,
        ["t2m/dynamic", "tokenizer/vq"] + (["discord/vq"] if args.decoder == "discord" else []),
        decoder=args.decoder,
        lengths=" ".join(str(n) for n in lengths),
        T_s=args.T_s,
        data=args.data or "embedded",
        precision=args.settings.resolved_precision(get_device(args.device)),
    )
    written = save_motion(features, args.out, title=" / ".join(texts), provenance=record, segments=segments)
    print(written)  # the path alone on stdout, for scripts; what to do with it goes to stderr
    for line in _after_generate(written, profile):
        print(line, file=sys.stderr)
    return 0


def _warn_unknown_words(texts: list[str], dataset, profile: str, data: str | None) -> None:
    """A ``warning:`` line per text with words the model's vocabulary lacks (the model reads each as the same
    unknown-word token), then where to see the words it knows."""
    from .text.known import unknown_word_warnings

    lines = unknown_word_warnings(texts, model_vocabulary(dataset, profile)) if texts else []
    for line in lines:
        print(f"warning: {line}", file=sys.stderr)
    if lines:
        options = f" --profile {profile}" + (f" --data {data}" if data else "")
        print(
            f"note: `motionlab generate --list-words{options}` lists the words the model knows and its data's actions",
            file=sys.stderr,
            flush=True,
        )


def model_vocabulary(dataset, profile: str):
    """The word vocabulary (:class:`motionlab.text.Vocabulary`) of the text-to-motion model trained on ``dataset``
    at ``profile``: built from the training split's captions as
    :func:`motionlab.diffusion.pipeline.text_to_motion_for_dataset` builds it, so it is known without training or
    loading the model."""
    from .diffusion.training import build_vocabulary, diffusion_training_config

    config = diffusion_training_config(profile, num_codes=2)  # the text settings do not depend on the codebook
    return build_vocabulary([[c.text for c in clip.captions] for clip in dataset.split("train")], config)


def _list_words(args: argparse.Namespace) -> int:
    """``generate --list-words``: the embedded data's action families and the words the model knows."""
    from .text.known import action_families, known_words, unknown_word_warnings

    if args.out is not None:
        raise ValueError("--list-words lists what the model knows and generates nothing; leave out --out")
    profile = args.settings.profile
    dataset = _command_dataset(args.data, profile)
    vocabulary = model_vocabulary(dataset, profile)
    words = known_words(vocabulary)
    if args.data is None:
        families = action_families()
        print(f"actions ({len(families)} families of the embedded data): {', '.join(families)}")
    else:
        print(f"actions: those the captions of {args.data} describe (in the words below)")
    print(f"words the {profile} text-to-motion model knows ({len(words)}; it reads any other word as unknown):")
    print(textwrap.fill(" ".join(words), width=100, break_on_hyphens=False))
    for line in unknown_word_warnings([t.strip() for t in args.texts if t.strip()], vocabulary):
        print(f"warning: {line}", file=sys.stderr)
    return 0


def _after_generate(path: Path, profile: str) -> list[str]:
    """What a reader does next with the file ``generate`` wrote, and, under ``smoke``, what its motion is worth."""
    suffix = path.suffix.lower()
    if suffix in (".html", ".htm"):
        lines = [f"open {path} in a browser (it needs no network); how it was made is listed under the animation"]
    elif suffix == ".bvh":
        lines = [
            f"import {path} into Blender (File > Import > Motion Capture (.bvh)) or any BVH viewer; "
            f"how it was made is in {path.name}.json"
        ]
    else:
        lines = [
            f"{path} holds HumanML3D features (frames x 263); `motionlab convert {path} {path.stem}.html` draws "
            f"them; how it was made is in {path.name}.json"
        ]
    if profile == "smoke":
        lines.append(
            "note: smoke models train for seconds, so this motion only shows that the code runs; "
            "without --profile smoke the laptop models train once (minutes) and move like the text"
        )
    return lines


def _announce_training(profile: str, models: list[str], data: str | None = None, flow_options: dict | None = None):
    """Before anything trains on first use: one line naming the missing models, in order, with the expected
    time, and how to get a quick taste instead. Silent when everything is cached."""
    from .build.book_models import jobs_for
    from .build.plan import plan_line

    try:
        line = plan_line(jobs_for(models, profile, data=data, flow_options=flow_options or None), workers=1)
    except Exception:  # noqa: BLE001 - advisory only: the command itself reports a bad dataset or cache
        return
    if line:
        taste = "" if profile == "smoke" else "; for a quick taste instead, add --profile smoke (seconds per model)"
        print(f"note: {line}{taste}", file=sys.stderr, flush=True)


@contextlib.contextmanager
def _probe_then_run():
    """Around a command's :func:`_announce_training` and its work: what the plan probe loaded (the dataset,
    the cached models) is what the command uses, so nothing is read and verified twice."""
    from .models import forget_book_datasets
    from .train.cache import reuse_probed_models

    forget_book_datasets()  # the dataset as it is now, not one an earlier call in this process left in memory
    with reuse_probed_models():
        yield


def _command_dataset(data: str | None, profile: str):
    """The command's dataset (seed 0, as ``load_dataset``'s default): inside :func:`_probe_then_run`, the
    instance the plan probe loaded, else loaded now (as it is when the probe failed or was skipped)."""
    from .models import book_dataset

    return book_dataset(profile, 0, data)


def _check_generation_lengths(lengths: list[int], profile: str) -> None:
    """Each length within what the diffusion model was trained on (longer ones also need memory quadratic
    in length for attention); several texts make a longer motion."""
    from .diffusion.pipeline import FRAMES_PER_TOKEN, check_lengths
    from .diffusion.training import diffusion_training_config

    for n in lengths:  # the library's check_lengths, in the words of the option
        if n < FRAMES_PER_TOKEN or n % FRAMES_PER_TOKEN:
            raise ValueError(
                f"--length {n}: lengths are positive multiples of {FRAMES_PER_TOKEN} frames at 20 fps "
                f"(a token is {FRAMES_PER_TOKEN} frames), e.g. 40 or 120"
            )
    check_lengths(lengths, len(lengths))
    longest = diffusion_training_config(profile, num_codes=2).max_tokens * FRAMES_PER_TOKEN
    for n in lengths:
        if n > longest:
            raise ValueError(
                f"--length {n} exceeds the longest motion the model was trained on, {longest} frames "
                f"({longest / 20:.1f} s at 20 fps); give several texts for a longer motion"
            )


def _check_output(path: Path, force: bool, option: str) -> None:
    """Refuse an output path before any work: a folder, an existing file without ``--force``, an unknown
    extension, or a folder that does not exist or cannot be written."""
    from .io.files import MOTION_SUFFIXES

    if path.is_dir():
        raise ValueError(f"{option} {path} is a folder; give a file name ending in {', '.join(MOTION_SUFFIXES)}")
    if path.suffix.lower() not in MOTION_SUFFIXES:
        raise ValueError(
            f"{option} {str(path)!r} has an unknown extension {path.suffix.lower()!r}; expected one of "
            f"{', '.join(MOTION_SUFFIXES)}"
        )
    if path.exists() and not force:
        raise ValueError(f"{path} exists; pass --force to replace it")
    _check_writable_folder(path.parent, option)


def _check_writable_folder(folder: Path, option: str) -> None:
    folder = folder if str(folder) else Path(".")
    if not folder.is_dir():
        raise ValueError(f"the folder {str(folder)!r} of {option} does not exist")
    if not os.access(folder, os.W_OK | os.X_OK):
        raise ValueError(f"cannot write to the folder {str(folder)!r} of {option} (permission denied)")


def _check_cache_writable() -> None:
    """The model/data cache must take new files (training and dataset generation write there)."""
    from .paths import cache_dir

    try:
        root = cache_dir()
    except OSError as err:
        raise ValueError(f"cannot create the cache folder ($MOTIONLAB_HOME): {err}") from None
    if not os.access(root, os.W_OK | os.X_OK):
        raise ValueError(
            f"cannot write to the cache {root} ($MOTIONLAB_HOME); point MOTIONLAB_HOME at a writable folder"
        )


def _convert(args: argparse.Namespace) -> int:
    from .io import convert_motion

    _check_mapping(args.mapping)
    if not args.dst.is_dir() and args.dst.exists() and not args.force:
        print(f"error: {args.dst} exists; pass --force to replace it", file=sys.stderr)
        return 2
    _check_output(args.dst, args.force, "the output")
    path = convert_motion(
        args.src, args.dst, mapping=args.mapping, scale=args.scale, up=args.up, start=args.start, end=args.end
    )
    print(path)
    return 0


def _evaluate(args: argparse.Namespace) -> int:
    from .evaluation import EVALUATORS, check_json_path, default_repeats, write_json

    profile = args.settings.profile
    config = _evaluation_config(args, default_repeats(profile) if args.repeats is None else args.repeats)
    if args.json is not None:
        if args.json.is_file() and not args.force:  # the library's check, in the words of the options
            raise ValueError(f"--json {args.json} exists; pass --force to replace it")
        check_json_path(args.json, force=args.force)  # refuse before hours of work, not after
        _check_writable_folder(args.json.parent, "--json")
    _check_evaluation_size(config)
    with _probe_then_run():
        _announce_training(profile, _evaluation_models(args.task, config), args.data, _flow_overrides(config))
        dataset = _command_dataset(args.data, profile)
        with _phase_lines(not sys.stderr.isatty()):  # bars on a terminal, one line per phase in a log
            table = EVALUATORS[args.task](dataset, config, profile, device=args.device, progress=sys.stderr.isatty())
    print(table)  # its header line, then the Markdown table
    if args.json is not None:
        print(f"wrote {write_json(table, args.json, force=args.force)}", file=sys.stderr)
    return 0


def _evaluation_models(task: str, config) -> list[str]:
    """The models an evaluation loads (or trains on first use), as names of the book's plan."""
    if task == "reconstruction":
        return config.book_models()
    models = list(config.models) if task == "t2m" else [getattr(config, "model", "t2m/dynamic")]
    return [*models, "evaluator"] + (["discord/vq"] if config.decoder == "discord" else [])


def _flow_overrides(options) -> dict:
    """The DisCoRD training options given (command-line args or an evaluation config): they select another decoder."""
    from .evaluation import FLOW_TRAINING_OPTIONS

    return {k: getattr(options, k) for k in FLOW_TRAINING_OPTIONS if getattr(options, k, None) is not None}


@contextlib.contextmanager
def _phase_lines(enabled: bool):
    """Print evaluation's phase lines (``motionlab.evaluate`` log records) to stderr while active."""
    import logging

    from .evaluation import log

    if not enabled:
        yield
        return
    handler = logging.StreamHandler(sys.stderr)
    handler.setFormatter(logging.Formatter("evaluate %(asctime)s %(message)s", "%H:%M:%S"))
    level, log.level = log.level, logging.INFO
    log.addHandler(handler)
    try:
        yield
    finally:
        log.removeHandler(handler)
        log.setLevel(level)


def _check_evaluation_size(config) -> None:
    """Refuse sizes whose generated motions would not fit in memory (estimated before any work)."""
    from .evaluation import available_memory, estimated_memory

    need, what = estimated_memory(config)
    have = available_memory()
    if have is not None and need > 0.8 * have:
        raise ValueError(
            f"{what} would need about {need / 2**30:.1f} GiB of memory, more than the "
            f"{have / 2**30:.1f} GiB available here; ask for fewer"
        )


def _evaluation_config(args: argparse.Namespace, repeats: int):
    """The task's config from the parsed options (``CLI_OPTIONS``; the config validates them)."""
    from .evaluation import CONFIGS, config_from_options

    return config_from_options(args.task, CONFIGS[args.task], {**vars(args), "repeats": repeats})


def _add_flow_training_options(parser: argparse.ArgumentParser) -> None:
    """Which DisCoRD decoder: options fixed at training time (default: the profile's)."""
    parser.add_argument(
        "--predict",
        dest="prediction",
        choices=["v", "x"],
        default=None,
        help="DisCoRD: the network predicts the velocity (v, the paper's) or the clean motion (x) (default: the "
        "profile's: x in laptop, v in smoke and full)",
    )
    parser.add_argument(
        "--normalization",
        choices=["std", "feat_bias"],
        default=None,
        help="DisCoRD: plain std, or the public code's root/contact weighting (feat_bias) (default: the profile's: "
        "std in laptop, feat_bias in smoke and full)",
    )
    parser.add_argument(
        "--time-distribution",
        dest="time_distribution",
        choices=["uniform", "logit_normal"],
        default=None,
        help="DisCoRD training times (default: the profile's)",
    )


def _add_evaluate(sub) -> None:
    """``evaluate TASK``: one sub-command per paper table, sharing the data, model and output options."""
    profiles = ["smoke", "laptop", "full"]
    common = argparse.ArgumentParser(add_help=False)
    common.add_argument(
        "--profile", choices=profiles, default=None, help="model size (default: $MOTIONLAB_PROFILE or laptop)"
    )
    common.add_argument("--data", default=None, help="a HumanML3D/KIT-ML folder (default: the embedded dataset)")
    common.add_argument("--device", default=None, help="cpu, cuda, cuda:1 ... (default: CUDA when present)")
    common.add_argument(
        "--repeats",
        type=int,
        default=None,
        help="evaluations for the 95%% intervals (default: 2 smoke, 5 laptop, 20 full)",
    )
    common.add_argument("--seed", type=_seed_argument, default=0, help="seeds every random draw (default: 0)")
    common.add_argument("--split", choices=["train", "val", "test"], default="test", help="(default: test)")
    common.add_argument(
        "--json", type=Path, default=None, help="also write the table to this .json file (default: none)"
    )
    common.add_argument("--force", action="store_true", help="replace an existing --json file")
    flow = argparse.ArgumentParser(add_help=False)
    flow.add_argument("--steps", type=int, default=None, help="DisCoRD ODE intervals (default: its config's)")
    flow.add_argument("--solver", default=None, help="DisCoRD ODE solver: euler or midpoint (default: its config's)")
    sampling = argparse.ArgumentParser(add_help=False)
    sampling.add_argument("--num-steps", type=int, default=None, help="diffusion sampling steps (default: all T)")
    sampling.add_argument(
        "--guidance-scale", type=float, default=None, help="classifier-free guidance s (default: 4, M2D2M's)"
    )
    sampling.add_argument(
        "--guidance-on",
        choices=["x0", "posterior"],
        default=None,
        help="where guidance acts: p(x0 | x_t), as VQ-Diffusion's code does, or p(x_t-1 | x_t), as M2D2M's Eq. 9 "
        "writes (default: x0)",
    )

    evaluate = sub.add_parser(
        "evaluate",
        help="the papers' tables with 95%% CIs: reconstruction, t2m, multi",
        description="Evaluate the book's cached models (trained on first use) and print a "
        "paper-style Markdown table, mean ± 95% half-width per cell.",
        epilog=examples_epilog(
            ("evaluate reconstruction --decoder discord", "DisCoRD Table 1: feed-forward vs DisCoRD rows"),
            ("evaluate t2m --guidance-scales 0,4", "M2D2M Table 3's metrics, one row per guidance scale"),
            ("evaluate multi --methods tps,independent", "M2D2M's multi-motion table"),
        ),
    )
    tasks = evaluate.add_subparsers(dest="task", required=True, metavar="TASK")
    rec = tasks.add_parser(
        "reconstruction",
        parents=[common, flow],
        help="DisCoRD Table 1: tokens -> decoded motion",
        description="Ground truth -> tokens -> decoded motion: FID, MPJPE, sJPE, Noise and "
        "Static sJPE. The feed-forward decoder is deterministic (one run).",
        epilog=examples_epilog(
            ("evaluate reconstruction --decoder discord --json table1.json", "DisCoRD Table 1, also as JSON"),
            ("evaluate reconstruction --grid euler:1,midpoint:15 --timing-repeats 5", "Table E: steps, solvers, time"),
            ("evaluate reconstruction --decoder vq --jerk", "the VQ tokenizer's own decoder, with mean jerk"),
        ),
    )
    rec.add_argument(
        "--decoder",
        default="discord",
        help="vq | rvq (that book tokenizer's feed-forward decoder), discord (feed-forward and DisCoRD rows, the "
        "book's), feed-forward (--tokenizer's own decoder), or discord:FOLDER[,TOKENIZER] (a released DisCoRD "
        "decoder; default: discord)",
    )
    rec.add_argument(
        "--tokenizer",
        default=None,
        help="whose tokens: the book's vq | rvq (default: rvq), or a released checkpoint, momask:FOLDER[,CHECKPOINT] "
        "| t2mgpt:PATH[,META] (default with a released decoder: the one its config_model.yaml names)",
    )
    rec.add_argument(
        "--evaluator",
        default=None,
        help="official:FOLDER: the released T2M evaluator (checkpoints/{t2m,kit}/text_mot_match, Comp_v6_KLD005) "
        "instead of the book's, which trains on --data on first use (default: the book's)",
    )
    rec.add_argument("--glove", default=None, help="with --evaluator official: the GloVe folder (default: FOLDER)")
    rec.add_argument(
        "--window",
        type=int,
        default=None,
        help="zero-pad every clip to this many frames before tokenising it, as the released evaluation does "
        "(default: 196 with released checkpoints, none with the book's)",
    )
    rec.add_argument(
        "--training-seed",
        type=int,
        default=None,
        help="K: the book's tokenizer and DisCoRD decoder trained with seed K, a replicate of the chain (default: 0, "
        "the book's; another seed trains on first use)",
    )
    rec.add_argument(
        "--xpred",
        action="store_true",
        help="decode with the laptop's x-predicting variant of the book's decoder (it predicts the clean motion and "
        "starts from zero noise; a lever, not the paper's decoder)",
    )
    rec.add_argument("--limit", type=int, default=None, help="score only the first K clips of the split (default: all)")
    _add_flow_training_options(rec)
    rec.add_argument(
        "--temperature",
        type=float,
        default=None,
        help="DisCoRD start-noise scale (default: the profile's; the paper samples at 1)",
    )
    rec.add_argument(
        "--spacing", choices=["uniform", "data_dense"], default=None, help="DisCoRD time grid (default: the profile's)"
    )
    rec.add_argument(
        "--final-prediction",
        dest="final_prediction",
        action="store_true",
        default=None,
        help="x-prediction decoders: return the network's x̂1 at the last step",
    )
    rec.add_argument(
        "--grid",
        default=None,
        help="DisCoRD Table E: one more DisCoRD row per solver:intervals, e.g. euler:1,euler:16,midpoint:15 "
        "(default: none)",
    )
    rec.add_argument(
        "--grid-repeats", type=int, default=None, help="sampling seeds of each --grid row (default: --repeats)"
    )
    rec.add_argument(
        "--timing-repeats",
        type=int,
        default=0,
        help="also time K decodes of one batch of 32 clips per decoder, and count its GFLOPs (default: 0, no timing)",
    )
    rec.add_argument(
        "--jerk", action="store_true", help="also the mean joint jerk (m/s³), with the ground truth's own as a row"
    )
    rec.add_argument(
        "--token-phases",
        dest="token_phases",
        action="store_true",
        help="also Noise sJPE by token phase (phase 0: jerk stencils centred on a token boundary) and phase 0's share",
    )

    t2m = tasks.add_parser(
        "t2m",
        parents=[common, flow, sampling],
        help="text to motion: R-precision, FID, ...",
        description="The text-to-motion protocol: R-precision top 1-3, FID, MM-Dist, "
        "Diversity (+ MultiModality) of the diffusion model and of the real "
        "motions.",
        epilog=examples_epilog(
            ("evaluate t2m --models t2m/uniform,t2m/dynamic", "uniform vs dynamic transitions (chapter 08)"),
            ("evaluate t2m --guidance-scales 0,1,2,4", "one row per classifier-free guidance scale"),
            ("evaluate t2m --multimodality --mm-texts 10 --repeats 2", "MultiModality too, a quick look"),
        ),
    )
    t2m.add_argument(
        "--decoder",
        choices=["vq", "discord"],
        default="vq",
        help="decode the generated VQ tokens with the VQ decoder or DisCoRD (default: vq)",
    )
    t2m.add_argument("--limit", type=int, default=None, help="use only the first K clips, K >= 32 (default: all)")
    t2m.add_argument("--multimodality", action="store_true", help="also MultiModality (slow)")
    t2m.add_argument("--mm-texts", type=int, default=100, help="texts for MultiModality (default: 100)")
    t2m.add_argument("--mm-repeats", type=int, default=30, help="generations per text (default: 30)")
    t2m.add_argument(
        "--models",
        default="t2m/dynamic",
        help="comma-separated model names (motionlab.models), one row each, e.g. t2m/uniform,t2m/dynamic-seed1 "
        "(default: t2m/dynamic)",
    )
    t2m.add_argument(
        "--guidance-scales",
        default=None,
        help="comma-separated guidance scales, one row per scale and model, e.g. 0,1,2,4 (instead of --guidance-scale; "
        "default: --guidance-scale's one row)",
    )
    t2m.add_argument(
        "--top-p",
        type=float,
        default=None,
        help="truncate p(x0 | x_t) to its top-p mass, e.g. 0.85 (default: no truncation)",
    )
    t2m.add_argument("--reconstruction", action="store_true", help="also the VQ-VAE reconstruction of the real motions")
    t2m.add_argument(
        "--token-stats",
        action="store_true",
        help="also the sampled codes' histogram TV to the real codes and their adjacent-repeat rate",
    )

    multi = tasks.add_parser(
        "multi",
        parents=[common, flow, sampling],
        help="M2D2M multi-motion: TPS vs baselines",
        description="Multi-action instances from the split's single-action clips; "
        "per-action and transition metrics (FID, Diversity, Jerk).",
        epilog=examples_epilog(
            ("evaluate multi --methods tps,independent --segment-jerk", "TPS vs independent sampling"),
            ("evaluate multi --methods tps:T_s=50,slerp:transition=40,handshake", "a switch step and two baselines"),
            ("evaluate multi --model t2m/multi-eta0.25 --actions 2", "M2D2M's multi-motion model, two actions"),
        ),
    )
    multi.add_argument(
        "--methods",
        default="tps,independent",
        help="comma-separated, of tps, independent, separate, slerp, handshake, each with options after colons: "
        "tps:T_s=50, tps:joint_text=all (the compound condition), slerp:transition=40 (default: tps,independent)",
    )
    multi.add_argument(
        "--model",
        default="t2m/dynamic",
        help="the text-to-motion model, by its training-plan name: t2m/dynamic, t2m/uniform, t2m/multi-eta0.25 "
        "(M2D2M's multi-motion eta), ... (default: t2m/dynamic)",
    )
    multi.add_argument(
        "--segment-jerk",
        dest="segment_jerk",
        action="store_true",
        help="also the Jerk inside the actions, away from the transitions",
    )
    multi.add_argument(
        "--instances", type=int, default=None, help="multi-action instances (default: as many as the pool covers once)"
    )
    multi.add_argument("--actions", type=int, default=4, help="actions per instance (default: 4)")
    multi.add_argument(
        "--T-s", dest="T_s", type=int, default=None, help="TPS switch step where a method gives none (default: 0.9 T)"
    )
    multi.add_argument("--decoder", choices=["vq", "discord"], default="vq", help="token decoder (default: vq)")
    for task in (rec, t2m, multi):
        task.set_defaults(func=_evaluate)


def _settings(args: argparse.Namespace):
    """The run's settings, resolved once from the options and the environment, and made the run's (exported, so
    that worker processes and chapter kernels inherit them); every command reads them from ``args.settings``."""
    from .precision import explain_precision
    from .profiles import env_threads
    from .settings import MAX_THREADS, apply_settings, cpu_load, resolve_settings, threads_for_load
    from .train.device import get_device

    if args.threads is not None and not 1 <= args.threads <= MAX_THREADS:
        raise ValueError(f"--threads must be a positive int (at most {MAX_THREADS}), got {args.threads}")
    if args.force_precision:
        if args.precision is None:
            raise ValueError("--force-precision insists on a --precision; give one")
        os.environ["MOTIONLAB_FORCE_PRECISION"] = "1"  # exported: workers and chapter kernels insist too
    threads = args.threads if args.threads is not None else env_threads()
    # The commands that run models in this process choose by the load; the others keep their own choice: the book's
    # kernels and the workers of `train book` run one thread each, whatever the process that starts them has
    in_process = getattr(args, "model", None) != "book"
    runs_models = getattr(args, "command", None) in ("train", "generate", "evaluate") and in_process
    load = cpu_load() if threads is None and runs_models else None
    if (threads_now := threads_for_load(load)) is not None:
        threads = threads_now
        print(
            f"note: other programs are using the CPU (load {load:.1f} on {os.cpu_count()} cores): "
            f"{threads} torch thread{'s' * (threads > 1)}, which is faster then; --threads N chooses",
            file=sys.stderr,
        )
    settings = apply_settings(
        resolve_settings(getattr(args, "profile", None), args.precision, threads, args.deterministic, args.compile)
    )
    explain_precision(settings.precision, get_device(getattr(args, "device", None)))  # refuses before any work
    return settings


def build_parser() -> argparse.ArgumentParser:
    from . import __version__

    parser = _Parser(prog="motionlab", description=__doc__.splitlines()[0], epilog=EPILOG)
    parser.add_argument("--version", action="version", version=f"motionlab {__version__}", help="print the version")
    parser.add_argument(
        "--threads",
        type=int,
        default=None,
        help="torch CPU threads (default: $MOTIONLAB_THREADS, else torch's choice on an idle machine and the cores "
        "other programs leave free, at least 1, on a busy one)",
    )
    parser.add_argument(
        "--precision",
        choices=["auto", "fp32", "bf16"],
        default=None,
        help="numeric precision of training and sampling (default: $MOTIONLAB_PRECISION, else auto: "
        "bf16 where the CPU has bf16 matrix units (AMX, or AVX512-BF16 on AMD) or the GPU "
        "supports it, else fp32); metrics, losses and weights stay fp32. bf16 on a CPU with neither AMX nor "
        "AVX512-BF16 is refused (hundreds of times slower than fp32 there)",
    )
    parser.add_argument(
        "--force-precision",
        action="store_true",
        help="run the --precision asked for even where it is refused (default: $MOTIONLAB_FORCE_PRECISION)",
    )
    parser.add_argument(
        "--deterministic",
        action="store_true",
        default=None,
        help="deterministic kernels only, so a GPU run repeats bit for bit (resume included); slower on a GPU, "
        "no change on a CPU, whose kernels already are (default: $MOTIONLAB_DETERMINISTIC, else off)",
    )
    parser.add_argument(
        "--compile",
        choices=["auto", "on", "graphs", "off"],
        default=None,
        help="torch.compile the networks while training: auto compiles on CUDA where it was measured to pay "
        "(the DisCoRD U-Net), never on a CPU; on compiles every trained network; graphs as on, and on CUDA "
        "replays the launch-bound denoiser as CUDA graphs; off compiles nothing (default: $MOTIONLAB_COMPILE, "
        "else auto)",
    )
    sub = parser.add_subparsers(dest="command", required=True)

    data = sub.add_parser(
        "data",
        help="datasets: generate the embedded one, check a folder, convert BVH takes",
        description="The datasets the models train on: the embedded procedural one (made on first use), a "
        "HumanML3D/KIT-ML folder, or your own BVH takes converted to that layout.",
        epilog=examples_epilog(
            ("data check ~/data/HumanML3D", "is a downloaded dataset complete?"),
            ("data make-embedded --profile smoke --out embedded-smoke", "the embedded dataset, into a folder"),
            ("data from-bvh takes/ --out my-mocap", "your mocap; then: motionlab train vq --data my-mocap"),
        ),
    )
    data_sub = data.add_subparsers(dest="data_command", required=True)

    check = data_sub.add_parser(
        "check",
        help="validate a HumanML3D/KIT-ML folder and list what is missing",
        description="Validate a HumanML3D/KIT-ML folder: list what is missing or malformed (exit 1), or say it is "
        "complete (exit 0).",
        epilog=examples_epilog(("data check ~/data/HumanML3D", "new_joint_vecs/, texts/, the splits, Mean.npy, ...")),
    )
    check.add_argument("path", type=Path, help="the dataset folder (new_joint_vecs/, texts/, train.txt, Mean.npy, ...)")
    check.set_defaults(func=_data_check)

    make = data_sub.add_parser(
        "make-embedded",
        help="generate the embedded procedural dataset",
        description="Generate the embedded procedural dataset (HumanML3D layout, t2m skeleton) into the cache, or "
        "into --out. Training does this on first use; the same seed gives the same clips.",
        epilog=examples_epilog(
            ("data make-embedded", "the laptop profile's dataset, into the cache"),
            ("data make-embedded --profile smoke --out embedded-smoke", "a small one, into a folder to look at"),
        ),
    )
    make.add_argument(
        "--profile",
        choices=["smoke", "laptop", "full"],
        default=None,
        help="dataset size (default: $MOTIONLAB_PROFILE or laptop)",
    )
    make.add_argument("--seed", type=_seed_argument, default=0, help="seeds the procedural clips and their split")
    make.add_argument(
        "--out", type=Path, default=None, help="write here instead of the cache (must not exist; default: the cache)"
    )
    make.add_argument("--clips", type=int, default=None, help="number of clips, with --out (default: the profile's)")
    make.set_defaults(func=_data_make_embedded)

    from_bvh = data_sub.add_parser(
        "from-bvh",
        help="convert a folder of BVH takes into a HumanML3D-layout dataset (resumable)",
        description="Your own mocap as a dataset the book trains on (train ... --data DATASET): every .bvh in "
        "FOLDER becomes new_joints, new_joint_vecs and texts; then splits and Mean/Std. Each take's rig is "
        "detected from its joint names (a BVH motionlab wrote, CMU's, t2m's) unless --mapping gives one. A re-run "
        "converts only new or changed takes. Skipped takes are listed with the reason.",
        epilog=examples_epilog(
            ("data from-bvh takes/ --out my-mocap", "captions from the file names, the rig from the joint names"),
            ("data from-bvh takes/ --out my-mocap --captions captions.csv", "your captions and crops"),
            ("data from-bvh takes/ --out my-mocap --mapping my-rig.json --scale 0.01", "your rig's joint map"),
        ),
    )
    from_bvh.add_argument("folder", type=Path, help="folder with the .bvh takes (not searched recursively)")
    from_bvh.add_argument("--out", type=Path, required=True, help="the dataset folder to write (or resume)")
    from_bvh.add_argument(
        "--captions",
        type=Path,
        default=None,
        help="CSV with columns take,caption[,start,end] (crop in frames at 20 fps); "
        "default: captions from the file names",
    )
    from_bvh.add_argument("--mapping", type=_mapping_argument, default="auto", help=MAPPING_HELP)
    from_bvh.add_argument("--scale", type=float, default=None, help="BVH units to metres (default: the rig's)")
    from_bvh.add_argument("--up", choices=["y", "z"], default=None, help="up axis of the BVH (default: y)")
    from_bvh.add_argument("--seed", type=_seed_argument, default=0, help="seeds the train/val/test split (default: 0)")
    from_bvh.add_argument(
        "--force",
        action="store_true",
        help="convert into a non-empty --out that holds no earlier from-bvh dataset, or rebuild one from scratch; "
        "only the files from-bvh wrote (listed in --out's .motionlab-manifest.json) are replaced, any other "
        "file there stays",
    )
    from_bvh.set_defaults(func=_data_from_bvh)

    train = sub.add_parser(
        "train",
        help="train a model of the book (or load it if already trained); resumable",
        description="Train a model of the book once and cache it (or load it if already trained). Ctrl-C stops; "
        "the same command resumes from the last checkpoint. 'discord' is the DisCoRD decoder of RVQ "
        "tokens (DisCoRD Table 1, `evaluate reconstruction`); `generate`/`evaluate t2m|multi "
        "--decoder discord` use a second DisCoRD decoder, of the diffusion model's VQ tokens: "
        "`train discord --tokenizer vq` trains that one.",
        epilog=examples_epilog(
            ("train rvq --profile smoke", "the RVQ tokenizer, in seconds"),
            ("train discord --tokenizer vq", "the DisCoRD decoder that generate --decoder discord uses"),
            ("train book --jobs 2", "every model the chapters load, two at a time"),
            ("train diffusion --data ~/data/HumanML3D --profile full --device cuda", "the paper's size, on a GPU"),
        ),
    )
    train.add_argument(
        "model",
        choices=["vq", "rvq", "evaluator", "discord", "diffusion", "book"],
        help="which model; 'book': every model the chapters load, several at a time",
    )
    train.add_argument(
        "--jobs",
        type=int,
        default=None,
        help="with 'book': models trained at once, one process and one torch thread each (default 2)",
    )
    train.add_argument(
        "--record",
        action="store_true",
        help="with 'book', in the book's repository: also merge the trained models' times into "
        "book/data/build_times/<profile>-training.json (what the intro's chapter map reads); every "
        "run there merges them into _build/executed/<profile>/training.json",
    )
    train.add_argument(
        "--tokenizer",
        choices=["rvq", "vq"],
        default=None,
        help="discord only: decode RVQ tokens (default; DisCoRD Table 1) or the VQ tokens that "
        "generate --decoder discord needs",
    )
    train.add_argument(
        "--profile",
        choices=["smoke", "laptop", "full"],
        default=None,
        help="model size (default: $MOTIONLAB_PROFILE or laptop)",
    )
    train.add_argument("--data", default=None, help="a HumanML3D/KIT-ML folder (default: the embedded dataset)")
    train.add_argument("--device", default=None, help="cpu, cuda, cuda:1 ... (default: CUDA when present)")
    _add_flow_training_options(train)
    train.set_defaults(func=_train)

    book = sub.add_parser(
        "book",
        help="build steps of the book (run in its repository); `make book` calls them",
        description="The steps `make book` runs after `motionlab train book`, run in the book's repository.",
        epilog=examples_epilog(
            ("book execute --profile smoke", "every chapter at the smoke profile, then the site's sources")
        ),
    )
    book_sub = book.add_subparsers(dest="step", required=True)
    execute = book_sub.add_parser(
        "execute",
        help="execute the chapters in parallel (a stalled kernel is restarted) and stage the site",
        description="Execute every chapter of book/_toc.yml into _build/executed/<profile>/notebooks, several at a "
        "time, each in its own kernel; then stage _build/site-src, which Jupyter Book renders without "
        "executing the chapters again. Run `motionlab train book` first so the chapters only load models.",
        epilog=examples_epilog(
            ("book execute --profile smoke --jobs 2", "every chapter at the smoke profile, two at a time"),
            ("book execute --chapters 05_discord --force", "one chapter again, even if nothing changed"),
        ),
    )
    execute.add_argument(
        "--profile",
        choices=["smoke", "laptop", "full"],
        default=None,
        help="run profile (default: $MOTIONLAB_PROFILE or laptop)",
    )
    execute.add_argument("--jobs", type=int, default=2, help="chapters executed at once (default 2)")
    execute.add_argument(
        "--chapters",
        nargs="+",
        default=None,
        help="only these chapters, e.g. 05_discord; the site is not staged (default: every chapter)",
    )
    execute.add_argument(
        "--force",
        action="store_true",
        help="execute every chapter, also those whose notebook, library and models are unchanged "
        "since their last successful execution (kept by default)",
    )
    execute.add_argument("--root", default=".", help="the book's repository (default: the current folder)")
    execute.add_argument(
        "--stall-seconds",
        type=float,
        default=180.0,
        help="a running cell whose kernel sends nothing and uses no CPU this long is restarted",
    )
    execute.add_argument(
        "--record",
        action="store_true",
        help="also write the timings to book/data/build_times/<profile>.json (committed)",
    )
    execute.set_defaults(func=_book_execute)
    stale = book_sub.add_parser(
        "stale",
        help="list the committed study records a change to the code makes stale, and what measuring them costs",
        description="Every record under book/data/ (scale points, training-seed runs, budget and η models) carries the "
        "configs it was measured with; list those the working tree no longer reproduces, each with the command "
        "that measures it again and how long that took last time. Nothing runs. Exit 1 where any is stale.",
        epilog=examples_epilog(("book stale", "after changing sizes.py or a model, before committing")),
    )
    stale.add_argument(
        "--profile", choices=["smoke", "laptop", "full"], default=None, help="whose records (default: laptop)"
    )
    stale.set_defaults(func=_book_stale)

    gen = sub.add_parser(
        "generate",
        help="text to motion; several texts make one multi-action motion (TPS)",
        description="Generate a motion from text with the book's discrete-diffusion model (trained on first use). "
        "Several texts are generated jointly with Two-Phase Sampling. The model knows only the words of its "
        "training captions (with the embedded data: walk, run, jump, wave and its other action families); "
        "--list-words lists them, and a warning names any word of a text it does not know.",
        epilog=examples_epilog(
            ('generate "a person waves" --profile smoke --out wave.html', "seconds; then open wave.html"),
            ('generate "a person walks" "a person jumps" --length 80 --out two.html', "two actions, one motion"),
            ('generate "a person waves" --decoder discord --out wave.bvh', "DisCoRD-decoded, for Blender"),
            ('generate "a person waves" --seed 1 --out wave.npy', "another sample; HumanML3D features"),
            ("generate --list-words", "the actions and words the model knows"),
        ),
    )
    gen.add_argument(
        "texts",
        nargs="*",
        help='one or more action descriptions, e.g. "a person waves"; words the model does not know are named '
        "in a warning before anything is generated",
    )
    gen.add_argument(
        "--list-words",
        action="store_true",
        help="list the action families of the embedded data and every word the model knows, then stop "
        "(generates nothing; no --out)",
    )
    gen.add_argument(
        "--length",
        type=int,
        nargs="+",
        default=[120],
        help="frames at 20 fps, a multiple of 4: one for all texts or one per text",
    )
    gen.add_argument(
        "--decoder",
        choices=["vq", "discord"],
        default="vq",
        help="token decoder (default: vq); discord: the DisCoRD decoder of the VQ tokens (not the RVQ "
        "one of `train discord`; `train discord --tokenizer vq` trains it ahead). At the laptop's sizes it is the "
        "paper's velocity decoder narrower than the motion's features and trained for minutes, so its motion is "
        "jerkier than vq's (chapter 09 measures it)",
    )
    gen.add_argument(
        "--out",
        type=Path,
        default=None,
        help="output .npy (features), .bvh (fixed bone lengths) or .html; never replaced without --force (no "
        "default: required, except with --list-words)",
    )
    gen.add_argument("--force", action="store_true", help="replace an existing --out file")
    gen.add_argument(
        "--T-s", dest="T_s", type=int, default=None, help="TPS switch step, with two or more texts (default: 0.9 T)"
    )
    gen.add_argument(
        "--seed", type=_seed_argument, default=0, help="seeds the sampling: the same seed gives the same motion"
    )
    gen.add_argument(
        "--profile",
        choices=["smoke", "laptop", "full"],
        default=None,
        help="model size: smoke trains in seconds and only shows that the code runs, laptop in minutes on a CPU "
        "(once, then cached), full is the papers' (default: $MOTIONLAB_PROFILE or laptop)",
    )
    gen.add_argument("--data", default=None, help="a HumanML3D/KIT-ML folder (default: the embedded dataset)")
    gen.add_argument("--device", default=None, help="cpu, cuda, cuda:1 ... (default: CUDA when present)")
    gen.set_defaults(func=_generate)

    convert = sub.add_parser(
        "convert",
        help="convert motion between .bvh, .npy (HumanML3D features) and .html",
        description="Mocap (BVH) becomes HumanML3D features on the t2m skeleton at 20 fps; "
        "features or joints become BVH or a standalone HTML animation.",
        epilog=examples_epilog(
            ("convert take.bvh take.html", "look at a take in the browser"),
            ("convert take.bvh take.npy --start 40 --end 200", "frames 40-199 as HumanML3D features"),
            ("convert wave.npy wave.bvh", "features to BVH with the t2m skeleton's bones"),
            ("convert wave.bvh wave.html", "motionlab's own BVH back (its rig is detected, as CMU's is)"),
        ),
    )
    convert.add_argument("src", type=Path, help="input .bvh or .npy (features (T, 263) or joints (T, 22, 3))")
    convert.add_argument("dst", type=Path, help="output .npy, .bvh or .html")
    convert.add_argument("--mapping", type=_mapping_argument, default="auto", help=MAPPING_HELP)
    convert.add_argument("--scale", type=float, default=None, help="BVH units to metres (default: the rig's)")
    convert.add_argument("--up", choices=["y", "z"], default=None, help="up axis of the BVH (default: y)")
    convert.add_argument("--start", type=int, default=0, help="first frame to keep, at 20 fps")
    convert.add_argument(
        "--end", type=int, default=None, help="frame to stop before, at 20 fps (default: the last frame)"
    )
    convert.add_argument("--force", action="store_true", help="replace an existing output file")
    convert.set_defaults(func=_convert)

    _add_evaluate(sub)
    from .pretrained import add_subcommands

    add_subcommands(sub, examples_epilog)  # `pretrained check FOLDER`, `pretrained convert FOLDER --out DIR`
    return parser


def _show_warning(message, category, filename, lineno, file=None, line=None) -> None:
    print(f"warning: {message}", file=sys.stderr)


def _interrupted(started: float) -> str:
    """One line for Ctrl-C: the model being trained (a checkpoint folder written since ``started``), its
    last checkpoint, and that the same command resumes; or just that nothing was written."""
    from .paths import cache_dir
    from .train.checkpoint import latest_checkpoint

    try:
        works = [w for w in (cache_dir() / "models").glob("*/*/*.work") if w.stat().st_mtime >= started - 1]
    except OSError:
        works = []
    if not works:
        return "interrupted; the same command starts again (any training resumes from its last checkpoint)"
    work = max(works, key=lambda w: w.stat().st_mtime)
    name, profile = work.parent.parent.name, work.parent.name
    ckpt = latest_checkpoint(work)
    where = f"at its checkpoint of step {int(ckpt.name[5:]):,}" if ckpt else "from the start (no checkpoint yet)"
    return f"interrupted while training {name!r} ({profile}); the same command resumes it {where}"


MAPPING_HELP = (
    "the BVH rig's joint names: auto (detected from them: a BVH motionlab wrote, CMU's, t2m's), cmu, t2m, or "
    "FILE.json, your rig's joint map (t2m joint name -> BVH joint name, optionally with scale and up; "
    "book/command_line.md shows one)"
)


def _mapping_argument(text: str) -> str:
    """``--mapping``: a preset name or a joint-map ``.json`` file (whose existence :func:`_check_mapping` judges
    before any work)."""
    from .io.bvh_import import MAPPINGS

    if text.lower() in MAPPINGS:
        return text.lower()
    if text.lower().endswith(".json"):
        return text
    raise argparse.ArgumentTypeError(
        f"expected {', '.join(MAPPINGS)} or a joint map FILE.json (t2m joint name -> BVH joint name), got {text!r}"
    )


MAX_SEED = 2**63 - 1  # the largest seed torch's generators take


def _seed_argument(text: str) -> int:
    """``--seed``: an integer in [0, 2**63 - 1], judged when the options are parsed (before any work)."""
    try:
        seed = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"must be an integer, got {text!r}") from None
    if not 0 <= seed <= MAX_SEED:
        raise argparse.ArgumentTypeError(f"must be in [0, 2**63 - 1], got {text}")
    return seed


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    started = time.time()
    with warnings.catch_warnings():
        warnings.showwarning = _show_warning  # one "warning:" line each, restored on exit
        try:
            args.settings = _settings(args)
            return args.func(args)
        except (ValueError, FileNotFoundError) as err:
            print(f"error: {err}", file=sys.stderr)
            return 2
        except OSError as err:  # a full disk, a read-only folder: one line, not a traceback
            print(f"error: {err.strerror or err}{f': {err.filename}' if err.filename else ''}", file=sys.stderr)
            return 1
        except KeyboardInterrupt:
            print(f"\n{_interrupted(started)}", file=sys.stderr)
            return 130


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
