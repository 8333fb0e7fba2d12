"""A tiny RVQ on the two real HumanML3D clips shipped beside the project (skipped when they are absent)."""

import numpy as np
import pytest
import torch
import torch.nn.functional as F

from motionlab.paths import shared_data_dir
from motionlab.representation import Normalizer
from motionlab.tokenizers import build_tokenizer, rvq_config, tokenizer_loss_fn
from motionlab.train import TrainConfig, Trainer, WindowDataset, collate_clips

DATA = shared_data_dir()
FILES = ("humanml3d-sample/new_joint_vecs/012314.npy", "momask-example/000612.npy")
pytestmark = pytest.mark.skipif(
    DATA is None or not all((DATA / f).is_file() for f in FILES), reason="shared real clips not available"
)


def test_tiny_rvq_learns_real_clips():
    norm = Normalizer.load(DATA / "humanml3d-sample")
    clips = [norm.normalize(np.load(DATA / f).astype(np.float32)) for f in FILES]
    train = TrainConfig(steps=150, lr=3e-3, warmup_steps=10, log_every=50)
    config = rvq_config("smoke", window=32, batch_size=16, width=48, code_dim=32, quantize_dropout=0.0, train=train)
    model = build_tokenizer(config)
    motion, lengths = collate_clips(clips)  # whole clips: 168 and 196 frames
    assert lengths.tolist() == [168, 196]

    def full_clip_error():
        model.eval()
        with torch.no_grad():
            errs = [
                F.mse_loss(model.decode(model.encode(m[None, :n])).cpu(), m[None, :n]) for m, n in zip(motion, lengths)
            ]
        return float(torch.stack(errs).mean())

    before = full_clip_error()
    Trainer(model, tokenizer_loss_fn, WindowDataset(clips, 32).batches(16), train, progress=False).fit()
    after = full_clip_error()
    assert after < 0.5 * before, (before, after)  # trained on windows, decodes whole clips
