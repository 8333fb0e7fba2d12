"""Damaged, mismatched and unsafe checkpoints: one clear CheckpointError naming the file and the problem."""

from __future__ import annotations

import collections

import numpy as np
import pytest
import torch
from released_layouts import VQSize, momask_manifest, random_state, training_states, write_momask, write_t2mgpt

from motionlab.pretrained import CheckpointError, load_momask_rvq, load_t2mgpt_vq
from motionlab.pretrained.files import SAFE_GLOBALS, load_torch_file


class Payload:
    """An arbitrary object: what a malicious pickle would carry."""


def _resave(released, state=None, **extra):
    opt_state, sched_state = training_states()
    blob = {"vq_model": released.state if state is None else state, "opt_vq_model": opt_state, "scheduler": sched_state}
    torch.save({**blob, "ep": 1, "total_it": 2, **extra}, released.checkpoint)


def test_renamed_key_names_both(tmp_path):
    released = write_momask(tmp_path / "rvq")
    state = dict(released.state)
    state["encoder.model.0.kernel"] = state.pop("encoder.model.0.weight")
    _resave(released, state)
    with pytest.raises(CheckpointError) as err:
        load_momask_rvq(released.folder)
    text = str(err.value)
    assert str(released.checkpoint) in text
    assert "missing keys (1): encoder.model.0.weight" in text and "unexpected keys (1): encoder.model.0.kernel" in text
    assert "opt.txt" in text and "meta/mean.npy" in text  # what the folder should hold


def test_missing_codebook(tmp_path):
    released = write_momask(tmp_path / "rvq")
    state = {k: v for k, v in released.state.items() if k != "quantizer.layers.1.codebook"}
    _resave(released, state)
    with pytest.raises(CheckpointError, match=r"missing keys \(1\): quantizer\.layers\.1\.codebook"):
        load_momask_rvq(released.folder)


def test_reshaped_key_gives_expected_and_found(tmp_path):
    released = write_momask(tmp_path / "rvq")
    state = dict(released.state, **{"decoder.model.6.weight": torch.zeros(263, 32, 5)})
    _resave(released, state)
    with pytest.raises(CheckpointError) as err:
        load_momask_rvq(released.folder)
    assert "decoder.model.6.weight: expected shape (263, 32, 3), found (263, 32, 5)" in str(err.value)


def test_opt_and_weights_disagree(tmp_path):
    big = random_state(momask_manifest(VQSize(width=48)))  # weights of another width than opt.txt says
    released = write_momask(tmp_path / "rvq", state=big)
    with pytest.raises(CheckpointError, match=r"shape mismatches \(\d+\): encoder\.model\.0\.weight: expected"):
        load_momask_rvq(released.folder)


def test_non_tensor_value_and_missing_state_dict(tmp_path):
    released = write_momask(tmp_path / "rvq")
    _resave(released, dict(released.state, **{"encoder.model.0.bias": [0.0] * 32}))
    with pytest.raises(CheckpointError, match="encoder.model.0.bias: expected a tensor"):
        load_momask_rvq(released.folder)
    torch.save({"model": released.state}, released.checkpoint)
    with pytest.raises(CheckpointError, match="no state dict under 'vq_model' or 'net'.*'model'"):
        load_momask_rvq(released.folder)


@pytest.mark.parametrize("cut", [0.5, 0.05])
def test_truncated_file(tmp_path, cut):
    released = write_momask(tmp_path / "rvq")
    data = released.checkpoint.read_bytes()
    released.checkpoint.write_bytes(data[: int(len(data) * cut)])
    with pytest.raises(CheckpointError) as err:
        load_momask_rvq(released.folder)
    assert str(released.checkpoint) in str(err.value) and "damaged or truncated" in str(err.value)


def test_garbage_file(tmp_path):
    released = write_t2mgpt(tmp_path / "t2m")
    released.checkpoint.write_bytes(b"not a checkpoint at all")
    with pytest.raises(CheckpointError, match="net_last.pth: not a readable torch checkpoint"):
        load_t2mgpt_vq(released.checkpoint, released.extra["meta"])


def test_object_carrying_pickle_is_refused_not_run(tmp_path):
    released = write_momask(tmp_path / "rvq")
    _resave(released, extra={"payload": Payload()})
    with pytest.raises(CheckpointError) as err:
        load_momask_rvq(released.folder)
    text = str(err.value)
    assert "weights_only=True) refused it" in text and "Payload" in text and str(released.checkpoint) in text


def test_scheduler_counter_is_allowed_and_only_it(tmp_path):
    assert SAFE_GLOBALS == (collections.Counter,)
    path = tmp_path / "state.tar"
    _, sched_state = training_states()
    assert isinstance(sched_state["milestones"], collections.Counter)
    torch.save({"scheduler": sched_state, "vq_model": {}}, path)
    loaded = load_torch_file(path)
    assert loaded["scheduler"]["milestones"] == collections.Counter({150000: 1, 250000: 1})


def test_damaged_meta(tmp_path):
    released = write_momask(tmp_path / "rvq")
    (released.folder / "meta" / "std.npy").write_bytes(b"junk")
    with pytest.raises(CheckpointError, match="std.npy: not a readable .npy"):
        load_momask_rvq(released.folder)
    np.save(released.folder / "meta" / "std.npy", np.ones(10))
    with pytest.raises(CheckpointError, match="bad mean/std"):
        load_momask_rvq(released.folder)
