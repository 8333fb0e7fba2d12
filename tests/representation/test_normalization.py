import numpy as np
import pytest
import torch

from motionlab.representation import Normalizer, feature_slices, group_std


def test_group_std_is_constant_within_groups():
    rng = np.random.default_rng(0)
    x = rng.normal(size=(500, 263)) * rng.uniform(0.1, 3.0, size=263)
    std = group_std(x)
    for sl in feature_slices("t2m").values():
        assert np.allclose(std[sl], x[:, sl].std(axis=0).mean())


def test_normalize_round_trip_numpy_and_torch(tmp_path):
    rng = np.random.default_rng(1)
    clips = [rng.normal(size=(30, 263)) for _ in range(4)]
    norm = Normalizer.fit(clips)
    z = norm.normalize(clips[0].astype(np.float32))
    assert np.allclose(norm.denormalize(z), clips[0], atol=1e-5)
    zt = norm.normalize(torch.tensor(clips[0], dtype=torch.float32))
    assert isinstance(zt, torch.Tensor) and torch.allclose(zt, torch.tensor(z), atol=1e-6)
    norm.save(tmp_path)
    again = Normalizer.load(tmp_path)
    assert np.load(tmp_path / "Mean.npy").dtype == np.float32
    assert np.array_equal(again.mean, norm.mean) and np.array_equal(again.std, norm.std)


def test_bad_inputs(tmp_path):
    with pytest.raises(FileNotFoundError, match="Mean.npy"):
        Normalizer.load(tmp_path)
    with pytest.raises(ValueError, match="strictly positive"):
        Normalizer(np.zeros(3), np.array([1.0, 0.0, 1.0]))
    with pytest.raises(ValueError, match="last dimension 263"):
        Normalizer(np.zeros(263), np.ones(263)).normalize(np.zeros((4, 251)))


def test_shipped_stats_load(shared_data):
    norm = Normalizer.load(shared_data / "humanml3d-sample")
    assert norm.dim == 263
    # HumanML3D's std is group-averaged: one value per group.
    for sl in feature_slices("t2m").values():
        assert np.allclose(norm.std[sl], norm.std[sl][0])
