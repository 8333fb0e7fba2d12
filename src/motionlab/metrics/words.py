"""Words for the text-motion evaluator: ``word/POS`` tokens -> (300-d word input, 15-d POS one-hot, length).

Captions arrive tokenised as ``word/POS`` (spaCy's universal tags, lemmatised words), e.g.
``["a/DET", "person/NOUN", "walk/VERB", "forward/ADV"]``. The official evaluator feeds its text encoder

* a 300-d GloVe vector per word (unknown words get the vector of ``unk``), and
* a 15-d one-hot of the word's category: 9 POS tags, 5 "VIP" categories of motion words that override
  the tag (``left`` is always ``Loc_VIP``, ``arm`` always ``Body_VIP``, ...), and ``OTHER``.
  A word missing from the vocabulary is ``OTHER`` whatever its tag.

A caption is cut to 20 tokens, wrapped in ``sos``/``eos`` and padded with ``unk`` to 22; its length
counts ``sos`` and ``eos``. Two word sources share this interface: :class:`WordVectorizer` reads the
official GloVe files, :class:`CaptionVocabulary` + :class:`LearnedWordEmbedding` give a trainable
embedding for the project's own (embedded) captions.
"""

from __future__ import annotations

import os
import pickle
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import torch
from torch import nn

POS_CATEGORIES = (
    "VERB",
    "NOUN",
    "DET",
    "ADP",
    "NUM",
    "AUX",
    "PRON",
    "ADJ",
    "ADV",
    "Loc_VIP",
    "Body_VIP",
    "Obj_VIP",
    "Act_VIP",
    "Desc_VIP",
    "OTHER",
)
POS_INDEX = {name: i for i, name in enumerate(POS_CATEGORIES)}

# The evaluator's hard-coded motion vocabulary: these words get their VIP category instead of their tag.
VIP_WORDS = {
    "Loc_VIP": (
        "left",
        "right",
        "clockwise",
        "counterclockwise",
        "anticlockwise",
        "forward",
        "back",
        "backward",
        "up",
        "down",
        "straight",
        "curve",
    ),
    "Body_VIP": (
        "arm",
        "chin",
        "foot",
        "feet",
        "face",
        "hand",
        "mouth",
        "leg",
        "waist",
        "eye",
        "knee",
        "shoulder",
        "thigh",
    ),
    "Obj_VIP": ("stair", "dumbbell", "chair", "window", "floor", "car", "ball", "handrail", "baseball", "basketball"),
    "Act_VIP": (
        "walk",
        "run",
        "swing",
        "pick",
        "bring",
        "kick",
        "put",
        "squat",
        "throw",
        "hop",
        "dance",
        "jump",
        "turn",
        "stumble",
        "stop",
        "sit",
        "lift",
        "lower",
        "raise",
        "wash",
        "stand",
        "kneel",
        "stroll",
        "rub",
        "bend",
        "balance",
        "flap",
        "jog",
        "shuffle",
        "lean",
        "rotate",
        "spin",
        "spread",
        "climb",
    ),
    "Desc_VIP": (
        "slowly",
        "carefully",
        "fast",
        "careful",
        "slow",
        "quickly",
        "happy",
        "angry",
        "sad",
        "happily",
        "angrily",
        "sadly",
    ),
}
_VIP_OF = {word: cat for cat, words in VIP_WORDS.items() for word in words}

SOS, EOS, UNK = "sos", "eos", "unk"
MAX_TEXT_LEN = 20  # caption tokens kept before adding sos/eos


def split_token(token: str) -> tuple[str, str]:
    """``"walk/VERB"`` -> ``("walk", "VERB")``."""
    word, sep, pos = token.rpartition("/")
    if not sep or not word:
        raise ValueError(f"tokens must look like 'word/POS', got {token!r}")
    return word, pos


def pos_category(word: str, pos: str, known: bool = True) -> int:
    """Index into :data:`POS_CATEGORIES`: VIP category first, then the tag, ``OTHER`` if unknown."""
    if not known:
        return POS_INDEX["OTHER"]
    return POS_INDEX.get(_VIP_OF.get(word, pos), POS_INDEX["OTHER"])


def pad_caption(tokens: Sequence[str], max_text_len: int = MAX_TEXT_LEN) -> tuple[list[str], int]:
    """Crop to ``max_text_len``, add ``sos``/``eos``, pad with ``unk/OTHER`` to ``max_text_len + 2``.

    Returns the padded tokens and the sentence length (including ``sos`` and ``eos``).
    """
    if len(tokens) == 0:
        raise ValueError("a caption needs at least one token")
    body = [f"{SOS}/OTHER", *tokens[:max_text_len], f"{EOS}/OTHER"]
    return body + [f"{UNK}/OTHER"] * (max_text_len + 2 - len(body)), len(body)


@dataclass
class EncodedCaptions:
    """A batch of captions ready for the text encoder."""

    words: torch.Tensor  # (B, L, 300) float vectors (GloVe) or (B, L) int64 ids (vocabulary)
    pos_onehot: torch.Tensor  # (B, L, 15)
    lengths: torch.Tensor  # (B,) int64, sos/eos included


def _onehot(indices: Sequence[int]) -> np.ndarray:
    out = np.zeros((len(indices), len(POS_CATEGORIES)), dtype=np.float32)
    out[np.arange(len(indices)), indices] = 1.0
    return out


class WordVectorizer:
    """The official GloVe lookup: ``{prefix}_data.npy`` (V, 300), ``{prefix}_words.pkl``, ``{prefix}_idx.pkl``."""

    def __init__(self, glove_dir: str | os.PathLike, prefix: str = "our_vab"):
        glove_dir = Path(glove_dir)
        files = [glove_dir / f"{prefix}_{name}" for name in ("data.npy", "words.pkl", "idx.pkl")]
        missing = [str(f) for f in files if not f.is_file()]
        if missing:
            raise FileNotFoundError(f"GloVe files missing: {', '.join(missing)}")
        vectors = np.load(files[0]).astype(np.float32)
        with open(files[1], "rb") as f:
            words = pickle.load(f)
        with open(files[2], "rb") as f:
            word2idx = pickle.load(f)
        if vectors.ndim != 2:
            raise ValueError(f"{files[0]} must hold a (V, dim) matrix, got {vectors.shape}")
        if UNK not in word2idx:
            raise ValueError(f"{files[2]} has no entry for {UNK!r}")
        self.dim = vectors.shape[1]
        self.word2vec = {w: vectors[word2idx[w]] for w in words}

    def __len__(self) -> int:
        return len(self.word2vec)

    def __getitem__(self, token: str) -> tuple[np.ndarray, np.ndarray]:
        """``"word/POS"`` -> (vector ``(dim,)``, POS one-hot ``(15,)``)."""
        word, pos = split_token(token)
        known = word in self.word2vec
        vec = self.word2vec[word if known else UNK]
        return vec, _onehot([pos_category(word, pos, known)])[0]

    def encode(self, captions: Sequence[Sequence[str]], max_text_len: int = MAX_TEXT_LEN) -> EncodedCaptions:
        """Captions (lists of ``word/POS`` tokens) -> vectors ``(B, L, dim)``, one-hots, lengths."""
        vecs, ohots, lengths = [], [], []
        for tokens in captions:
            padded, n = pad_caption(tokens, max_text_len)
            pairs = [self[t] for t in padded]
            vecs.append(np.stack([p[0] for p in pairs]))
            ohots.append(np.stack([p[1] for p in pairs]))
            lengths.append(n)
        return EncodedCaptions(
            torch.from_numpy(np.stack(vecs)),
            torch.from_numpy(np.stack(ohots)),
            torch.tensor(lengths, dtype=torch.int64),
        )


class CaptionVocabulary:
    """A word list built from the project's captions; ids index a :class:`LearnedWordEmbedding`.

    Ids 0, 1, 2 are ``sos``, ``eos``, ``unk`` (the official word list starts the same way); the rest are
    the caption words in alphabetical order, so the same captions always give the same ids.
    """

    def __init__(self, words: Sequence[str]):
        if list(words[:3]) != [SOS, EOS, UNK]:
            raise ValueError(f"a vocabulary must start with {SOS!r}, {EOS!r}, {UNK!r}, got {list(words[:3])}")
        if len(set(words)) != len(words):
            raise ValueError("vocabulary words must be unique")
        self.words = list(words)
        self.index = {w: i for i, w in enumerate(self.words)}

    @classmethod
    def build(cls, captions: Iterable[Sequence[str]], min_count: int = 1) -> CaptionVocabulary:
        """From tokenised captions (lists of ``word/POS``); words seen fewer than ``min_count`` times -> unk."""
        counts: dict[str, int] = {}
        for tokens in captions:
            for token in tokens:
                word = split_token(token)[0]
                counts[word] = counts.get(word, 0) + 1
        kept = sorted(w for w, c in counts.items() if c >= min_count and w not in (SOS, EOS, UNK))
        return cls([SOS, EOS, UNK, *kept])

    def __len__(self) -> int:
        return len(self.words)

    def encode(self, captions: Sequence[Sequence[str]], max_text_len: int = MAX_TEXT_LEN) -> EncodedCaptions:
        """Captions -> ids ``(B, L)``, POS one-hots ``(B, L, 15)``, lengths ``(B,)``."""
        ids, ohots, lengths = [], [], []
        for tokens in captions:
            padded, n = pad_caption(tokens, max_text_len)
            split = [split_token(t) for t in padded]
            ids.append([self.index.get(w, self.index[UNK]) for w, _ in split])
            ohots.append(_onehot([pos_category(w, p, w in self.index) for w, p in split]))
            lengths.append(n)
        return EncodedCaptions(
            torch.tensor(ids, dtype=torch.int64),
            torch.from_numpy(np.stack(ohots)),
            torch.tensor(lengths, dtype=torch.int64),
        )


class LearnedWordEmbedding(nn.Module):
    """Trainable ``ids (B, L) -> (B, L, dim)`` standing in for GloVe, so the same text encoder trains on it."""

    def __init__(self, vocab_size: int, dim: int = 300, generator: torch.Generator | None = None):
        super().__init__()
        self.embedding = nn.Embedding(vocab_size, dim)
        with torch.no_grad():  # unit-variance rows, like normalised word vectors up to scale
            self.embedding.weight.copy_(torch.randn(vocab_size, dim, generator=generator))

    def forward(self, ids: torch.Tensor) -> torch.Tensor:
        return self.embedding(ids)
