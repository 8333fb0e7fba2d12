"""Two-Phase Sampling: the T_s = T identity, layouts and boundaries, the joint phase's context, bad inputs."""

from __future__ import annotations

import pytest
import torch

from motionlab.diffusion import sample
from motionlab.multimotion import (
    MAX_ACTIONS,
    SegmentLayout,
    independent_sample,
    joint_condition,
    phase_grid,
    two_phase_sample,
)

D_TEXT, T = 8, 10  # as in conftest.py


def text(n_segments: int, n_tokens: int = 4, seed: int = 2) -> torch.Tensor:
    return torch.randn(n_segments, n_tokens, D_TEXT, generator=torch.Generator().manual_seed(seed))


def gen(seed: int = 0) -> torch.Generator:
    return torch.Generator().manual_seed(seed)


LENGTHS = [[16, 24, 8], [12, 20]]  # two instances: 4+6+2 and 3+5 tokens
SAMPLING = dict(guidance_scale=2.0, top_p=0.9)


@pytest.fixture(scope="module")
def padded_text():
    tokens = text(5)
    pad = torch.zeros(5, 4, dtype=torch.bool)
    pad[1, 2:] = True  # a shorter caption
    pad[4, 3:] = True
    return tokens, pad


@pytest.mark.parametrize("num_steps", [None, 4])
def test_ts_equal_T_is_bit_identical_to_independent_sampling(tiny, padded_text, num_steps):
    model, tr = tiny
    tokens, pad = padded_text
    out = two_phase_sample(model, tr, (tokens, pad), LENGTHS, T_s=T, generator=gen(3), num_steps=num_steps, **SAMPLING)
    ref = sample(model, tr, tokens, pad, lengths=[4, 6, 2, 3, 5], generator=gen(3), num_steps=num_steps, **SAMPLING)
    assert torch.equal(out.ids, ref)
    alone = independent_sample(model, tr, (tokens, pad), LENGTHS, generator=gen(3), num_steps=num_steps, **SAMPLING)
    assert torch.equal(alone.ids, ref)


@pytest.mark.parametrize("T_s", [0, 4, T])
def test_segments_keep_their_lengths_and_boundaries(tiny, padded_text, T_s):
    model, tr = tiny
    out = two_phase_sample(model, tr, padded_text, LENGTHS, T_s=T_s, generator=gen(), **SAMPLING)
    assert out.ids.shape == (5, 6)
    for b, inst in enumerate(LENGTHS):
        segs = out.segments(b)
        assert [len(s) * 4 for s in segs] == inst
        assert all(((s >= 0) & (s < tr.mask_id)).all() for s in segs)  # codes only, no mask left
    assert (out.ids[2, 2:] == -1).all() and (out.ids[3, 3:] == -1).all()
    assert out.boundaries(0) == [16, 40] and out.boundaries(1) == [12]
    whole = out.concatenated()  # (B, L_c)
    assert whole.shape == (2, 12)
    assert torch.equal(whole[0], torch.cat(out.segments(0))) and (whole[1, 8:] == -1).all()
    assert torch.equal(whole[1, :8], torch.cat(out.segments(1)))


def test_same_seed_same_tokens_and_different_seed_differs(tiny, padded_text):
    model, tr = tiny
    a = two_phase_sample(model, tr, padded_text, LENGTHS, T_s=5, generator=gen(7))
    b = two_phase_sample(model, tr, padded_text, LENGTHS, T_s=5, generator=gen(7))
    c = two_phase_sample(model, tr, padded_text, LENGTHS, T_s=5, generator=gen(8))
    assert torch.equal(a.ids, b.ids) and not torch.equal(a.ids, c.ids)


def test_one_action_per_instance_makes_the_joint_phase_independent(tiny, padded_text):
    """With a single segment the canvas *is* the segment and the cross mask allows its own text only, so every
    T_s gives the same tokens: the joint phase adds context from neighbours and nothing else."""
    model, tr = tiny
    single = [[16], [24], [8], [12], [20]]
    ref = two_phase_sample(model, tr, padded_text, single, T_s=T, generator=gen(4), **SAMPLING).ids
    for T_s in (0, 6):
        assert torch.equal(
            two_phase_sample(model, tr, padded_text, single, T_s=T_s, generator=gen(4), **SAMPLING).ids, ref
        )


def test_joint_phase_lets_tokens_depend_on_the_neighbours_text(tiny):
    """Changing action 2's text changes action 1's tokens when T_s < T, never when T_s = T."""
    model, tr = tiny
    base = text(3)
    changed = base.clone()
    changed[1] = text(1, seed=99)[0]
    lengths = [16, 16, 16]

    def changes(T_s: int) -> tuple[int, int]:
        first = last = 0
        for seed in range(4):
            a = two_phase_sample(model, tr, (base, None), lengths, T_s=T_s, generator=gen(seed))
            b = two_phase_sample(model, tr, (changed, None), lengths, T_s=T_s, generator=gen(seed))
            first += int((a.ids[0] != b.ids[0]).sum())
            last += int((a.ids[2] != b.ids[2]).sum())
        return first, last

    assert changes(T) == (0, 0)
    assert sum(changes(0)) > 0
    assert sum(changes(T // 2)) > 0


def test_joint_model_output_of_a_segment_depends_on_the_neighbours_text(tiny):
    """The mechanism, one network call: in the joint condition segment 1's log p(x_0 | x_T) moves when only
    segment 2's text changes (self-attention across the boundary); cross-attention still sees its own text."""
    model, tr = tiny
    layout = SegmentLayout.from_frames([16, 16])
    base, changed = text(2), text(2)
    changed[1] = text(1, seed=99)[0]
    x = torch.full((1, 8), tr.mask_id)
    outs = []
    for tokens in (base, changed):
        cond = joint_condition(layout, tokens, torch.zeros(2, 4, dtype=torch.bool))
        outs.append(model(x, torch.tensor([T]), cond.text, cond.text_padding_mask, cross_mask=cond.cross_mask))
    assert not torch.allclose(outs[0][0, :4], outs[1][0, :4])
    alone = [model(torch.full((1, 4), tr.mask_id), torch.tensor([T]), tokens[:1]) for tokens in (base, changed)]
    assert torch.equal(alone[0], alone[1])


def test_joint_condition_pairs_each_token_with_its_own_text():
    layout = SegmentLayout.from_frames([[8, 12], [4]])  # tokens 2+3 and 1
    tokens = text(3, n_tokens=2)
    pad = torch.tensor([[False, False], [False, True], [False, False]])
    cond = joint_condition(layout, tokens, pad)
    assert cond.text.shape == (2, 4, D_TEXT)  # two segments' texts side by side (N_max = 2, S = 2)
    assert torch.equal(cond.text[0], tokens[:2].flatten(0, 1)) and torch.equal(cond.text[1, :2], tokens[2])
    assert cond.text_padding_mask.tolist() == [[False, False, False, True], [False, False, True, True]]
    assert cond.padding_mask.tolist() == [[False] * 5, [False] + [True] * 4]
    expected0 = torch.tensor([[1, 1, 0, 0]] * 2 + [[0, 0, 1, 1]] * 3, dtype=torch.bool)
    assert torch.equal(cond.cross_mask[0], expected0)
    assert cond.cross_mask[1, 0].tolist() == [True, True, False, False]
    assert joint_condition(layout, tokens, pad, "all").cross_mask is None


def test_layout_split_and_merge_are_inverse():
    layout = SegmentLayout.from_frames([[8, 12, 4], [16]])
    canvas = torch.arange(2 * 6).view(2, 6)
    canvas[1, 4:] = -1
    batch = layout.split(canvas, -1)
    assert batch.tolist() == [[0, 1, -1, -1], [2, 3, 4, -1], [5, -1, -1, -1], [6, 7, 8, 9]]
    assert torch.equal(layout.merge(batch, -1), canvas)
    assert layout.flat_tokens == [2, 3, 1, 4] and layout.total_tokens == [6, 4]
    assert layout.boundaries(0) == [8, 20] and layout.boundaries(1) == []


def test_phase_grid_puts_T_s_on_the_grid():
    assert phase_grid(10, 7, num_steps=2) == [10, 7, 5, 0]
    assert phase_grid(10, 5, num_steps=2) == [10, 5, 0]
    assert phase_grid(10, 10) == list(range(10, -1, -1))
    assert phase_grid(10, 0, timesteps=[10, 3, 0]) == [10, 3, 0]


def test_bad_inputs(tiny):
    model, tr = tiny
    kw = dict(generator=gen())
    with pytest.raises(ValueError, match="non-empty"):
        two_phase_sample(model, tr, (text(1), None), [], T_s=5, **kw)
    with pytest.raises(ValueError, match="multiples of 4"):
        two_phase_sample(model, tr, (text(2), None), [16, 18], T_s=5, **kw)
    with pytest.raises(ValueError, match="multiples of 4"):
        SegmentLayout.from_frames([0])
    with pytest.raises(ValueError, match="max_actions"):
        SegmentLayout.from_frames([4] * (MAX_ACTIONS + 1))
    with pytest.raises(ValueError, match="max_actions"):
        SegmentLayout.from_frames([4, 4, 4], max_actions=2)
    for T_s in (-1, T + 1, 2.5, None):
        with pytest.raises(ValueError, match="T_s"):
            two_phase_sample(model, tr, (text(2), None), [16, 16], T_s=T_s, **kw)
    with pytest.raises(ValueError, match="one row per segment"):
        two_phase_sample(model, tr, (text(3), None), [16, 16], T_s=5, **kw)
    with pytest.raises(ValueError, match="joint_text"):
        two_phase_sample(model, tr, (text(2), None), [16, 16], T_s=5, joint_text="mine", **kw)
    with pytest.raises(ValueError, match="timesteps"):
        two_phase_sample(model, tr, (text(2), None), [16, 16], T_s=5, timesteps=[10, 5], **kw)


def test_compound_condition_changes_only_the_joint_phase(tiny):
    """joint_text="all" (every token sees every action's text) samples other tokens than "own" when there is a
    joint phase, and exactly the same ones when there is none (T_s = T)."""
    model, tr = tiny
    lengths = [16, 24, 12]
    kw = dict(generator=None, num_steps=5, **SAMPLING)
    out = {}
    for joint_text in ("own", "all"):
        for ts in (T, 3):
            kw["generator"] = gen(0)
            out[joint_text, ts] = two_phase_sample(
                model, tr, (text(3), None), lengths, T_s=ts, joint_text=joint_text, **kw
            ).ids
    assert torch.equal(out["own", T], out["all", T])
    assert not torch.equal(out["own", 3], out["all", 3])
