"""An evaluator for the book's own data: train the T2M text-motion networks on a dataset, then measure with them.

FID, R-precision, MM-Dist and Diversity are only as meaningful as the embedding they are computed in. The
official embedding (``finest.tar``, trained on HumanML3D with GloVe words) does not know the embedded
dataset's motions or captions, so the book trains the *same networks* (:mod:`motionlab.metrics.evaluator`)
on the data at hand, with two documented changes:

* **words**: a :class:`LearnedWordEmbedding` over the :class:`CaptionVocabulary` of the training captions
  replaces the frozen GloVe vectors (the POS one-hots are unchanged);
* **one stage**: the movement encoder trains jointly with the text and motion encoders under the
  contrastive loss. The reference pre-trains it as the encoder of a motion auto-encoder and freezes it; on a
  small procedural dataset one stage is simpler and reaches high R-precision within a CPU budget.

Training pairs a clip with one of its captions, crops the clip to a multiple of 4 frames at a random start
and minimises (Hadsell et al., margin ``m = 10``, a random cyclic shift ``s`` for the negatives)::

    L = mean_i ||t_i - x_i||^2 + mean_i max(0, m - ||t_i - x_{(i+s) mod B}||)^2

**Exact batching.** The movement encoder is two strided convolutions. Run on a zero-padded batch, the last
movement step of a short clip reads a frame of padding through the second convolution, so its embedding
would depend on its batch-mates. :func:`encode_motion_exact` zeroes the padding between the two
convolutions, which makes every embedding identical to encoding the clip alone (tested); the GRU is packed.
"""

from __future__ import annotations

import hashlib
import weakref
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import torch
from torch import nn

from ..profiles import get_profile
from ..representation import Normalizer
from ..sizes import EVALUATOR, resized
from ..train import TrainConfig, Trainer, model_device, train_or_load
from .distribution import diversity, fid
from .evaluator import EvaluatorConfig, TextMotionEvaluator, contrastive_loss
from .retrieval import retrieval_metrics
from .words import CaptionVocabulary, LearnedWordEmbedding

MODEL_NAME = "text_motion_evaluator"


@dataclass(frozen=True)
class EvaluatorTrainingConfig:
    """Network sizes plus how to train them (the reference: Adam lr 1e-4, grad-clip 0.5, margin 10)."""

    evaluator: EvaluatorConfig = field(default_factory=lambda: EvaluatorConfig.official("t2m"))
    steps: int = 40_000
    batch_size: int = 32
    lr: float = 1e-4
    grad_clip: float = 0.5
    margin: float = 10.0
    max_frames: int = 196  # longest crop fed to the motion encoder (HumanML3D's maximum length)
    min_word_count: int = 1  # rarer caption words map to "unk"
    val_every: int = 2000  # steps between validation R-precision rows in the history (0: only at the end)
    seed: int = 0

    def __post_init__(self):
        if self.steps < 1 or self.batch_size < 2 or self.lr <= 0 or self.margin <= 0:
            raise ValueError(f"need steps >= 1, batch_size >= 2, lr > 0 and margin > 0, got {self}")
        if self.max_frames < self.evaluator.unit_length:
            raise ValueError(f"max_frames must be at least unit_length={self.evaluator.unit_length}")


def evaluator_config(profile: str | None = None) -> EvaluatorTrainingConfig:
    """Sizes per profile: ``smoke`` tiny (seconds), ``laptop`` small (minutes on 2 cores), ``full`` official
    (the changes are ``EVALUATOR`` in :mod:`motionlab.sizes`)."""
    return resized(EvaluatorTrainingConfig(), EVALUATOR, profile)


class EvaluatorNetworks(nn.Module):
    """Learned word vectors + the three T2M evaluator networks, as one trainable module."""

    def __init__(self, config: EvaluatorConfig, vocab_size: int, generator: torch.Generator | None = None):
        super().__init__()
        self.config = config
        self.words = LearnedWordEmbedding(vocab_size, config.dim_word, generator)
        self.evaluator = TextMotionEvaluator(config, generator)

    def encode_text(self, ids: torch.Tensor, pos_onehot: torch.Tensor, lengths: torch.Tensor) -> torch.Tensor:
        """Word ids ``(B, L)``, POS one-hots ``(B, L, 15)``, lengths ``(B,)`` -> ``(B, dim_coemb)``, on the
        networks' device."""
        return self.evaluator.encode_text(self.words(ids.to(model_device(self, ids.device))), pos_onehot, lengths)

    def encode_motion(self, motions: torch.Tensor, lengths: torch.Tensor) -> torch.Tensor:
        """Normalised, zero-padded ``(B, T, D)``, lengths (multiples of 4) ``(B,)`` -> ``(B, dim_coemb)``."""
        return encode_motion_exact(self.evaluator, motions, lengths)


def _check_encode_motion_exact_inputs(motions: torch.Tensor, lengths: torch.Tensor, c: EvaluatorConfig) -> torch.Tensor:
    """Reject motions not ``(B, T, dim_pose)`` and lengths not whole units within T; return lengths as int64."""
    if motions.dim() != 3 or motions.shape[-1] != c.dim_pose:
        raise ValueError(f"motions must have shape (B, T, {c.dim_pose}), got {tuple(motions.shape)}")
    lengths = torch.as_tensor(lengths, dtype=torch.int64)
    if lengths.shape != (motions.shape[0],) or (lengths < c.unit_length).any() or (lengths > motions.shape[1]).any():
        raise ValueError(f"lengths must be ({motions.shape[0]},) values in [{c.unit_length}, {motions.shape[1]}]")
    if (lengths % c.unit_length).any():
        raise ValueError(f"lengths must be multiples of unit_length={c.unit_length}, got {lengths.tolist()}")
    return lengths


def encode_motion_exact(evaluator: TextMotionEvaluator, motions: torch.Tensor, lengths: torch.Tensor) -> torch.Tensor:
    """``TextMotionEvaluator.encode_motion`` without padding leaking into any clip's embedding.

    ``motions (B, T, D)`` are normalised; ``lengths (B,)`` must be multiples of ``unit_length`` (4). Frames
    past a length are zeroed, and so are the first convolution's outputs past ``length / 2``: exactly the
    zeros the convolutions' own padding supplies when the clip is encoded alone.
    """
    c = evaluator.config
    lengths = _check_encode_motion_exact_inputs(motions, lengths, c)
    motions = motions.to(next(evaluator.parameters()).device)  # the embeddings live on the evaluator's device
    conv = evaluator.movement_encoder
    steps = torch.arange(motions.shape[1], device=motions.device)
    x = motions[..., :-4].float() * (steps < lengths.to(motions.device)[:, None])[..., None]  # (B, T, D-4)
    h = conv.main[:3](x.transpose(1, 2))  # (B, H, T/2): conv, dropout, LeakyReLU
    half = torch.arange(h.shape[-1], device=h.device) < (lengths.to(h.device) // 2)[:, None]  # (B, T/2)
    h = conv.main[3:](h * half[:, None, :])  # (B, latent, T/4)
    movements = conv.out_net(h.transpose(1, 2))  # (B, T/4, latent)
    return evaluator.motion_encoder(movements, lengths // c.unit_length)


# ---------------------------------------------------------------------------------------------------------
# Inputs: captions and clips as tensors


def caption_tokens(caption) -> list[str]:
    """A :class:`~motionlab.data.Caption` (its ``.tokens``) or a list of ``word/POS`` strings -> tokens."""
    tokens = getattr(caption, "tokens", caption)
    if isinstance(tokens, str) or not all(isinstance(t, str) for t in tokens) or len(tokens) == 0:
        raise ValueError(f"a caption must be a Caption or a non-empty list of 'word/POS' tokens, got {caption!r}")
    return list(tokens)


def _check_features(motions: Sequence, dim: int, unit: int) -> list[np.ndarray]:
    if isinstance(motions, np.ndarray) and motions.ndim == 2:
        raise ValueError("motions must be a list of (T, D) arrays (or an (N, T, D) array), not one (T, D) clip")
    if len(motions) == 0:
        raise ValueError("motions is empty")
    out = []
    for i, m in enumerate(motions):
        a = np.asarray(m.detach().cpu() if isinstance(m, torch.Tensor) else m, dtype=np.float32)
        if a.ndim != 2 or a.shape[1] != dim or a.shape[0] < unit:
            raise ValueError(f"motions[{i}] must have shape (T >= {unit}, {dim}), got {a.shape}")
        if not np.isfinite(a).all():
            raise ValueError(f"motions[{i}] contains NaN or inf values")
        out.append(a)
    return out


def pad_batch(clips: Sequence[np.ndarray]) -> tuple[torch.Tensor, torch.Tensor]:
    """Clips ``(T_i, D)`` -> zero-padded ``(B, max T, D)`` and lengths ``(B,)``."""
    lengths = torch.tensor([len(c) for c in clips], dtype=torch.int64)
    out = torch.zeros(len(clips), int(lengths.max()), clips[0].shape[1])
    for i, c in enumerate(clips):
        out[i, : len(c)] = torch.as_tensor(c)
    return out, lengths


class EvaluatorBatches:
    """Training batches: ``B`` distinct clips, one random caption each, random crops to multiples of 4."""

    def __init__(
        self,
        clips: Sequence[Any],
        normalizer: Normalizer,
        vocabulary: CaptionVocabulary,
        config: EvaluatorTrainingConfig,
    ):
        self.unit, self.max_frames, self.batch_size = config.evaluator.unit_length, config.max_frames, config.batch_size
        self.motions = [normalizer.normalize(c.features).astype(np.float32) for c in clips]
        self.captions = [[caption_tokens(cap) for cap in c.captions] for c in clips]
        self.vocabulary = vocabulary
        if len(self.motions) < config.batch_size:
            raise ValueError(f"need at least batch_size={config.batch_size} training clips, got {len(self.motions)}")

    def __call__(self, step: int, generator: torch.Generator) -> dict[str, torch.Tensor]:
        chosen = torch.randperm(len(self.motions), generator=generator)[: self.batch_size].tolist()
        crops, texts = [], []
        for i in chosen:
            motion = self.motions[i]
            keep = min(len(motion), self.max_frames) // self.unit * self.unit
            start = int(torch.randint(len(motion) - keep + 1, (1,), generator=generator))
            crops.append(motion[start : start + keep])
            caps = self.captions[i]
            texts.append(caps[int(torch.randint(len(caps), (1,), generator=generator))])
        motions, lengths = pad_batch(crops)  # (B, T, D), (B,)
        enc = self.vocabulary.encode(texts)
        return {
            "ids": enc.words,
            "pos": enc.pos_onehot,
            "text_lengths": enc.lengths,
            "motions": motions,
            "motion_lengths": lengths,
        }


# ---------------------------------------------------------------------------------------------------------
# The trained evaluator


@dataclass
class EmbeddedEvaluator:
    """Trained networks + the caption vocabulary + the dataset normaliser: raw inputs in, embeddings out."""

    networks: EvaluatorNetworks
    vocabulary: CaptionVocabulary
    normalizer: Normalizer
    batch_size: int = 64
    history: list[dict[str, float]] = field(default_factory=list)

    @property
    def dim(self) -> int:
        return self.networks.config.dim_coemb

    def _device(self) -> torch.device:
        return next(self.networks.parameters()).device

    @torch.no_grad()
    def embed_motions(self, motions: Sequence) -> np.ndarray:
        """Raw (un-normalised) features, a list of ``(T_i, 263)`` -> ``(N, dim_coemb)`` in the caller's order.

        Each clip is cropped to its first ``floor(T / 4) * 4`` frames and normalised with the dataset's
        mean/std; clips are batched by length (the order does not change any embedding).
        """
        c = self.networks.config
        clips = _check_features(motions, c.dim_pose, c.unit_length)
        crops = [self.normalizer.normalize(a[: len(a) // c.unit_length * c.unit_length]) for a in clips]
        self.networks.eval()
        order = np.argsort([len(a) for a in crops], kind="stable")
        out = np.zeros((len(crops), self.dim), dtype=np.float32)
        for s in range(0, len(crops), self.batch_size):
            idx = order[s : s + self.batch_size]
            x, lengths = pad_batch([crops[i] for i in idx])
            out[idx] = self.networks.encode_motion(x.to(self._device()), lengths).cpu().numpy()
        return out

    @torch.no_grad()
    def embed_texts(self, captions: Sequence) -> np.ndarray:
        """Captions (``Caption`` objects or ``word/POS`` token lists) -> ``(N, dim_coemb)``."""
        if isinstance(captions, str) or len(captions) == 0:
            raise ValueError("captions must be a non-empty list of Caption objects or token lists")
        tokens = [caption_tokens(cap) for cap in captions]
        self.networks.eval()
        dev = self._device()
        out = []
        for s in range(0, len(tokens), self.batch_size):
            enc = self.vocabulary.encode(tokens[s : s + self.batch_size])
            out.append(self.networks.encode_text(enc.words.to(dev), enc.pos_onehot.to(dev), enc.lengths).cpu())
        return torch.cat(out).numpy()

    def evaluate_generation(
        self,
        gt_clips: Sequence,
        generated_features: Sequence,
        captions: Sequence,
        rng: np.random.Generator | int,
        batch_size: int = 32,
        diversity_pairs: int = 300,
    ) -> dict[str, float]:
        """The text-to-motion protocol for one set of generated motions.

        ``gt_clips``: real clips (``MotionClip`` or raw ``(T, D)`` arrays), the reference distribution for FID;
        ``generated_features``: raw ``(T_i, D)`` motions, ``generated_features[i]`` made for ``captions[i]``.
        Returns ``fid`` (generated vs real embeddings), ``top1``/``top2``/``top3`` (R-precision in shuffled
        batches of ``batch_size``), ``mm_dist`` and ``diversity`` (``diversity_pairs`` random pairs) of the
        generated motions. Passing the real clips as ``generated_features`` scores the ground truth.
        """
        if len(generated_features) != len(captions):
            raise ValueError(f"{len(generated_features)} generated motions but {len(captions)} captions")
        real = self.embed_motions([getattr(c, "features", c) for c in gt_clips])
        return protocol_scores(
            real, self.embed_motions(generated_features), self.embed_texts(captions), rng, batch_size, diversity_pairs
        )


def protocol_scores(
    real_emb: np.ndarray,
    generated_emb: np.ndarray,
    text_emb: np.ndarray,
    rng: np.random.Generator | int,
    batch_size: int = 32,
    diversity_pairs: int = 300,
) -> dict[str, float]:
    """FID, R-precision top-1/2/3, MM-Dist and Diversity from embeddings (see ``evaluate_generation``).

    ``text_emb[i]`` describes ``generated_emb[i]``; ``real_emb`` is the reference set for FID. Useful when the
    same motions are scored against many caption draws: embed the motions once.
    """
    rng = np.random.default_rng(rng) if isinstance(rng, (int, np.integer)) else rng
    if not isinstance(rng, np.random.Generator):
        raise ValueError(f"rng must be a numpy Generator or an integer seed, got {type(rng).__name__}")
    scores = retrieval_metrics(text_emb, generated_emb, batch_size=batch_size, top_k=3, rng=rng)
    top = {f"top{k + 1}": float(v) for k, v in enumerate(scores.r_precision)}
    return {
        "fid": fid(real_emb, generated_emb),
        **top,
        "mm_dist": scores.mm_dist,
        "diversity": diversity(generated_emb, rng, n_pairs=diversity_pairs),
    }


def pick_captions(clips: Sequence[Any], rng: np.random.Generator) -> list[Any]:
    """One caption per clip, drawn uniformly (the evaluation loaders draw one caption per clip too)."""
    return [c.captions[int(rng.integers(len(c.captions)))] for c in clips]


# ---------------------------------------------------------------------------------------------------------
# Training and caching


# dataset object -> {min_word_count: vocabulary}: a command's plan probe and its own evaluator share one build
_vocabularies: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def build_vocabulary(dataset, config: EvaluatorTrainingConfig) -> CaptionVocabulary:
    """The vocabulary of the dataset's *training* captions (test words it never saw become ``unk``).

    Built once per dataset object and ``min_word_count`` (reading every caption file takes seconds); a
    dataset object that cannot be weakly referenced (e.g. a list of clips) is read every time."""
    try:
        built = _vocabularies.setdefault(dataset, {})
    except TypeError:
        built = {}
    if config.min_word_count not in built:
        built[config.min_word_count] = _read_vocabulary(dataset, config.min_word_count)
    return built[config.min_word_count]


def _read_vocabulary(dataset, min_count: int) -> CaptionVocabulary:
    if hasattr(dataset, "captions"):  # captions only: the motions are not read
        captions = [cap for caps in dataset.captions("train") for cap in caps]
    else:
        captions = [cap for clip in dataset.split("train") for cap in clip.captions]
    return CaptionVocabulary.build((caption_tokens(cap) for cap in captions), min_count=min_count)


def _validation_fn(dataset, vocabulary: CaptionVocabulary, split: str = "val"):
    """``model -> {"top1", "top3", "mm_dist"}`` on ``split`` (first caption per clip, fixed batches)."""
    clips = dataset.split(split)
    feats, caps = [c.features for c in clips], [c.captions[0] for c in clips]
    batch = min(32, len(clips))

    def val_fn(model: EvaluatorNetworks) -> dict[str, float]:
        ev = EmbeddedEvaluator(model, vocabulary, dataset.normalizer)
        scores = retrieval_metrics(ev.embed_texts(caps), ev.embed_motions(feats), batch_size=batch, top_k=3)
        return {"top1": float(scores.r_precision[0]), "top3": float(scores.r_precision[2]), "mm_dist": scores.mm_dist}

    return val_fn


# The evaluator trains in fp32 whatever the run's precision: it is a metric (every precision's models are scored by
# the same evaluator, so their FIDs compare), and bf16 does not pay here: its GRUs gain nothing under autocast
# (benchmarks/bench_train.py: a bf16 step 0.99x the fp32 one on an AVX512-BF16 CPU).
EVALUATOR_PRECISION = "fp32"


def evaluator_trainer(
    model: EvaluatorNetworks,
    dataset,
    vocabulary: CaptionVocabulary,
    config: EvaluatorTrainingConfig,
    *,
    workdir: Path | None = None,
    device=None,
    progress: bool = False,
    precision: str = EVALUATOR_PRECISION,
) -> Trainer:
    """The :class:`~motionlab.train.Trainer` of the evaluator's networks on ``dataset``'s train split (not run yet:
    :func:`train_evaluator` and the cache fit it; ``benchmarks/bench_train.py`` times its steps)."""

    def loss_fn(model: EvaluatorNetworks, batch: dict, generator: torch.Generator) -> dict[str, torch.Tensor]:
        text = model.encode_text(batch["ids"], batch["pos"], batch["text_lengths"])  # (B, d)
        motion = model.encode_motion(batch["motions"], batch["motion_lengths"])  # (B, d)
        # the negatives' cyclic shift, drawn here so that a CUDA generator works too
        shift = int(torch.randint(1, text.shape[0], (1,), generator=generator, device=generator.device))
        losses = contrastive_loss(text, motion, margin=config.margin, shift=shift)
        return {"loss": losses.total, "positive": losses.positive, "negative": losses.negative}

    batches = EvaluatorBatches(dataset.split("train"), dataset.normalizer, vocabulary, config)
    train = TrainConfig(
        steps=config.steps,
        lr=config.lr,
        betas=(0.9, 0.999),
        schedule="cosine",
        grad_clip=config.grad_clip,
        seed=config.seed,
        log_every=max(1, config.steps // 50),
        val_every=config.val_every,
    )
    return Trainer(
        model,
        loss_fn,
        batches,
        train,
        val_fn=_validation_fn(dataset, vocabulary),
        workdir=workdir,
        device=device,
        desc="evaluator",
        progress=progress,
        precision=precision,
    )


def _train_fn(dataset, vocabulary: CaptionVocabulary, config: EvaluatorTrainingConfig, progress: bool, device=None):
    """``train_fn(model, workdir)`` for :func:`motionlab.train.train_or_load`; the data is read only when called."""

    def train_fn(model: nn.Module, workdir: Path | None) -> dict:
        trainer = evaluator_trainer(
            model, dataset, vocabulary, config, workdir=workdir, device=device, progress=progress
        )
        history = trainer.fit()
        return {"history": history, "final_val": trainer.validate()}

    return train_fn


def _builder(vocabulary: CaptionVocabulary, seed: int):
    def build(config: EvaluatorTrainingConfig) -> EvaluatorNetworks:
        return EvaluatorNetworks(config.evaluator, len(vocabulary), torch.Generator().manual_seed(seed))

    return build


def _check_dataset(dataset) -> None:
    for name in ("split", "normalizer", "key"):
        if not hasattr(dataset, name):
            raise ValueError(f"dataset must be a MotionDataset (split(), normalizer, key); it lacks {name!r}")


def train_evaluator(
    dataset,
    profile: str | None = None,
    config: EvaluatorTrainingConfig | None = None,
    *,
    workdir: str | Path | None = None,
    device: str | None = None,
    progress: bool = False,
) -> EmbeddedEvaluator:
    """Train a fresh evaluator on ``dataset``'s train split (no cache; see :func:`load_or_train_evaluator`)."""
    _check_dataset(dataset)
    config = config or evaluator_config(profile)
    vocabulary = build_vocabulary(dataset, config)
    model = _builder(vocabulary, config.seed)(config)
    result = _train_fn(dataset, vocabulary, config, progress, device)(model, Path(workdir) if workdir else None)
    return EmbeddedEvaluator(model.eval(), vocabulary, dataset.normalizer, history=result["history"])


def cache_extra(dataset, vocabulary: CaptionVocabulary) -> dict[str, str]:
    """What besides the config identifies a trained evaluator: the data and its vocabulary."""
    words = hashlib.sha1("\n".join(vocabulary.words).encode()).hexdigest()[:10]
    return {"data": dataset.key, "vocabulary": f"{len(vocabulary)}-{words}"}


def load_or_train_evaluator(
    dataset,
    profile: str | None = None,
    config: EvaluatorTrainingConfig | None = None,
    *,
    device: str | None = None,
    retrain: bool = False,
    progress: bool = True,
) -> EmbeddedEvaluator:
    """The evaluator for ``dataset`` and ``profile``: trained once (cached under ``models/``), loaded after."""
    from ..train import load_result

    _check_dataset(dataset)
    profile = get_profile(profile)
    config = config or evaluator_config(profile)
    vocabulary = build_vocabulary(dataset, config)
    extra = cache_extra(dataset, vocabulary)
    model = train_or_load(
        MODEL_NAME,
        config,
        _builder(vocabulary, config.seed),
        _train_fn(dataset, vocabulary, config, progress, device),
        profile,
        extra=extra,
        device=device,
        retrain=retrain,
        precision=EVALUATOR_PRECISION,
    )
    history = load_result(MODEL_NAME, config, profile, extra, device, EVALUATOR_PRECISION)["history"]
    return EmbeddedEvaluator(model, vocabulary, dataset.normalizer, history=history)
