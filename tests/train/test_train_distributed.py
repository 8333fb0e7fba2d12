"""Data-parallel training: 2 CPU processes under torchrun (gloo) equal one process on the same global batch."""

import os
import subprocess
import sys
import textwrap

import pytest
import torch
from torch import nn

from motionlab.train import TrainConfig, Trainer, distributed
from motionlab.train.distributed import DistributedContext, init_distributed, rank_device, shard_batch

SCRIPT = textwrap.dedent(
    """
    import sys
    import torch
    from torch import nn
    from motionlab.train import TrainConfig, Trainer
    from motionlab.train.distributed import init_distributed

    def build():
        torch.manual_seed(0)
        return nn.Sequential(nn.Linear(3, 8), nn.Tanh(), nn.Linear(8, 1))

    def batch_fn(step, generator):  # the global batch: 8 rows
        x = torch.randn(8, 3, generator=generator)
        return x, x.sum(dim=1, keepdim=True).sin()

    def loss_fn(model, batch, generator):
        x, y = batch
        return {"loss": ((model(x) - y) ** 2).mean()}

    def run(workdir, until, out):
        ctx = init_distributed("gloo")
        trainer = Trainer(build(), loss_fn, batch_fn, TrainConfig(steps=6, lr=1e-2, grad_clip=1.0, ema_decay=0.9),
                          workdir=workdir, progress=False)
        trainer.fit(until=until)
        torch.save({k: v.clone() for k, v in trainer.model.state_dict().items()}, f"{out}.rank{ctx.rank}.pt")

    if __name__ == "__main__":
        run(sys.argv[1], int(sys.argv[2]), sys.argv[3])
    """
)


def torchrun(script, *args):
    cmd = [sys.executable, "-m", "torch.distributed.run", "--standalone", "--nproc_per_node", "2", str(script), *args]
    env = {**os.environ, "MOTIONLAB_DEVICE": "cpu"}  # gloo ranks on the CPU, whatever the machine has
    done = subprocess.run(cmd, capture_output=True, text=True, timeout=240, env=env)
    assert done.returncode == 0, done.stdout[-2000:] + done.stderr[-4000:]


def test_two_ranks_match_one_process_and_resume(tmp_path):
    script = tmp_path / "ddp_script.py"
    script.write_text(SCRIPT)
    work = tmp_path / "work"
    torchrun(script, str(work), "3", str(tmp_path / "half"))  # 3 steps, checkpoint by rank 0
    assert sorted(p.name for p in work.iterdir()) == ["step_00000003"]
    torchrun(script, str(work), "6", str(tmp_path / "ddp"))  # resume to 6
    rank0 = torch.load(tmp_path / "ddp.rank0.pt")
    rank1 = torch.load(tmp_path / "ddp.rank1.pt")

    sys.path.insert(0, str(tmp_path))
    try:
        import ddp_script  # the same functions, in this single process
    finally:
        sys.path.remove(str(tmp_path))
    single = Trainer(
        ddp_script.build(),
        ddp_script.loss_fn,
        ddp_script.batch_fn,
        TrainConfig(steps=6, lr=1e-2, grad_clip=1.0, ema_decay=0.9),
        progress=False,
        device="cpu",
    )
    single.fit()
    for name, value in single.model.state_dict().items():
        assert torch.equal(rank0[name], rank1[name]), f"ranks disagree on {name}"
        assert torch.allclose(rank0[name], value, atol=1e-6), f"2 ranks != 1 process on {name}"


def test_shard_batch_splits_nested_batches():
    batch = {"x": torch.arange(8).view(8, 1), "pair": (torch.arange(8), "label")}
    shard = shard_batch(batch, DistributedContext(rank=1, world_size=2))
    assert shard["x"].flatten().tolist() == [4, 5, 6, 7] and shard["pair"][1] == "label"
    assert shard_batch(batch, DistributedContext()) is batch
    with pytest.raises(ValueError, match="does not split evenly"):
        shard_batch(torch.zeros(7), DistributedContext(rank=0, world_size=2))


def test_single_process_context_changes_nothing():
    model = nn.Linear(2, 1)
    trainer = Trainer(
        model,
        lambda m, b, g: {"loss": m(b).pow(2).mean()},
        lambda s, g: torch.randn(4, 2, generator=g),
        TrainConfig(steps=2),
        progress=False,
    )
    assert not trainer.dist.enabled and trainer.dist.is_main
    trainer.fit()


def test_each_rank_takes_its_own_gpu_and_the_cpu_when_asked(monkeypatch):
    monkeypatch.delenv("MOTIONLAB_DEVICE", raising=False)
    second = DistributedContext(rank=1, world_size=2, local_rank=1)
    assert rank_device(DistributedContext(), None) is None  # one process: the default choice
    assert rank_device(second, "cuda") == "cuda:1" and rank_device(second, "cpu") == "cpu"
    monkeypatch.setenv("MOTIONLAB_DEVICE", "cpu")
    assert rank_device(second) == "cpu"


def test_more_ranks_than_gpus_fail_at_start_in_one_line(monkeypatch):
    joined = []
    monkeypatch.setattr(distributed.dist, "init_process_group", lambda backend: joined.append(backend))
    monkeypatch.setattr(distributed.dist, "is_initialized", lambda: False)
    monkeypatch.setattr(torch.cuda, "is_available", lambda: True)
    monkeypatch.setattr(torch.cuda, "device_count", lambda: 1)
    monkeypatch.delenv("MOTIONLAB_DEVICE", raising=False)
    for name, value in {"WORLD_SIZE": "2", "LOCAL_WORLD_SIZE": "2", "RANK": "1", "LOCAL_RANK": "1"}.items():
        monkeypatch.setenv(name, value)
    with pytest.raises(
        ValueError, match=r"2 processes .* 1 GPU\(s\): use --nproc_per_node 1, or set MOTIONLAB_DEVICE=cpu"
    ):
        init_distributed()
    assert joined == []
    init_distributed(device="cpu")  # the same ranks on the CPU join with gloo
    assert joined == ["gloo"]
