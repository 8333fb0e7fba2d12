"""What a text-to-motion model of the book knows: the words of its training captions, and the actions behind them.

The book's text encoder (:class:`~motionlab.text.word.WordTextEncoder`) reads a text as word ids of a vocabulary
built from the training captions; any other word becomes ``<unk>``, the same id for "guitar" as for "salsa".
So a text whose words the vocabulary lacks is not refused: the model simply does not see those words. This module
says which words those are, before a motion is generated:

* :func:`known_words` -- a vocabulary's words (the text-to-motion model's is
  ``motionlab.diffusion.training.build_vocabulary`` of its training captions, known before any training);
* :func:`text_coverage` / :func:`unknown_word_warnings` -- per text, its known and unknown words, as warning lines;
* :func:`action_families` -- the embedded dataset's action families (what its captions, and so the models, can
  describe), read from its generator.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

from motionlab.text.word import BOS, PAD, UNK, Vocabulary, words

SPECIAL_TOKENS = (PAD, UNK, BOS)


def action_families() -> list[str]:
    """The embedded dataset's action families in the generator's order, as words: ``"side step"`` for
    ``side_step`` (:data:`motionlab.data.embedded.generator.FAMILIES` defines them)."""
    from motionlab.data.embedded.generator import FAMILIES

    return [name.replace("_", " ") for name in FAMILIES]


def known_words(vocabulary: Vocabulary) -> list[str]:
    """The vocabulary's words, alphabetically, without ``<pad>``, ``<unk>`` and ``<s>``."""
    return sorted(w for w in vocabulary.tokens if w not in SPECIAL_TOKENS)


@dataclass(frozen=True)
class TextCoverage:
    """One text's words split by whether the vocabulary has them (each word once, in text order)."""

    text: str
    known: tuple[str, ...]
    unknown: tuple[str, ...]

    @property
    def none_known(self) -> bool:
        """True when the model sees none of the text's words (or the text has no words at all)."""
        return not self.known


def text_coverage(text: str, vocabulary: Vocabulary) -> TextCoverage:
    """Which words of ``text`` (split as the encoder splits it, :func:`~motionlab.text.word.words`) the
    vocabulary knows."""
    seen = list(dict.fromkeys(words(text)))
    return TextCoverage(
        text,
        tuple(w for w in seen if w in vocabulary.index),
        tuple(w for w in seen if w not in vocabulary.index),
    )


def unknown_word_warnings(texts: Sequence[str], vocabulary: Vocabulary) -> list[str]:
    """One line per text with a word the vocabulary lacks, naming every such word; a text none of whose words
    is known says so plainly. Empty when every word of every text is known."""
    lines = []
    for text in texts:
        cover = text_coverage(text, vocabulary)
        if cover.none_known:
            lines.append(
                f"{text!r}: the model knows none of its words ({', '.join(cover.unknown) or 'it has none'}), "
                "so this motion follows no text"
            )
        elif cover.unknown:
            n, total = len(cover.unknown), len(cover.unknown) + len(cover.known)
            lines.append(
                f"{text!r}: the model does not know {n} of its {total} words and reads each as {UNK}: "
                f"{', '.join(cover.unknown)} (it knows: {', '.join(cover.known)})"
            )
    return lines


__all__ = [
    "SPECIAL_TOKENS",
    "TextCoverage",
    "action_families",
    "known_words",
    "text_coverage",
    "unknown_word_warnings",
]
