"""DisCoRD Table 1: test clips → tokens → decoded by the feed-forward decoder and by DisCoRD, scored."""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, fields
from typing import Any

import numpy as np

from motionlab.estimate import Estimate, mean_ci
from motionlab.profiles import get_profile

from .common import (
    FLOW_OPTIONS,
    FLOW_SAMPLING_OPTIONS,
    FLOW_TRAINING_OPTIONS,
    _bar,
    _check_common,
    _check_flow_options,
    _check_int,
    _config,
    _flow_label,
    _flow_options_label,
    _phase,
    _split_clips,
    _table,
    command_line,
    repeat_seed,
)
from .papers import PAPER_NUMBERS
from .table import RECONSTRUCTION_METRICS, EvaluationTable

GROUND_TRUTH = "Ground truth"  # the row of the real motion's own joint jerk (with ``jerk``)
TIMING_BATCH = 32  # Table E times one batch of 32 token sequences
OFFICIAL_WINDOW = 196  # the released evaluations zero-pad every clip to 196 frames before tokenising it
BOOK_DECODERS = ("vq", "rvq", "discord", "feed-forward")
RELEASED_TOKENIZERS = ("momask", "t2mgpt", "auto")  # spec kinds of motionlab.pretrained.parse_model_spec


def _paper_row(decoder: str) -> dict[str, Estimate]:
    # the paper prints sJPE on the ratio variant's [0, 1] scale: its numbers go in that column
    keys = {"fid": "fid", "mpjpe_mm": "mpjpe", "sjpe_ratio": "sjpe"}
    return {metric: Estimate(PAPER_NUMBERS[f"discord/{key}_{decoder}"][0]) for metric, key in keys.items()}


# DisCoRD Table 1 as printed (HumanML3D, MoMask's tokens): rows to set beside an evaluation's (``table.with_rows``).
PAPER_TABLE_1 = {"paper, HumanML3D: MoMask": _paper_row("ff"), "paper, HumanML3D: MoMask + DisCoRD": _paper_row("rf")}


@dataclass(frozen=True)
class ReconstructionConfig:
    """DisCoRD Table 1. ``decoder``: ``"vq"``/``"rvq"`` (that tokenizer's feed-forward decoder alone), ``"discord"``
    (the feed-forward row and the DisCoRD row, both on ``tokenizer``'s ids; default ``"rvq"`` as MoMask + DisCoRD,
    ``"vq"`` gives T2M-GPT + DisCoRD), ``"feed-forward"`` (``tokenizer``'s own decoder alone) or
    ``"discord:FOLDER"`` (a released DisCoRD decoder: the feed-forward row of its tokenizer and its DisCoRD row).
    ``tokenizer``: the book's ``"vq"``/``"rvq"``, or a released checkpoint, ``"momask:FOLDER"`` /
    ``"t2mgpt:PATH[,META]"`` (:func:`motionlab.pretrained.parse_model_spec`; None with a released decoder: the one
    its YAML names). ``repeats`` applies to the DisCoRD row only. ``prediction``/``normalization``/
    ``time_distribution`` choose (and train on first use) a book decoder other than the profile's;
    ``temperature``/``spacing``/``final_prediction`` change only how it samples.

    ``xpred``: the DisCoRD row is the laptop's x-predicting variant of the book's decoder (``discord/rvq-xpred``: it
    predicts the clean motion and decodes from zero start noise, :mod:`motionlab.sizes` ``DISCORD_XPRED``), a lever
    chapter 05 shows beside the paper's decoder; the flow options above still apply on top of it.

    ``training_seed``: 0, the book's tokenizer and DisCoRD decoder; ``k``, the replicate of that chain trained with
    seed ``k`` (``tokenizer/<kind>-seed<k>`` and ``discord/<kind>-seed<k>``, :mod:`motionlab.models`), as the
    training-seed study (``experiments/training_seeds.py``) evaluates them.

    ``evaluator``: None (the book's, trained on ``dataset``) or ``"official:FOLDER"``, the released T2M evaluator
    (:func:`motionlab.metrics.load_official_evaluator`; ``glove`` its GloVe folder, default FOLDER). ``window``:
    zero-pad every clip to this many frames before it is tokenised, as the released evaluation scripts do (None:
    196, the official window, with released models; each clip at its own length with the book's).

    Beyond Table 1 (each adds columns or rows, and the CLI prints them):

    - ``grid``: DisCoRD Table E, one more DisCoRD row per ``(solver, intervals)`` (a ``"euler:1,midpoint:15"`` text
      is read too), each decoded from the first ``grid_repeats`` seeds of the DisCoRD row (default ``repeats``);
    - ``timing_repeats``: a time column (mean over that many timed decodes of one batch of the 32 longest clips,
      after one untimed) and the GFLOPs of one such decode, for every decoder row;
    - ``jerk``: the mean joint jerk (m/s³) of the sJPE joints as a column, and a ground-truth row with the real
      motion's own;
    - ``token_phases``: Noise sJPE split by where each jerk stencil sits in the token grid, one column per phase
      (phase 0 centred on a token boundary; they sum to Noise sJPE), and phase 0's share of the total.
    """

    decoder: str = "discord"
    tokenizer: str | None = None
    steps: int | None = None  # ODE intervals (None: the decoder's config)
    solver: str | None = None  # "euler" | "midpoint" (None: the decoder's config)
    prediction: str | None = None  # "v" | "x"
    normalization: str | None = None  # "std" | "feat_bias"
    time_distribution: str | None = None  # "uniform" | "logit_normal"
    temperature: float | None = None  # start-noise scale
    spacing: str | None = None  # "uniform" | "data_dense"
    final_prediction: bool | None = None  # x-prediction: return x̂1 at the last step
    training_seed: int = 0  # the book's tokenizer and decoder (0) or a replicate of that chain
    xpred: bool = False  # the DisCoRD row decodes with the laptop's x-predicting variant (discord/rvq-xpred)
    split: str = "test"
    limit: int | None = None  # the first `limit` clips of the split
    repeats: int = 1
    seed: int = 0
    grid: tuple[tuple[str, int], ...] = ()  # Table E rows: (solver, intervals), e.g. ("midpoint", 15)
    grid_repeats: int | None = None  # sampling seeds of each grid row (None: repeats)
    timing_repeats: int = 0  # timed decodes per decoder row (0: no time column)
    jerk: bool = False
    token_phases: bool = False
    evaluator: str | None = None  # None: the book's; "official:FOLDER": the released T2M evaluator
    glove: str | None = None  # the official evaluator's GloVe folder (default: its FOLDER)
    window: int | None = None  # zero-pad clips to this many frames before tokenising (None: 196 for released models)

    def __post_init__(self):
        object.__setattr__(self, "grid", _parse_grid(self.grid))
        self._check_models()
        _check_flow_options(self, self.uses_flow)
        if self.released_decoder:
            chosen = [name for name in FLOW_TRAINING_OPTIONS if getattr(self, name) is not None]
            if chosen:
                raise ValueError(
                    f"{', '.join(chosen)} choose which book decoder to train; a released decoder is what it was "
                    "trained as"
                )
        _check_common(self, 2, " (FID needs two clips)")
        if self.grid and not self.uses_flow:
            raise ValueError("grid adds DisCoRD rows; it needs decoder='discord' (or a released 'discord:FOLDER')")
        if self.grid_repeats is not None:
            _check_int("grid_repeats", self.grid_repeats, 1)
            if not self.grid:
                raise ValueError("grid_repeats sets the seeds of the grid rows; it needs a grid")
        _check_int("timing_repeats", self.timing_repeats, 0)
        for name in ("jerk", "token_phases"):
            if not isinstance(getattr(self, name), bool):
                raise ValueError(f"{name} must be True or False, got {getattr(self, name)!r}")
        if self.window is not None:
            _check_int("window", self.window, 4)
            if self.window % 4:
                raise ValueError(f"window must be a multiple of 4 frames (one token), got {self.window}")

    def _check_models(self) -> None:
        """Which tokenizer, decoder and evaluator: the book's (by kind) or released ones (by spec), sensibly paired."""
        released_tokens = self.released_tokenizer
        if self.decoder not in BOOK_DECODERS and not self.released_decoder:
            raise ValueError(f"decoder must be one of {BOOK_DECODERS} or 'discord:FOLDER', got {self.decoder!r}")
        if released_tokens and self.tokenizer.partition(":")[0] not in RELEASED_TOKENIZERS:
            kinds = ", ".join(f"'{k}:PATH'" for k in RELEASED_TOKENIZERS)
            raise ValueError(f"a released tokenizer is one of {kinds}, got {self.tokenizer!r}")
        if not released_tokens and self.tokenizer not in (None, "vq", "rvq"):
            raise ValueError(
                f"tokenizer must be 'vq', 'rvq' or a released checkpoint 'momask:FOLDER', got {self.tokenizer!r}"
            )
        if self.tokenizer is not None and self.decoder in ("vq", "rvq"):
            raise ValueError(
                f"decoder={self.decoder!r} is that tokenizer's own decoder; give tokenizer= with decoder='discord', "
                "'feed-forward' or 'discord:FOLDER'"
            )
        if released_tokens and self.decoder == "discord":
            raise ValueError(
                "decoder='discord' is the book's decoder, trained on the book's tokens; decode a released tokenizer's "
                "tokens with a released decoder ('discord:FOLDER') or its own ('feed-forward')"
            )
        if self.released_decoder and self.tokenizer in ("vq", "rvq"):
            raise ValueError(
                "a released DisCoRD decoder reads the codes of the tokenizer it was trained on: give "
                "tokenizer='momask:FOLDER' or None (the one its config_model.yaml names)"
            )
        if self.released_decoder and released_tokens and "," in self.decoder:
            raise ValueError("name the tokenizer once: tokenizer= or the ',TOKENIZER' part of 'discord:FOLDER,...'")
        _check_int("training_seed", self.training_seed, 0)
        if not isinstance(self.xpred, bool):
            raise ValueError(f"xpred must be True or False, got {self.xpred!r}")
        if self.xpred and (self.decoder != "discord" or self.tokenizer_kind != "rvq" or self.training_seed):
            raise ValueError(
                "xpred is the book's x-predicting variant of the RVQ tokens' decoder (discord/rvq-xpred): it needs "
                "decoder='discord', the book's rvq tokenizer and training_seed=0"
            )
        if self.training_seed and self.released:
            raise ValueError("training_seed picks a replicate of the book's models; released checkpoints have one")
        if self.evaluator is not None and not (self.evaluator.startswith("official:") and self.evaluator[9:]):
            raise ValueError(f"evaluator must be None (the book's) or 'official:FOLDER', got {self.evaluator!r}")
        if self.glove is not None and self.evaluator is None:
            raise ValueError("glove is the official evaluator's vocabulary; it needs evaluator='official:FOLDER'")

    @property
    def released_tokenizer(self) -> bool:
        return isinstance(self.tokenizer, str) and ":" in self.tokenizer

    @property
    def released_decoder(self) -> bool:
        return isinstance(self.decoder, str) and self.decoder.startswith("discord:")

    @property
    def released(self) -> bool:
        """Whether the tokens come from a released checkpoint (then no book tokenizer or decoder is loaded)."""
        return self.released_tokenizer or self.released_decoder

    @property
    def uses_flow(self) -> bool:
        return self.decoder == "discord" or self.released_decoder

    def book_models(self) -> list[str]:
        """The book's models (:func:`motionlab.models.load` names) this evaluation loads, or trains on first use."""
        chain = self.tokenizer_kind + (f"-seed{self.training_seed}" if self.training_seed else "")
        names = [] if self.released else [f"tokenizer/{chain}"]
        names += ["evaluator"] if self.evaluator is None else []
        return names + ([f"discord/{chain}" + "-xpred" * self.xpred] if self.decoder == "discord" else [])

    @classmethod
    def from_sizes(cls, sizes: Any, **options: Any) -> ReconstructionConfig:
        """Chapter 05's evaluation from its sizes (``settings.sizes.discord``, :mod:`motionlab.sizes`): Table 1 on
        ``test_clips`` clips with ``seeds`` sampling seeds, Table E's Euler and midpoint rows with ``grid_seeds``
        seeds, timed ``timing_repeats`` times, with the joint jerk and Noise sJPE by token phase; ``options``
        override fields (e.g. ``seed``)."""
        from motionlab.sizes import DiscordSizes

        if not isinstance(sizes, DiscordSizes):
            raise ValueError(f"sizes must be DiscordSizes (settings.sizes.discord), got {type(sizes).__name__}")
        unknown = sorted(set(options) - {f.name for f in fields(cls)})
        if unknown:
            raise ValueError(f"unknown ReconstructionConfig option(s): {', '.join(unknown)}")
        grid = [("euler", s) for s in sizes.euler_steps] + [("midpoint", s) for s in sizes.midpoint_steps]
        chosen = dict(
            limit=sizes.test_clips,
            repeats=sizes.seeds,
            grid=tuple(grid),
            grid_repeats=sizes.grid_seeds if grid else None,
            timing_repeats=sizes.timing_repeats,
            jerk=True,
            token_phases=True,
        )
        return cls(**{**chosen, **options})

    def grid_row(self, solver: str, steps: int) -> str:
        """The row name of the grid's ``(solver, steps)`` decode: ``"DisCoRD, 15 midpoint steps (30 evaluations)"``."""
        from motionlab.flow import n_evaluations

        if (solver, steps) not in self.grid:
            raise KeyError(f"({solver!r}, {steps}) is not in this config's grid {list(self.grid)}")
        nfe = n_evaluations(steps, solver)
        return f"DisCoRD, {steps} {solver} step{'s' * (steps != 1)} ({nfe} evaluation{'s' * (nfe != 1)})"

    def command_line(self, profile: str | None = None) -> str:
        """The ``motionlab evaluate reconstruction`` command that computes this table (see :func:`command_line`)."""
        return command_line(self, "reconstruction", profile)

    @property
    def tokenizer_kind(self) -> str:
        """The book tokenizer's kind, ``"vq"`` or ``"rvq"`` ("released" for a released checkpoint)."""
        if self.released:
            return "released"
        return self.decoder if self.decoder in ("vq", "rvq") else (self.tokenizer or "rvq")


def _parse_grid(grid: Any) -> tuple[tuple[str, int], ...]:
    """``"euler:1,midpoint:15"``, ``["euler:1"]`` or ``[("euler", 1)]`` -> ``(("euler", 1), ...)``, checked."""
    from motionlab.flow import SOLVERS

    if grid is None:
        return ()
    items = [part.strip() for part in grid.split(",") if part.strip()] if isinstance(grid, str) else list(grid)
    out = []
    for item in items:
        if isinstance(item, str):
            solver, _, steps = item.partition(":")
            try:
                item = (solver.strip(), int(steps))
            except ValueError as err:
                raise ValueError(f"grid entries look like 'midpoint:15', got {item!r}") from err
        if not isinstance(item, (tuple, list)) or len(item) != 2:
            raise ValueError(f"grid entries are (solver, steps) pairs or 'solver:steps' texts, got {item!r}")
        solver, steps = item
        if solver not in SOLVERS:
            raise ValueError(f"grid solver must be one of {SOLVERS}, got {solver!r}")
        _check_int("grid steps", steps, 1)
        out.append((str(solver), int(steps)))
    if len(set(out)) != len(out):
        raise ValueError(f"grid entries must be distinct, got {out}")
    return tuple(out)


# ----------------------------------------------------------------------------------------------- the tasks

# A tokenizer trained on other motion may keep a clip's poses and lose where it goes: a walk decoded on the spot. Say so
# where a clip that travels at least TRAVEL_METRES keeps under TRAVEL_KEPT of it, in at least TRAVEL_SHARE of the clips
# that travel (a newcomer's CMU take went 3.27 m -> 0.12 m through the laptop tokenizer, and every pose score looked
# fine; the book's own test split loses it in 1 of its 35 travelling clips, which is no pattern to warn about).
TRAVEL_METRES = 0.5
TRAVEL_KEPT = 0.5
TRAVEL_SHARE = 0.25


def lost_travel(truth: Any, decoded: Any, what: str = "the tokenizer's decoder") -> tuple[list[int], str | None]:
    """The clips whose reconstruction loses most of their travel on the ground, and a note when they form a pattern.

    ``truth`` and ``decoded`` are :class:`~motionlab.metrics.ClipJoints` of the same clips. A clip loses its travel
    where the truth travels at least :data:`TRAVEL_METRES` and the reconstruction ends less than :data:`TRAVEL_KEPT`
    of that from its start: the tokens (or the decoder) did not carry the root's motion, which pose metrics do not
    show. The note (else ``None``) comes when at least :data:`TRAVEL_SHARE` of the travelling clips do (a single
    clip: when it does); :func:`evaluate_reconstruction` prints it under its table.
    """
    true_travel, kept = truth.root_travel(), decoded.root_travel()
    travelling = true_travel >= TRAVEL_METRES
    lost = np.flatnonzero(travelling & (kept < TRAVEL_KEPT * true_travel))
    note = None
    if len(lost) and len(lost) >= TRAVEL_SHARE * travelling.sum():
        worst = int(lost[np.argmin(kept[lost] / true_travel[lost])])
        note = (
            f"Travel lost: {len(lost)} of {len(truth)} clips lose most of their travel through {what} (clip {worst}: "
            f"{true_travel[worst]:.2f} m -> {kept[worst]:.2f} m from start to end): the tokens do not carry the root's "
            "motion there, and pose scores (MPJPE, sJPE) do not show it."
        )
    return [int(i) for i in lost], note


def evaluate_reconstruction(
    dataset,
    config: ReconstructionConfig | None = None,
    profile: str | None = None,
    *,
    device: str | None = None,
    progress: bool = False,
) -> EvaluationTable:
    """DisCoRD Table 1 on ``config.split``: ground truth → tokens → decoded, scored against the ground truth.

    The ground truth is each clip cropped to whole tokens (raw features); FID compares evaluator embeddings
    of the reconstructions with those of the ground truth. The feed-forward row is one run (deterministic);
    the DisCoRD row repeats ``config.repeats`` times, repeat r decoding from seed ``repeat_seed(seed, r)``, except
    at sampling temperature 0, where every seed decodes the same motion and one run is the whole distribution.
    The rows are, in order: the feed-forward decoder, DisCoRD, then (with the options of :class:`ReconstructionConfig`)
    the grid rows and the ground truth. :attr:`EvaluationTable.samples` holds every row's values run by run.
    """
    from motionlab.flow.reconstruction import decode_clips, reconstruction_scores
    from motionlab.metrics import ClipJoints

    cfg = _config(config, ReconstructionConfig)
    profile = get_profile(profile)
    clips = _split_clips(dataset, cfg.split, cfg.limit, 2, "FID")
    models = _load_models(cfg, dataset, profile, device, progress, len(clips))
    tokenizer, normalizer = models.tokenizer, models.normalizer
    q = int(tokenizer.downsample)
    window = cfg.window if cfg.window is not None else (OFFICIAL_WINDOW if cfg.released else None)
    features = [c.features if window is None else c.features[:window] for c in clips]  # the official loader's crop
    normalized = [normalizer.normalize(f) for f in features]  # (T_i, D) each, what the tokenizer reads
    gt = [f[: len(f) // q * q] for f in features]  # raw, whole tokens
    evaluator = models.evaluator
    gt_embeddings = evaluator.embed_motions(gt)  # (N, d), shared by every row's FID
    gt_joints = ClipJoints.from_features(gt)  # recovered once, shared by every row's MPJPE and sJPE
    phases = _phase_metrics(q) if cfg.token_phases else ()

    def score(recon: list[np.ndarray], space=normalizer) -> tuple[dict[str, float], dict[str, np.ndarray]]:
        """One run's columns, and each clip's value of the metrics averaged over clips (or frames)."""
        raw = [space.denormalize(r) for r in recon]
        joints = ClipJoints.from_features(raw)
        scored = reconstruction_scores(raw, gt, evaluator.embed_motions, gt_embeddings, gt_joints, joints)
        scores = scored.as_dict()
        if phases:
            scores.update(_token_phases(joints, gt_joints, q))
        return scores, scored.per_clip

    _announce(_cost_line(models, normalized, window, cfg), progress)
    feed_forward = f"{models.tokens} decoder"
    _phase(f"scoring the {feed_forward}")
    feed_forward_recon = decode_clips(normalized, tokenizer, pad_to=window)
    _, travel_note = lost_travel(
        gt_joints, ClipJoints.from_features([normalizer.denormalize(r) for r in feed_forward_recon])
    )
    runs = {feed_forward: [score(feed_forward_recon)]}
    deterministic = [feed_forward]
    notes = ["The feed-forward decoder is deterministic: one run, no interval."]
    if travel_note:
        notes.append(travel_note)
    if window is not None:
        notes.append(f"Every clip was tokenised zero-padded to {window} frames, as the released evaluation does.")
    timers: dict[str, Callable[[], Any]] = {}
    batch = _timing_batch(normalized, tokenizer) if cfg.timing_repeats else None
    if batch is not None:
        timers[feed_forward] = lambda: tokenizer.decode(batch)
    if models.flow is not None:
        flow = models.flow
        seeded = not flow.deterministic  # at temperature 0 every seed decodes the same motion
        decoded: dict[tuple[int, str], list[tuple]] = {}  # (steps, solver) -> scored runs, repeat by repeat

        def flow_runs(steps: int, solver: str, repeats: int, what: str) -> list[tuple]:
            # repeat r always decodes from repeat_seed(seed, r): a grid row at the DisCoRD row's steps reuses its runs
            done = decoded.setdefault((steps, solver), [])
            todo = range(len(done), repeats if seeded else 1)
            with _bar(len(todo), f"DisCoRD {what}", progress) as bar:
                for r in todo:
                    _phase(f"DisCoRD {what}: repeat {r + 1} of {repeats if seeded else 1}")
                    seed = repeat_seed(cfg.seed, r)
                    recon = decode_clips(
                        normalized, tokenizer, flow, steps=steps, solver=solver, seed=seed, pad_to=window
                    )
                    done.append(score(recon, models.flow_normalizer))
                    bar.update()
            return done[: repeats if seeded else 1]

        def timer(steps: int, solver: str) -> Callable[[], Any]:
            seed = repeat_seed(cfg.seed, 0)
            return lambda: flow.decode(batch, tokenizer=tokenizer, steps=steps, solver=solver, seed=seed)

        steps = flow.config.sample_steps if cfg.steps is None else cfg.steps
        solver = flow.config.solver if cfg.solver is None else cfg.solver
        options = "" if cfg.released_decoder else _flow_options_label(flow)  # a released decoder is the paper's
        flow_row = f"{models.tokens} tokens + {models.flow_name} ({_flow_label(flow, cfg.steps, cfg.solver)}{options})"
        runs[flow_row] = flow_runs(steps, solver, cfg.repeats, "repeats")
        if batch is not None:
            timers[flow_row] = timer(steps, solver)
        flow_rows = [flow_row]
        grid_repeats = cfg.repeats if cfg.grid_repeats is None else cfg.grid_repeats
        for grid_solver, grid_steps in cfg.grid:
            row = cfg.grid_row(grid_solver, grid_steps)
            runs[row] = flow_runs(grid_steps, grid_solver, grid_repeats, f"{grid_steps} {grid_solver} steps")
            if batch is not None:
                timers[row] = timer(grid_steps, grid_solver)
            flow_rows.append(row)
        if seeded:
            notes.append(f"DisCoRD: {cfg.repeats} sampling seeds.")
        else:
            notes.append("DisCoRD at temperature 0 decodes every seed to the same motion: one run, no interval.")
            deterministic.extend(flow_rows)
        if cfg.grid:
            seeds = f"the first {grid_repeats} of the DisCoRD row's seeds" if seeded else "one run each"
            notes.append(
                f"Grid rows: the same decoder{options} with other ODE steps, {seeds}; "
                "an evaluation is one network call."
            )
    clip_values = {row: _per_clip_means([clips for _, clips in values]) for row, values in runs.items()}
    runs = {row: [scores for scores, _ in values] for row, values in runs.items()}
    rows = {row: _summarize(values) for row, values in runs.items()}
    samples = {row: {m: [run[m] for run in values] for m in values[0]} for row, values in runs.items()}
    metrics = list(RECONSTRUCTION_METRICS)
    if cfg.jerk:
        metrics.append("joint_jerk")
        own = reconstruction_scores(gt, gt, gt_joints=gt_joints, pred_joints=gt_joints).joint_jerk
        rows[GROUND_TRUTH] = {"joint_jerk": Estimate(own)}
        deterministic.append(GROUND_TRUTH)
        notes.append("Joint jerk: the mean jerk magnitude of the sJPE joints; the ground truth's is its own.")
    if phases:
        metrics.extend(phases + ("noise_sjpe_boundary_share",))
        notes.append(
            f"Noise sJPE by token phase: the part from jerk stencils at phase p of the {q}-frame token grid (phase 0 "
            f"centred on a token boundary; the phases sum to Noise sJPE); a decoder blind to the grid has a share of "
            f"{1 / q:.2f} on the boundaries."
        )
    if batch is not None:
        metrics.extend(("seconds", "gflops"))
        for row, fn in timers.items():
            seconds, flops = _time_and_count(fn, cfg.timing_repeats)
            rows[row].update(seconds=mean_ci(seconds), gflops=Estimate(flops / 1e9))
            samples[row]["seconds"] = [float(x) for x in seconds]
        size, tokens = int(batch.shape[0]), int(batch.shape[1])
        notes.append(
            f"Time: mean over {cfg.timing_repeats} timed decodes (after one untimed) of one batch of {size} × {tokens} "
            f"tokens ({tokens * q} frames), the {size} longest clips cropped to the shortest of them; GFLOPs: matrix "
            "products and convolutions of one such decode."
        )
    table = _table(
        "reconstruction",
        dataset,
        profile,
        cfg,
        {"clips": len(clips)},
        metrics,
        rows,
        device,
        deterministic=tuple(deterministic),
        notes=[" ".join(notes)],
        samples=samples,
        clip_values=clip_values,
        clip_weights={"mpjpe_mm": [float(n) for n in gt_joints.lengths]},  # MPJPE pools frames, not clips
    )
    if cfg.released_decoder and int(tokenizer.feature_dim) == 263:  # the paper's HumanML3D rows, to read beside
        table = table.with_rows(PAPER_TABLE_1, deterministic=tuple(PAPER_TABLE_1))
    return table


# the claims' names of Table 1's metrics (``discord/<name>_rf``, ``discord/<name>_ff``) and their units
CLAIM_METRICS = {
    "fid": "fid",
    "mpjpe": "mpjpe_mm",
    "sjpe": "sjpe",
    "noise_sjpe": "noise_sjpe",
    "static_sjpe": "static_sjpe",
    "joint_jerk": "joint_jerk",
    "noise_sjpe_boundary_share": "noise_sjpe_boundary_share",
}
CLAIM_UNITS = {"mpjpe_mm": "mm", "joint_jerk": "m/s³", "seconds": "s"}


def claim_cells(table, cfg: ReconstructionConfig) -> dict[str, tuple[str, str]]:
    """Which cell of a reconstruction table each of DisCoRD's claim numbers is: ``{key: (row, metric)}``.

    The keys are the ``discord/<key>`` results the claims table judges: Table 1's metrics of the DisCoRD decoder
    (``_rf``) and the feed-forward decoder (``_ff``), and, where ``cfg`` has the paper's 2 and 16 midpoint grid
    points (1 and 15 intervals) in its grid, their FID, sJPE, Noise sJPE and time (``_steps2``, ``_steps16``).
    Cells the table lacks (no ``jerk`` or ``token_phases`` columns, no timing) are left out.
    """
    if not cfg.uses_flow:
        raise ValueError("the claims compare the DisCoRD decoder with the feed-forward one: decoder='discord'")
    ff_row, rf_row = list(table.rows)[:2]  # the feed-forward decoder, then DisCoRD at its own steps
    cells = {
        f"{key}_{who}": (row, m) for key, m in CLAIM_METRICS.items() for who, row in (("rf", rf_row), ("ff", ff_row))
    }
    cells |= {"joint_jerk_gt": (GROUND_TRUTH, "joint_jerk"), "time_ff": (ff_row, "seconds")}
    for n, intervals in ((2, 1), (16, 15)):  # the paper's steps are midpoint grid points: 2 steps = 1 interval
        if ("midpoint", intervals) in cfg.grid:
            row = cfg.grid_row("midpoint", intervals)
            cells |= {f"{key}_steps{n}": (row, key if key != "time" else "seconds") for key in ("fid", "sjpe", "time")}
            cells |= {f"noise_sjpe_steps{n}": (row, "noise_sjpe")}
    return {key: (row, m) for key, (row, m) in cells.items() if m in table.rows.get(row, {})}


# the claims whose two sides are per-clip means over the same test clips: ``discord/<name>`` is their paired difference
CLIP_PAIRED = ("sjpe", "noise_sjpe", "static_sjpe", "mpjpe")


def clip_cells(table, cfg: ReconstructionConfig) -> dict[str, tuple[str, str, str]]:
    """Which paired differences over the test clips back DisCoRD's claims: ``{key: (row_a, row_b, metric)}``.

    ``<metric>_rf_minus_ff`` (DisCoRD − the feed-forward decoder) for sJPE, its two parts and MPJPE, and, with the
    paper's 2 and 16 midpoint grid points in ``cfg.grid``, ``sjpe_steps2_minus_steps16``. Both rows decode the same
    clips, so :meth:`EvaluationTable.paired_clips` gives each the interval of drawing the test set, which a
    deterministic decoder's row lacks; the claims table adds it to the verdict's interval. Cells without per-clip
    values (FID is not a mean over clips) are left out.
    """
    cells = claim_cells(table, cfg)
    out = {}
    for name in CLIP_PAIRED:
        (rf_row, metric), (ff_row, _) = cells.get(f"{name}_rf", (None, None)), cells.get(f"{name}_ff", (None, None))
        if rf_row is not None and ff_row is not None:
            out[f"{name}_rf_minus_ff"] = (rf_row, ff_row, metric)
    if "sjpe_steps2" in cells and "sjpe_steps16" in cells:
        out["sjpe_steps2_minus_steps16"] = (cells["sjpe_steps2"][0], cells["sjpe_steps16"][0], "sjpe")
    return {k: v for k, v in out.items() if all(v[2] in table.clip_values.get(row, {}) for row in v[:2])}


def _announce(text: str, progress: bool) -> None:
    """A line the reader must see before the work starts: a phase line, and on a terminal above the bars."""
    import sys

    from tqdm.auto import tqdm

    _phase(text)
    if progress:
        tqdm.write(text, file=sys.stderr)


def _cost_line(models: _Models, normalized: list[np.ndarray], window: int | None, cfg: ReconstructionConfig) -> str:
    """What the evaluation will cost, counted before it runs (:func:`motionlab.flow.reconstruction.decode_cost` of a
    median clip): each decoder's arithmetic per clip, and the total over the clips and repeats, in CPU time at the
    rate one network call ran at here."""
    from motionlab.flow import n_evaluations
    from motionlab.flow.reconstruction import decode_cost

    q, flow = int(models.tokenizer.downsample), models.flow
    frames = window or sorted(len(c) // q * q for c in normalized)[len(normalized) // 2]  # a median clip
    cost = decode_cost(models.tokenizer, flow, frames, cfg.steps, cfg.solver)
    parts = [f"feed-forward decoder {cost.feed_forward_gflop:.3g} GFLOP per clip"]
    total = cost.total_gflop(len(normalized), 0)
    if flow is not None:
        runs = [(cost.discord_calls, cfg.repeats)]
        grid_repeats = cfg.repeats if cfg.grid_repeats is None else cfg.grid_repeats
        runs += [(n_evaluations(k, s), grid_repeats) for s, k in cfg.grid]
        total += (
            sum(calls * (1 if flow.deterministic else r) for calls, r in runs)
            * cost.discord_call_gflop
            * len(normalized)
        )
        parts.append(
            f"DisCoRD {cost.discord_gflop:.3g} GFLOP per clip ({cost.discord_calls} network calls, "
            f"{cost.discord_gflop / cost.feed_forward_gflop:.0f}x the feed-forward decoder)"
        )
    seconds = total / cost.gflop_per_cpu_second
    if seconds >= 3600:
        spent = f"{seconds / 3600:,.1f} CPU-hours"
    else:
        spent = f"{seconds / 60:.0f} CPU-minutes" if seconds >= 90 else f"{seconds:.0f} CPU-seconds"
    return (
        f"reconstruction cost: {', '.join(parts)}; {len(normalized)} clips of {frames} frames in all: "
        f"{total / 1e3:.3g} TFLOP, about {spent} at the {cost.gflop_per_cpu_second:.0f} GFLOP per CPU-second one "
        "network call ran at here"
    )


@dataclass
class _Models:
    """What a reconstruction decodes with: the tokenizer (and the feature space its inputs live in), the DisCoRD
    decoder if any (and the space its output lives in), the evaluator, and the names of the rows."""

    tokenizer: Any
    normalizer: Any
    evaluator: Any
    tokens: str  # "RVQ-VAE", "MoMask RVQ-VAE (released)", ...
    flow: Any = None
    flow_normalizer: Any = None
    flow_name: str = "DisCoRD"


_RELEASED_NAMES = {"momask_rvq": "MoMask RVQ-VAE (released)", "t2mgpt_vq": "T2M-GPT VQ-VAE (released)"}


def _load_models(cfg: ReconstructionConfig, dataset, profile: str, device, progress: bool, clips: int) -> _Models:
    """The book's models (loaded from the cache, trained on first use) or the released ones the config names."""
    from motionlab.metrics.evaluator_training import load_or_train_evaluator

    evaluator_name = "the official evaluator" if cfg.evaluator else "the evaluator"
    if cfg.released:
        _phase(f"reconstruction: {clips} {cfg.split} clips; loading the released checkpoints and {evaluator_name}")
        models = _released_models(cfg, device)
    else:
        from motionlab.tokenizers import tokenizer_for_dataset

        kind = cfg.tokenizer_kind
        _phase(
            f"reconstruction: {clips} {cfg.split} clips; loading (or training) the {kind} tokenizer, {evaluator_name}"
        )
        seed = cfg.training_seed
        tokenizer = tokenizer_for_dataset(kind, dataset, profile, seed=seed, device=device, progress=progress)
        tokens = "VQ-VAE" if kind == "vq" else "RVQ-VAE"
        models = _Models(tokenizer, dataset.normalizer, None, tokens)
        if cfg.decoder == "discord":
            models.flow, models.flow_normalizer = _book_decoder(cfg, dataset, tokenizer, profile, device, progress)
    dim = int(models.tokenizer.feature_dim)
    if dataset.normalizer.dim != dim:
        raise ValueError(
            f"the tokenizer reads {dim}-d features but the dataset {dataset.key} has {dataset.normalizer.dim}"
        )
    if cfg.evaluator is not None:
        from motionlab.metrics import load_official_evaluator

        root = cfg.evaluator.partition(":")[2]
        official = "t2m" if dim == 263 else "kit"
        models.evaluator = load_official_evaluator(root, cfg.glove or root, official, device=_device(device))
    else:
        models.evaluator = load_or_train_evaluator(dataset, profile, device=device, progress=progress)
    return models


def _book_decoder(cfg: ReconstructionConfig, dataset, tokenizer, profile: str, device, progress: bool):
    """The book's DisCoRD decoder for ``tokenizer``'s tokens, with the config's options, and its output space."""
    from motionlab.flow import discord_config, train_or_load_discord
    from motionlab.models import xpred_config

    chosen = {name: getattr(cfg, name) for name in FLOW_OPTIONS if getattr(cfg, name) is not None}
    training = {k: v for k, v in chosen.items() if k in FLOW_TRAINING_OPTIONS}
    if cfg.xpred:
        flow_config = xpred_config(profile, tokenizer, cfg.training_seed, **training)
    else:
        flow_config = discord_config(profile, tokenizer=tokenizer, seed=cfg.training_seed, **training)
    _phase("loading (or training) the DisCoRD decoder")
    flow = train_or_load_discord(dataset, tokenizer, profile, config=flow_config, device=device, progress=progress)
    sampling = {k: v for k, v in chosen.items() if k in FLOW_SAMPLING_OPTIONS}
    return (flow.with_sampling(**sampling) if sampling else flow), dataset.normalizer


def _released_models(cfg: ReconstructionConfig, device) -> _Models:
    """The released tokenizer (and DisCoRD decoder), each with the normalisation of its folder."""
    from motionlab.pretrained import load_discord_decoder, parse_model_spec

    flow = None
    if cfg.released_decoder and cfg.released_tokenizer:
        tokenizer = parse_model_spec(cfg.tokenizer, device=_device(device))
        flow = load_discord_decoder(cfg.decoder.partition(":")[2], tokenizer=tokenizer, device=_device(device))
    elif cfg.released_decoder:
        flow = parse_model_spec(cfg.decoder, device=_device(device))
        tokenizer = flow.tokenizer
    else:
        tokenizer = parse_model_spec(cfg.tokenizer, device=_device(device))
    tokens = _RELEASED_NAMES.get(tokenizer.provenance.kind, "released tokenizer")
    models = _Models(tokenizer, tokenizer.normalizer, None, tokens)
    if flow is not None:
        sampling = {name: getattr(cfg, name) for name in FLOW_SAMPLING_OPTIONS if getattr(cfg, name) is not None}
        models.flow = flow.with_sampling(**sampling) if sampling else flow
        models.flow_normalizer, models.flow_name = flow.normalizer, "DisCoRD (released)"
    return models


def _device(device) -> Any:
    from motionlab.train.device import get_device

    return get_device(device)


def _phase_metrics(q: int) -> tuple[str, ...]:
    return tuple(f"noise_sjpe_phase{p}" for p in range(q))  # headers: table.metric_label


def _token_phases(joints, gt_joints, q: int) -> dict[str, float]:
    """Noise sJPE by token phase, and phase 0's share of the total (NaN where there is no Noise sJPE at all)."""
    from motionlab.metrics import noise_sjpe_by_phase

    parts = noise_sjpe_by_phase(joints, gt_joints, q)
    total = float(parts.sum())
    share = float(parts[0]) / total if total > 0 else float("nan")
    return {**{f"noise_sjpe_phase{p}": float(x) for p, x in enumerate(parts)}, "noise_sjpe_boundary_share": share}


def _per_clip_means(runs: Sequence[Mapping[str, np.ndarray]]) -> dict[str, list[float]]:
    """Each clip's value per metric, averaged over a row's runs (its sampling seeds): one value per test clip."""
    return {m: np.mean([run[m] for run in runs], axis=0).tolist() for m in runs[0]}


def _summarize(runs: Sequence[Mapping[str, float]]) -> dict[str, Estimate]:
    """One Estimate per metric over the runs; a metric with a non-finite value is NaN ± NaN rather than an error."""
    out = {}
    for metric in runs[0]:
        values = [float(run[metric]) for run in runs]
        finite = all(np.isfinite(values))
        out[metric] = mean_ci(values) if finite else Estimate(float("nan"), float("nan"), len(values))
    return out


def _timing_batch(normalized: list[np.ndarray], tokenizer):
    from motionlab.flow.reconstruction import timing_batch

    return timing_batch(normalized, tokenizer, TIMING_BATCH)


def _time_and_count(fn: Callable[[], Any], repeats: int) -> tuple[np.ndarray, int]:
    """Seconds of ``repeats`` timed calls of ``fn`` (no gradients) and its FLOPs, counted in one untimed call first
    (which also serves as the warm-up: on a slow CPU each decode at 16 steps is seconds of work)."""
    import torch

    from motionlab.flow.reconstruction import count_flops, time_calls

    flops = count_flops(fn)
    with torch.no_grad():
        return time_calls(fn, repeats=repeats, warmup=0), flops
