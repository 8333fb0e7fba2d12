"""build_vocabulary reads a dataset's captions once per dataset object: a command's plan probe and its
evaluator share the build."""

from __future__ import annotations

from dataclasses import replace

from motionlab.metrics.evaluator_training import EvaluatorTrainingConfig, build_vocabulary


class CaptionsOnly:
    """A dataset that counts how often its training captions are read."""

    def __init__(self):
        self.reads = 0

    def captions(self, split: str) -> list[list[list[str]]]:
        self.reads += 1
        return [[["a/DET", "man/NOUN", "walks/VERB"]], [["a/DET", "man/NOUN", "runs/VERB"]]]


def test_one_read_per_dataset_object_and_word_count():
    config = EvaluatorTrainingConfig()
    dataset = CaptionsOnly()
    first = build_vocabulary(dataset, config)
    assert build_vocabulary(dataset, config) is first and dataset.reads == 1
    stricter = build_vocabulary(dataset, replace(config, min_word_count=2))  # another vocabulary: built anew
    assert dataset.reads == 2 and "walks" in first.words and "walks" not in stricter.words
    other = CaptionsOnly()
    assert build_vocabulary(other, config).words == first.words and other.reads == 1


def test_a_dataset_without_weak_references_is_read_every_time():
    class Clip:
        captions = [["a/DET", "man/NOUN"]]

    class Slotted:  # no __weakref__: nothing can be remembered for it
        __slots__ = ()

        def split(self, split: str) -> list[Clip]:
            return [Clip(), Clip()]

    assert build_vocabulary(Slotted(), EvaluatorTrainingConfig()).words[3:] == ["a", "man"]
