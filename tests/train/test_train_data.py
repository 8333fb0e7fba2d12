"""Window sampling and padded collation of motion clips."""

import numpy as np
import pytest
import torch

from motionlab.train import WindowDataset, collate_clips, crop_length, get_device, seed_everything


def clips_of(lengths, dim=5):
    # each frame holds (clip id, frame index) so a window tells where it came from
    out = []
    for i, n in enumerate(lengths):
        c = np.zeros((n, dim), dtype=np.float32)
        c[:, 0], c[:, 1] = i, np.arange(n)
        out.append(c)
    return out


def test_windows_are_contiguous_and_short_clips_skipped():
    data = WindowDataset(clips_of([10, 3, 6]), window=4)
    assert data.skipped == 1 and len(data) == (10 - 4 + 1) + (6 - 4 + 1)
    for i in range(len(data)):
        w = data[i]
        assert w.shape == (4, 5)
        assert torch.equal(w[:, 1], w[0, 1] + torch.arange(4.0))  # consecutive frames of one clip
    with pytest.raises(IndexError):
        data[len(data)]


def test_sampling_is_proportional_to_window_count_and_seeded():
    data = WindowDataset(clips_of([13, 7]), window=4)  # 10 and 4 windows
    batch = data.sample(7000, torch.Generator().manual_seed(0))
    share = (batch[:, 0, 0] == 0).float().mean().item()
    assert abs(share - 10 / 14) < 0.02
    again = data.sample(7000, torch.Generator().manual_seed(0))
    assert torch.equal(batch, again)
    fn = data.batches(3)
    assert fn(0, torch.Generator().manual_seed(1)).shape == (3, 4, 5)


def test_window_dataset_bad_inputs():
    with pytest.raises(ValueError, match="at least window"):
        WindowDataset(clips_of([3, 2]), window=4)
    with pytest.raises(ValueError, match=r"clips\[1\]"):
        WindowDataset([np.zeros((8, 5)), np.zeros((8, 6))], window=4)
    with pytest.raises(ValueError, match="empty"):
        WindowDataset([], window=4)


def test_collate_crops_to_multiples_of_four_and_pads():
    motion, lengths = collate_clips(clips_of([10, 4, 7]))
    assert lengths.tolist() == [8, 4, 4] and motion.shape == (3, 8, 5)
    assert torch.all(motion[1, 4:] == 0) and torch.equal(motion[0, :, 1], torch.arange(8.0))
    assert crop_length(199) == 196
    with pytest.raises(ValueError, match="fewer than unit"):
        collate_clips(clips_of([10, 3]))


def test_device_and_seed(monkeypatch):
    monkeypatch.setenv("MOTIONLAB_DEVICE", "cpu")
    assert get_device() == torch.device("cpu")
    assert get_device("cpu") == torch.device("cpu")
    if not torch.cuda.is_available():
        with pytest.raises(ValueError, match="CUDA"):
            get_device("cuda")
    with pytest.raises(ValueError):
        get_device("not-a-device")
    for other in ("mps", "meta", "xpu"):  # torch parses them; the library runs on the CPU or CUDA only
        with pytest.raises(ValueError, match="'cpu' or 'cuda'"):
            get_device(other)
    g1, g2 = seed_everything(3), seed_everything(3)
    assert torch.equal(torch.rand(4, generator=g1), torch.rand(4, generator=g2))
    with pytest.raises(ValueError):
        seed_everything(-1)


def per_item_windows(clips, window, batch_size, generator):
    """The per-item path the gather replaced: find each drawn window's clip and slice it, one at a time."""
    kept = [torch.as_tensor(c) for c in clips if len(c) >= window]
    counts = torch.tensor([c.shape[0] - window + 1 for c in kept])
    offsets = torch.cumsum(counts, 0) - counts
    idx = torch.randint(int(counts.sum()), (batch_size,), generator=generator)
    out = []
    for i in idx.tolist():
        clip = int(torch.searchsorted(offsets, torch.tensor(i), right=True)) - 1
        start = i - int(offsets[clip])
        out.append(kept[clip][start : start + window])
    return torch.stack(out)


def test_batches_are_one_gather_with_the_same_draws_as_the_per_item_path():
    rng = np.random.default_rng(3)
    clips = [rng.normal(size=(n, 7)).astype(np.float32) for n in (40, 12, 9, 64, 16, 33)]
    data = WindowDataset(clips, window=16)
    for seed in range(5):
        expected = per_item_windows(clips, 16, 256, torch.Generator().manual_seed(seed))
        assert torch.equal(data.sample(256, torch.Generator().manual_seed(seed)), expected)
    for i in range(len(data)):  # the table agrees with indexing one window
        assert torch.equal(data[i], data.frames[data.window_starts[i] : data.window_starts[i] + 16])
    assert [c.shape[0] for c in data.clips] == [40, 64, 16, 33]


def test_window_batches_move_with_the_dataset_and_reject_nan():
    data = WindowDataset(clips_of([10, 6]), window=4)
    batches = data.batches(3)
    assert batches.to("cpu") is batches and data.device == torch.device("cpu")
    with pytest.raises(ValueError, match="batch_size"):
        data.batches(0)
    bad = clips_of([10])
    bad[0][3, 2] = np.nan
    with pytest.raises(ValueError, match="NaN"):
        WindowDataset(bad, window=4)


def test_an_empty_cache_variable_is_not_the_current_folder(monkeypatch, tmp_path):
    from motionlab.paths import cache_dir

    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("HOME", str(tmp_path / "user"))
    for empty in ("", "  "):
        monkeypatch.setenv("MOTIONLAB_HOME", empty)
        assert cache_dir() == tmp_path / "user" / ".cache" / "motionlab"
