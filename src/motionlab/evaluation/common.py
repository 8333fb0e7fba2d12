"""What the three evaluations share: input checks, size bounds, seeds, progress and the models they load."""

from __future__ import annotations

import logging
import math
import os
import sys
from collections.abc import Mapping
from dataclasses import asdict, dataclass
from typing import Any

import numpy as np
from tqdm.auto import tqdm

from motionlab.precision import network_precision
from motionlab.profiles import get_profile
from motionlab.sizes import run_sizes

from .table import SPLITS, EvaluationTable

# ----------------------------------------------------------------------------------------------- configs


def _check_int(name: str, value: Any, minimum: int, why: str = "") -> None:
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < minimum:
        raise ValueError(f"{name} must be an int >= {minimum}{why}, got {value!r}")


def _check_common(cfg: Any, min_limit: int, why: str = "") -> None:
    if cfg.split not in SPLITS:
        raise ValueError(f"split must be one of {SPLITS}, got {cfg.split!r}")
    _check_int("repeats", cfg.repeats, 1)
    _check_int("seed", cfg.seed, 0)
    if getattr(cfg, "limit", None) is not None:
        _check_int("limit", cfg.limit, min_limit, why)


def _check_flow_options(cfg: Any, uses_flow: bool) -> None:
    """``steps``/``solver`` (and the decoder options) configure DisCoRD; refuse them where no flow decoder runs."""
    if not uses_flow and (cfg.steps is not None or cfg.solver is not None):
        raise ValueError("steps and solver set the DisCoRD decoder's ODE; they need decoder='discord'")
    chosen = [name for name in FLOW_OPTIONS if getattr(cfg, name, None) is not None]
    if not uses_flow and chosen:
        raise ValueError(f"{', '.join(chosen)} configure the DisCoRD decoder; they need decoder='discord'")
    if chosen:
        from motionlab.flow import DisCoRDConfig

        DisCoRDConfig(**{name: getattr(cfg, name) for name in chosen})  # validates each value
    if cfg.steps is not None:
        _check_int("steps", cfg.steps, 1)
    if cfg.solver is not None:
        from motionlab.flow import SOLVERS

        if cfg.solver not in SOLVERS:
            raise ValueError(f"solver must be one of {SOLVERS}, got {cfg.solver!r}")


# DisCoRD decoder options a reconstruction can choose (None: the profile's): which trained decoder, then how it samples.
FLOW_TRAINING_OPTIONS = ("prediction", "normalization", "time_distribution")
FLOW_SAMPLING_OPTIONS = ("temperature", "spacing", "final_prediction")
FLOW_OPTIONS = FLOW_TRAINING_OPTIONS + FLOW_SAMPLING_OPTIONS


# ------------------------------------------------------------------------------------------ the command line
# Each task's config fields as `motionlab evaluate TASK` spells them: the CLI builds the config from exactly these
# options (their argparse destinations are the field names) and a config writes itself back as the command that
# computes its table (:func:`command_line`). Kinds: "value" (one value), "switch" (a flag, given when true), "list"
# (comma-separated words), "numbers" (comma-separated numbers), "grid" (comma-separated solver:intervals).


@dataclass(frozen=True)
class Option:
    """One config field on the command line: its option and how its value is written."""

    flag: str
    kind: str = "value"

    def parse(self, value: Any) -> Any:
        """The option's parsed value (argparse's, a text for the comma-separated kinds) -> the config field's."""
        if not isinstance(value, str) or self.kind not in ("list", "numbers"):
            return value  # a grid's text is read by its config
        parts = [part.strip() for part in value.split(",")]
        if self.kind == "list":
            return tuple(parts)
        try:
            return tuple(float(part) for part in parts)
        except ValueError as err:
            raise ValueError(f"{self.flag} must be comma-separated numbers, got {value!r}") from err

    def words(self, value: Any) -> list[str]:
        """The command-line words that give ``value``."""
        if self.kind == "switch":
            return [self.flag] if value else []
        if self.kind == "grid":
            return [self.flag, ",".join(f"{solver}:{steps}" for solver, steps in value)]
        if self.kind in ("list", "numbers"):
            return [self.flag, ",".join(_option_text(v) for v in value)]
        return [self.flag, _option_text(value)]


def _option_text(value: Any) -> str:
    """A value as an option reads it: a float in its shortest form that reads back the same."""
    if isinstance(value, float):
        short = f"{value:g}"
        return short if float(short) == value else repr(value)
    return str(value)


_SHARED_OPTIONS = {
    "decoder": Option("--decoder"),
    "steps": Option("--steps"),
    "solver": Option("--solver"),
    "split": Option("--split"),
    "repeats": Option("--repeats"),
    "seed": Option("--seed"),
}
_SAMPLING_OPTIONS = {
    "num_steps": Option("--num-steps"),
    "guidance_scale": Option("--guidance-scale"),
    "guidance_on": Option("--guidance-on"),
}
CLI_OPTIONS: dict[str, dict[str, Option]] = {
    "reconstruction": {
        **_SHARED_OPTIONS,
        "tokenizer": Option("--tokenizer"),
        "training_seed": Option("--training-seed"),
        "xpred": Option("--xpred", "switch"),
        "limit": Option("--limit"),
        "prediction": Option("--predict"),
        "normalization": Option("--normalization"),
        "time_distribution": Option("--time-distribution"),
        "temperature": Option("--temperature"),
        "spacing": Option("--spacing"),
        "final_prediction": Option("--final-prediction", "switch"),
        "grid": Option("--grid", "grid"),
        "grid_repeats": Option("--grid-repeats"),
        "timing_repeats": Option("--timing-repeats"),
        "jerk": Option("--jerk", "switch"),
        "token_phases": Option("--token-phases", "switch"),
        "evaluator": Option("--evaluator"),
        "glove": Option("--glove"),
        "window": Option("--window"),
    },
    "t2m": {
        **_SHARED_OPTIONS,
        **_SAMPLING_OPTIONS,
        "models": Option("--models", "list"),
        "limit": Option("--limit"),
        "guidance_scales": Option("--guidance-scales", "numbers"),
        "top_p": Option("--top-p"),
        "multimodality": Option("--multimodality", "switch"),
        "mm_texts": Option("--mm-texts"),
        "mm_repeats": Option("--mm-repeats"),
        "reconstruction": Option("--reconstruction", "switch"),
        "token_stats": Option("--token-stats", "switch"),
    },
    "multi": {
        **_SHARED_OPTIONS,
        **_SAMPLING_OPTIONS,
        "methods": Option("--methods", "list"),
        "model": Option("--model"),
        "instances": Option("--instances"),
        "actions": Option("--actions"),
        "T_s": Option("--T-s"),
        "segment_jerk": Option("--segment-jerk", "switch"),
    },
}


def config_from_options(task: str, config_class: type, options: Mapping[str, Any]) -> Any:
    """``config_class`` from a task's parsed options (argparse's namespace as a mapping); None keeps a default."""
    table = CLI_OPTIONS[task]
    return config_class(**{name: table[name].parse(options[name]) for name in table if options.get(name) is not None})


def command_line(config: Any, task: str, profile: str | None = None) -> str:
    """The ``motionlab evaluate TASK`` command that computes ``config``'s table: ``--profile`` when one is given,
    options at their defaults left out, ``--repeats`` always (the command's default depends on the profile)."""
    default, words = type(config)(), ["motionlab", "evaluate", task]
    words += [] if profile is None else ["--profile", get_profile(profile)]
    for name, option in CLI_OPTIONS[task].items():
        value = getattr(config, name)
        if value is not None and (name == "repeats" or value != getattr(default, name)):
            words += option.words(value)
    return " ".join(words)


# ------------------------------------------------------------------------------------------ size bounds

_MOTION_BYTES = 196 * 263 * 4  # one generated motion at the longest evaluated length, float32 features


def estimated_memory(config: Any) -> tuple[int, str]:
    """Bytes the generated motions of one evaluation step hold at once (an upper estimate), and which option
    sets it: multi holds every instance's actions for every method; MultiModality generates ``mm_texts ×
    mm_repeats`` motions in one go. Reconstruction is bounded by the dataset itself."""
    if hasattr(config, "methods") and config.instances is not None:  # a MultiMotionConfig
        n = config.instances * config.actions * (len(config.methods) + 1)
        return n * _MOTION_BYTES * 2, f"--instances {config.instances}"  # features and joints
    if getattr(config, "multimodality", False):  # a TextToMotionConfig
        n = config.mm_texts * config.mm_repeats
        return n * _MOTION_BYTES * 2, f"--mm-texts {config.mm_texts} × --mm-repeats {config.mm_repeats}"
    return 0, ""


def available_memory() -> int | None:
    """Bytes of memory available to a new allocation (Linux ``MemAvailable``), None where unknown."""
    try:
        with open("/proc/meminfo") as fh:
            for line in fh:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except (OSError, ValueError):
        pass
    try:
        return os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
    except (ValueError, OSError, AttributeError):
        return None


def _check_sampling(cfg: Any) -> None:
    from motionlab.diffusion.sampling import check_guidance_space

    if cfg.num_steps is not None:
        _check_int("num_steps", cfg.num_steps, 1)
    if cfg.guidance_scale is not None and not (math.isfinite(cfg.guidance_scale) and cfg.guidance_scale >= 0):
        raise ValueError(f"guidance_scale must be a finite number >= 0, got {cfg.guidance_scale!r}")
    check_guidance_space(cfg.guidance_on)


def default_repeats(profile: str | None = None) -> int:
    """Repeats per profile: 2 (smoke), 5 (laptop), the papers' 20 (full); see :class:`motionlab.sizes.RunSizes`."""
    return run_sizes(profile).evaluation_repeats


# ----------------------------------------------------------------------------------------------- helpers


def _check_dataset(dataset: Any) -> None:
    for name in ("split", "normalizer", "key"):
        if not hasattr(dataset, name):
            raise ValueError(f"dataset must be a MotionDataset (split, normalizer, key); it lacks {name!r}")


def _split_clips(dataset: Any, split: str, limit: int | None, minimum: int, why: str) -> list:
    _check_dataset(dataset)
    clips = list(dataset.split(split))[:limit]
    if len(clips) < minimum:
        raise ValueError(f"the {split} split gives {len(clips)} clips but {why} needs at least {minimum}")
    return clips


def repeat_seed(seed: int, repeat: int, stream: int = 0) -> int:
    """A 32-bit seed for repeat ``repeat`` of ``stream``, drawn from ``SeedSequence([seed, stream, repeat])``:
    unrelated across repeats even where a decode adds a batch index to it (``decode_clips`` does)."""
    return int(np.random.SeedSequence([int(seed), int(stream), int(repeat)]).generate_state(1)[0])


def _bar(total: int, desc: str, progress: bool, unit: str = "it"):
    return tqdm(total=total, desc=desc, disable=not progress, file=sys.stderr, leave=False, unit=unit)


# One INFO line per phase (the CLI shows them when stderr is a log file rather than a terminal).
log = logging.getLogger("motionlab.evaluate")


def _phase(text: str) -> None:
    log.info(text)


def _duration(seconds: float) -> str:
    return f"{seconds:.0f} s" if seconds < 90 else f"{seconds / 60:.0f} min"


@dataclass
class _FlowSteps:
    """A DisCoRD decoder with the ODE's ``steps``/``solver`` fixed (callers that pass none get these)."""

    decoder: Any
    steps: int | None
    solver: str | None

    def decode(self, ids, tokenizer=None, steps=None, solver=None, generator=None, seed=None):
        steps = self.steps if steps is None else steps
        solver = self.solver if solver is None else solver
        return self.decoder.decode(ids, tokenizer=tokenizer, steps=steps, solver=solver, generator=generator, seed=seed)


def _flow_label(decoder: Any, steps: int | None, solver: str | None) -> str:
    cfg = decoder.config
    return f"{cfg.sample_steps if steps is None else steps} {cfg.solver if solver is None else solver} steps"


def _flow_options_label(decoder: Any) -> str:
    """``", x-prediction, temperature 0.5"``: what sets this decoder apart from the paper's (or "")."""
    from motionlab.flow import DisCoRDConfig

    cfg, paper = decoder.config, DisCoRDConfig()  # the class defaults are the paper's (the full profile)
    labels = {
        "prediction": f"{cfg.prediction}-prediction",
        "normalization": f"{cfg.normalization} normalisation",
        "time_distribution": f"{cfg.time_distribution} times",
        "temperature": f"temperature {cfg.temperature:g}",
        "spacing": f"{cfg.spacing} grid",
        "final_prediction": "last step x̂1",
    }
    return "".join(", " + text for name, text in labels.items() if getattr(cfg, name) != getattr(paper, name))


def _config(config: Any, kind: type) -> Any:
    if config is None:
        return kind()
    if not isinstance(config, kind):
        raise ValueError(f"config must be a {kind.__name__}, got {type(config).__name__}")
    return config


def _sampling(cfg) -> dict[str, Any]:
    options = {"num_steps": cfg.num_steps, "guidance_scale": cfg.guidance_scale, "guidance_on": cfg.guidance_on}
    return {k: v for k, v in options.items() if v is not None}


def _table(task: str, dataset, profile: str, cfg, counts, metrics, rows, device=None, **kw) -> EvaluationTable:
    from motionlab.train.device import get_device

    return EvaluationTable(
        task,
        profile,
        dataset.key,
        cfg.split,
        cfg.repeats,
        cfg.seed,
        asdict(cfg),
        counts,
        tuple(metrics),
        rows,
        precision=network_precision(get_device(device)),
        **kw,
    )
