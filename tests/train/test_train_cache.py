"""train_or_load: trains once, caches by config hash, never loads a half-finished run."""

import dataclasses
import json
from dataclasses import dataclass

import pytest
import torch
from torch import nn

from motionlab.train import (
    DamagedArtefactError,
    TrainConfig,
    Trainer,
    artefact_dir,
    config_hash,
    is_trained,
    load_result,
    load_trained,
    seeded,
    train_or_load,
    training_sittings,
)


@dataclass
class ToyConfig:
    hidden: int = 4
    train: TrainConfig = None

    def __post_init__(self):
        if self.train is None:
            self.train = TrainConfig(steps=10, lr=1e-2, log_every=5)


def build(config):
    with seeded(0):
        return nn.Sequential(nn.Linear(2, config.hidden), nn.Tanh(), nn.Linear(config.hidden, 1))


def batch_fn(step, generator):
    x = torch.randn(8, 2, generator=generator)
    return x, x.sum(-1, keepdim=True)


def loss_fn(model, batch, generator):
    x, y = batch
    return {"loss": ((model(x) - y) ** 2).mean()}


class Counter:
    def __init__(self, fail_at=None):
        self.calls, self.fail_at = 0, fail_at

    def __call__(self, model, workdir):
        self.calls += 1
        self.work_info = json.loads((workdir / "config.json").read_text())  # what a training in progress trains
        trainer = Trainer(model, loss_fn, batch_fn, model_config(model).train, workdir=workdir, progress=False)
        self.started_at = trainer.step
        if self.fail_at is not None:
            trainer.fit(until=self.fail_at)
            raise RuntimeError("killed")
        return trainer.fit()


def model_config(model):
    return ToyConfig(hidden=model[0].out_features)


@pytest.fixture(autouse=True)
def home(tmp_path, monkeypatch):
    monkeypatch.setenv("MOTIONLAB_HOME", str(tmp_path))
    return tmp_path


def test_trains_once_then_loads(home):
    cfg, train = ToyConfig(), Counter()
    assert not is_trained("toy", cfg, "smoke")
    with pytest.raises(FileNotFoundError):
        load_trained("toy", cfg, build, "smoke")
    first = train_or_load("toy", cfg, build, train, "smoke", device="cpu")
    second = train_or_load("toy", cfg, build, train, "smoke", device="cpu")
    assert train.calls == 1 and not second.training
    for a, b in zip(first.state_dict().values(), second.state_dict().values()):
        assert torch.equal(a, b)
    folder = artefact_dir("toy", cfg, "smoke")
    assert folder.parent == home / "models" / "toy" / "smoke" and folder.name == config_hash(cfg, {"precision": "fp32"})
    assert sorted(p.name for p in folder.iterdir()) == ["config.json", "model.safetensors", "result.json"]
    assert not folder.with_name(folder.name + ".work").exists()  # checkpoints cleaned up
    assert load_result("toy", cfg, "smoke")[-1]["step"] == 10


def test_config_profile_and_extra_change_retrains():
    train = Counter()
    train_or_load("toy", ToyConfig(), build, train, "smoke")
    train_or_load("toy", ToyConfig(hidden=5), build, train, "smoke")
    train_or_load("toy", ToyConfig(), build, train, "laptop")
    train_or_load("toy", ToyConfig(), build, train, "smoke", extra={"data": "v2"})
    assert train.calls == 4
    changed = ToyConfig(train=TrainConfig(steps=10, lr=2e-2, log_every=5))
    assert config_hash(changed) != config_hash(ToyConfig())
    train_or_load("toy", ToyConfig(), build, train, "smoke", retrain=True)
    assert train.calls == 5


def test_failed_training_leaves_no_artefact_and_resumes():
    cfg = ToyConfig()
    with pytest.raises(RuntimeError, match="killed"):
        train_or_load("toy", cfg, build, Counter(fail_at=6), "smoke")
    assert not is_trained("toy", cfg, "smoke")
    again = Counter()
    train_or_load("toy", cfg, build, again, "smoke")
    assert again.started_at == 6  # picked up the interrupted run's checkpoint
    assert is_trained("toy", cfg, "smoke")


def test_bad_names_and_configs():
    with pytest.raises(ValueError, match="plain folder"):
        artefact_dir("a/b", ToyConfig(), "smoke")
    with pytest.raises(ValueError, match="dataclass"):
        config_hash({"hidden": 4})
    with pytest.raises(ValueError, match="profile"):
        artefact_dir("toy", ToyConfig(), "huge")


# ---------------------------------------------------------------------------------------- damaged artefacts


def _damage(path, how):
    data = bytearray(path.read_bytes())
    if how == "truncated":
        path.write_bytes(bytes(data[: len(data) // 2]))
    elif how == "garbage":
        path.write_bytes(b"not a safetensors file at all" * 10)
    else:  # one bit of the last weight's exponent: the header stays valid, a value turns huge, inf or NaN
        data[-1] ^= 0x40
        path.write_bytes(bytes(data))


def test_the_checksum_of_the_weights_is_recorded():
    import hashlib
    import json

    cfg = ToyConfig()
    train_or_load("toy", cfg, build, Counter(), "smoke")
    folder = artefact_dir("toy", cfg, "smoke")
    recorded = json.loads((folder / "config.json").read_text())["sha256"]
    assert recorded == hashlib.sha256((folder / "model.safetensors").read_bytes()).hexdigest()


@pytest.mark.parametrize("how", ["truncated", "garbage", "bitflip"])
def test_damaged_weights_are_named_moved_aside_and_retrained(how, capsys):
    cfg, train = ToyConfig(), Counter()
    first = train_or_load("toy", cfg, build, train, "smoke")
    folder = artefact_dir("toy", cfg, "smoke")
    _damage(folder / "model.safetensors", how)
    with pytest.raises(DamagedArtefactError, match="model.safetensors") as err:  # loading only: a clear stop
        load_trained("toy", cfg, build, "smoke")
    assert "\n" not in str(err.value) and "damaged" in str(err.value)
    again = train_or_load("toy", cfg, build, train, "smoke")
    assert train.calls == 2
    assert "damaged" in capsys.readouterr().err
    moved = [p.name for p in folder.parent.iterdir() if ".damaged-" in p.name]
    assert len(moved) == 1 and moved[0].startswith(folder.name)
    for a, b in zip(first.state_dict().values(), again.state_dict().values()):
        assert torch.equal(a, b)  # the same deterministic training again
    load_trained("toy", cfg, build, "smoke")  # and the new artefact verifies


def test_unreadable_config_json_counts_as_damage():
    cfg = ToyConfig()
    train_or_load("toy", cfg, build, Counter(), "smoke")
    (artefact_dir("toy", cfg, "smoke") / "config.json").write_text("{trunc")
    with pytest.raises(DamagedArtefactError, match="config.json"):
        load_trained("toy", cfg, build, "smoke")


def test_legacy_artefacts_without_a_checksum(home):
    import json

    from safetensors.torch import save_file

    cfg = ToyConfig()
    train_or_load("toy", cfg, build, Counter(), "smoke")
    folder = artefact_dir("toy", cfg, "smoke")
    info = json.loads((folder / "config.json").read_text())
    del info["sha256"]
    (folder / "config.json").write_text(json.dumps(info))
    load_trained("toy", cfg, build, "smoke")  # finite weights load, and their checksum is recorded now
    assert "sha256" in json.loads((folder / "config.json").read_text())
    # a legacy artefact with NaN weights is refused rather than producing NaN motion
    state = {k: torch.full_like(v, float("nan")) for k, v in build(cfg).state_dict().items()}
    save_file(state, str(folder / "model.safetensors"))
    (folder / "config.json").write_text(json.dumps(info))
    with pytest.raises(DamagedArtefactError, match="NaN"):
        load_trained("toy", cfg, build, "smoke")


def test_a_finished_artefact_keeps_the_sittings_that_trained_it():
    config = ToyConfig()
    with pytest.raises(RuntimeError, match="killed"):
        train_or_load("toy", config, build, Counter(fail_at=4))
    train_or_load("toy", config, build, Counter())
    sittings = training_sittings(artefact_dir("toy", config))
    assert [s["steps"] for s in sittings] == [[0, 4], [4, 10]]
    assert all(s["seconds"] > 0 and s["device"] == "cpu" for s in sittings)


def test_a_training_in_progress_says_what_it_trains():
    config, train = ToyConfig(hidden=3), Counter()
    train_or_load("toy", config, build, train, "smoke")
    written = train.work_info["config"]
    assert set(written) == {"hidden", "train"} and written["hidden"] == 3
    assert written["train"] == json.loads(json.dumps(dataclasses.asdict(config.train)))  # the schedule it trains
    assert (written["train"]["steps"], written["train"]["lr"], written["train"]["log_every"]) == (10, 1e-2, 5)
    assert train.work_info["hash"] == artefact_dir("toy", config, "smoke").name
