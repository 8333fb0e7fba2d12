"""What each recorded key measures, as a reader reads it: ``chapter/key`` -> (quantity, condition)."""

from __future__ import annotations

# ----------------------------------------------------------------------------------------------
# What each key measures, for sentences a reader can follow (no raw keys on a page)

# ``chapter/key`` -> (quantity, condition). Every key a claim, a mechanism or a chapter finding reads has one (a test
# checks); a key without one (an ad-hoc claim) is shown by its name.
QUANTITIES: dict[str, tuple[str, str]] = {
    # 01 Motion as data
    "motion_data/roundtrip_error": ("largest joints → features → joints error", ""),
    "motion_data/wrist_jerk_slow": ("mean wrist jerk", "a slow clip"),
    "motion_data/wrist_jerk_noisy": ("mean wrist jerk", "the same clip + 5 mm noise"),
    "motion_data/wrist_jerk_fast": ("mean wrist jerk", "a fast clip"),
    # 02 Vector quantization
    "vq/mpjpe_vq": ("MPJPE", "VQ, one codebook"),
    "vq/mpjpe_rvq": ("MPJPE", "residual VQ"),
    "vq/mpjpe_rvq_layers1": ("MPJPE", "first residual layer only"),
    "vq/static_sjpe_ff_vq": ("Static sJPE", "VQ decoder"),
    "vq/static_sjpe_ff_rvq": ("Static sJPE", "residual VQ decoder"),
    "vq/noise_sjpe_ff_vq": ("Noise sJPE", "VQ decoder"),
    "vq/noise_sjpe_ff_rvq": ("Noise sJPE", "residual VQ decoder"),
    "vq/sjpe_ff_vq": ("sJPE", "VQ decoder"),
    "vq/sjpe_ff_rvq": ("sJPE", "residual VQ decoder"),
    # 03 Rectified flow
    "flow/straightness_unconditional": ("path straightness (chord/arc)", "unconditional field"),
    "flow/straightness_conditional": ("path straightness (chord/arc)", "class-conditional field"),
    "flow/energy_unconditional_euler_nfe1": ("energy distance to the data", "unconditional, 1 Euler step"),
    "flow/energy_conditional_euler_nfe1": ("energy distance to the data", "conditional, 1 Euler step"),
    "flow/energy_unconditional_euler_nfe16": ("energy distance to the data", "unconditional, 16 Euler steps"),
    "flow/energy_unconditional_midpoint_nfe30": ("energy distance to the data", "unconditional, 15 midpoint steps"),
    "flow/energy_floor": ("energy distance", "two samples of the data (the noise floor)"),
    # 04 Condition projection
    "projection/heldout_mse_stacked": ("held-out reconstruction MSE", "stacked projection"),
    "projection/heldout_mse_repeat_linear": ("held-out reconstruction MSE", "repeat & linear"),
    "projection/heldout_mse_transposed": ("held-out reconstruction MSE", "transposed convolution"),
    "projection/train_fm_stacked": ("flow-matching loss", "training clips, stacked"),
    "projection/heldout_fm_stacked": ("flow-matching loss", "held-out clips, stacked"),
    # 05 DisCoRD
    "discord/sjpe_rf": ("sJPE", "flow decoder"),
    "discord/sjpe_ff": ("sJPE", "feed-forward decoder"),
    "discord/noise_sjpe_rf": ("Noise sJPE", "flow decoder"),
    "discord/noise_sjpe_ff": ("Noise sJPE", "feed-forward decoder"),
    "discord/static_sjpe_rf": ("Static sJPE", "flow decoder"),
    "discord/static_sjpe_ff": ("Static sJPE", "feed-forward decoder"),
    "discord/fid_rf": ("reconstruction FID", "flow decoder"),
    "discord/fid_ff": ("reconstruction FID", "feed-forward decoder"),
    "discord/mpjpe_rf": ("MPJPE", "flow decoder"),
    "discord/mpjpe_ff": ("MPJPE", "feed-forward decoder"),
    "discord/fid_steps2": ("FID", "2 steps"),
    "discord/fid_steps16": ("FID", "16 steps"),
    "discord/sjpe_steps2": ("sJPE", "2 steps"),
    "discord/sjpe_steps16": ("sJPE", "16 steps"),
    "discord/sjpe_rf_minus_ff": ("sJPE, flow − feed-forward decoder", "paired over the test clips"),
    "discord/noise_sjpe_rf_minus_ff": ("Noise sJPE, flow − feed-forward decoder", "paired over the test clips"),
    "discord/static_sjpe_rf_minus_ff": ("Static sJPE, flow − feed-forward decoder", "paired over the test clips"),
    "discord/mpjpe_rf_minus_ff": ("MPJPE, flow − feed-forward decoder", "paired over the test clips"),
    "discord/sjpe_steps2_minus_steps16": ("sJPE, 2 − 16 steps", "paired over the test clips"),
    "discord/time_steps2": ("time to decode a batch", "2 steps"),
    "discord/time_steps16": ("time to decode a batch", "16 steps"),
    "discord/time_ff": ("time to decode a batch", "feed-forward decoder"),
    "discord/noise_sjpe_boundary_share_rf": (
        "share of Noise sJPE on jerk centred on a token boundary",
        "flow decoder (¼ if the token grid left no trace)",
    ),
    "discord/noise_sjpe_boundary_share_ff": (
        "share of Noise sJPE on jerk centred on a token boundary",
        "feed-forward decoder",
    ),
    "discord/noise_sjpe_extra_at_boundaries": (
        "Noise sJPE the flow decoder adds over the feed-forward one",
        "on the ¼ of jerk stencils centred on a token boundary",
    ),
    "discord/noise_sjpe_extra_elsewhere": (
        "Noise sJPE the flow decoder adds over the feed-forward one",
        "on the other ¾",
    ),
    "discord/joint_jerk_rf": ("mean joint jerk", "flow decoder"),
    "discord/joint_jerk_ff": ("mean joint jerk", "feed-forward decoder"),
    "discord/joint_jerk_gt": ("mean joint jerk", "ground truth"),
    "discord/train_steps": ("training steps", "flow decoder (the paper: 481,896 at batch 768)"),
    "discord/sjpe_crossing_minutes": (
        "training minutes at which sJPE falls below the feed-forward decoder's",
        "x-prediction variant, longest sweep run",
    ),
    "discord/longest_run_minutes": ("training minutes", "longest sweep run (x-prediction variant)"),
    "discord/noise_floor": ("t = 0 loss floor (D − w)/D", "the paper's decoder at the build's width"),
    "discord/sjpe_xpred": ("sJPE", "x-prediction variant, zero start noise"),
    "discord/noise_sjpe_xpred": ("Noise sJPE", "x-prediction variant, zero start noise"),
    "discord/static_sjpe_xpred": ("Static sJPE", "x-prediction variant, zero start noise"),
    "discord/fid_xpred": ("FID", "x-prediction variant, zero start noise"),
    "discord/mpjpe_xpred": ("MPJPE", "x-prediction variant, zero start noise"),
    "discord/noise_sjpe_steps2": ("Noise sJPE", "2 steps"),
    "discord/noise_sjpe_steps16": ("Noise sJPE", "16 steps"),
    "discord/flops_ratio_steps16": ("arithmetic (FLOPs), 16 steps ÷ feed-forward", ""),
    "discord/time_ratio_steps16": ("CPU time, 16 steps ÷ feed-forward", ""),
    # 06 sJPE
    "sjpe/noise_sjpe_low": ("Noise sJPE", "low noise"),
    "sjpe/noise_sjpe_mid": ("Noise sJPE", "medium noise"),
    "sjpe/noise_sjpe_high": ("Noise sJPE", "high noise"),
    "sjpe/static_sjpe_high": ("Static sJPE", "high noise"),
    # 07 Discrete diffusion
    "diffusion/fid_guided": ("FID", "guided, s = 4"),
    "diffusion/fid_unguided": ("FID", "unguided, s = 0"),
    "diffusion/nll_uncond_xt": ("NLL of the true code at t = T", "unconditional branch"),
    "diffusion/unigram_entropy": ("entropy", "the code frequencies"),
    "diffusion/entropy_xt_s0": ("entropy of p(x0 | x_T)", "s = 0"),
    "diffusion/entropy_xt_s4": ("entropy of p(x0 | x_T)", "s = 4"),
    "diffusion/hist_tv_s0": ("code-histogram TV to real tokens", "s = 0"),
    "diffusion/hist_tv_s4": ("code-histogram TV to real tokens", "s = 4"),
    "diffusion/repeat_rate_real": ("adjacent repeats", "real tokens"),
    "diffusion/repeat_rate_s0": ("adjacent repeats", "s = 0"),
    "diffusion/repeat_rate_s4": ("adjacent repeats", "s = 4"),
    "diffusion/top3_unguided": ("R-Top3", "s = 0"),
    "diffusion/top3_guided": ("R-Top3", "s = 4"),
    # 08 Dynamic transitions
    "transitions/fid_dynamic": ("FID", "dynamic β(t, d)"),
    "transitions/fid_uniform": ("FID", "uniform β_t"),
    "transitions/max_tv_eta0.25": ("largest TV", "η = 0.25"),
    "transitions/max_tv_eta0.5": ("largest TV", "η = 0.5"),
    "transitions/max_tv_eta2": ("largest TV", "η = 2"),
    "transitions/kbeta_bar_t": ("the cap K·β̄_T", ""),
    "transitions/fid_dynamic_minus_uniform": ("FID, dynamic − uniform", ""),
    "transitions/fid_seed_gap_dynamic": ("FID, seed 1 − seed 0", "dynamic"),
    "transitions/fid_seed_gap_uniform": ("FID, seed 1 − seed 0", "uniform"),
    # 09 Two-Phase Sampling
    "tps/jerk_gt_single": ("transition Jerk", "real single motions"),
    "tps/jerk_gt_concat": ("transition Jerk", "real motions concatenated"),
    "tps/jerk_tps": ("transition Jerk", "TPS"),
    "tps/jerk_independent": ("transition Jerk", "independent sampling"),
    "tps/jerk_handshake": ("transition Jerk", "Handshake"),
    "tps/jerk_slerp": ("transition Jerk", "SLERP"),
    "tps/jerk_tps_uniform": ("transition Jerk", "TPS, uniform β_t"),
    "tps/fid_ts100": ("individual-motion FID", "T_s = T"),
    "tps/fid_ts90": ("individual-motion FID", "T_s = 0.9 T"),
    "tps/fid_ts50": ("individual-motion FID", "T_s = 0.5 T"),
    "tps/fid_handshake": ("individual-motion FID", "Handshake"),
    "tps/fid_separate": ("individual-motion FID", "actions decoded alone"),
    "tps/jerk_separate": ("transition Jerk", "actions decoded alone, motions concatenated"),
    "tps/segment_jerk_tps": ("Jerk inside the actions", "TPS"),
    "tps/jerk_tps_minus_independent": ("transition Jerk, TPS − independent", "paired per boundary"),
    "tps/jerk_tps_minus_uniform": ("transition Jerk, TPS dynamic − uniform β", "paired per boundary"),
    "tps/jerk_concat_minus_inside": ("transition Jerk, real cut − inside the clips it joins", "paired per boundary"),
    "tps/tokens_changed_ts90": ("tokens the joint phase changes", "T_s = 0.9 T"),
    "tps/tokens_changed_ts50": ("tokens the joint phase changes", "T_s = 0.5 T"),
}


def quantity(key: str) -> tuple[str, str]:
    """``(quantity, condition)`` of a ``chapter/key``: ``("sJPE", "flow decoder")``."""
    return QUANTITIES.get(key, (key.split("/", 1)[-1], ""))
