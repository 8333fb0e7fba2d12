"""Captions for generated clips, with HumanML3D's ``word/POS`` token annotations.

HumanML3D tags its captions with spaCy: each alphabetic word becomes ``lemma/POS`` with a coarse
part-of-speech tag (NOUN, VERB, ADJ, ...). The generator only ever says what its own phrase templates
say, so a small lexicon replaces the tagger; an unknown word is a bug in a template and raises.
"""

from __future__ import annotations

import re

import numpy as np

# word -> (lemma, POS). Verbs are lemmatised to the infinitive, nouns to the singular.
_VERBS = {
    "walks": "walk",
    "strolls": "stroll",
    "moves": "move",
    "hurries": "hurry",
    "takes": "take",
    "jogs": "jog",
    "runs": "run",
    "running": "run",
    "is": "be",
    "sprints": "sprint",
    "dashes": "dash",
    "side": "side",
    "sidesteps": "sidestep",
    "shuffles": "shuffle",
    "steps": "step",
    "turns": "turn",
    "spins": "spin",
    "makes": "make",
    "jumps": "jump",
    "leaps": "leap",
    "hops": "hop",
    "does": "do",
    "performs": "perform",
    "spreading": "spread",
    "raising": "raise",
    "waves": "wave",
    "raises": "raise",
    "rotates": "rotate",
    "swings": "swing",
    "lifts": "lift",
    "lowers": "lower",
    "holds": "hold",
    "puts": "put",
    "claps": "clap",
    "applauds": "applaud",
    "punches": "punch",
    "throws": "throw",
    "jabs": "jab",
    "boxes": "box",
    "punching": "punch",
    "alternating": "alternate",
    "kicks": "kick",
    "squats": "squat",
    "bends": "bend",
    "crouches": "crouch",
    "stands": "stand",
    "bows": "bow",
    "straightens": "straighten",
    "standing": "stand",
    "stops": "stop",
    "starts": "start",
    "begins": "begin",
    "finishes": "finish",
    "goes": "go",
}
_NOUNS = {
    "person": "person",
    "man": "man",
    "woman": "woman",
    "someone": "someone",
    "figure": "figure",
    "human": "human",
    "pace": "pace",
    "curve": "curve",
    "steps": "step",
    "degrees": "degree",
    "turn": "turn",
    "times": "time",
    "jacks": "jack",
    "legs": "leg",
    "leg": "leg",
    "arms": "arm",
    "arm": "arm",
    "head": "head",
    "hand": "hand",
    "hands": "hand",
    "hello": "hello",
    "circles": "circle",
    "height": "height",
    "shoulder": "shoulder",
    "moment": "moment",
    "chest": "chest",
    "fist": "fist",
    "fists": "fist",
    "punches": "punch",
    "foot": "foot",
    "kick": "kick",
    "knee": "knee",
    "knees": "knee",
    "squat": "squat",
    "squats": "squat",
    "bow": "bow",
    "bows": "bow",
    "waist": "waist",
    "place": "place",
    "reverse": "reverse",
    "way": "way",
    "side": "side",
    "spot": "spot",
    "front": "front",
}
_OTHER = {
    "a": "DET",
    "an": "DET",
    "the": "DET",
    "his": "DET",
    "her": "DET",
    "their": "DET",
    "both": "DET",
    "few": "ADJ",
    "slow": "ADJ",
    "normal": "ADJ",
    "fast": "ADJ",
    "easy": "ADJ",
    "steady": "ADJ",
    "big": "ADJ",
    "small": "ADJ",
    "high": "ADJ",
    "low": "ADJ",
    "deep": "ADJ",
    "quarter": "ADJ",
    "half": "ADJ",
    "full": "ADJ",
    "jumping": "ADJ",
    "straight": "ADV",
    "forward": "ADV",
    "forwards": "ADV",
    "backward": "ADV",
    "backwards": "ADV",
    "ahead": "ADV",
    "diagonally": "ADV",
    "slowly": "ADV",
    "quickly": "ADV",
    "leisurely": "ADV",
    "steadily": "ADV",
    "briskly": "ADV",
    "lightly": "ADV",
    "very": "ADV",
    "sideways": "ADV",
    "around": "ADV",
    "all": "ADV",
    "up": "ADP",
    "down": "ADP",
    "once": "ADV",
    "twice": "ADV",
    "several": "ADJ",
    "deeply": "ADV",
    "back": "ADV",
    "then": "ADV",
    "first": "ADV",
    "again": "ADV",
    "still": "ADV",
    "in": "ADP",
    "at": "ADP",
    "to": "ADP",
    "with": "ADP",
    "out": "ADP",
    "of": "ADP",
    "above": "ADP",
    "for": "ADP",
    "on": "ADP",
    "while": "SCONJ",
    "after": "ADP",
    "that": "PRON",
    "and": "CCONJ",
    "it": "PRON",
    "them": "PRON",
    "he": "PRON",
    "she": "PRON",
    "they": "PRON",
    "one": "NUM",
    "two": "NUM",
    "three": "NUM",
    "four": "NUM",
    "five": "NUM",
    "six": "NUM",
    "seven": "NUM",
    "eight": "NUM",
    "nine": "NUM",
    "ten": "NUM",
    "ninety": "NUM",
    "hundred": "NUM",
    "eighty": "NUM",
    "sixty": "NUM",
}
_SIDE_WORDS = {"left", "right"}  # NOUN after "the", ADJ before a noun, ADV otherwise ("turns left")

SUBJECTS = ("a person", "the person", "someone", "a man", "a woman", "a figure", "the man", "a human")
_PRONOUN = {"a man": "he", "the man": "he", "a woman": "she"}


def _tag_word(words: list[str], i: int, unknown: str | None = None) -> str:
    w = words[i]
    if w in _SIDE_WORDS:
        prev, nxt = (words[i - 1] if i else ""), (words[i + 1] if i + 1 < len(words) else "")
        if prev == "the" and nxt not in _NOUNS:
            return f"{w}/NOUN"
        return f"{w}/ADJ" if nxt in _NOUNS else f"{w}/ADV"
    # A word that is both a verb and a noun ("steps", "bows") is a verb right after the subject or "and".
    prev = words[i - 1] if i else ""
    verb_slot = prev in {"person", "someone", "man", "woman", "figure", "human", "he", "she", "and", "then"}
    if w in _VERBS and (verb_slot or w not in _NOUNS):
        return f"{_VERBS[w]}/VERB" if w not in {"is"} else "be/AUX"
    if w in _NOUNS:
        return f"{_NOUNS[w]}/NOUN"
    if w in _OTHER:
        return f"{w}/{_OTHER[w]}"
    if unknown is not None:
        return f"{w}/{unknown}"
    raise ValueError(f"the caption lexicon has no entry for {w!r}; add it to captions.py")


def tag(caption: str, unknown: str | None = None) -> list[str]:
    """``lemma/POS`` tokens of a caption's alphabetic words, e.g. ``["a/DET", "person/NOUN", "walk/VERB"]``.

    A word outside the lexicon raises, unless ``unknown`` names the tag it gets instead (captions written
    by people, e.g. ``"X"``, spaCy's "other"; the word itself is kept, lower-cased, as its lemma).
    """
    words = re.findall(r"[a-z]+", caption.lower())
    return [_tag_word(words, i, unknown) for i in range(len(words))]


def caption_line(caption: str) -> str:
    """One line of a HumanML3D ``texts/<id>.txt`` file describing the whole clip."""
    return f"{caption}#{' '.join(tag(caption))}#0.0#0.0"


def _sentence(rng: np.random.Generator, text: str) -> str:
    text = re.sub(r"\s+", " ", text).strip()
    if rng.random() < 0.5:
        text = text[0].upper() + text[1:]
    return text + "."


def make_captions(
    rng: np.random.Generator, phrases: list[list[str]], stationary: bool, lead_in_s: float, k: int
) -> list[str]:
    """``k`` distinct captions for a clip made of one or more actions (``phrases[i]``: synonyms of action i).

    Sentence shapes vary: plain ("a person waves"), with a standing lead-in ("a person stands still, then
    waves"), while-standing framing for in-place actions, and "X and then Y" / "first X, then Y" chains.
    """
    candidates: list[tuple[str, tuple[int, ...]]] = []  # (text, which synonym of each action it uses)
    for subject in SUBJECTS:
        pron = _PRONOUN.get(subject, subject.replace("a ", "the ", 1))
        for i0, p0 in enumerate(phrases[0]):
            if len(phrases) == 1:
                shapes = [f"{subject} {p0}"]
                if stationary:
                    shapes.append(f"while standing, {subject} {p0}")
                if lead_in_s > 0.7:
                    shapes.append(f"{subject} stands still, then {p0}")
                candidates += [(text, (i0,)) for text in shapes]
                continue
            for i1, p1 in enumerate(phrases[1]):
                shapes = [
                    f"{subject} {p0} and then {p1}",
                    f"{subject} {p0}, then {p1}",
                    f"first {subject} {p0}, after that {pron} {p1}",
                ]
                candidates += [(text, (i0, i1)) for text in shapes]
    order = rng.permutation(len(candidates))
    chosen: list[str] = []
    used: set[tuple[int, ...]] = set()
    # First pass: one caption per synonym combination, so the captions differ in wording, not just subject.
    for idx in order:
        text, key = candidates[idx]
        if key not in used and len(chosen) < k:
            used.add(key)
            chosen.append(text)
    for idx in order:  # top up if there were fewer synonym combinations than captions wanted
        if len(chosen) < k and candidates[idx][0] not in chosen:
            chosen.append(candidates[idx][0])
    return [_sentence(rng, c) for c in chosen]
