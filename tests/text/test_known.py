"""What the models know: a text's words split by the vocabulary, the warning lines, the embedded data's families."""

from __future__ import annotations

from motionlab.data.embedded.generator import FAMILIES
from motionlab.text import Vocabulary, action_families, known_words, text_coverage, unknown_word_warnings

VOCAB = Vocabulary.build(["a person walks forward", "a person waves the left hand", "someone jumps"])


def test_coverage_splits_words_as_the_encoder_does():
    cover = text_coverage("A person plays the guitar, the GUITAR!", VOCAB)
    assert cover.known == ("a", "person", "the") and cover.unknown == ("plays", "guitar")  # each word once
    assert not cover.none_known
    assert text_coverage("xyzzy foo", VOCAB).none_known and text_coverage("!!!", VOCAB).none_known


def test_warnings_name_every_unknown_word_and_say_when_none_is_known():
    texts = ["a person walks forward", "a person plays the guitar while dancing salsa", "xyzzy plugh", "?!"]
    lines = unknown_word_warnings(texts, VOCAB)
    assert len(lines) == 3  # the first text is fully known: no line
    partly, none, empty = lines
    for word in ("plays", "guitar", "while", "dancing", "salsa"):
        assert word in partly
    assert "5 of its 8 words" in partly and "it knows: a, person, the" in partly
    assert "knows none of its words (xyzzy, plugh)" in none and "follows no text" in none
    assert "knows none of its words (it has none)" in empty
    assert unknown_word_warnings(["someone jumps"], VOCAB) == []


def test_known_words_leave_out_the_special_tokens():
    words = known_words(VOCAB)
    assert words == sorted(words) and "<unk>" not in words and "<s>" not in words and "waves" in words


def test_action_families_are_the_generators():
    families = action_families()
    assert families == [name.replace("_", " ") for name in FAMILIES] and len(families) == len(FAMILIES)
    assert "jumping jacks" in families and "side step" in families and "walk" in families
