"""A folder of BVH takes -> a HumanML3D-layout dataset: synthetic takes the tests write, and three CMU takes.

The CMU takes (../shared/data/cmu-bvh, test data only) come from the CMU Graphics Lab Motion Capture
Database. "The data used in this project was obtained from mocap.cs.cmu.edu. The database was created with
funding from NSF EIA-0196217."
"""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import pytest

from motionlab.cli import main
from motionlab.data import MotionDataset, check_dataset, read_captions, read_split_ids
from motionlab.data import from_bvh as from_bvh_module
from motionlab.data.embedded import generate_clip
from motionlab.data.from_bvh import caption_from_name, dataset_from_bvh, read_captions_csv
from motionlab.io import bvh_to_features, save_bvh
from motionlab.paths import shared_data_dir
from motionlab.representation import T2M, recover_from_ric

GOOD = {  # file -> (embedded family, poses at 20 fps, the caption its name gives)
    "walk_forward.bvh": ("walk", 81, "walk forward"),
    "WaveHello.bvh": ("wave", 61, "wave hello"),
    "jump-03.bvh": ("jump", 72, "jump"),
    "squat.bvh": ("squat", 57, "squat"),
    "kick.bvh": ("kick", 66, "kick"),
}
BAD = {  # file -> what the report must say
    "broken_take.bvh": "unreadable",
    "renamed_joints.bvh": "wrong skeleton",
    "short_wave.bvh": "too short",
    "0001.bvh": "no caption",
}


def _joints(family: str, n: int, seed: int) -> np.ndarray:
    return generate_clip(family, np.random.default_rng(seed), n_frames=max(n, 41)).joints[:n]  # (n, 22, 3)


@pytest.fixture(scope="module")
def takes(tmp_path_factory) -> Path:
    """Nine t2m-rig takes: five good ones and one of each kind of bad one."""
    folder = tmp_path_factory.mktemp("takes")
    for i, (name, (family, n, _)) in enumerate(GOOD.items()):
        save_bvh(_joints(family, n, i), folder / name)
    save_bvh(_joints("wave", 30, 7), folder / "short_wave.bvh")  # 29 feature frames < 40
    save_bvh(_joints("walk", 60, 8), folder / "0001.bvh")  # fine motion, but a name without words
    text = (folder / "walk_forward.bvh").read_text()
    (folder / "broken_take.bvh").write_text(text[: len(text) * 2 // 3])  # truncated mid-frame
    (folder / "renamed_joints.bvh").write_text(text.replace("left_knee", "LeftKnee"))
    (folder / "notes.txt").write_text("not a take")
    return folder


def _convert(folder, out, **kwargs):
    return dataset_from_bvh(folder, out, mapping="t2m", progress=False, **kwargs)


def _snapshot(root: Path) -> dict[str, bytes]:
    return {str(p.relative_to(root)): p.read_bytes() for p in sorted(root.rglob("*")) if p.is_file()}


def test_caption_from_name():
    assert caption_from_name("walk_forward_02") == "walk forward"
    assert caption_from_name("SideStep-left") == "side step left"
    assert caption_from_name("131_01") is None


def test_folder_becomes_a_checked_dataset_and_bad_takes_are_reported(takes, tmp_path):
    out = tmp_path / "ds"
    report = _convert(takes, out)
    ids = {Path(name).stem for name in GOOD}
    assert set(report.converted) == ids and report.reused == {}
    assert set(report.skipped) == set(BAD)
    for name, why in BAD.items():
        assert why in report.skipped[name], (name, report.skipped[name])
    assert check_dataset(out) == []

    for name, (_, n, caption) in GOOD.items():
        cid = Path(name).stem
        features = np.load(out / "new_joint_vecs" / f"{cid}.npy")
        assert features.dtype == np.float32 and features.shape == (n - 1, 263) == (report.converted[cid], 263)
        np.testing.assert_allclose(features, bvh_to_features(takes / name, mapping="t2m"), atol=1e-5)
        joints = np.load(out / "new_joints" / f"{cid}.npy")
        np.testing.assert_allclose(joints, recover_from_ric(features, 22), atol=1e-6)
        (cap,) = read_captions(out / "texts" / f"{cid}.txt")
        assert cap.text == caption and cap.tokens and (cap.start, cap.end) == (0.0, 0.0)

    # Tokens as the embedded generator tags them; words outside its lexicon get spaCy's "other" tag X.
    assert read_captions(out / "texts" / "WaveHello.txt")[0].tokens == ("wave/X", "hello/NOUN")

    splits = {s: read_split_ids(out, s) for s in ("train", "val", "test", "all")}
    assert sorted(splits["train"] + splits["val"] + splits["test"]) == splits["all"] == sorted(ids)
    assert [len(splits[s]) for s in ("train", "val", "test")] == [3, 1, 1]
    train = np.concatenate([np.load(out / "new_joint_vecs" / f"{i}.npy") for i in splits["train"]])
    np.testing.assert_allclose(np.load(out / "Mean.npy"), train.mean(axis=0), rtol=1e-4, atol=1e-5)

    ds = MotionDataset(out)  # what `train --data` loads
    assert ds.kind.name == "humanml3d" and sum(len(ds.split(s)) for s in ("train", "val", "test")) == 5
    meta = json.loads((out / "meta.json").read_text())
    assert meta["complete"] and set(meta["skipped"]) == set(BAD) and set(meta["clips"]) == ids
    assert "skipped 4" in report.summary() and "too short" in report.summary()


def test_rerun_converts_nothing_and_changes_no_byte(takes, tmp_path):
    out = tmp_path / "ds"
    _convert(takes, out)
    before = _snapshot(out)
    again = _convert(takes, out)
    assert again.converted == {} and len(again.reused) == 5 and set(again.skipped) == set(BAD)
    assert _snapshot(out) == before


def test_rerun_follows_the_folder(takes, tmp_path):
    folder, out = tmp_path / "takes", tmp_path / "ds"
    shutil.copytree(takes, folder)
    _convert(folder, out)
    save_bvh(_joints("squat", 70, 11), folder / "squat.bvh")  # changed take
    save_bvh(_joints("bow", 64, 12), folder / "bow.bvh")  # new take
    (folder / "kick.bvh").unlink()  # removed take
    report = _convert(folder, out)
    assert set(report.converted) == {"squat", "bow"} and report.converted["squat"] == 69
    assert set(report.reused) == {"walk_forward", "WaveHello", "jump-03"}
    assert not (out / "new_joint_vecs" / "kick.npy").exists() and not (out / "texts" / "kick.txt").exists()
    assert "kick" not in read_split_ids(out, "all") and check_dataset(out) == []


def test_an_interrupted_run_resumes_where_it_stopped(takes, tmp_path, monkeypatch):
    out = tmp_path / "ds"
    real, calls = from_bvh_module.convert_clip, []

    def interrupted(path, plan, rig):
        calls.append(plan.clip_id)
        if len(calls) == 3:
            raise KeyboardInterrupt
        return real(path, plan, rig)

    monkeypatch.setattr(from_bvh_module, "convert_clip", interrupted)
    with pytest.raises(KeyboardInterrupt):
        _convert(takes, out)
    monkeypatch.setattr(from_bvh_module, "convert_clip", real)
    done = {Path(n).stem for n in GOOD} & set(calls[:2])  # the clips written before the interruption
    assert done
    report = _convert(takes, out)
    assert set(report.reused) == done and set(report.converted) == {Path(n).stem for n in GOOD} - done
    fresh = tmp_path / "fresh"
    _convert(takes, fresh)
    assert _snapshot(out) == _snapshot(fresh)  # same bytes as an uninterrupted run


def test_captions_csv_gives_captions_crops_and_reports_the_rest(takes, tmp_path):
    csv = tmp_path / "captions.csv"
    csv.write_text(
        "take,caption,start,end\n"
        "walk_forward.bvh,A person walks forward.,,\n"
        "walk_forward,someone strolls ahead,,\n"
        "walk_forward,the first steps,0,45\n"
        "0001,a person walks,,\n"
        "short_wave,a person waves,,\n"
        "missing_take,this take is not in the folder,,\n"
    )
    out = tmp_path / "ds"
    report = _convert(takes, out, captions=csv)
    assert set(report.converted) == {"walk_forward", "walk_forward_0-45", "0001"}
    assert report.converted["walk_forward_0-45"] == 44
    texts = [c.text for c in read_captions(out / "texts" / "walk_forward.txt")]
    assert texts == ["A person walks forward.", "someone strolls ahead"]
    assert report.skipped["jump-03.bvh"] == "no row in the captions CSV"
    assert "too short" in report.skipped["short_wave.bvh"]
    assert any("missing_take" in note for note in report.notes)
    assert check_dataset(out) == []


@pytest.mark.parametrize(
    "text, match",
    [
        ("take,caption,mood\nkick,a kick,happy\n", "header must name"),
        ("take,captoin\nkick,a kick\n", "header must name"),
        ("take,caption\nkick,a kick,extra\n", "3 cells"),
        ("take,caption\nkick,a # kick\n", "must not contain '#'"),
        ("take,caption\nkick,42\n", "has no words"),
        ("take,caption,start,end\nkick,a kick,10,5\n", "greater than start"),
        ("take,caption,start\nkick,a kick,1.5\n", "whole number"),
        ("take,caption\n", "no caption rows"),
    ],
)
def test_bad_captions_csv_is_refused_before_any_work(takes, tmp_path, text, match):
    csv = tmp_path / "captions.csv"
    csv.write_text(text)
    with pytest.raises(ValueError, match=match):
        read_captions_csv(csv)
    with pytest.raises(ValueError, match=match):
        _convert(takes, tmp_path / "ds", captions=csv)
    assert not (tmp_path / "ds").exists()


def test_bad_arguments_are_judged_before_any_work(takes, tmp_path, monkeypatch):
    def no_work(*args):
        raise AssertionError("a take was converted")

    monkeypatch.setattr(from_bvh_module, "convert_clip", no_work)
    with pytest.raises(FileNotFoundError, match="does not exist"):
        _convert(tmp_path / "nowhere", tmp_path / "ds")
    (tmp_path / "empty").mkdir()
    with pytest.raises(ValueError, match="no .bvh files"):
        _convert(tmp_path / "empty", tmp_path / "ds")
    with pytest.raises(FileNotFoundError, match="captions file"):
        _convert(takes, tmp_path / "ds", captions=tmp_path / "nope.csv")
    with pytest.raises(ValueError, match="unknown BVH rig"):
        dataset_from_bvh(takes, tmp_path / "ds", mapping="vicon", progress=False)
    with pytest.raises(ValueError, match="seed"):
        _convert(takes, tmp_path / "ds", seed=-1)
    with pytest.raises(ValueError, match="must not be the BVH folder"):
        _convert(takes, takes, force=True)
    foreign = tmp_path / "foreign"
    foreign.mkdir()
    (foreign / "precious.txt").write_text("keep me")
    with pytest.raises(FileExistsError, match="force=True converts into it anyway"):
        _convert(takes, foreign)
    assert _snapshot(foreign) == {"precious.txt": b"keep me"}
    assert not (tmp_path / "ds").exists()


def test_force_converts_into_a_foreign_folder_and_keeps_its_files(takes, tmp_path):
    out = tmp_path / "ds"
    out.mkdir()
    (out / "old.txt").write_text("old")
    report = _convert(takes, out, force=True)
    assert len(report.converted) == 5 and (out / "old.txt").read_text() == "old" and check_dataset(out) == []
    manifest = json.loads((out / from_bvh_module.MANIFEST).read_text())
    on_disk = {str(p.relative_to(out)) for p in out.rglob("*") if p.is_file()}
    assert set(manifest["files"]) == on_disk - {"old.txt"}  # every file it wrote, and nothing else
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".")]  # the folder it built in is gone


def test_small_datasets_get_usable_splits(tmp_path):
    folder = tmp_path / "takes"
    folder.mkdir()
    save_bvh(_joints("wave", 50, 0), folder / "wave.bvh")
    one = _convert(folder, tmp_path / "one")
    assert one.splits == {"train": 1, "val": 1, "test": 1} and "repeat the training clips" in one.notes[0]
    assert check_dataset(tmp_path / "one") == [] and len(MotionDataset(tmp_path / "one").split("test")) == 1
    for i, family in enumerate(("walk", "squat")):
        save_bvh(_joints(family, 50, i + 1), folder / f"{family}.bvh")
    three = _convert(folder, tmp_path / "three", seed=5)
    assert three.splits == {"train": 1, "val": 1, "test": 1} and three.notes == []
    splits = [read_split_ids(tmp_path / "three", s) for s in ("train", "val", "test")]
    assert sorted(sum(splits, [])) == ["squat", "walk", "wave"]
    _convert(folder, tmp_path / "again", seed=5)
    assert [read_split_ids(tmp_path / "again", s) for s in ("train", "val", "test")] == splits


def test_nothing_convertible_is_an_error_and_leaves_nothing(tmp_path):
    folder = tmp_path / "takes"
    folder.mkdir()
    save_bvh(_joints("wave", 30, 0), folder / "wave.bvh")
    with pytest.raises(ValueError, match="the only take in .* could not be converted.*too short"):
        _convert(folder, tmp_path / "ds")
    assert not (tmp_path / "ds").exists()
    (tmp_path / "empty").mkdir()
    with pytest.raises(ValueError, match="the only take in .* could not be converted"):
        _convert(folder, tmp_path / "empty")
    assert list((tmp_path / "empty").iterdir()) == []


def test_a_rerun_that_converts_nothing_leaves_the_dataset_as_it_was(takes, tmp_path):
    """With or without ``force``: a re-run whose takes all fail is an error and changes no byte of the dataset."""
    out = tmp_path / "ds"
    _convert(takes, out)
    before = _snapshot(out)
    failing = tmp_path / "failing"
    failing.mkdir()
    save_bvh(_joints("wave", 30, 0), failing / "wave.bvh")  # too short
    for force in (False, True):
        with pytest.raises(ValueError, match="the only take in .* could not be converted"):
            _convert(failing, out, force=force)
        assert _snapshot(out) == before, force
    assert [p.name for p in tmp_path.iterdir() if p.name.startswith(".")] == []  # no half-built folder beside it


# --- three real CMU takes ---------------------------------------------------------------------------------

CMU = {
    "131_01": ("a person starts walking and stops", None),
    "131_02": ("a person walks and stops", (10, 208)),
    "131_03": ("a person hops forward and stops", None),
}


@pytest.fixture
def cmu_folder() -> Path:
    data = shared_data_dir()
    folder = data / "cmu-bvh" if data is not None else None
    if folder is None or not folder.is_dir():
        pytest.skip("the CMU takes (../shared/data/cmu-bvh) are not here")
    return folder


def test_cmu_takes_become_a_dataset(cmu_folder, tmp_path):
    csv = tmp_path / "captions.csv"
    rows = [f"{take},{text},{crop[0] if crop else ''},{crop[1] if crop else ''}" for take, (text, crop) in CMU.items()]
    csv.write_text("take,caption,start,end\n" + "\n".join(rows) + "\n")
    out = tmp_path / "cmu"
    report = dataset_from_bvh(cmu_folder, out, captions=csv, progress=False)
    # The frame counts of the HumanML3D clips cut from these takes (see the data folder's README), minus one.
    assert report.converted == {"131_01": 165, "131_02_10-208": 197, "131_03": 183} and report.skipped == {}
    assert check_dataset(out) == []
    features = np.load(out / "new_joint_vecs" / "131_02_10-208.npy")
    np.testing.assert_allclose(features, bvh_to_features(cmu_folder / "131_02.bvh", start=10, end=208), atol=1e-5)
    assert [len(MotionDataset(out).split(s)) for s in ("train", "val", "test")] == [1, 1, 1]


def test_cmu_takes_without_captions_or_crops_are_reported(cmu_folder, tmp_path):
    with pytest.raises(ValueError, match="131_01.bvh: no caption: the file name has no words"):
        dataset_from_bvh(cmu_folder, tmp_path / "ds", progress=False)
    assert not (tmp_path / "ds").exists()
    csv = tmp_path / "captions.csv"
    csv.write_text("take,caption\n" + "".join(f"{take},{text}\n" for take, (text, _) in CMU.items()))
    report = dataset_from_bvh(cmu_folder, tmp_path / "ds", captions=csv, progress=False)
    assert set(report.converted) == {"131_01", "131_03"}
    assert "too long: 207 frames" in report.skipped["131_02.bvh"]  # the whole take; HumanML3D crops it


# --- the command line -------------------------------------------------------------------------------------


def test_cli_converts_resumes_and_refuses(takes, tmp_path, capsys):
    out = tmp_path / "ds"
    args = ["data", "from-bvh", str(takes), "--out", str(out), "--mapping", "t2m"]
    assert main(args) == 0
    captured = capsys.readouterr()
    assert "5 converted" in captured.out and "broken_take.bvh: unreadable" in captured.out
    assert "from-bvh: converted 5 clips" in captured.err  # stderr is no terminal here: a line per phase
    assert main(["data", "check", str(out)]) == 0
    assert main(args) == 0 and "0 converted" in capsys.readouterr().out  # resumed, nothing new
    assert main(["data", "from-bvh", str(takes), "--out", str(takes / "notes.txt")]) == 2
    assert "exists and is a file" in capsys.readouterr().err
    assert main(["data", "from-bvh", str(tmp_path / "nowhere"), "--out", str(tmp_path / "x")]) == 2
    assert "does not exist" in capsys.readouterr().err
    foreign = tmp_path / "foreign"
    foreign.mkdir()
    (foreign / "keep.txt").write_text("x")
    assert main(["data", "from-bvh", str(takes), "--out", str(foreign), "--mapping", "t2m"]) == 2
    err = capsys.readouterr().err
    assert f"--out {foreign} is not empty" in err and "pass --force" in err and "force=True" not in err


def test_cli_ctrl_c_says_how_to_resume(takes, tmp_path, monkeypatch, capsys):
    def interrupted(*args):
        raise KeyboardInterrupt

    monkeypatch.setattr(from_bvh_module, "convert_clip", interrupted)
    assert main(["data", "from-bvh", str(takes), "--out", str(tmp_path / "ds"), "--mapping", "t2m"]) == 130
    assert "the same command resumes" in capsys.readouterr().err


def test_a_converted_folder_trains(takes, tmp_path, isolated_cache, capsys):
    out = tmp_path / "ds"
    assert main(["data", "from-bvh", str(takes), "--out", str(out), "--mapping", "t2m"]) == 0
    assert main(["train", "vq", "--profile", "smoke", "--data", str(out), "--device", "cpu"]) == 0
    assert "trained and cached" in capsys.readouterr().out


# --- your files are safe (a manifest), and every rig reads ---------------------------------------------------


def test_force_keeps_a_file_the_user_put_in_the_dataset(takes, tmp_path, capsys):
    """Issue 63: `data from-bvh ... --force` deleted a notes.txt the user had put in the output folder."""
    out = tmp_path / "ds"
    args = ["data", "from-bvh", str(takes), "--out", str(out), "--mapping", "t2m"]
    assert main(args) == 0
    (out / "notes.txt").write_text("my notes")
    (out / "texts" / "README.txt").write_text("mine too")
    assert main([*args, "--force"]) == 0
    assert (out / "notes.txt").read_text() == "my notes" and (out / "texts" / "README.txt").read_text() == "mine too"
    assert check_dataset(out) == [] and "5 converted" in capsys.readouterr().out
    # a take that goes away takes its clip with it, but only the clip's own files
    fewer = tmp_path / "fewer"
    shutil.copytree(takes, fewer)
    (fewer / "kick.bvh").unlink()
    assert main(["data", "from-bvh", str(fewer), "--out", str(out), "--mapping", "t2m"]) == 0
    assert not (out / "new_joint_vecs" / "kick.npy").exists() and (out / "texts" / "README.txt").is_file()
    listed = json.loads((out / from_bvh_module.MANIFEST).read_text())["files"]
    assert "new_joint_vecs/kick.npy" not in listed and "notes.txt" not in listed


def test_a_user_file_where_the_dataset_needs_one_stops_the_run_before_any_work(takes, tmp_path, monkeypatch):
    out = tmp_path / "ds"
    out.mkdir()
    (out / "Mean.npy").write_bytes(b"my own statistics")
    monkeypatch.setattr(from_bvh_module, "convert_clip", lambda *args: pytest.fail("a take was converted"))
    with pytest.raises(ValueError, match=r"holds 1 file that the dataset would overwrite.*Mean\.npy; move it away"):
        _convert(takes, out, force=True)
    assert _snapshot(out) == {"Mean.npy": b"my own statistics"}


def test_a_dataset_without_a_manifest_is_known_by_its_meta(takes, tmp_path):
    """A dataset written before manifests existed: its meta.json says which files are the command's."""
    out = tmp_path / "ds"
    _convert(takes, out)
    (out / from_bvh_module.MANIFEST).unlink()
    (out / "notes.txt").write_text("keep")
    assert from_bvh_module.written_files(out) >= {"meta.json", "Mean.npy", "new_joint_vecs/kick.npy"}
    report = _convert(takes, out, force=True)
    assert len(report.converted) == 5 and (out / "notes.txt").read_text() == "keep"
    assert (out / from_bvh_module.MANIFEST).is_file()


def test_the_summary_counts_in_words(tmp_path):
    folder = tmp_path / "takes"
    folder.mkdir()
    save_bvh(_joints("wave", 50, 0), folder / "wave.bvh")
    save_bvh(_joints("wave", 30, 1), folder / "short_wave.bvh")
    report = dataset_from_bvh(folder, tmp_path / "ds", progress=False)
    summary = report.summary()
    assert "1 clip," in summary and "1 clips" not in summary and "skipped 1 take:" in summary
    assert "rigs: t2m (1 clip)" in summary and "only 1 clip:" in summary


def test_the_rig_is_detected_per_take_and_a_joint_map_reads_any_rig(cmu_folder, tmp_path, capsys):
    """A folder that mixes a CMU take, a t2m take in centimetres and a renamed rig: auto reads the first two and
    names what the third has; a joint-map file reads it."""
    folder = tmp_path / "takes"
    folder.mkdir()
    shutil.copy(cmu_folder / "131_03.bvh", folder / "hop_forward.bvh")
    joints = _joints("squat", 60, 0)
    save_bvh(joints, folder / "squat.bvh", unit="cm")
    rename = {"pelvis": "Root", "left_knee": "LKnee", "head": "Skull"}
    text = (folder / "squat.bvh").read_text()
    for old, new in rename.items():
        text = text.replace(f" {old}\n", f" {new}\n")
    (folder / "renamed_squat.bvh").write_text(text)
    report = dataset_from_bvh(folder, tmp_path / "auto", progress=False)
    assert set(report.converted) == {"hop_forward", "squat"}
    assert report.rigs == {"hop_forward": "cmu", "squat": "t2m"}
    why = report.skipped["renamed_squat.bvh"]
    assert why.startswith("wrong skeleton") and "Root" in why and "--mapping FILE.json" in why
    meters = np.load(tmp_path / "auto" / "new_joint_vecs" / "squat.npy")
    np.testing.assert_allclose(meters, bvh_to_features(folder / "squat.bvh", mapping="t2m", scale=0.01), atol=1e-5)

    joint_map = tmp_path / "my-rig.json"
    joint_map.write_text(json.dumps({"joints": {n: rename.get(n, n) for n in T2M.joint_names}, "scale": 0.01}))
    only = tmp_path / "only"
    only.mkdir()
    shutil.copy(folder / "renamed_squat.bvh", only / "squat.bvh")
    assert main(["data", "from-bvh", str(only), "--out", str(tmp_path / "mapped"), "--mapping", str(joint_map)]) == 0
    capsys.readouterr()
    np.testing.assert_allclose(np.load(tmp_path / "mapped" / "new_joint_vecs" / "squat.npy"), meters, atol=1e-5)
    assert main(["data", "from-bvh", str(only), "--out", str(tmp_path / "x"), "--mapping", "nope.json"]) == 2
    assert "--mapping nope.json: the joint map does not exist" in capsys.readouterr().err
    assert not (tmp_path / "x").exists()
