"""Load the official T2M evaluator from files the user downloaded (motionlab never downloads anything).

Expected layout (as the MoMask / T2M-GPT download scripts leave it)::

    checkpoints/{t2m,kit}/text_mot_match/model/finest.tar        dict: text_encoder, motion_encoder,
                                                                   movement_encoder (+ epoch, optimisers)
    checkpoints/{t2m,kit}/Comp_v6_KLD005/meta/mean.npy, std.npy   the evaluator's feature normalisation
    glove/our_vab_words.pkl, our_vab_idx.pkl, our_vab_data.npy    the GloVe vocabulary

``checkpoint_root`` is the ``checkpoints`` folder or its parent; ``glove_dir`` the ``glove`` folder or
its parent.
"""

from __future__ import annotations

import os
import pickle
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import torch

from ..representation import Normalizer
from .evaluator import OFFICIAL_PARTS, EvaluatorConfig, TextMotionEvaluator, _check_lengths
from .words import WordVectorizer

GLOVE_PREFIX = "our_vab"


def official_paths(checkpoint_root, glove_dir, dataset: str = "t2m") -> dict[str, Path]:
    """Where each official file should be (after resolving the optional parent folders)."""
    if dataset not in ("t2m", "kit"):
        raise ValueError(f"dataset must be 't2m' or 'kit', got {dataset!r}")
    ckpt = Path(checkpoint_root)
    if not (ckpt / dataset).is_dir() and (ckpt / "checkpoints" / dataset).is_dir():
        ckpt = ckpt / "checkpoints"
    glove = Path(glove_dir)
    if not (glove / f"{GLOVE_PREFIX}_words.pkl").exists() and (glove / "glove").is_dir():
        glove = glove / "glove"
    meta = ckpt / dataset / "Comp_v6_KLD005" / "meta"
    return {
        "checkpoint": ckpt / dataset / "text_mot_match" / "model" / "finest.tar",
        "mean": meta / "mean.npy",
        "std": meta / "std.npy",
        "glove_words": glove / f"{GLOVE_PREFIX}_words.pkl",
        "glove_idx": glove / f"{GLOVE_PREFIX}_idx.pkl",
        "glove_data": glove / f"{GLOVE_PREFIX}_data.npy",
    }


@dataclass
class OfficialEvaluator:
    """The loaded evaluator with its word vectors and normalisation; embeds raw features and captions."""

    model: TextMotionEvaluator
    words: WordVectorizer
    normalizer: Normalizer
    dataset: str
    epoch: int | None

    @torch.no_grad()
    def embed_captions(self, captions: Sequence[Sequence[str]]) -> torch.Tensor:
        """Tokenised captions (``word/POS`` lists) -> ``(B, 512)``."""
        enc = self.words.encode(captions)
        dev = self._device()
        return self.model.encode_text(enc.words.to(dev), enc.pos_onehot.to(dev), enc.lengths)

    @torch.no_grad()
    def embed_batch(self, features, lengths) -> torch.Tensor:
        """*Raw* features ``(B, T, D)`` padded any way (normalised here) and lengths ``(B,)`` -> ``(B, 512)``.

        The padding never matters: a clip's embedding is the one the official evaluation gives its first
        ``lengths[i] // 4 * 4`` frames (4 to 196), zero-padded to the official 196-frame window
        (:func:`~motionlab.metrics.evaluator.official_motion_batch`)."""
        x = torch.as_tensor(features, dtype=torch.float32, device=self._device())
        if x.dim() != 3:
            raise ValueError(f"features must have shape (B, T, D), got {tuple(x.shape)}")
        lengths = _check_lengths(lengths, x.shape[0], x.shape[1], "lengths")
        return self.model.encode_motion(self.normalizer.normalize(x), lengths)

    def embed_motions(self, motions: Sequence, batch_size: int = 32) -> np.ndarray:
        """Raw clips, a list of ``(T_i, D)`` arrays (4 to 196 frames) -> ``(N, 512)`` in the caller's order: what
        every evaluation in motionlab asks of an evaluator, as the trained one's
        (:meth:`~motionlab.metrics.evaluator_training.EmbeddedEvaluator.embed_motions`) does. Batches of
        ``batch_size`` clips of similar length (no embedding depends on its batch)."""
        if isinstance(motions, np.ndarray) or len(motions) == 0:
            raise ValueError("motions must be a non-empty list of (T, D) arrays")
        clips = [np.asarray(m, dtype=np.float32) for m in motions]
        if any(c.ndim != 2 or c.shape[1] != self.normalizer.dim for c in clips):
            raise ValueError(f"every motion must have shape (T, {self.normalizer.dim})")
        order = np.argsort([len(c) for c in clips], kind="stable")
        out = np.zeros((len(clips), self.model.config.dim_coemb), dtype=np.float32)
        for s in range(0, len(clips), batch_size):
            idx = order[s : s + batch_size]
            longest = max(len(clips[i]) for i in idx)
            x = np.zeros((len(idx), longest, self.normalizer.dim), dtype=np.float32)  # (B, T_max, D)
            for j, i in enumerate(idx):
                x[j, : len(clips[i])] = clips[i]
            out[idx] = self.embed_batch(x, [len(clips[i]) for i in idx]).cpu().numpy()
        return out

    def _device(self) -> torch.device:
        return next(self.model.parameters()).device


def load_official_evaluator(
    checkpoint_root: str | os.PathLike,
    glove_dir: str | os.PathLike,
    dataset: str = "t2m",
    device: str | torch.device = "cpu",
    trusted: bool = False,
) -> OfficialEvaluator:
    """Build the evaluator, load ``finest.tar`` into it, and read GloVe and the evaluator's mean/std.

    Raises ``FileNotFoundError`` naming every missing file. The checkpoint is read with
    ``torch.load(weights_only=True)``; pass ``trusted=True`` only for a file you trust if that refuses it.
    Sizes are read off the checkpoint, and its feature size must match ``dataset`` (263 or 251).
    """
    paths = official_paths(checkpoint_root, glove_dir, dataset)
    missing = [f"{name}: {path}" for name, path in paths.items() if not path.is_file()]
    if missing:
        raise FileNotFoundError("official evaluator files missing:\n  " + "\n  ".join(missing))
    try:
        ckpt = torch.load(paths["checkpoint"], map_location="cpu", weights_only=not trusted)
    except pickle.UnpicklingError as err:
        raise ValueError(
            f"{paths['checkpoint']} holds objects torch.load(weights_only=True) refuses; "
            "if you trust the file, pass trusted=True"
        ) from err
    if not isinstance(ckpt, dict) or any(k not in ckpt for k in OFFICIAL_PARTS):
        raise ValueError(f"{paths['checkpoint']} must be a dict with keys {OFFICIAL_PARTS}")
    config = EvaluatorConfig.from_state_dicts(ckpt)
    expected = EvaluatorConfig.official(dataset).dim_pose
    if config.dim_pose != expected:
        raise ValueError(f"checkpoint expects {config.dim_pose}-d features but {dataset!r} has {expected}")
    model = TextMotionEvaluator(config)
    model.load_official_state(ckpt)
    words = WordVectorizer(paths["glove_data"].parent, GLOVE_PREFIX)
    if words.dim != config.dim_word:
        raise ValueError(f"GloVe vectors are {words.dim}-d but the text encoder expects {config.dim_word}")
    normalizer = Normalizer(np.load(paths["mean"]), np.load(paths["std"]))
    if normalizer.dim != config.dim_pose:
        raise ValueError(f"mean/std have {normalizer.dim} dims, expected {config.dim_pose}")
    epoch = ckpt.get("epoch")
    return OfficialEvaluator(model.to(device).eval(), words, normalizer, dataset, None if epoch is None else int(epoch))
