"""A small trainable text encoder that needs no download: word vocabulary + embedding + transformer layers.

The vocabulary is built from the training captions (lower-cased words; rare words map to ``<unk>``).
Every text starts with ``<s>``, so even an empty caption has one token. The encoder is trained together
with the denoiser; its vocabulary travels inside ``state_dict()`` (as extra state).
"""

from __future__ import annotations

import re
from collections import Counter
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field

import torch
from torch import Tensor, nn

from motionlab.precision import attention_kernel
from motionlab.text.base import TextEncoder, TextFeatures, check_texts

PAD, UNK, BOS = "<pad>", "<unk>", "<s>"
_WORD = re.compile(r"[a-z0-9]+(?:'[a-z]+)?")


def words(text: str) -> list[str]:
    """Lower-cased word tokens: ``"A person walks, then turns!"`` -> ``['a', 'person', 'walks', 'then', 'turns']``."""
    return _WORD.findall(text.lower())


@dataclass
class Vocabulary:
    """Word <-> id; ids 0, 1, 2 are ``<pad>``, ``<unk>``, ``<s>``."""

    tokens: list[str]
    index: dict[str, int] = field(init=False, repr=False)

    def __post_init__(self) -> None:
        if self.tokens[:3] != [PAD, UNK, BOS] or len(set(self.tokens)) != len(self.tokens):
            raise ValueError("a vocabulary starts with <pad>, <unk>, <s> and has no duplicates")
        self.index = {w: i for i, w in enumerate(self.tokens)}

    @classmethod
    def build(cls, captions: Iterable[str], min_count: int = 1, max_size: int | None = None) -> Vocabulary:
        """Words seen at least ``min_count`` times, most frequent first (ties alphabetical)."""
        counts = Counter(w for caption in captions for w in words(caption))
        ranked = sorted((w for w, c in counts.items() if c >= min_count), key=lambda w: (-counts[w], w))
        if max_size is not None:
            ranked = ranked[: max(0, max_size - 3)]
        return cls([PAD, UNK, BOS, *ranked])

    def __len__(self) -> int:
        return len(self.tokens)

    def encode(self, text: str) -> list[int]:
        return [self.index[BOS]] + [self.index.get(w, self.index[UNK]) for w in words(text)]


class WordTextEncoder(nn.Module, TextEncoder):
    """Embedding + learned positions + ``n_layers`` pre-norm transformer layers; sentence = masked mean."""

    def __init__(
        self,
        vocab: Vocabulary,
        dim: int = 256,
        n_layers: int = 2,
        n_heads: int = 4,
        max_len: int = 64,
        dropout: float = 0.0,
        seed: int = 0,
    ) -> None:
        super().__init__()
        if dim % n_heads:
            raise ValueError(f"dim={dim} must be divisible by n_heads={n_heads}")
        self.vocab, self.dim, self.max_len = vocab, dim, max_len
        self.embed = nn.Embedding(len(vocab), dim, padding_idx=0)
        self.pos = nn.Embedding(max_len, dim)
        layer = nn.TransformerEncoderLayer(
            dim, n_heads, 4 * dim, dropout, activation="gelu", batch_first=True, norm_first=True
        )
        self.layers = nn.TransformerEncoder(layer, n_layers, enable_nested_tensor=False)
        self.norm = nn.LayerNorm(dim)
        g = torch.Generator().manual_seed(seed)
        with torch.no_grad():
            for name, p in self.named_parameters():  # everything seeded: no draw from the global RNG
                if p.ndim >= 2:
                    nn.init.normal_(p, 0.0, 0.02, generator=g)
                elif name.endswith("bias"):
                    nn.init.zeros_(p)
            self.embed.weight[0].zero_()

    @classmethod
    def from_captions(cls, captions: Iterable[str], min_count: int = 1, max_size: int | None = None, **kw):
        """Build the vocabulary from ``captions`` and a fresh encoder on it."""
        return cls(Vocabulary.build(captions, min_count, max_size), **kw)

    @classmethod
    def from_state_dict(cls, state: dict, **kw) -> WordTextEncoder:
        """Rebuild an encoder (same ``dim``/``n_layers``/... in ``kw``) from its ``state_dict()``."""
        encoder = cls(Vocabulary(list(state["_extra_state"]["vocab"])), **kw)
        encoder.load_state_dict(state)
        return encoder

    def tokenize(self, texts: Sequence[str]) -> tuple[Tensor, Tensor]:
        """(B, S) ids and (B, S) padding mask (True at padding); texts longer than ``max_len`` are cut."""
        ids = [self.vocab.encode(t)[: self.max_len] for t in check_texts(texts)]
        S = max(len(i) for i in ids)
        out = torch.zeros(len(ids), S, dtype=torch.long)
        for b, row in enumerate(ids):
            out[b, : len(row)] = torch.tensor(row)
        return out, out == 0

    def encode(self, texts: Sequence[str]) -> TextFeatures:
        return self.encode_tokens(*self.tokenize(texts))

    def encode_tokens(self, ids: Tensor, pad: Tensor) -> TextFeatures:
        """Features of already tokenized texts: ``ids`` and ``pad`` ``(B, S)`` as :meth:`tokenize` returns them
        (moved to the encoder's device). A training loop tokenizes its captions once and calls this per batch."""
        device = self.embed.weight.device
        ids, pad = ids.to(device), pad.to(device)  # (B, S)
        h = self.embed(ids) + self.pos(torch.arange(ids.shape[1], device=device))[None]  # (B, S, dim)
        with attention_kernel(device):  # plain-matmul attention when training in CPU bf16 (motionlab.precision)
            h = self.norm(self.layers(h, src_key_padding_mask=pad))
        keep = (~pad).unsqueeze(-1).to(h.dtype)
        h = h * keep  # padded features are exactly zero
        sentence = h.sum(dim=1) / keep.sum(dim=1)  # (B, dim)
        return TextFeatures(h, pad, sentence)

    def forward(self, texts: Sequence[str]) -> TextFeatures:
        return self.encode(texts)

    def get_extra_state(self) -> dict:
        return {"vocab": list(self.vocab.tokens)}

    def set_extra_state(self, state: dict) -> None:
        if state["vocab"] != self.vocab.tokens:
            raise ValueError("the checkpoint's vocabulary differs from this encoder's; build it from the same captions")
