"""The multi-action test set: the single-action pool, seeding, distinct families, lengths, bad inputs."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from motionlab.data import MotionDataset
from motionlab.multimotion import build_multi_action_testset, single_action_pool
from motionlab.representation import Normalizer

FAMILIES = ["walk", "run", "jump", "wave", "kick", "bow"]


def write_layout(root: Path, with_meta: bool) -> MotionDataset:
    """A HumanML3D-layout folder: 3 single-action clips per family, 2 two-action clips, 2 training clips."""
    rng = np.random.default_rng(0)
    (root / "new_joint_vecs").mkdir(parents=True)
    (root / "texts").mkdir()
    clips, test_ids = {}, []
    for i in range(len(FAMILIES) * 3 + 4):
        cid = f"E{i:06d}"
        n = int(rng.integers(40, 120)) + 4  # every clip long enough for the pool (MIN_ACTION_FRAMES)
        np.save(root / "new_joint_vecs" / f"{cid}.npy", rng.normal(size=(n, 263)).astype(np.float32))
        if i < len(FAMILIES) * 3:
            fam, single = FAMILIES[i % len(FAMILIES)], True
            lines = [f"a person does {fam} {k}#a/DET person/NOUN {fam}/VERB {k}/NUM#0.0#0.0" for k in range(3)]
        else:
            fam, single = "walk", False
            lines = ["a person walks and then waves#a/DET person/NOUN walk/VERB and/CCONJ then/ADV wave/VERB#0.0#0.0"]
        (root / "texts" / f"{cid}.txt").write_text("\n".join(lines) + "\n")
        clips[cid] = {"family": fam, "single_action": single, "n_frames": n}
        if i < len(FAMILIES) * 3 + 2:
            test_ids.append(cid)
    (root / "test.txt").write_text("\n".join(test_ids) + "\n")
    Normalizer(np.zeros(263, np.float32), np.ones(263, np.float32)).save(root)
    if with_meta:
        (root / "meta.json").write_text(json.dumps({"clips": clips}))
    return MotionDataset(root)


@pytest.fixture(params=[True, False], ids=["meta.json", "pos-tags"])
def dataset(tmp_path, request) -> MotionDataset:
    return write_layout(tmp_path / "ds", with_meta=request.param)


def test_pool_holds_the_single_action_clips_with_their_family(dataset):
    pool = single_action_pool(dataset)
    assert len(pool) == 18  # the two-action clips are left out (meta flag, or two VERB tags)
    assert {p.family for p in pool} == set(FAMILIES)
    for p in pool:
        assert all(p.family in c.text for c in p.captions)


def test_instances_have_distinct_families_and_floored_lengths(dataset):
    inst = build_multi_action_testset(dataset, 4, seed=1)
    assert len(inst) == 18 // 4  # the pool covered once by default
    for x in inst:
        assert len(x.captions) == len(x.clips) == len(x.families) == len(x.lengths) == 4
        assert len(set(x.families)) == 4
        for clip, cap, fam, n in zip(x.clips, x.captions, x.families, x.lengths, strict=True):
            assert n % 4 == 0 and clip.length - 4 < n <= clip.length
            assert cap in clip.captions and fam in cap.text
        assert [len(s) for s in x.real_segments] == list(x.lengths)
        features, boundaries = x.real_concat()
        assert len(features) == sum(x.lengths) and boundaries == np.cumsum(x.lengths)[:-1].tolist()
        assert x.texts == [c.text for c in x.captions]


def test_seeding(dataset):
    a = build_multi_action_testset(dataset, 3, seed=7, n_instances=10)
    b = build_multi_action_testset(dataset, 3, seed=7, n_instances=10)
    c = build_multi_action_testset(dataset, 3, seed=8, n_instances=10)
    key = lambda inst: [(tuple(cl.name for cl in x.clips), x.texts) for x in inst]  # noqa: E731
    assert key(a) == key(b) and key(a) != key(c)


def test_repeated_families_when_allowed(dataset):
    inst = build_multi_action_testset(dataset, 8, seed=0, n_instances=5, distinct_families=False)
    for x in inst:
        assert len({c.name for c in x.clips}) == 8  # distinct clips, families may repeat
    assert any(len(set(x.families)) < 8 for x in inst)


def test_bad_inputs(dataset):
    with pytest.raises(ValueError, match="n_actions"):
        build_multi_action_testset(dataset, 0)
    with pytest.raises(ValueError, match="max_actions"):
        build_multi_action_testset(dataset, 5, max_actions=4)
    with pytest.raises(ValueError, match="only 6"):
        build_multi_action_testset(dataset, 7)
    with pytest.raises(ValueError, match="exceeds"):
        build_multi_action_testset(dataset, 19, distinct_families=False)
    with pytest.raises(ValueError, match="n_instances"):
        build_multi_action_testset(dataset, 2, n_instances=0)


def test_the_pool_keeps_only_actions_every_baseline_can_take(dataset):
    from motionlab.multimotion import DEFAULT_TRANSITION, MIN_ACTION_FRAMES, shortened_lengths

    lengths = sorted(p.clip.length for p in single_action_pool(dataset))
    shorter = single_action_pool(dataset, min_frames=lengths[len(lengths) // 2] + 4)  # half of them too short now
    assert 0 < len(shorter) < len(lengths) and all(p.clip.length >= lengths[len(lengths) // 2] + 4 for p in shorter)
    assert MIN_ACTION_FRAMES == DEFAULT_TRANSITION + 4  # 20 frames to each neighbour's transition, 4 left
    assert shortened_lengths([MIN_ACTION_FRAMES] * 3) == [24, 4, 24]
    with pytest.raises(ValueError, match="too short"):
        shortened_lengths([MIN_ACTION_FRAMES - 4] * 3)
