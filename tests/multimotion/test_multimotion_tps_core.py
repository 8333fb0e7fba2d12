"""Algorithm 1's core (`tps_loop`, shown in chapter 09) is what `two_phase_sample` runs, and the split of the sampler
into core and wrapper keeps every seeded sample: the wrapper's tokens equal those of the sampler written step by
step, as it was before the split (the canvas only when there is a joint step, the switch inside the loop)."""

from __future__ import annotations

import pytest
import torch

from motionlab.diffusion import denoise_step
from motionlab.multimotion import (
    PhaseCondition,
    joint_condition,
    phase_grid,
    segment_layout,
    tps_loop,
    two_phase_sample,
)

D_TEXT, T = 8, 10  # as in conftest.py
LENGTHS = [[16, 24, 8], [12, 20]]  # two instances: 4+6+2 and 3+5 tokens


def texts() -> tuple[torch.Tensor, torch.Tensor]:
    tokens = torch.randn(5, 4, D_TEXT, generator=torch.Generator().manual_seed(2))
    pad = torch.zeros(5, 4, dtype=torch.bool)
    pad[1, 2:] = True
    return tokens, pad


def step_by_step(model, tr, tokens, pad, lengths, T_s, generator, num_steps, joint_text, **sampling):
    """The sampler before the split into `tps_loop` and its wrapper, one `denoise_step` at a time."""
    layout = segment_layout(lengths)
    grid = phase_grid(tr.T, T_s, num_steps)
    kw = dict(generator=generator, **sampling)
    seg_padding = layout.batch_padding()
    joint = joint_condition(layout, tokens, pad, joint_text) if T_s < tr.T else None
    on_canvas = joint is not None
    shape = (layout.n_instances, layout.canvas_length) if on_canvas else tuple(seg_padding.shape)
    x = torch.full(shape, tr.mask_id, dtype=torch.long)
    for t, t_prev in zip(grid[:-1], grid[1:], strict=True):
        if t > T_s:
            x = denoise_step(
                model, tr, x, t, t_prev, joint.text, joint.text_padding_mask,
                padding_mask=joint.padding_mask, cross_mask=joint.cross_mask, **kw,
            )  # fmt: skip
            continue
        if on_canvas:
            x, on_canvas = layout.split(x, tr.mask_id), False
        x = denoise_step(model, tr, x, t, t_prev, tokens, pad, padding_mask=seg_padding, **kw)
    if on_canvas:
        x = layout.split(x, tr.mask_id)
    return x.masked_fill(seg_padding, -1)


@pytest.mark.parametrize("T_s", [0, 3, 7, T])
@pytest.mark.parametrize("num_steps", [None, 4])
@pytest.mark.parametrize("joint_text", ["own", "all"])
def test_wrapper_keeps_the_seeded_tokens_of_the_step_by_step_sampler(tiny, T_s, num_steps, joint_text):
    model, tr = tiny
    tokens, pad = texts()
    sampling = dict(guidance_scale=2.0, top_p=0.9)
    seeded = torch.Generator().manual_seed(3)
    ref = step_by_step(model, tr, tokens, pad, LENGTHS, T_s, seeded, num_steps, joint_text, **sampling)
    out = two_phase_sample(
        model, tr, (tokens, pad), LENGTHS, T_s=T_s, generator=torch.Generator().manual_seed(3),
        num_steps=num_steps, joint_text=joint_text, **sampling,
    )  # fmt: skip
    assert torch.equal(out.ids, ref)


def test_the_core_alone_gives_the_wrappers_tokens(tiny):
    """What the chapter shows is what runs: `tps_loop` fed by hand gives `two_phase_sample`'s tokens."""
    model, tr = tiny
    tokens, pad = texts()
    layout = segment_layout(LENGTHS)
    grid = phase_grid(tr.T, 6, 5)
    joint = joint_condition(layout, tokens, pad)
    independent = PhaseCondition(tokens, pad, layout.batch_padding(), None)
    z = tps_loop(model, tr, layout, grid, 6, joint, independent, generator=torch.Generator().manual_seed(1))
    out = two_phase_sample(
        model, tr, (tokens, pad), LENGTHS, T_s=6, num_steps=5, generator=torch.Generator().manual_seed(1)
    )
    assert z.shape == (layout.n_segments, layout.max_segment)
    assert torch.equal(z.masked_fill(independent.padding_mask, -1), out.ids)
    assert (z[independent.padding_mask] == tr.mask_id).all()  # padding stays [MASK] inside the core
    # a different T_s on the same grid and noise gives other tokens: the joint phase is in the loop
    other = tps_loop(model, tr, layout, grid, 0, joint, independent, generator=torch.Generator().manual_seed(1))
    assert not torch.equal(other, z)
