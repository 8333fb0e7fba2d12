"""Text in, motion out: the VQ tokenizer, a text encoder, the denoiser and its transitions, composed.

::

    texts ──text_encoder──► y (B, S, d) ─┐
                                         ├─► sample: all-mask x_T → … → x_0 (B, L) ──VQ decoder──► motion
    lengths (frames) ── /4 ──► L tokens ─┘     (denoise_step: Q_t, guidance s, truncation)   (raw features)

:class:`TextToMotion` holds the parts; :func:`text_to_motion_for_dataset` trains them once per dataset and
config (through :func:`motionlab.train.train_or_load`) and loads them afterwards. Two-Phase Sampling drives
``pipe.model``, ``pipe.transitions`` and ``pipe.text_encoder`` itself with
:func:`~motionlab.diffusion.denoise_step`.

The evaluation helpers at the end run the text-to-motion protocol (FID, R-precision, MM-Dist, Diversity
over repeated generations; MultiModality over repeated generations per text) with any evaluator that has
``evaluate_generation``, ``embed_motions`` and ``embed_texts`` (:mod:`motionlab.metrics.evaluator_training`).
"""

from __future__ import annotations

import hashlib
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import torch
from torch import Tensor

from motionlab.diffusion.sampling import sample
from motionlab.diffusion.training import (
    DiffusionTrainingConfig,
    TextToMotionNetworks,
    build_vocabulary,
    diffusion_training_config,
    make_transitions,
    tokenize_clips,
    train_text_to_motion,
    with_overrides,
)
from motionlab.diffusion.transformer import DenoisingTransformer, TransformerConfig
from motionlab.diffusion.transitions import Transitions
from motionlab.metrics.distribution import multimodality
from motionlab.metrics.evaluator_training import pick_captions
from motionlab.profiles import get_profile
from motionlab.representation import Normalizer
from motionlab.text import TextEncoder, TextFeatures, check_texts
from motionlab.train import load_result, train_or_load
from motionlab.train.compiling import uses_cuda_graphs
from motionlab.train.device import get_device

MODEL_NAME = "text_to_motion"
FRAMES_PER_TOKEN = 4


def check_lengths(lengths_in_frames: Sequence[int], n_texts: int, unit: int = FRAMES_PER_TOKEN) -> list[int]:
    """Validate motion lengths in frames: ``n_texts`` positive ints, each a multiple of ``unit``."""
    if isinstance(lengths_in_frames, (str, bytes)) or not hasattr(lengths_in_frames, "__len__"):
        raise ValueError(f"lengths_in_frames must be a list of ints, got {type(lengths_in_frames).__name__}")
    lengths = list(lengths_in_frames.tolist() if hasattr(lengths_in_frames, "tolist") else lengths_in_frames)
    if len(lengths) != n_texts:
        raise ValueError(f"lengths_in_frames has {len(lengths)} entries but there are {n_texts} texts")
    for i, n in enumerate(lengths):
        if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < unit or n % unit:
            raise ValueError(f"lengths_in_frames[{i}] = {n!r}: lengths must be positive multiples of {unit} frames")
    return [int(n) for n in lengths]


@dataclass
class TextToMotion:
    """A trained text-to-motion generator (M2D2M's single-motion model, small)."""

    tokenizer: Any  # VQVAE: encode / embed / decode / codebook()
    text_encoder: TextEncoder
    model: DenoisingTransformer
    transitions: Transitions
    normalizer: Normalizer
    config: TransformerConfig
    history: list[dict[str, float]] = field(default_factory=list, repr=False)  # training log, when known

    @property
    def device(self) -> torch.device:
        return next(self.model.parameters()).device

    @torch.no_grad()
    def encode_texts(self, texts: Sequence[str]) -> TextFeatures:
        """Texts → token features ``(B, S, text_dim)``, padding mask ``(B, S)`` and sentence features, on the model's
        device."""
        texts = check_texts(texts)
        self.text_encoder.eval()
        feats = self.text_encoder.encode(texts)
        dev = self.device
        return TextFeatures(feats.tokens.to(dev), feats.padding_mask.to(dev), feats.sentence.to(dev))

    @torch.no_grad()
    def sample_tokens(
        self,
        texts: Sequence[str],
        lengths_in_frames: Sequence[int],
        *,
        generator: torch.Generator,
        guidance_scale: float | None = None,
        guidance_on: str = "x0",
        num_steps: int | None = None,
        top_p: float | None = None,
        top_k: int | None = None,
        batch_size: int = 32,
    ) -> torch.LongTensor:
        """Token ids ``(B, max L)`` for each text, ``L = frames / 4``, padded with −1 (on CPU).

        ``guidance_scale`` None uses the config's s (4 for single motions); ``guidance_on`` says where it acts:
        ``"x0"`` on p_θ(x_0 | x_t) (VQ-Diffusion's code) or ``"posterior"`` on p_θ(x_{t-1} | x_t) (Eq. 9 as
        printed). ``num_steps`` None runs all T steps (ancestral), fewer skip steps with exact posterior jumps;
        ``top_p`` / ``top_k`` truncate p_θ(x_0 | x_t) at every step. Texts are sampled ``batch_size`` at a
        time, grouped by length (shortest first) so that a batch is padded little, all from the one ``generator``:
        in one batch of HumanML3D-like lengths (40–196 frames) about 40% of the positions are padding, and
        while the sampler keeps the network off them, each step's posterior and draw still cover them (one batch
        of 128 in request order made chapters 07 and 08 a third slower than sorted batches of 32).
        """
        texts = check_texts(texts)
        lengths = check_lengths(lengths_in_frames, len(texts))
        if not isinstance(generator, torch.Generator):
            raise ValueError("generator must be a seeded torch.Generator")
        if isinstance(batch_size, bool) or not isinstance(batch_size, int) or batch_size < 1:
            raise ValueError(f"batch_size must be a positive int, got {batch_size!r}")
        scale = self.config.guidance_scale if guidance_scale is None else float(guidance_scale)
        self.model.eval()
        tokens = [n // FRAMES_PER_TOKEN for n in lengths]
        out = torch.full((len(texts), max(tokens)), -1, dtype=torch.long)
        order = sorted(range(len(texts)), key=lambda i: tokens[i])  # stable: equal lengths keep their order
        for s in range(0, len(texts), batch_size):
            rows = order[s : s + batch_size]
            feats = self.encode_texts([texts[i] for i in rows])
            chunk = [tokens[i] for i in rows]
            ids = sample(
                self.model,
                self.transitions,
                feats.tokens,
                feats.padding_mask,
                lengths=chunk,
                generator=generator,
                num_steps=num_steps,
                guidance_scale=scale,
                guidance_on=guidance_on,
                top_p=top_p,
                top_k=top_k,
            )
            out[rows, : ids.shape[1]] = ids.cpu()
        return out

    @torch.no_grad()
    def decode(
        self, ids: Tensor, decoder: Any = None, *, generator: torch.Generator | None = None, steps: int | None = None
    ) -> list[np.ndarray]:
        """Ids ``(B, L)`` padded with −1 → one raw (denormalised) ``(4·n_b, 263)`` array per row.

        ``decoder`` None uses the tokenizer's feed-forward decoder; otherwise an object with
        ``.decode(ids, tokenizer=..., steps=..., generator=...)`` returning normalised motion (the DisCoRD
        flow decoder). Each row is decoded alone, so padding never leaks into a motion.
        """
        if not isinstance(ids, Tensor) or ids.ndim != 2 or ids.dtype.is_floating_point or ids.shape[0] == 0:
            raise ValueError(f"ids must be a (B, L) integer tensor with B >= 1, got {_shape(ids)}")
        K = self.tokenizer.codebook_size
        motions = []
        for b, row in enumerate(ids.long()):
            n = int((row >= 0).sum())
            if n == 0 or bool((row[:n] < 0).any()) or bool((row[n:] >= 0).any()) or int(row.max()) >= K:
                raise ValueError(f"ids[{b}] must be codes in [0, {K}) followed only by -1 padding")
            codes = row[:n][None]  # (1, n)
            if decoder is None:
                x = self.tokenizer.decode(codes)  # (1, 4n, D) normalised
            else:
                x = decoder.decode(codes, tokenizer=self.tokenizer, steps=steps, generator=generator)
            motions.append(self.normalizer.denormalize(x[0].detach().cpu().float().numpy()))
        return motions

    def reconstruct(self, clips: Sequence[np.ndarray]) -> list[np.ndarray]:
        """Raw clips ``(T_i, 263)`` → tokenizer → decoder → raw ``(floor(T_i / 4)·4, 263)``: the VQ-VAE's
        reconstruction, the best any token generator with this tokenizer can do."""
        feats = [np.asarray(getattr(c, "features", c), dtype=np.float32) for c in clips]
        sequences = tokenize_clips(self.tokenizer, [self.normalizer.normalize(f) for f in feats])
        ids = torch.full((len(sequences), max(len(s) for s in sequences)), -1, dtype=torch.long)
        for b, seq in enumerate(sequences):
            ids[b, : len(seq)] = seq
        return self.decode(ids)

    def generate(
        self,
        texts: Sequence[str],
        lengths_in_frames: Sequence[int],
        *,
        seed: int = 0,
        decoder: Any = None,
        **sampling,
    ) -> list[np.ndarray]:
        """Raw motions ``(lengths_in_frames[i], 263)`` for ``texts``; the same seed gives the same motions.

        ``sampling``: ``guidance_scale``, ``guidance_on``, ``num_steps``, ``top_p``, ``top_k``, ``batch_size``
        (see :meth:`sample_tokens`) and ``steps`` for a flow ``decoder``.
        """
        return self.generate_with_tokens(texts, lengths_in_frames, seed=seed, decoder=decoder, **sampling)[0]

    def generate_with_tokens(
        self,
        texts: Sequence[str],
        lengths_in_frames: Sequence[int],
        *,
        seed: int = 0,
        decoder: Any = None,
        **sampling,
    ) -> tuple[list[np.ndarray], torch.LongTensor]:
        """:meth:`generate`, also returning the sampled token ids ``(B, max L)`` (−1 padding) it decoded."""
        if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
            raise ValueError(f"seed must be a non-negative int, got {seed!r}")
        steps = sampling.pop("steps", None)
        generator = torch.Generator().manual_seed(int(seed))
        ids = self.sample_tokens(texts, lengths_in_frames, generator=generator, **sampling)
        return self.decode(ids, decoder, generator=generator, steps=steps), ids


# ----------------------------------------------------------------------------------- train once, load after


def _shape(x) -> str:
    return str(tuple(x.shape)) if hasattr(x, "shape") else type(x).__name__


def _digest(*parts: bytes) -> str:
    h = hashlib.sha1()
    for p in parts:
        h.update(p)
    return h.hexdigest()[:10]


def cache_extra(dataset, tokenizer, vocabulary) -> dict[str, str]:
    """What identifies a trained model besides its config: the data, the exact codebook, the vocabulary."""
    codebook = tokenizer.codebook().detach().cpu().float().numpy()
    words = "\n".join(vocabulary.tokens).encode()
    return {
        "data": dataset.key,
        "codebook": f"{codebook.shape[0]}-{_digest(codebook.tobytes())}",
        "vocabulary": f"{len(vocabulary)}-{_digest(words)}",
    }


def _train_captions(clips) -> list[list[str]]:
    return [[c.text for c in clip.captions] for clip in clips]


def text_to_motion_for_dataset(
    dataset,
    profile: str | None = None,
    *,
    eta: float | None = None,
    distance: str = "l2_rank",
    schedule: str | None = None,
    progress: bool = True,
    device: str | None = None,
    config: DiffusionTrainingConfig | None = None,
    seed: int | None = None,
    retrain: bool = False,
) -> TextToMotion:
    """The text-to-motion model of ``dataset`` for ``profile``, trained on first use and cached after.

    The tokenizer is the dataset's standard VQ (``tokenizer_for_dataset("vq", ...)``, shared with chapter 02).
    ``eta`` None is the paper's 0.5; ``eta = 0`` is uniform β_t, a different cached model; ``distance`` and
    ``schedule`` choose d(·,·) and the noise schedule (:func:`diffusion_training_config`). ``config`` replaces
    the whole training config (then ``eta``/``distance``/``schedule`` must be left at their defaults).
    ``seed`` (None: the config's, 0) is the training seed (initial weights, batches, noise): seed 0 is the one
    cached model every chapter shares; other seeds are replicates that measure training-seed variance.
    """
    from motionlab.tokenizers import tokenizer_for_dataset

    for name in ("split", "normalized", "normalizer", "key"):
        if not hasattr(dataset, name):
            raise ValueError(f"dataset must be a MotionDataset (split, normalized, normalizer, key); it lacks {name!r}")
    profile = get_profile(profile)
    tokenizer = tokenizer_for_dataset("vq", dataset, profile, device=device, progress=progress)
    K = tokenizer.codebook_size
    if config is None:
        config = diffusion_training_config(profile, num_codes=K, eta=eta, distance=distance, schedule=schedule)
    elif eta is not None or distance != "l2_rank" or schedule is not None:
        raise ValueError("pass either config= or eta/distance/schedule, not both")
    if seed is not None:
        if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
            raise ValueError(f"seed must be a non-negative int, got {seed!r}")
        config = with_overrides(config, seed=int(seed))
    if config.transformer.num_codes != K:
        raise ValueError(f"config.transformer.num_codes={config.transformer.num_codes} but the tokenizer has {K} codes")
    clips = dataset.split("train")
    captions = _train_captions(clips)
    vocabulary = build_vocabulary(captions, config)
    transitions = make_transitions(config.transformer, tokenizer.codebook().cpu())
    extra = cache_extra(dataset, tokenizer, vocabulary)
    if uses_cuda_graphs("denoiser", get_device(device)):  # graphs pad every batch to one shape: other training data
        extra["compile"] = "graphs"  # only then, so that every other run keeps its cache key

    def build(cfg: DiffusionTrainingConfig) -> TextToMotionNetworks:
        return TextToMotionNetworks(cfg, vocabulary)

    def train_fn(networks: TextToMotionNetworks, workdir) -> dict:
        sequences = tokenize_clips(tokenizer, dataset.normalized("train"))
        history = train_text_to_motion(
            networks, sequences, captions, transitions, config, workdir=workdir, device=device, progress=progress
        )
        n_tokens = int(sum(s.numel() for s in sequences))
        return {"history": history, "n_clips": len(sequences), "n_tokens": n_tokens}

    networks = train_or_load(MODEL_NAME, config, build, train_fn, profile, extra=extra, device=device, retrain=retrain)
    history = load_result(MODEL_NAME, config, profile, extra, device).get("history", [])
    transitions.to(next(networks.parameters()).device)
    return TextToMotion(
        tokenizer,
        networks.text_encoder,
        networks.denoiser,
        transitions,
        dataset.normalizer,
        config.transformer,
        history,
    )


# ------------------------------------------------------------------------------------------ evaluation


def generation_lengths(clips) -> list[int]:
    """Each clip's length in frames, floored to a multiple of 4 (the length asked of the generator)."""
    return [len(getattr(c, "features", c)) // FRAMES_PER_TOKEN * FRAMES_PER_TOKEN for c in clips]


def _check_eval_args(clips, repeats: int, seed: int) -> None:
    if len(clips) < 2:
        raise ValueError(f"need at least 2 clips to evaluate, got {len(clips)}")
    if isinstance(repeats, bool) or not isinstance(repeats, int) or repeats < 1:
        raise ValueError(f"repeats must be a positive int, got {repeats!r}")
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise ValueError(f"seed must be a non-negative int, got {seed!r}")


def evaluate_text_to_motion(
    generate: Callable[..., list[np.ndarray]] | TextToMotion,
    evaluator,
    clips,
    *,
    repeats: int = 1,
    seed: int = 0,
    **sampling,
) -> list[dict[str, float]]:
    """The single-motion protocol, ``repeats`` times: one metrics dict per repeat.

    Repeat r draws one caption per clip (``rng = default_rng([seed, r])``), generates a motion of the
    clip's length for it (``seed = 1000·seed + r``), and scores the set against the real ``clips`` with
    ``evaluator.evaluate_generation`` (FID, top1–3 R-precision, MM-Dist, Diversity). ``generate`` is a
    :class:`TextToMotion` or any ``generate(texts, lengths, seed=..., **sampling)`` function.
    """
    _check_eval_args(clips, repeats, seed)
    fn = generate.generate if isinstance(generate, TextToMotion) else generate
    lengths = generation_lengths(clips)
    runs = []
    for r in range(repeats):
        rng = np.random.default_rng([int(seed), r])
        captions = pick_captions(clips, rng)
        motions = fn([c.text for c in captions], lengths, seed=1000 * int(seed) + r, **sampling)
        runs.append(evaluator.evaluate_generation(clips, motions, captions, rng))
    return runs


def evaluate_fixed_motions(
    evaluator, clips, motions: Sequence[np.ndarray], *, repeats: int = 1, seed: int = 0
) -> list[dict[str, float]]:
    """The same protocol for motions that do not depend on the caption (``motions[i]`` stands for clip i):
    the real motions ("Ground Truth") or their VQ-VAE reconstructions. Only the caption draws repeat."""
    _check_eval_args(clips, repeats, seed)
    if len(motions) != len(clips):
        raise ValueError(f"need one motion per clip, got {len(motions)} motions for {len(clips)} clips")
    runs = []
    for r in range(repeats):
        rng = np.random.default_rng([int(seed), r])
        captions = pick_captions(clips, rng)
        runs.append(evaluator.evaluate_generation(clips, list(motions), captions, rng))
    return runs


def evaluate_ground_truth(evaluator, clips, *, repeats: int = 1, seed: int = 0) -> list[dict[str, float]]:
    """The protocol with the real motions in place of generated ones (the "Ground Truth" row)."""
    return evaluate_fixed_motions(evaluator, clips, [c.features for c in clips], repeats=repeats, seed=seed)


def multimodality_score(
    pipe: TextToMotion,
    evaluator,
    clips,
    *,
    n_repeats: int = 10,
    n_pairs: int = 10,
    seed: int = 0,
    **sampling,
) -> float:
    """MultiModality: the mean distance between embeddings of motions generated for the same text.

    Each clip's first caption is generated ``n_repeats`` times (one batch, one seed) at the clip's length.
    """
    _check_eval_args(clips, 1, seed)
    if n_repeats < n_pairs or n_pairs < 1:
        raise ValueError(f"need n_repeats >= n_pairs >= 1, got n_repeats={n_repeats}, n_pairs={n_pairs}")
    lengths = generation_lengths(clips)
    texts = [c.captions[0].text for c in clips for _ in range(n_repeats)]
    motions = pipe.generate(texts, [n for n in lengths for _ in range(n_repeats)], seed=int(seed), **sampling)
    emb = evaluator.embed_motions(motions).reshape(len(clips), n_repeats, -1)  # (texts, repeats, d)
    return multimodality(emb, np.random.default_rng(int(seed)), n_pairs=n_pairs)
