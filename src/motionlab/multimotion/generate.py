"""Texts in, multi-motions out: one front end over TPS and the baselines for a trained text-to-motion model.

:class:`MultiMotionGenerator` holds the pieces (denoiser, transitions, text encoder, a decode function) so it
works with :class:`motionlab.diffusion.pipeline.TextToMotion` (:meth:`MultiMotionGenerator.from_pipeline`,
duck-typed: nothing is imported from the pipeline module) as well as with a tiny random model in tests.

``decode`` maps (B, L) token ids padded with −1 to a list of B raw feature arrays (4·L_b, D), the
signature of ``TextToMotion.decode``. Unless a call passes ``guidance_scale``, M2D2M's multi-motion s = 2 is
used (``TextToMotion`` defaults to the single-motion s = 4). η is a property of the trained model, not of the
sampler: M2D2M's multi-action model uses :data:`MULTI_MOTION_ETA` = 0.25, i.e.
``text_to_motion_for_dataset(dataset, profile, eta=MULTI_MOTION_ETA)``. Extra keyword arguments reach the
sampler, e.g. ``joint_text="all"`` for TPS (:func:`~motionlab.multimotion.two_phase_sample`). Methods:

==============  ===========================================================================================
``tps``         Two-Phase Sampling; the concatenated tokens are decoded as one sequence (Algorithm 1)
``independent`` T_s = T: each action alone, tokens concatenated, decoded as one sequence (T2M-GPT baseline)
``separate``    each action alone and decoded alone; feature rows concatenated (no joint step anywhere)
``slerp``       each action ``W/2`` frames shorter per inner end, decoded alone, ``W`` blended frames between
``handshake``   neighbouring actions share ``W`` frames while sampling; decoded as one sequence
==============  ===========================================================================================
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np
import torch
from torch import nn

from motionlab.diffusion import Transitions
from motionlab.multimotion.baselines import (
    DEFAULT_TRANSITION,
    handshake_sample,
    independent_sample,
    shortened_lengths,
)
from motionlab.multimotion.stitch import blend_segments, concatenate_segments
from motionlab.multimotion.tps import MultiMotionTokens, segment_layout, two_phase_sample

METHODS = ("tps", "independent", "separate", "slerp", "handshake")
DEFAULT_TS_FRACTION = 0.9  # M2D2M: T_s = 90 of T = 100
MULTI_MOTION_GUIDANCE = 2.0  # M2D2M's s for multi-motion (4 for single motions)
MULTI_MOTION_ETA = 0.25  # M2D2M appendix A.1: η of β(t, d) for multi-action generation (0.5 for single motions)


@dataclass
class MultiMotion:
    """One generated multi-action motion: raw features (T, D) and where each action starts."""

    features: np.ndarray
    boundaries: list[int]
    texts: list[str]
    method: str

    @property
    def segment_lengths(self) -> list[int]:
        edges = [0, *self.boundaries, len(self.features)]
        return [b - a for a, b in zip(edges, edges[1:], strict=False)]


def _instances(texts, lengths) -> tuple[list[list[str]], list[list[int]]]:
    nested = len(texts) > 0 and not isinstance(texts[0], str)
    texts = [list(t) for t in texts] if nested else [list(texts)]
    lengths = [list(n) for n in lengths] if nested else [list(lengths)]
    if not texts or any(len(t) == 0 for t in texts):
        raise ValueError("texts must be a non-empty list of action texts (or a list of such lists)")
    if len(texts) != len(lengths) or any(len(t) != len(n) for t, n in zip(texts, lengths, strict=False)):
        raise ValueError(
            f"texts and lengths must match one to one, got {len(texts)} instance(s) of texts and lengths {lengths}"
        )
    return texts, lengths


_PLAIN = (int, float, str, bool, type(None))  # sampler options that can key a draw; a tensor or a callable cannot


def token_key(method: str, texts, lengths, seed: int, T_s: int | None, transition: int, sampling: dict):
    """What one draw of tokens depends on, as a hashable key (None if a sampler option is not a plain value).

    ``independent`` and ``separate`` share a key: they sample the same tokens and differ only in the decoding.
    ``texts``/``lengths`` are the nested per-instance lists of :func:`_instances`; ``T_s`` counts for ``tps`` only,
    ``transition`` for ``slerp`` and ``handshake``.
    """
    kind = "independent" if method == "separate" else method
    options = []
    for name, value in sorted(sampling.items()):
        sequence = isinstance(value, (list, tuple))
        items = tuple(value) if sequence else (value,)
        if not all(isinstance(v, _PLAIN) for v in items):
            return None
        options.append((name, sequence, items))
    extra = T_s if kind == "tps" else transition if kind in ("slerp", "handshake") else None
    shapes = (tuple(tuple(t) for t in texts), tuple(tuple(int(n) for n in inst) for inst in lengths))
    return (kind, *shapes, int(seed), extra, tuple(options))


@dataclass
class MultiMotionGenerator:
    """The model's pieces and a decode function; :meth:`generate` runs any of :data:`METHODS`.

    ``token_cache`` (a dict, or None: no caching) keeps every draw of tokens by :func:`token_key`: a second call
    with the same method, texts, lengths, seed and sampler options returns the tokens of the first instead of
    sampling again (the draw is a pure function of those, seeded by ``seed``). ``separate`` thereby decodes the
    very tokens ``independent`` sampled, and two generators of one model that share the dict, one per decoder,
    decode the same tokens.
    """

    model: nn.Module
    transitions: Transitions
    text_encoder: nn.Module
    decode: Callable[[torch.Tensor], list[np.ndarray]]
    guidance_scale: float = MULTI_MOTION_GUIDANCE  # used when a call passes none
    token_cache: dict | None = field(default=None, repr=False)

    @classmethod
    def from_pipeline(cls, pipe, decoder=None, token_cache: dict | None = None) -> MultiMotionGenerator:
        """From a ``TextToMotion`` (anything with model, transitions, text_encoder and decode(ids, decoder))."""
        for name in ("model", "transitions", "text_encoder", "decode"):
            if not hasattr(pipe, name):
                raise ValueError(f"pipe needs a {name!r} attribute (a TextToMotion), got {type(pipe).__name__}")
        if token_cache is not None and not isinstance(token_cache, dict):
            raise ValueError(f"token_cache must be a dict or None, got {type(token_cache).__name__}")
        decode = lambda ids: pipe.decode(ids, decoder=decoder)  # noqa: E731
        return cls(pipe.model, pipe.transitions, pipe.text_encoder, decode, token_cache=token_cache)

    @torch.no_grad()
    def encode(self, texts: Sequence[str]):
        """Text features (M, S, d) on the denoiser's device, the encoder in eval mode."""
        was_training = self.text_encoder.training
        self.text_encoder.eval()
        try:
            feats = self.text_encoder.encode(list(texts))
        finally:
            self.text_encoder.train(was_training)
        dev = next(self.model.parameters()).device
        return feats.tokens.to(dev), feats.padding_mask.to(dev)

    def sample_tokens(
        self,
        texts,
        lengths,
        *,
        method: str = "tps",
        seed: int = 0,
        T_s: int | None = None,
        transition: int = DEFAULT_TRANSITION,
        **sampling,
    ) -> MultiMotionTokens:
        """Token ids of every action for ``method`` (``slerp`` samples each action shorter, as
        :func:`~motionlab.multimotion.baselines.shortened_lengths` says, so the blend restores ``lengths``); from
        ``token_cache`` when the same draw was made before. The ids are on the denoiser's device."""
        texts, lengths = _instances(texts, lengths)
        sampling.setdefault("guidance_scale", self.guidance_scale)
        if method == "tps" and T_s is None:
            T_s = round(DEFAULT_TS_FRACTION * self.transitions.T)
        key = None
        if self.token_cache is not None:
            key = token_key(method, texts, lengths, seed, T_s, transition, sampling)
            if key in self.token_cache:
                return self.token_cache[key]
        tokens = self._sample(texts, lengths, method, seed, T_s, transition, sampling)
        if key is not None:
            self.token_cache[key] = tokens
        return tokens

    def _sample(self, texts, lengths, method, seed, T_s, transition, sampling) -> MultiMotionTokens:
        text = self.encode([t for inst in texts for t in inst])
        g = torch.Generator().manual_seed(int(seed))
        args = (self.model, self.transitions, text)
        if method == "tps":
            return two_phase_sample(*args, lengths, T_s=T_s, generator=g, **sampling)
        if method in ("independent", "separate"):
            return independent_sample(*args, lengths, generator=g, **sampling)
        if method == "slerp":
            shorter = [shortened_lengths(n, transition) for n in lengths]
            return independent_sample(*args, shorter, generator=g, **sampling)
        if method == "handshake":
            return handshake_sample(*args, lengths, generator=g, transition=transition, **sampling)
        raise ValueError(f"method must be one of {METHODS}, got {method!r}")

    def generate(
        self,
        texts,
        lengths,
        *,
        method: str = "tps",
        seed: int = 0,
        T_s: int | None = None,
        transition: int = DEFAULT_TRANSITION,
        **sampling,
    ) -> list[MultiMotion]:
        """Multi-motions for one instance (``texts``: list of str, ``lengths``: frames, multiples of 4) or a
        batch (lists of lists). ``sampling``: num_steps, timesteps, guidance_scale, top_p, top_k, ...;
        ``T_s`` for ``tps`` (default 0.9·T), ``transition`` (frames) for ``slerp`` and ``handshake``."""
        if method not in METHODS:
            raise ValueError(f"method must be one of {METHODS}, got {method!r}")
        texts, lengths = _instances(texts, lengths)
        segment_layout(lengths)  # validate before any work
        out = self.sample_tokens(texts, lengths, method=method, seed=seed, T_s=T_s, transition=transition, **sampling)
        if method in ("tps", "independent", "handshake"):  # one decoder pass over the concatenated tokens
            decoded = self.decode(out.concatenated())
            return [MultiMotion(np.asarray(f), out.boundaries(b), texts[b], method) for b, f in enumerate(decoded)]
        segments = self.decode(out.ids)  # one row per action, decoded alone
        motions, m = [], 0
        for inst in texts:
            parts = [np.asarray(f) for f in segments[m : m + len(inst)]]
            m += len(inst)
            feats, bounds = blend_segments(parts, transition) if method == "slerp" else concatenate_segments(parts)
            motions.append(MultiMotion(feats, bounds, inst, method))
        return motions
