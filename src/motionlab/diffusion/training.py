"""Training the text-to-motion denoiser: a text encoder and the denoising transformer, on VQ token sequences.

The motion side is frozen. Every training clip is turned into its token sequence once, by the VQ tokenizer
(:func:`tokenize_clips`); from then on training never touches a 263-dim feature. One step::

    clip b ~ uniform,  caption ~ uniform over the clip's captions
    x_0 = a random crop of at most ``max_tokens`` of its tokens            (B, L), padded, padding_mask (B, L)
    y   = text_encoder(caption)                                              (B, S, text_dim)
    loss = diffusion_loss(denoiser, transitions, x_0, y, ...)      (VB + λ·aux; y → ∅ 10 % of the time)

The text encoder (the book's small :class:`~motionlab.text.WordTextEncoder` by default; M2D2M uses a frozen
CLIP) trains jointly with the denoiser, so both live in one module, :class:`TextToMotionNetworks`, which is
what the train-once cache stores. Optimiser and schedule are M2D2M's (appendix A.1): AdamW, β = (0.9, 0.99),
weight decay 4.5e-2, the learning rate dropped to a tenth at epoch 100 of 110. Profiles that count steps
instead of epochs drop it at the same fraction (100/110) of their steps.
"""

from __future__ import annotations

import math
import os
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, fields, replace

import numpy as np
import torch
from torch import Tensor, nn

from motionlab.diffusion.loss import diffusion_loss
from motionlab.diffusion.schedule import DEFAULT_SCHEDULE, SCHEDULES, get_schedule
from motionlab.diffusion.transformer import DenoisingTransformer, TransformerConfig, transformer_config
from motionlab.diffusion.transitions import DISTANCES, Transitions, build_transitions
from motionlab.profiles import get_profile
from motionlab.sizes import DIFFUSION_TRAINING, WORD_ENCODER, resized
from motionlab.text import Vocabulary, WordTextEncoder
from motionlab.train import TrainConfig, Trainer
from motionlab.train.compiling import compile_for_training, release_compiled, uses_cuda_graphs

PAPER_ETA = 0.5  # M2D2M appendix A.1: η for single-motion generation (0.25 for multi-motion)


@dataclass(frozen=True)
class WordEncoderConfig:
    """Sizes of the trainable word encoder (:class:`~motionlab.text.WordTextEncoder`)."""

    dim: int = 512  # CLIP ViT-B/32's text width, which M2D2M's denoiser reads
    n_layers: int = 4
    n_heads: int = 8
    max_len: int = 64  # words per caption (longer ones are cut)
    min_word_count: int = 1  # rarer caption words map to <unk>


@dataclass(frozen=True)
class DiffusionTrainingConfig:
    """Everything that decides a trained text-to-motion model (the cache key hashes all of it).

    ``transformer`` carries the network, the diffusion process (schedule, η, distance, λ, condition
    dropout, T) and the optimiser settings; the fields here add the text encoder and the data pipeline.
    """

    transformer: TransformerConfig
    text: WordEncoderConfig = field(default_factory=WordEncoderConfig)
    max_tokens: int = 49  # longest training crop (196 frames, HumanML3D's longest clip)
    warmup_steps: int = 1000
    grad_clip: float | None = 1.0
    seed: int = 0
    log_every: int = 100

    def __post_init__(self) -> None:
        t = self.transformer
        if t.text_dim != self.text.dim:
            raise ValueError(f"transformer.text_dim={t.text_dim} must equal the text encoder's dim={self.text.dim}")
        if self.max_tokens < 1:
            raise ValueError(f"max_tokens must be >= 1, got {self.max_tokens}")
        if t.schedule not in SCHEDULES:
            raise ValueError(f"transformer.schedule must be one of {sorted(SCHEDULES)}, got {t.schedule!r}")
        if t.distance not in DISTANCES:
            raise ValueError(f"transformer.distance must be one of {DISTANCES}, got {t.distance!r}")
        if not math.isfinite(t.eta):
            raise ValueError(f"transformer.eta must be finite, got {t.eta}")


def diffusion_training_config(
    profile: str | None = None,
    *,
    num_codes: int,
    eta: float | None = None,
    distance: str = "l2_rank",
    schedule: str | None = None,
    **transformer_overrides,
) -> DiffusionTrainingConfig:
    """The training config of a profile for a codebook of ``num_codes`` codes.

    ``eta`` None is the paper's 0.5; ``eta = 0`` is VQ-Diffusion's uniform β_t (the distance is then
    irrelevant and set to the default, so every η = 0 request shares one cached model). ``schedule`` None is
    the book's :data:`~motionlab.diffusion.DEFAULT_SCHEDULE`. Other keyword arguments override fields of the
    :class:`TransformerConfig`.
    """
    profile = get_profile(profile)
    if isinstance(num_codes, bool) or not isinstance(num_codes, int) or num_codes < 2:
        raise ValueError(f"num_codes must be an int >= 2, got {num_codes!r}")
    eta = PAPER_ETA if eta is None else eta
    if isinstance(eta, bool) or not isinstance(eta, (int, float)) or not math.isfinite(eta):
        raise ValueError(f"eta must be a finite number, got {eta!r}")
    if distance not in DISTANCES:
        raise ValueError(f"distance must be one of {DISTANCES}, got {distance!r}")
    schedule = DEFAULT_SCHEDULE if schedule is None else schedule
    if schedule not in SCHEDULES:
        raise ValueError(f"schedule must be one of {sorted(SCHEDULES)}, got {schedule!r}")
    if float(eta) == 0.0:
        distance = DISTANCES[0]
    text = resized(WordEncoderConfig(), WORD_ENCODER, profile)
    settings = {
        "num_codes": num_codes,
        "text_dim": text.dim,
        "eta": float(eta),
        "distance": distance,
        "schedule": schedule,
        **transformer_overrides,
    }
    config = DiffusionTrainingConfig(transformer_config(profile, **settings), text)
    return resized(config, DIFFUSION_TRAINING, profile)


def budget_config(profile: str | None, *, num_codes: int, dynamic: bool, steps: int) -> DiffusionTrainingConfig:
    """The profile's config of one arm (``dynamic``: the paper's η; else uniform, η = 0) trained for ``steps`` steps,
    its schedule stretched to them (the learning rate still drops at 100/110 of the run): the budget study's models.
    At the profile's own steps it is the profile's model."""
    if isinstance(steps, bool) or not isinstance(steps, int) or steps < 1:
        raise ValueError(f"a training budget needs at least 1 step, got {steps!r}")
    config = diffusion_training_config(profile, num_codes=num_codes, eta=PAPER_ETA if dynamic else 0.0)
    return with_overrides(config, transformer=replace(config.transformer, train_steps=steps))


def with_overrides(config: DiffusionTrainingConfig, **overrides) -> DiffusionTrainingConfig:
    """A copy with top-level fields replaced (``transformer=...``, ``max_tokens=...``); unknown names fail."""
    unknown = sorted(set(overrides) - {f.name for f in fields(config)})
    if unknown:
        raise ValueError(f"unknown DiffusionTrainingConfig field(s): {', '.join(unknown)}")
    return replace(config, **overrides)


# --------------------------------------------------------------------------------------------- the model


class TextToMotionNetworks(nn.Module):
    """The two trainable parts, as one module: ``text_encoder`` (texts → token features) and ``denoiser``."""

    def __init__(self, config: DiffusionTrainingConfig, vocabulary: Vocabulary) -> None:
        super().__init__()
        t = config.text
        self.text_encoder = WordTextEncoder(
            vocabulary, dim=t.dim, n_layers=t.n_layers, n_heads=t.n_heads, max_len=t.max_len, seed=config.seed
        )
        self.denoiser = DenoisingTransformer(config.transformer, seed=config.seed)

    # The word encoder keeps its vocabulary as "extra state" (a dict of strings), which the safetensors
    # checkpoints of motionlab.train cannot hold. The vocabulary is rebuilt from the training captions and
    # its digest is part of the cache key, so the tensors alone are saved and the vocabulary is re-attached.
    def state_dict(self, *args, **kwargs):
        state = super().state_dict(*args, **kwargs)
        for key in [k for k in state if k.endswith("_extra_state")]:
            del state[key]
        return state

    def load_state_dict(self, state_dict, strict: bool = True, assign: bool = False):
        state = dict(state_dict)
        state.setdefault("text_encoder._extra_state", self.text_encoder.get_extra_state())
        return super().load_state_dict(state, strict=strict, assign=assign)


def build_vocabulary(captions: Sequence[Sequence[str]], config: DiffusionTrainingConfig) -> Vocabulary:
    """The word vocabulary of the training captions (one list of caption strings per clip)."""
    texts = (text for caps in captions for text in caps)
    return Vocabulary.build(texts, min_count=config.text.min_word_count)


def make_transitions(config: TransformerConfig, codebook: Tensor | None = None) -> Transitions:
    """Q_t and Q̄_t of a config: uniform when η = 0, else M2D2M's β(t, d) on ``codebook`` (K, D)."""
    schedule = get_schedule(config.schedule, config.timesteps)
    if config.eta == 0.0:
        return build_transitions(schedule, num_codes=config.num_codes)
    if codebook is None:
        raise ValueError(f"eta={config.eta} needs the tokenizer's codebook (K, D) for the code distances")
    if codebook.ndim != 2 or codebook.shape[0] != config.num_codes:
        raise ValueError(f"codebook must be ({config.num_codes}, D), got {tuple(codebook.shape)}")
    return build_transitions(schedule, codebook=codebook, eta=config.eta, distance=config.distance)


# ---------------------------------------------------------------------------------------------- the data


@torch.no_grad()
def tokenize_clips(tokenizer, clips: Sequence[np.ndarray], unit: int = 4, batch_size: int = 64) -> list[Tensor]:
    """Normalised clips ``(T_i, D)`` → token sequences ``(floor(T_i / 4),)`` (long, CPU), in order.

    Each clip is cropped to a multiple of ``unit`` frames; clips of equal length are encoded together (no
    padding, so a clip's tokens never depend on its batch-mates).
    """
    if len(clips) == 0:
        raise ValueError("clips is empty")
    arrays = [np.asarray(c, dtype=np.float32) for c in clips]
    for i, a in enumerate(arrays):
        if a.ndim != 2 or a.shape[0] < unit:
            raise ValueError(f"clips[{i}] must be (T >= {unit}, D), got {a.shape}")
    lengths = [a.shape[0] // unit * unit for a in arrays]
    out: list[Tensor | None] = [None] * len(arrays)
    was_training = tokenizer.training
    tokenizer.eval()
    for n in sorted(set(lengths)):
        idx = [i for i, m in enumerate(lengths) if m == n]
        for s in range(0, len(idx), batch_size):
            chunk = idx[s : s + batch_size]
            x = torch.from_numpy(np.stack([arrays[i][:n] for i in chunk]))  # (b, n, D)
            ids = tokenizer.encode(x).cpu().long()  # (b, n / 4)
            for i, row in zip(chunk, ids, strict=True):
                out[i] = row
    tokenizer.train(was_training)
    return out  # type: ignore[return-value]


class TokenBatches:
    """``batch_fn(step, generator)`` over token sequences with captions.

    A batch is ``{"ids": (B, L) long, "padding_mask": (B, L) bool (True at padding), "caption": (B,) long}``;
    ``caption`` indexes :attr:`texts`, a flat list of every caption (tensors only, so batches shard across
    processes). Clips are drawn uniformly with replacement, a caption uniformly among the clip's, and a crop
    of ``min(len, max_tokens)`` tokens at a uniform start. Padding holds code 0 (never read: it is masked).

    With ``tokenize`` (a text encoder's ``texts -> (ids, padding_mask)``) every caption is tokenized once, here,
    and batches also carry ``"text_ids"`` and ``"text_padding_mask"`` ``(B, S)``, S the longest caption drawn.

    The draws come from the (CPU) data generator; which rows to take is worked out on the host from them, and the
    tokens are gathered in one indexing operation where the tables live (``to(device)`` moves them, once).

    With ``fixed_shapes`` every batch is padded to the same shape, ``L = min(max_tokens, longest sequence)`` and
    ``S`` = the longest caption of all: the same draws and the same rows, more padding. What a network replayed as
    CUDA graphs needs (:mod:`motionlab.train.compiling`); off by default, because the loss's noise is drawn per
    position, so padding changes which numbers a clip's tokens get.
    """

    def __init__(
        self,
        sequences: Sequence[Tensor],
        captions: Sequence[Sequence[str]],
        batch_size: int,
        max_tokens: int,
        tokenize: Callable[[Sequence[str]], tuple[Tensor, Tensor]] | None = None,
        fixed_shapes: bool = False,
    ) -> None:
        if len(sequences) == 0 or len(sequences) != len(captions):
            raise ValueError(f"need as many caption lists as sequences (> 0), got {len(sequences)} and {len(captions)}")
        if any(len(c) == 0 for c in captions):
            raise ValueError("every clip needs at least one caption")
        if any(s.ndim != 1 or s.numel() == 0 for s in sequences):
            raise ValueError("every token sequence must be a non-empty 1-D tensor")
        if batch_size < 1 or max_tokens < 1:
            raise ValueError(f"batch_size and max_tokens must be >= 1, got {batch_size}, {max_tokens}")
        self.sequences = [s.long() for s in sequences]
        self.texts = [t for caps in captions for t in caps]
        counts = torch.tensor([len(c) for c in captions])
        self.first_caption, self.n_captions = torch.cumsum(counts, 0) - counts, counts
        self.batch_size, self.max_tokens, self.fixed_shapes = batch_size, max_tokens, fixed_shapes
        # host-side tables for working out a batch's rows, device-side tables to gather them from
        self._lengths = np.array([s.numel() for s in self.sequences], dtype=np.int64)
        self._row_width = int(self._lengths.max())
        self._tokens = torch.zeros(len(self.sequences), self._row_width, dtype=torch.long)  # (N, longest), 0-padded
        for i, seq in enumerate(self.sequences):
            self._tokens[i, : seq.numel()] = seq
        self._first_caption, self._n_captions = self.first_caption.numpy(), counts.numpy().astype(np.float32)
        self._text_ids: Tensor | None = None
        if tokenize is not None:
            self._text_ids, text_padding = tokenize(self.texts)  # (n_texts, longest caption)
            self._text_lengths = (~text_padding).sum(dim=1).numpy()

    def to(self, device: str | torch.device) -> TokenBatches:
        """Keep the token (and caption) tables on ``device``; returns ``self``."""
        self._tokens = self._tokens.to(device)
        if self._text_ids is not None:
            self._text_ids = self._text_ids.to(device)
        return self

    def __call__(self, step: int, generator: torch.Generator) -> dict[str, Tensor]:
        B = self.batch_size
        clips = torch.randint(len(self.sequences), (B,), generator=generator)
        u = torch.rand(B, 2, generator=generator)  # crop start and caption choice
        # The crop of each row, on the host: the same float32 arithmetic as indexing each clip in turn.
        c, u = clips.numpy(), u.numpy()
        n = self._lengths[c]
        keep = np.minimum(n, self.max_tokens)
        start = (u[:, 0] * (n - keep + 1).astype(np.float32)).astype(np.int64)
        L = min(self.max_tokens, self._row_width) if self.fixed_shapes else int(keep.max())
        offsets = np.arange(L)
        padding = offsets[None, :] >= keep[:, None]  # (B, L)
        flat = np.where(padding, 0, c[:, None] * self._row_width + start[:, None] + offsets[None, :])
        caption = self._first_caption[c] + (u[:, 1] * self._n_captions[c]).astype(np.int64)
        device = self._tokens.device
        padding_mask = _to(padding, device)
        ids = self._tokens.view(-1)[_to(flat, device)].masked_fill(padding_mask, 0)  # (B, L): one gather
        batch = {"ids": ids, "padding_mask": padding_mask, "caption": torch.from_numpy(caption)}
        if self._text_ids is not None:
            S = self._text_ids.shape[1] if self.fixed_shapes else int(self._text_lengths[caption].max())
            text_ids = self._text_ids[_to(caption, device), :S]  # (B, S)
            batch.update(text_ids=text_ids, text_padding_mask=text_ids == 0)
        return batch


def _to(array: np.ndarray, device: torch.device) -> Tensor:
    """A host array as a tensor on ``device`` (an asynchronous copy: the host does not wait for the device)."""
    return torch.from_numpy(array).to(device, non_blocking=True)


# ------------------------------------------------------------------------------------------ the training


def diffusion_loss_fn(transitions: Transitions, texts: Sequence[str], config: DiffusionTrainingConfig):
    """The :class:`~motionlab.train.Trainer` loss: encode the batch's captions, then VB + λ·aux."""
    t = config.transformer

    def loss_fn(model: TextToMotionNetworks, batch: dict[str, Tensor], generator: torch.Generator) -> dict:
        if "text_ids" in batch:  # tokenized once by the batch source
            text = model.text_encoder.encode_tokens(batch["text_ids"], batch["text_padding_mask"])
        else:
            text = model.text_encoder.encode([texts[i] for i in batch["caption"].tolist()])
        # text: tokens (B, S, text_dim), padding_mask (B, S)
        out = diffusion_loss(
            model.denoiser,
            transitions,
            batch["ids"],
            text.tokens,
            text.padding_mask,
            batch["padding_mask"],
            generator=generator,
            aux_weight=t.aux_weight,
            cond_drop_prob=t.cond_drop_prob,
        )
        return {"loss": out.loss, "vb": out.vb, "aux": out.aux}

    return loss_fn


def optimisation(config: DiffusionTrainingConfig, n_clips: int) -> TrainConfig:
    """M2D2M's optimiser and step decay, for a budget of ``train_steps`` or for epochs over ``n_clips``."""
    t = config.transformer
    if t.train_steps is not None:
        steps = t.train_steps
    else:
        steps = t.epochs * max(1, math.ceil(n_clips / t.batch_size))
    decay_at = max(1, round(steps * t.decay_epoch / t.epochs))
    milestones = (decay_at,) if decay_at < steps else ()
    return TrainConfig(
        steps=steps,
        lr=t.lr,
        betas=t.betas,
        weight_decay=t.weight_decay,
        schedule="multistep",
        warmup_steps=min(config.warmup_steps, steps - 1),
        milestones=milestones,
        gamma=t.lr_decayed / t.lr,
        grad_clip=config.grad_clip,
        seed=config.seed,
        log_every=config.log_every,
        ckpt_every=max(0, steps // 4),
    )


def text_to_motion_trainer(
    networks: TextToMotionNetworks,
    sequences: Sequence[Tensor],
    captions: Sequence[Sequence[str]],
    transitions: Transitions,
    config: DiffusionTrainingConfig,
    *,
    workdir: str | os.PathLike | None = None,
    device: str | None = None,
    progress: bool = True,
    precision: str | None = None,
) -> Trainer:
    """The :class:`~motionlab.train.Trainer` of ``networks`` on token ``sequences`` and their ``captions``, with
    ``transitions`` on its device (not run yet: :func:`train_text_to_motion` fits it; ``bench_train.py`` times it)."""
    if transitions.num_codes != config.transformer.num_codes or transitions.T != config.transformer.timesteps:
        raise ValueError(
            f"transitions (K={transitions.num_codes}, T={transitions.T}) do not match the "
            f"config (K={config.transformer.num_codes}, T={config.transformer.timesteps})"
        )
    K = config.transformer.num_codes
    if any(int(s.min()) < 0 or int(s.max()) >= K for s in sequences if s.numel()):
        raise ValueError(f"token sequences must hold code ids in [0, {K})")
    batches = TokenBatches(
        sequences, captions, config.transformer.batch_size, config.max_tokens, tokenize=networks.text_encoder.tokenize
    )
    train = optimisation(config, len(sequences))
    trainer = Trainer(
        networks,
        diffusion_loss_fn(transitions, batches.texts, config),
        batches,
        train,
        workdir=workdir,
        device=device,
        desc="text-to-motion",
        progress=progress,
        precision=precision,
    )
    transitions.to(trainer.device)
    compile_for_training([networks.denoiser], "denoiser", trainer.device)  # the run's --compile setting
    if uses_cuda_graphs("denoiser", trainer.device):  # graphs replay one shape: every batch gets the same
        batches.fixed_shapes = trainer.marks_graph_steps = True
    return trainer


def train_text_to_motion(
    networks: TextToMotionNetworks,
    sequences: Sequence[Tensor],
    captions: Sequence[Sequence[str]],
    transitions: Transitions,
    config: DiffusionTrainingConfig,
    *,
    workdir: str | os.PathLike | None = None,
    device: str | None = None,
    progress: bool = True,
) -> list[dict[str, float]]:
    """Train ``networks`` in place on token ``sequences`` (one per clip) and their ``captions``.

    Returns the logged history (``loss``, ``vb``, ``aux`` averaged over ``log_every`` steps). Resumes from
    ``workdir``'s latest checkpoint when there is one.
    """
    trainer = text_to_motion_trainer(
        networks, sequences, captions, transitions, config, workdir=workdir, device=device, progress=progress
    )
    try:
        history = trainer.fit()
    finally:
        release_compiled(networks)
    networks.eval()
    return history
