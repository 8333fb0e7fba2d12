import pytest
import torch


def _smooth_motion(n: int, frames: int, dim: int = 263, seed: int = 0, rank: int = 6) -> torch.Tensor:
    """``n`` smooth synthetic clips ``(n, frames, dim)``: a few slow sinusoids mixed into every dim."""
    g = torch.Generator().manual_seed(seed)
    t = torch.arange(frames).float()[None, :, None]
    freq = torch.rand(n, 1, rank, generator=g) * 0.15 + 0.02  # cycles per frame
    phase = torch.rand(n, 1, rank, generator=g) * 6.28
    basis = torch.sin(2 * torch.pi * freq * t + phase)  # (n, frames, rank)
    mix = torch.randn(rank, dim, generator=g) / rank**0.5
    return basis @ mix  # (n, frames, dim)


@pytest.fixture
def smooth_motion():
    return _smooth_motion


@pytest.fixture(autouse=True)
def isolated_cache(tmp_path, monkeypatch):
    """Nothing a test trains may land in the real cache."""
    monkeypatch.setenv("MOTIONLAB_HOME", str(tmp_path / "home"))
