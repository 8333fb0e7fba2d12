import shutil

import numpy as np
import pytest

from motionlab.data import MotionDataset, check_dataset, crop_to_unit, parse_caption_line
from motionlab.representation import Normalizer


def write_tiny_dataset(root, dim=263, lengths=(60, 120, 30, 199, 80)):
    rng = np.random.default_rng(0)
    (root / "new_joint_vecs").mkdir(parents=True)
    (root / "texts").mkdir()
    ids = [f"{i:06d}" for i in range(len(lengths))]
    clips = []
    for clip_id, n in zip(ids, lengths):
        feats = rng.normal(size=(n, dim)).astype(np.float32)
        clips.append(feats)
        np.save(root / "new_joint_vecs" / f"{clip_id}.npy", feats)
        lines = [
            "a person walks forward#a/DET person/NOUN walk/VERB forward/ADV#0.0#0.0",
            "someone strolls ahead#someone/PRON stroll/VERB ahead/ADV#0.0#0.0",
        ]
        if clip_id == "000001":
            lines.append("then the person waves#then/ADV the/DET person/NOUN wave/VERB#1.0#4.0")
        (root / "texts" / f"{clip_id}.txt").write_text("\n".join(lines) + "\n")
    (root / "train.txt").write_text("\n".join(ids[:3]) + "\n")
    (root / "val.txt").write_text(ids[3] + "\n")
    (root / "test.txt").write_text(ids[4] + "\n")
    Normalizer.fit(clips).save(root)
    return ids


def test_loader_reads_the_real_layout(tmp_path):
    write_tiny_dataset(tmp_path)
    ds = MotionDataset(tmp_path)
    assert ds.kind.name == "humanml3d" and ds.fps == 20
    train = ds.split("train")
    names = [c.name for c in train]
    # 000002 (30 frames) is below the 40-frame minimum; 000001 gives its whole clip plus a 60-frame segment.
    assert names == ["000000", "000001", "A_000001"]
    assert train[2].length == 60 and train[2].captions[0].text == "then the person waves"
    assert train[0].captions[1].tokens == ("someone/PRON", "stroll/VERB", "ahead/ADV")
    assert [c.length for c in ds.split("val")] == [199]  # the standard filter keeps 40 <= T < 200


def test_length_bounds(tmp_path):
    write_tiny_dataset(tmp_path, lengths=(60, 120, 30, 200, 80))
    ds = MotionDataset(tmp_path)
    with pytest.raises(ValueError, match="no clips within the length limits"):
        ds.split("val")  # 200 frames: the standard filter keeps 40 <= T < 200
    assert [c.length for c in ds.split("val", filter_lengths=False)] == [200]


def test_kit_layout_is_recognised(tmp_path):
    write_tiny_dataset(tmp_path, dim=251)
    ds = MotionDataset(tmp_path)
    assert ds.kind.name == "kit" and ds.skeleton.name == "kit" and ds.fps == 12.5
    assert ds.kind.min_length == 24


def test_missing_pieces_are_named(tmp_path):
    write_tiny_dataset(tmp_path)
    assert check_dataset(tmp_path) == []
    (tmp_path / "new_joint_vecs" / "000004.npy").unlink()
    (tmp_path / "texts" / "000000.txt").write_text("no hash here\n")
    problems = check_dataset(tmp_path)
    assert any("000004" in p and "new_joint_vecs" in p for p in problems)
    assert any("texts/000000.txt" in p and "malformed" in p for p in problems)
    with pytest.raises(ValueError, match="unknown dataset kind"):
        MotionDataset(tmp_path, kind="amass")
    with pytest.raises(ValueError, match="expects 251"):
        MotionDataset(tmp_path, kind="kit")
    shutil.rmtree(tmp_path / "texts")
    with pytest.raises(FileNotFoundError, match="texts"):
        MotionDataset(tmp_path)
    with pytest.raises(FileNotFoundError, match="does not exist"):
        MotionDataset(tmp_path / "nope")


def test_empty_npy_files_are_named_not_tracebacks(tmp_path):
    """A 0-byte .npy (a copy cut off at its start) is a problem the check names, and a clear error on loading."""
    write_tiny_dataset(tmp_path)
    (tmp_path / "new_joint_vecs" / "000001.npy").write_bytes(b"")
    assert any("000001.npy cannot be read" in p for p in check_dataset(tmp_path))
    with pytest.raises(ValueError, match="000001.npy cannot be read"):
        MotionDataset(tmp_path).split("train")
    (tmp_path / "Std.npy").write_bytes(b"")
    assert any("Std.npy cannot be read" in p for p in check_dataset(tmp_path))
    with pytest.raises(ValueError, match="Std.npy cannot be read"):
        Normalizer.load(tmp_path)


def test_unknown_split(tmp_path):
    write_tiny_dataset(tmp_path)
    with pytest.raises(ValueError, match="unknown split"):
        MotionDataset(tmp_path).split("dev")


def test_caption_parsing_and_cropping():
    cap = parse_caption_line("a man jumps#a/DET man/NOUN jump/VERB#0.5#2.0")
    assert (cap.text, cap.start, cap.end) == ("a man jumps", 0.5, 2.0)
    assert parse_caption_line("x#x/NOUN#nan#nan").start == 0.0
    with pytest.raises(ValueError, match="malformed"):
        parse_caption_line("just text")
    m = np.arange(103)[:, None]
    assert len(crop_to_unit(m)) == 100 and crop_to_unit(m)[0, 0] == 0
    starts = {int(crop_to_unit(m, rng=np.random.default_rng(s))[0, 0]) for s in range(20)}
    assert starts <= {0, 1, 2, 3} and len(starts) > 1


def test_real_sample_folder_is_checked(shared_data):
    problems = check_dataset(shared_data / "humanml3d-sample")
    assert "missing texts" in problems and "missing split file train.txt" in problems


def test_normalized_clips_and_key(tmp_path):
    write_tiny_dataset(tmp_path)
    ds = MotionDataset(tmp_path)
    z = ds.normalized("train")
    assert len(z) == len(ds.split("train"))
    assert np.allclose(ds.normalizer.denormalize(z[0]), ds.split("train")[0].features, atol=1e-5)
    key = ds.key
    Normalizer(np.zeros(263), np.ones(263)).save(tmp_path)
    assert MotionDataset(tmp_path).key != key  # other statistics, other models


def test_captions_only_match_the_split_without_reading_motions(tmp_path, monkeypatch):
    write_tiny_dataset(tmp_path)
    expected = [c.captions for c in MotionDataset(tmp_path).split("train")]
    fresh = MotionDataset(tmp_path)
    real_load = np.load

    def header_only(path, *args, **kwargs):  # reading a motion's values here would be the slow path
        assert kwargs.get("mmap_mode") == "r", f"{path} was read, not mapped"
        return real_load(path, *args, **kwargs)

    monkeypatch.setattr(np, "load", header_only)
    assert fresh.captions("train") == expected and len(expected) == 3  # same clips, segments and length filter


@pytest.mark.parametrize("version", [(1, 0), (2, 0)])
def test_the_shape_is_read_from_the_npy_header_alone(tmp_path, version):
    from motionlab.data.humanml3d import _shape_only

    array = np.arange(7 * 5, dtype=np.float32).reshape(7, 5)
    path = tmp_path / "clip.npy"
    with open(path, "wb") as f:
        np.lib.format.write_array(f, array, version=version)
    stand_in = _shape_only(path)
    assert stand_in.shape == (7, 5) and len(stand_in[2:6]) == 4 and stand_in.nbytes == array.nbytes
