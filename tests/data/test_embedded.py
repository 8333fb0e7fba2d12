"""The embedded (procedural) dataset: clips, kinematics, captions, on-disk layout, determinism, atomicity."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from motionlab.data.embedded import (
    FAMILIES,
    MAX_FRAMES,
    MIN_FRAMES,
    ensure_embedded,
    generate_clip,
    write_embedded_dataset,
)
from motionlab.data.embedded import writer as writer_module
from motionlab.data.embedded.captions import tag
from motionlab.representation import T2M, feature_slices, joints_to_features, process_joints, recover_from_ric
from motionlab.sizes import RUN, run_sizes

N_SMALL = 3 * len(FAMILIES)  # the smallest dataset that still stratifies


def _rng(seed: int = 0) -> np.random.Generator:
    return np.random.default_rng(seed)


def _bone_lengths(joints: np.ndarray) -> np.ndarray:
    parents = np.array(T2M.parents[1:])
    return np.linalg.norm(joints[:, 1:] - joints[:, parents], axis=-1)  # (T, 21)


@pytest.fixture(scope="module")
def clips():
    """Two whole clips of every family (seeds 0 and 1), two cut out of takes as the dataset's are (seeds 10 and
    13: both ends cut, and only the start), plus a chained one."""
    out = {(f, s): generate_clip(f, _rng(s)) for f in FAMILIES for s in (0, 1)}
    out |= {(f, s): generate_clip(f, _rng(s), cuts=True) for f in FAMILIES for s in (10, 13)}
    out[("walk+wave", 0)] = generate_clip("walk+wave", _rng(0))
    out[("walk+wave", 10)] = generate_clip("walk+wave", _rng(10), cuts=True)
    return out


@pytest.fixture(scope="module")
def dataset(tmp_path_factory) -> Path:
    return write_embedded_dataset(tmp_path_factory.mktemp("emb") / "ds", N_SMALL, seed=3, progress=False)


# --- clips -------------------------------------------------------------------------------------------------


def test_at_least_twelve_families():
    assert len(FAMILIES) >= 12


def test_every_family_generates_valid_clips(clips):
    for (family, _), clip in clips.items():
        assert clip.joints.dtype == np.float64 and clip.joints.shape[1:] == (22, 3), family
        assert MIN_FRAMES <= len(clip.joints) <= MAX_FRAMES, (family, len(clip.joints))
        assert np.isfinite(clip.joints).all()
        assert len(set(clip.captions)) >= 3, clip.captions
        for caption in clip.captions:
            tokens = tag(caption)
            assert tokens and all("/" in t and t.split("/")[1].isupper() for t in tokens), caption
        assert clip.family == family.split("+")[0]
        assert clip.single_action == ("+" not in family)


def test_bone_lengths_are_constant_and_match_the_target_skeleton(clips):
    for (family, _), clip in clips.items():
        lengths = _bone_lengths(clip.joints)
        np.testing.assert_allclose(
            lengths, np.broadcast_to(T2M.bone_lengths[1:], lengths.shape), atol=1e-9, err_msg=family
        )


def test_features_round_trip_through_recover_from_ric(clips):
    for (family, _), clip in clips.items():
        processed = process_joints(clip.joints, "t2m", retarget_to_target=False)
        assert processed.features.shape == (len(clip.joints) - 1, 263)
        recovered = recover_from_ric(processed.features, 22)
        np.testing.assert_allclose(recovered, processed.joints[:-1], atol=1e-5, err_msg=family)
        # The clips already carry the target bone lengths, so retargeting changes nothing.
        np.testing.assert_allclose(joints_to_features(clip.joints), processed.features, atol=1e-6)


def test_same_rng_seed_gives_the_same_clip_and_overrides_apply():
    a = generate_clip("wave", _rng(5), side="left", reps=3)
    b = generate_clip("wave", _rng(5), side="left", reps=3)
    c = generate_clip("wave", _rng(6), side="left", reps=3)
    np.testing.assert_array_equal(a.joints, b.joints)
    assert a.captions == b.captions
    assert not np.allclose(a.joints[: len(c.joints)], c.joints[: len(a.joints)])
    assert a.params["side"] == "left" and a.params["reps"] == 3
    assert any("left hand" in cap for cap in a.captions)
    assert len(generate_clip("walk", _rng(0), n_frames=120).joints) == 120


def test_walking_keeps_a_planted_foot_and_moves_forward():
    clip = generate_clip("walk", _rng(1), direction="forward", speed="normal", path="straight", duration=6.0)
    j = process_joints(clip.joints, retarget_to_target=False).joints  # canonical: floor y=0, facing +z
    feet = j[:, [7, 10, 8, 11]]
    lowest = feet[..., 1].argmin(axis=1)
    assert feet[..., 1].min(axis=1).max() < 0.03  # some foot joint is on the floor in every frame
    planted = feet[np.arange(len(j) - 1), lowest[:-1]]
    planted_next = feet[np.arange(1, len(j)), lowest[:-1]]
    slide = np.linalg.norm((planted_next - planted)[:, [0, 2]], axis=-1)
    assert np.median(slide) < 0.005  # the support foot does not skate (m per frame)
    assert j[-1, 0, 2] - j[0, 0, 2] > 3.0  # about 1 m/s for 6 s, forward
    contacts = joints_to_features(clip.joints)[:, feature_slices()["foot_contact"]]
    assert contacts[:, :2].max() == 1 and contacts[:, 2:].max() == 1  # both feet make contact ...
    assert contacts[:, :2].min() == 0 and contacts[:, 2:].min() == 0  # ... and both lift off


def test_backward_walk_goes_backward():
    clip = generate_clip("walk", _rng(2), direction="backward", path="straight", duration=5.0)
    j = process_joints(clip.joints, retarget_to_target=False).joints
    assert j[-1, 0, 2] - j[0, 0, 2] < -1.0


def test_jumps_leave_the_ground_and_land():
    clip = generate_clip("jump", _rng(0), mode="in_place", reps=1, height=0.3)
    j = process_joints(clip.joints, retarget_to_target=False).joints
    lowest = j[:, [7, 10, 8, 11], 1].min(axis=1)  # height of the lowest foot joint per frame
    assert lowest.max() > 0.2  # mid-air: every foot joint well above the floor
    assert lowest[0] < 0.02 and lowest[-1] < 0.02  # standing before and after
    air = lowest > 0.05
    contacts = joints_to_features(clip.joints)[:, feature_slices()["foot_contact"]]
    # HumanML3D labels contact by foot speed only, so the slow apex frames may count as contact, but the
    # fast frames of the flight do not, while the idle lead-in does.
    assert (contacts[air[:-1]].sum(axis=1) == 0).any()
    assert (contacts[0] == 1).all()
    forward = generate_clip("jump", _rng(0), mode="forward", reps=1, distance=0.8)
    jf = process_joints(forward.joints, retarget_to_target=False).joints
    assert 0.5 < jf[-1, 0, 2] - jf[0, 0, 2] < 1.2


def test_fast_actions_are_jerkier_than_slow_ones():
    def peak_wrist_jerk(clip):
        jerk = np.diff(clip.joints[:, [20, 21]], n=3, axis=0) * 20.0**3  # m/s^3
        return np.linalg.norm(jerk, axis=-1).max()

    fast = peak_wrist_jerk(generate_clip("punch", _rng(0), side="right", reps=3))
    slow = peak_wrist_jerk(generate_clip("raise_arms", _rng(0), direction="forward", reps=1))
    assert fast > 3 * slow


def test_chained_clip_is_flagged_and_captioned_as_a_sequence(clips):
    for seed in (0, 10):
        clip = clips[("walk+wave", seed)]
        assert not clip.single_action and clip.families == ("walk", "wave")
        assert all("then" in c.lower() or "after that" in c.lower() for c in clip.captions)
        assert [a["family"] for a in clip.params["actions"]] == ["walk", "wave"]


@pytest.mark.parametrize(
    "call",
    [
        lambda: generate_clip("fly", _rng()),
        lambda: generate_clip("walk+run+jump", _rng()),
        lambda: generate_clip("walk", _rng(), direction="up"),
        lambda: generate_clip("walk", _rng(), wings=2),
        lambda: generate_clip("walk", _rng(), n_frames=-5),
        lambda: generate_clip("walk", _rng(), n_frames=500),
        lambda: generate_clip("wave", _rng(), reps=-1),
        lambda: generate_clip("walk", _rng(), duration=-2.0),
        lambda: generate_clip("walk", 0),
        lambda: write_embedded_dataset("unused", len(FAMILIES) - 1),
        lambda: write_embedded_dataset("unused", N_SMALL, seed=-1),
    ],
)
def test_bad_inputs_raise_value_errors(call):
    with pytest.raises(ValueError):
        call()


# --- the dataset on disk ----------------------------------------------------------------------------------


def test_layout_matches_humanml3d(dataset):
    from motionlab.data import check_dataset, read_captions

    assert check_dataset(dataset) == []
    assert check_dataset(dataset / "nowhere") == [f"{dataset / 'nowhere'} does not exist"]
    splits = {s: (dataset / f"{s}.txt").read_text().split() for s in ("train", "val", "test", "all")}
    assert sorted(splits["train"] + splits["val"] + splits["test"]) == sorted(splits["all"])
    assert len(set(splits["all"])) == N_SMALL and all(i.startswith("E") and len(i) == 7 for i in splits["all"])
    meta = json.loads((dataset / "meta.json").read_text())
    assert meta["seed"] == 3 and meta["version"] >= 1 and len(meta["clips"]) == N_SMALL
    for split in ("train", "val", "test"):  # stratified: every family in every split
        assert {meta["clips"][i]["family"] for i in splits[split]} == set(FAMILIES), split
    for cid in splits["all"]:
        feats = np.load(dataset / "new_joint_vecs" / f"{cid}.npy")
        joints = np.load(dataset / "new_joints" / f"{cid}.npy")
        assert feats.dtype == np.float32 and feats.shape[1] == 263 and 40 <= len(feats) <= 196
        assert joints.dtype == np.float32 and joints.shape == (len(feats), 22, 3)
        np.testing.assert_allclose(recover_from_ric(feats, 22), joints, atol=1e-5)
        captions = read_captions(dataset / "texts" / f"{cid}.txt")
        assert len(captions) >= 3 and all(c.tokens and c.start == 0.0 and c.end == 0.0 for c in captions)
        assert meta["clips"][cid]["n_frames"] == len(feats)
        assert isinstance(meta["clips"][cid]["single_action"], bool)
    for name in ("Mean.npy", "Std.npy"):
        stats = np.load(dataset / name)
        assert stats.dtype == np.float32 and stats.shape == (263,)
    train = np.concatenate([np.load(dataset / "new_joint_vecs" / f"{i}.npy") for i in splits["train"]])
    np.testing.assert_allclose(np.load(dataset / "Mean.npy"), train.mean(axis=0), rtol=1e-4, atol=1e-6)


def _snapshot(root: Path) -> dict[str, bytes]:
    return {str(p.relative_to(root)): p.read_bytes() for p in sorted(root.rglob("*")) if p.is_file()}


def test_same_seed_same_bytes_different_seed_different(dataset, tmp_path):
    again = write_embedded_dataset(tmp_path / "again", N_SMALL, seed=3, progress=False)
    assert _snapshot(again) == _snapshot(dataset)
    other = write_embedded_dataset(tmp_path / "other", N_SMALL, seed=4, progress=False)
    a, b = _snapshot(dataset), _snapshot(other)
    assert a.keys() == b.keys()
    assert a["new_joint_vecs/E000000.npy"] != b["new_joint_vecs/E000000.npy"]


def test_failed_write_leaves_nothing_at_the_target(tmp_path, monkeypatch):
    real = writer_module.build_clip

    def flaky(seed, index, spec):
        if index == 10:
            raise RuntimeError("simulated crash while writing clip 10")
        return real(seed, index, spec)

    monkeypatch.setattr(writer_module, "build_clip", flaky)
    target = tmp_path / "data"
    with pytest.raises(RuntimeError, match="simulated"):
        write_embedded_dataset(target, N_SMALL, progress=False)
    assert not target.exists()
    assert list(tmp_path.iterdir()) == []  # the temporary folder is gone too


def test_existing_dataset_is_kept_unless_overwrite(dataset, tmp_path, monkeypatch):
    target = tmp_path / "keep"
    target.mkdir()
    (target / "precious.txt").write_text("do not lose me")
    with pytest.raises(FileExistsError):
        write_embedded_dataset(target, N_SMALL, progress=False)
    monkeypatch.setattr(writer_module.Normalizer, "fit", lambda *a, **k: (_ for _ in ()).throw(OSError("disk")))
    with pytest.raises(OSError, match="disk"):
        write_embedded_dataset(target, N_SMALL, progress=False, overwrite=True)
    assert (target / "precious.txt").read_text() == "do not lose me"


def test_ensure_embedded_generates_once_into_the_cache(isolated_cache, monkeypatch):
    monkeypatch.setitem(RUN["smoke"], "embedded_clips", N_SMALL)
    first = ensure_embedded("smoke", seed=1)
    assert first.is_relative_to(isolated_cache) and f"-n{N_SMALL}-s1" in first.name
    stamp = (first / "meta.json").stat().st_mtime_ns
    assert ensure_embedded("smoke", seed=1) == first
    assert (first / "meta.json").stat().st_mtime_ns == stamp  # read from the cache, not regenerated
    with pytest.raises(ValueError):
        ensure_embedded("huge")


def test_a_damaged_cached_dataset_is_moved_aside_and_generated_again(isolated_cache, monkeypatch, capsys):
    from motionlab.data import load_dataset

    monkeypatch.setitem(RUN["smoke"], "embedded_clips", N_SMALL)
    first = ensure_embedded("smoke", seed=1, progress=False)
    clip = sorted((first / "new_joint_vecs").iterdir())[5]
    whole = clip.read_bytes()
    clip.write_bytes(whole[: len(whole) // 2])  # a truncated file (a full disk, a killed copy)
    again = ensure_embedded("smoke", seed=1, progress=False)
    assert again == first and clip.read_bytes() == whole  # regenerated, byte for byte
    assert clip.name in capsys.readouterr().err
    assert [p for p in first.parent.iterdir() if ".damaged-" in p.name]
    # a folder given by path (not the cache) is never touched, but the error names the file
    mean = (again / "Mean.npy").read_bytes()
    (again / "Mean.npy").write_bytes(b"junk")
    assert writer_module.embedded_damage(again).startswith(str(again / "Mean.npy"))
    with pytest.raises(ValueError, match="Mean.npy"):
        load_dataset(again)
    (again / "Mean.npy").write_bytes(mean)
    clip.write_bytes(whole[:300])
    with pytest.raises(ValueError, match=clip.name):
        load_dataset(again).split("all", filter_lengths=False)


def test_profile_sizes_are_ordered():
    clips = [run_sizes(p).embedded_clips for p in ("smoke", "laptop", "full")]
    assert clips[0] >= 3 * len(FAMILIES) and clips == sorted(set(clips))


# --- fine structure ----------------------------------------------------------------------------------------


def test_fine_structure_changes_only_the_fine_motion():
    fine, plain = generate_clip("wave", _rng(5)), generate_clip("wave", _rng(5), fine=False)
    assert fine.captions == plain.captions and fine.params == plain.params  # every other draw is the same
    shift = np.abs(fine.joints - plain.joints).max()
    # tenths of a millimetre per frame; the root placement integrates the feet's motion, so the shift adds up to
    # at most a couple of centimetres over a clip: nothing a caption would notice
    assert 1e-5 < shift < 0.03


def test_fine_structure_matches_real_capture_jerk(shared_data):
    from motionlab.data.embedded.realism import embedded_sample, jerk_percentiles, real_reference_clips

    real = jerk_percentiles(list(real_reference_clips(shared_data).values()))
    ours = jerk_percentiles(embedded_sample(100))
    for p in ("p10", "p50", "p90"):  # the stated tolerance: within a factor of 1.5 of the pooled real clips
        assert real[p] / 1.5 < ours[p] < real[p] * 1.5, (p, ours[p], real[p])
    without = jerk_percentiles(embedded_sample(100, fine=False))
    assert without["p10"] < real["p10"] / 5  # what version 1 lacked: the quiet frames were far too still


# --- clips cut out of takes ---------------------------------------------------------------------------------

N_SAMPLE = 140


@pytest.fixture(scope="module")
def sample() -> list[tuple[np.ndarray, np.ndarray, dict]]:
    """Features of the first clips of a dataset (seed 0) as the writer builds them, the same clips whole (as
    version 2 made them), and their meta."""
    from motionlab.data.embedded.writer import _rng as clip_rng
    from motionlab.data.embedded.writer import build_clip, plan_families

    out = []
    for index, spec in enumerate(plan_families(N_SAMPLE, 0)):
        features, _, _, meta = build_clip(0, index, spec)
        whole = generate_clip(spec, clip_rng(0, 1, index)).joints
        out.append((features, joints_to_features(whole, "t2m", retarget_to_target=False), meta))
    return out


def test_most_dataset_clips_begin_and_end_moving(sample):
    from motionlab.data.embedded.generator import CUT_SHARE
    from motionlab.data.embedded.realism import edge_speeds

    cut = np.array([[edge_speeds(f)[f"moving_{e}"] for e in ("start", "end")] for f, _, _ in sample])
    whole = np.array([[edge_speeds(w)[f"moving_{e}"] for e in ("start", "end")] for _, w, _ in sample])
    assert (cut.mean(axis=0) > 0.35).all(), cut.mean(axis=0)  # about half: a slow move or wind-up reads as still
    assert (whole.mean(axis=0) < 0.1).all(), whole.mean(axis=0)  # whole clips stand still at both ends
    kinds = np.array([[m["params"]["starts"], m["params"]["ends"]] for _, _, m in sample])
    assert set(kinds.ravel()) <= {"rest", "move", "gait"}
    assert (np.abs((kinds != "rest").mean(axis=0) - CUT_SHARE) < 0.12).all()  # each end cut with CUT_SHARE
    gait = kinds == "gait"
    assert gait.any() and cut[gait].mean() > 0.9  # mid-stride is always moving
    assert cut[kinds == "rest"].mean() < 0.15


def test_cutting_makes_concatenations_jerkier_than_single_clips(sample):
    """M2D2M's "ground truth (concat)" Jerk above its "ground truth (single)": what the cuts are for. Whole clips
    (version 2) joined at rest gave the opposite."""
    from motionlab.data.embedded.realism import seam_pose_jump
    from motionlab.metrics import log_jerk_batch
    from motionlab.multimotion import concatenate_segments, real_windows, transition_jerk

    def concat(clips):  # four single actions in a row, as chapter 09's test set
        fours = [clips[i : i + 4] for i in range(0, len(clips) - 3, 4)]
        jerk = np.concatenate([transition_jerk(*concatenate_segments(f)) for f in fours])
        jumps = [seam_pose_jump(a, b) for f in fours for a, b in zip(f, f[1:])]
        return np.nanmean(jerk), np.median(jumps)

    single = [i for i, (_, _, m) in enumerate(sample) if m["single_action"]]
    cut, whole = [sample[i][0] for i in single], [sample[i][1] for i in single]
    (cut_jerk, cut_jump), (whole_jerk, whole_jump) = concat(cut), concat(whole)
    windows = real_windows(cut, 40, 0, n=3 * (len(cut) // 4))
    single_jerk = np.nanmean(log_jerk_batch(recover_from_ric(np.stack(windows))))
    assert cut_jump > 1.5 * whole_jump, (cut_jump, whole_jump)  # the pose jumps where two clips meet
    assert cut_jerk > whole_jerk + 0.15, (cut_jerk, whole_jerk)
    assert cut_jerk > single_jerk, (cut_jerk, single_jerk)


def test_a_take_keeps_counted_actions_whole_and_cuts_into_walks():
    from motionlab.data.embedded.generator import make_take

    for family, fn in FAMILIES.items():
        for seed in range(6):
            segment = fn(_rng(seed), MAX_FRAMES)
            take = make_take(_rng(100 + seed), [segment], segment.plan, (5, 5), (MIN_FRAMES, MAX_FRAMES))
            a, b = take.actions
            assert 0 <= take.start < take.stop <= len(take.plan) and MIN_FRAMES <= take.stop - take.start
            np.testing.assert_array_equal(take.plan.angles[a:b], segment.plan.angles)  # the action, unchanged
            if take.stop - take.start == MAX_FRAMES:
                continue  # trimmed to the longest clip
            if segment.continuous:  # walks and runs: a cut end is mid-stride
                assert (take.start > a) == (take.ends[0] == "gait") and (take.stop < b) == (take.ends[1] == "gait")
            else:  # the captions count repetitions or name a goal: the whole action is shown
                assert take.start <= a and take.stop >= b, (family, seed, take.ends)
                assert "gait" not in take.ends
            if take.ends[0] == "move":  # mid-way through a move from another posture: not at its start pose yet
                assert not np.allclose(take.plan.angles[take.start], segment.plan.angles[0])


def test_cut_clips_honour_the_requested_length():
    for family in ("walk", "turn", "punch", "run+clap"):
        for n_frames in (MIN_FRAMES, 120, MAX_FRAMES):
            for seed in (10, 11, 13):
                clip = generate_clip(family, _rng(seed), cuts=True, n_frames=n_frames)
                assert len(clip.joints) == n_frames, (family, n_frames, seed, clip.params)
                assert np.isfinite(clip.joints).all()


def test_cuts_change_the_window_not_the_action():
    for family in ("walk", "wave", "squat"):
        whole, cut = generate_clip(family, _rng(10)), generate_clip(family, _rng(10), cuts=True)
        again = generate_clip(family, _rng(10), cuts=True)
        np.testing.assert_array_equal(cut.joints, again.joints)  # deterministic
        assert cut.captions == again.captions and cut.params == again.params
        window = {"lead_in_s", "lead_out_s", "starts", "ends"}
        assert {k: v for k, v in whole.params.items() if k not in window} == {
            k: v for k, v in cut.params.items() if k not in window
        }
        assert whole.params["starts"] == whole.params["ends"] == "rest"
        assert cut.params["starts"] != "rest" and cut.params["lead_in_s"] == 0.0
        assert not any("stands still" in c for c in cut.captions)  # it does not: it starts moving


def test_real_clips_cut_out_of_takes_begin_moving(shared_data):
    """The yardstick on real data: the CMU takes (whole "start, walk, stop" recordings) begin at rest, windows
    cut out of them mid-take do not. CMU data: mocap.cs.cmu.edu, created with funding from NSF EIA-0196217."""
    from motionlab.data.embedded.realism import edge_speeds
    from motionlab.io.bvh_import import bvh_to_features

    for take in ("131_02", "131_03"):
        path = shared_data / "cmu-bvh" / f"{take}.bvh"
        assert edge_speeds(bvh_to_features(path))["moving_start"] == 0.0
        assert edge_speeds(bvh_to_features(path, start=100, end=161))["moving_start"] == 1.0
