"""sJPE (DisCoRD): hand-computed cases, properties, batching without padding leaks, KIT units."""

from pathlib import Path

import numpy as np
import pytest
import torch

from motionlab.metrics import mpjpe, sjpe, sjpe_dataset, sjpe_from_features

REPO = Path(__file__).resolve().parents[2]
SAMPLE_DIRS = [Path("/work/shared/data/humanml3d-sample"), REPO.parent / "shared" / "data" / "humanml3d-sample"]


def wiggly(rng: np.random.Generator, frames: int, joints: int = 22, scale: float = 0.05) -> np.ndarray:
    return np.cumsum(rng.normal(scale=scale, size=(frames, joints, 3)), axis=0)


def spike(frames: int, joints: int, joint: int, axis: int, height: float) -> np.ndarray:
    """All zeros except one coordinate that jumps to ``height`` at frame 3."""
    x = np.zeros((frames, joints, 3))
    x[3, joint, axis] = height
    return x


def test_hand_computed_small_clip():
    # T = 5 -> 2 jerk frames. Third differences of [0, 0, 0, h, 0] are h and -3h, times fps^3 = 8000.
    gt = spike(5, 22, 10, 0, 1.0) + spike(5, 22, 20, 1, 1.0)  # foot and wrist move in the ground truth
    pred = spike(5, 22, 10, 0, 2.0)  # the foot moves twice as much, the wrist not at all
    pred[:, 5] = np.random.default_rng(0).normal(size=(5, 3))  # joint 5 is not selected: ignored
    out = sjpe(pred, gt)
    # foot: |16000-8000|/24000 = 1/3 and |48000-24000|/72000 = 1/3 -> noise 2/3 over 2 frames
    assert out["noise"] == pytest.approx(1 / 3, abs=1e-9)
    # wrist: 8000/(8000+1e-6) and 24000/(24000+1e-6), both ~1 -> static 2 / 2 frames
    assert out["static"] == pytest.approx(1.0, abs=1e-9)
    assert out["sjpe"] == pytest.approx(out["noise"] + out["static"], abs=1e-12)
    ratio = sjpe(pred, gt, variant="ratio")
    # over = 8000 + 24000, under = 8000 + 24000, total = (24000 + 72000) + (8000 + 24000)
    assert ratio["noise"] == pytest.approx(0.25) and ratio["static"] == pytest.approx(0.25)


def test_identical_clips_score_zero():
    clip = wiggly(np.random.default_rng(1), 60)
    for variant in ("element", "ratio"):
        assert sjpe(clip, clip.copy(), variant=variant) == {"sjpe": 0.0, "noise": 0.0, "static": 0.0}


def test_static_ground_truth_is_all_noise_and_about_n_joints():
    rng = np.random.default_rng(2)
    gt = np.broadcast_to(rng.normal(size=(1, 22, 3)), (50, 22, 3))
    out = sjpe(wiggly(rng, 50), gt)
    assert out["static"] == 0.0
    assert out["noise"] == pytest.approx(4.0, abs=1e-6)  # 4 selected joints, each element ~1, / (T-3) only
    assert sjpe(gt, wiggly(rng, 50))["static"] == pytest.approx(4.0, abs=1e-6)  # and the mirror image


def test_per_clip_bounds_and_symmetry():
    rng = np.random.default_rng(3)
    for _ in range(5):
        a, b = wiggly(rng, 40), wiggly(rng, 40, scale=rng.uniform(0.01, 0.2))
        e, r = sjpe(a, b), sjpe(a, b, variant="ratio")
        assert 0.0 <= e["sjpe"] <= 4.0 and 0.0 <= r["sjpe"] <= 1.0
        swapped = sjpe(b, a)  # swapping prediction and truth swaps noise and static
        assert swapped["noise"] == pytest.approx(e["static"]) and swapped["static"] == pytest.approx(e["noise"])


def test_kit_units_joints_and_frame_rate():
    # Joint 7 jumps by 1000 mm = 1 m: jerks 1 and 3 m * 12.5^3 in the two jerk frames.
    gt = spike(5, 21, 7, 2, 1000.0)
    res = sjpe_dataset([np.zeros_like(gt)], [gt], skeleton="kit")
    assert res.jerk_gt_per_clip[0] == pytest.approx((1 + 3) * 12.5**3 / (2 * 2))  # mean over 2 frames x 2 joints
    assert res.static == pytest.approx(1.0, abs=1e-9)  # one joint, two frames: 2/2
    assert sjpe(np.zeros_like(gt), spike(5, 21, 5, 2, 1000.0), skeleton="kit")["sjpe"] == 0.0  # joint 5 unused
    t2m = sjpe_dataset([np.zeros((5, 22, 3))], [spike(5, 22, 21, 0, 1.0)])
    assert t2m.jerk_gt_per_clip[0] == pytest.approx((1 + 3) * 20.0**3 / (2 * 4))


def test_dataset_of_variable_lengths_matches_clip_by_clip():
    rng = np.random.default_rng(4)
    lengths = [40, 4, 73, 196]
    preds = [wiggly(rng, n) for n in lengths]
    gts = [wiggly(rng, n) for n in lengths]
    res = sjpe_dataset(preds, gts)
    singles = [sjpe(p, g) for p, g in zip(preds, gts)]
    np.testing.assert_allclose(res.sjpe_per_clip, [s["sjpe"] for s in singles], rtol=1e-12)
    np.testing.assert_allclose(res.noise_per_clip, [s["noise"] for s in singles], rtol=1e-12)
    assert res.sjpe == pytest.approx(np.mean([s["sjpe"] for s in singles]))
    # the same clips zero-padded, then with garbage in the padding: identical scores
    for fill in (0.0, 1e3, np.nan):
        pad_p = np.full((4, 196, 22, 3), fill)
        pad_g = np.full((4, 196, 22, 3), -fill)
        for i, n in enumerate(lengths):
            pad_p[i, :n], pad_g[i, :n] = preds[i], gts[i]
        padded = sjpe_dataset(torch.from_numpy(pad_p), pad_g, lengths=lengths)
        np.testing.assert_allclose(padded.sjpe_per_clip, res.sjpe_per_clip, rtol=1e-12)


def test_sjpe_from_features_crops_and_matches_joints():
    from motionlab.representation import recover_from_ric

    rng = np.random.default_rng(5)
    feats = rng.normal(scale=0.1, size=(2, 30, 263))
    noisy = feats + rng.normal(scale=0.01, size=feats.shape)
    lengths = [30, 17]
    res = sjpe_from_features(noisy, feats, lengths=lengths)
    for i, n in enumerate(lengths):
        p = np.asarray(recover_from_ric(noisy[i, :n], 22))
        g = np.asarray(recover_from_ric(feats[i, :n], 22))
        assert res.sjpe_per_clip[i] == pytest.approx(sjpe(p, g)["sjpe"], rel=1e-10)
    garbage = noisy.copy()
    garbage[1, 17:] = np.nan  # past the length: must not matter, not even be looked at
    np.testing.assert_allclose(sjpe_from_features(garbage, feats, lengths).sjpe_per_clip, res.sjpe_per_clip)


def test_real_clip_against_a_perturbed_copy():
    d = next((d for d in SAMPLE_DIRS if (d / "new_joint_vecs" / "012314.npy").is_file()), None)
    if d is None:
        pytest.skip("HumanML3D sample clip not available")
    feats = np.load(d / "new_joint_vecs" / "012314.npy").astype(np.float64)
    assert sjpe_from_features(feats, feats).sjpe == 0.0
    noisy = feats + np.random.default_rng(6).normal(scale=0.01, size=feats.shape)
    res = sjpe_from_features(noisy, feats)
    assert res.noise > res.static  # frame-wise noise adds jerk: mostly Noise sJPE (DisCoRD Fig. 4)


@pytest.mark.parametrize(
    "pred, gt, kwargs, match",
    [
        (np.zeros((10, 22, 3)), np.zeros((11, 22, 3)), {}, "same shape"),
        (np.zeros((3, 22, 3)), np.zeros((3, 22, 3)), {}, "at least 4 frames"),
        (np.zeros((10, 21, 3)), np.zeros((10, 21, 3)), {}, r"\(T, 22, 3\)"),
        (np.zeros((10, 22, 3)), np.zeros((10, 22, 3)), {"skeleton": "kit"}, r"\(T, 21, 3\)"),
        (np.full((10, 22, 3), np.nan), np.zeros((10, 22, 3)), {}, "NaN"),
        (np.zeros((10, 22, 3)), np.zeros((10, 22, 3)), {"variant": "mean"}, "variant"),
        (np.zeros((10, 22, 3)), np.zeros((10, 22, 3)), {"skeleton": "smpl"}, "skeleton"),
    ],
)
def test_sjpe_rejects_bad_input(pred, gt, kwargs, match):
    with pytest.raises(ValueError, match=match):
        sjpe(pred, gt, **kwargs)


def test_sjpe_dataset_rejects_mismatches():
    a = [np.zeros((10, 22, 3)), np.zeros((12, 22, 3))]
    with pytest.raises(ValueError, match="clips"):
        sjpe_dataset(a, a[:1])
    with pytest.raises(ValueError, match="clip 1"):
        sjpe_dataset(a, [a[0], np.zeros((13, 22, 3))])
    with pytest.raises(ValueError, match="exceeds"):
        sjpe_dataset(np.zeros((2, 10, 22, 3)), np.zeros((2, 10, 22, 3)), lengths=[10, 11])


def test_mpjpe_aligns_the_pelvis():
    rng = np.random.default_rng(7)
    gt = rng.normal(size=(8, 22, 3))
    shifted = gt + rng.normal(size=(8, 1, 3))  # a per-frame global offset costs nothing
    assert mpjpe(shifted, gt) == pytest.approx(0.0, abs=1e-12)
    pred = gt.copy()
    pred[:, 3] += [0.3, 0.4, 0.0]  # one of 22 joints off by 0.5
    assert mpjpe(pred, gt) == pytest.approx(0.5 / 22)
    assert mpjpe([pred, gt[:3]], [gt, gt[:3]]) == pytest.approx(0.5 * 8 / (22 * 11))  # poses pooled
    with pytest.raises(ValueError, match="same shape"):
        mpjpe(pred, gt[:4])


def test_sjpe_variants_score_each_variant_as_sjpe_dataset_does():
    from motionlab.metrics import sjpe_variants

    rng = np.random.default_rng(4)
    gt = [rng.normal(0, 0.1, (n, 22, 3)) for n in (10, 17)]
    pred = [g + rng.normal(0, 0.01, g.shape) for g in gt]
    both = sjpe_variants(pred, gt)
    for variant in ("element", "ratio"):
        alone = sjpe_dataset(pred, gt, variant=variant)
        np.testing.assert_array_equal(both[variant].noise_per_clip, alone.noise_per_clip)
        np.testing.assert_array_equal(both[variant].static_per_clip, alone.static_per_clip)
    with pytest.raises(ValueError, match="variants"):
        sjpe_variants(pred, gt, variants=("element", "mean"))


def test_noise_sjpe_by_phase_sums_to_noise_and_finds_a_token_grid():
    from motionlab.metrics import noise_sjpe_by_phase

    rng = np.random.default_rng(3)
    gt = [wiggly(rng, n) for n in (37, 52, 64)]
    # Jitter that ignores the tokens spreads over the phases; a step at every 4th frame (a blocky decoder) piles
    # the added jerk on the stencils centred on those boundaries (phase 0).
    smooth_noise = [g + 0.002 * rng.standard_normal(g.shape) for g in gt]
    blocky = [g + 0.01 * (np.arange(len(g)) // 4 % 2)[:, None, None] for g in gt]
    for pred in (smooth_noise, blocky):
        parts = noise_sjpe_by_phase(pred, gt, 4)
        assert parts.shape == (4,) and (parts >= 0).all()
        assert parts.sum() == pytest.approx(sjpe_dataset(pred, gt).noise, rel=1e-12)
    spread, piled = noise_sjpe_by_phase(smooth_noise, gt, 4), noise_sjpe_by_phase(blocky, gt, 4)
    assert spread.max() / spread.sum() < 0.35
    assert piled.argmax() == 0 and piled[0] / piled.sum() > 0.4
    assert piled[2] < 1e-9 * piled.sum()  # stencils inside one token (frames 4n .. 4n+3) see no step at all
    assert noise_sjpe_by_phase(gt, gt, 4).sum() == 0.0
    with pytest.raises(ValueError, match="period"):
        noise_sjpe_by_phase(gt, gt, 0)
    with pytest.raises(ValueError, match="same number"):
        noise_sjpe_by_phase(gt, gt[:2], 4)


def test_sjpe_elements_are_the_halves_one_clip_sums():
    from motionlab.metrics.jerk import finite_difference_jerk
    from motionlab.metrics.sjpe import SJPE_JOINTS, sjpe_elements

    jp, jt = np.array([3.0, 1.0, 0.0, 2.0]), np.array([1.0, 1.0, 0.0, 6.0])
    noise, static = sjpe_elements(jp, jt)
    np.testing.assert_allclose(noise, [2 / (4 + 1e-6), 0.0, 0.0, 0.0])  # only where the prediction has more
    np.testing.assert_allclose(static, [0.0, 0.0, 0.0, 4 / (8 + 1e-6)])  # only where it has less
    assert (noise * static == 0).all()
    # a clip's halves: the elements summed over jerk frames and the four joints, divided by T - 3
    rng = np.random.default_rng(5)
    gt, pred = wiggly(rng, 30), wiggly(rng, 30)
    joints = list(SJPE_JOINTS["t2m"])
    mags = [np.linalg.norm(finite_difference_jerk(x[:, joints], 20.0, axis=0), axis=-1) for x in (pred, gt)]
    n, s = sjpe_elements(*mags)
    out = sjpe(pred, gt)
    assert out["noise"] == pytest.approx(n.sum() / 27, rel=1e-12)
    assert out["static"] == pytest.approx(s.sum() / 27, rel=1e-12)
