"""The registry: what the two papers claim, their numbers, the keys that are ours, and each chapter's findings."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

from motionlab.evaluation.papers import PAPER_NUMBERS

from .rules import AtMost, Between, Claim, Evidence, Greater, Increasing, Less, Rule, Within
from .store import Result

# ----------------------------------------------------------------------------------------------
# The registry. Paper numbers are HumanML3D unless marked; "FF" = the feed-forward VQ decoder.

# Why the laptop flow decoder lands where it does, as measured. First the noise floor of a velocity U-Net as narrow as
# the laptop's, then the lever the laptop build once pulled: the same network predicting the clean motion and decoding
# from zero noise (discord/rvq-xpred, never judged itself), then how far its budget is from a crossing (the sweep
# measured the variant), then where the extra jerk sits. The first line is the one-line "why" of a chapter's table and
# of What reproduces' overview.
_FLOW_BUDGET = (
    Evidence(
        "the start noise a velocity U-Net narrower than the motion cannot see: its t = 0 loss floor (D − w)/D, "
        "0 at the paper's width (study s1)",
        ("discord/noise_floor",),
    ),
    Evidence(
        "the x-prediction variant from zero noise (a lever, not the paper) on the same tokens: sJPE, Noise sJPE, "
        "Static sJPE, FID",
        ("discord/sjpe_xpred", "discord/noise_sjpe_xpred", "discord/static_sjpe_xpred", "discord/fid_xpred"),
    ),
    Evidence(
        "when the variant's sJPE falls below the feed-forward decoder's in the sweep (measured if inside the run, else "
        "extrapolated in log-time)",
        ("discord/sjpe_crossing_minutes",),
    ),
    Evidence("training steps, and the sweep's longest run", ("discord/train_steps", "discord/longest_run_minutes")),
    Evidence(
        "where the extra jerk sits: share on the ¼ of jerk stencils centred on a token boundary",
        (
            "discord/noise_sjpe_boundary_share_rf",
            "discord/noise_sjpe_boundary_share_ff",
            "discord/noise_sjpe_extra_at_boundaries",
            "discord/noise_sjpe_extra_elsewhere",
        ),
    ),
)
_JOINT_JERK = (
    Evidence(
        "mean joint jerk (m/s³): flow decoder, feed-forward decoder, ground truth",
        ("discord/joint_jerk_rf", "discord/joint_jerk_ff", "discord/joint_jerk_gt"),
    ),
)
_STEPS_NOISE = (
    Evidence(
        "Noise sJPE, 2 → 16 steps (the jitter an evaluation of the field leaves in each frame)",
        ("discord/noise_sjpe_steps2", "discord/noise_sjpe_steps16"),
    ),
)
_CPU_TIME = (
    Evidence(
        "CPU time vs arithmetic, 16 steps ÷ feed-forward (close when time follows FLOPs, as on a busy CPU; "
        "on a GPU a small batch is bound by kernel-launch latency instead)",
        ("discord/time_ratio_steps16", "discord/flops_ratio_steps16"),
    ),
)
# The multi-motion generator's seams: smoother than the insides of its actions, before TPS does anything.
_SEAMS = (
    Evidence(
        "Jerk inside the generated actions vs at their seams (tokens decoded together) vs actions decoded alone",
        ("tps/segment_jerk_tps", "tps/jerk_tps", "tps/jerk_separate"),
    ),
)

CLAIMS: tuple[Claim, ...] = (
    # --- DisCoRD (Cho et al.) ------------------------------------------------------------------
    Claim(
        "DisCoRD",
        "Table 1",
        "Decoding the same tokens with the rectified-flow decoder lowers sJPE.",
        "MoMask 0.512 → 0.385; T2M-GPT 0.564 → 0.488; KIT-ML MoMask 0.384 → 0.359",
        Less("discord/sjpe_rf", "discord/sjpe_ff", clips="discord/sjpe_rf_minus_ff"),
        mechanism=_FLOW_BUDGET,
    ),
    Claim(
        "DisCoRD",
        "Fig. 5, Fig. C",
        "The flow decoder removes frame-wise noise: Noise sJPE falls.",
        "shown per sample (jerk plots), no table",
        Less("discord/noise_sjpe_rf", "discord/noise_sjpe_ff", clips="discord/noise_sjpe_rf_minus_ff"),
        mechanism=_FLOW_BUDGET,
    ),
    Claim(
        "DisCoRD",
        "Fig. 5, Fig. B",
        "The flow decoder restores dynamism lost to quantization: Static sJPE falls.",
        "shown per sample (jerk plots), no table",
        Less("discord/static_sjpe_rf", "discord/static_sjpe_ff", clips="discord/static_sjpe_rf_minus_ff"),
        mechanism=_FLOW_BUDGET[1:2] + _JOINT_JERK,
    ),
    Claim(
        "DisCoRD",
        "Table 1",
        "Reconstruction FID improves with the flow decoder.",
        "MoMask 0.019 → 0.011; T2M-GPT 0.089 → 0.031; MMM 0.097 → 0.020",
        Less("discord/fid_rf", "discord/fid_ff"),
        mechanism=_FLOW_BUDGET[:4],  # the floor, the variant, the crossing and the budget
    ),
    Claim(
        "DisCoRD",
        "Table 1",
        "Positional accuracy is not what improves: MPJPE gets worse on HumanML3D.",
        "MoMask 29.5 → 33.3 mm; T2M-GPT 60.0 → 71.5 mm (KIT-ML MoMask improves: 37.5 → 33.0)",
        Greater("discord/mpjpe_rf", "discord/mpjpe_ff", clips="discord/mpjpe_rf_minus_ff"),
        mechanism=_FLOW_BUDGET[:2] + _FLOW_BUDGET[3:4] + _JOINT_JERK,  # the floor, the variant, the budget, the joints
    ),
    Claim(
        "DisCoRD",
        "Table E",
        "Few steps suffice: FID at 2 steps is close to FID at 16 steps (the paper's steps "
        "are midpoint grid points: 2 = 2 network evaluations, 16 = 30).",
        "FID 0.034 (2 steps) vs 0.032 (16 steps)",
        Within("discord/fid_steps2", "discord/fid_steps16", 0.25),
        mechanism=_STEPS_NOISE,
    ),
    Claim(
        "DisCoRD",
        "Fig. 6",
        "sJPE is more sensitive to the number of steps than FID: fewer steps, higher sJPE.",
        "sJPE rises as steps drop from 16 to 2 while FID barely moves (plot)",
        Greater("discord/sjpe_steps2", "discord/sjpe_steps16", clips="discord/sjpe_steps2_minus_steps16"),
        mechanism=_STEPS_NOISE,
    ),
    Claim(
        "DisCoRD",
        "Table E",
        "Decoding time grows with the number of steps (midpoint grid points).",
        "0.016 s (2 steps) → 0.221 s (16) → 1.426 s (100), batch of 32, RTX 4090",
        Less("discord/time_steps2", "discord/time_steps16"),
        mechanism=_CPU_TIME,
    ),
    Claim(
        "DisCoRD",
        "Table E, Fig. 6",
        "At 16 steps the flow decoder is about as fast as the feed-forward decoder.",
        "0.221 s vs MoMask 0.244 s on a GPU",
        Within("discord/time_steps16", "discord/time_ff", 0.5),
        mechanism=_CPU_TIME,
    ),
    Claim(
        "DisCoRD",
        "Table 6",
        "Stacked per-frame projection generalises better than Repeat & Linear to tokens not seen in training.",
        "generation FID 0.032 vs 0.038 (reconstruction FID 0.011 vs 0.011)",
        Less("projection/heldout_mse_stacked", "projection/heldout_mse_repeat_linear"),
        mechanism=(
            Evidence(
                "no generalisation gap to close at this budget: flow-matching loss on held-out vs training clips",
                ("projection/heldout_fm_stacked", "projection/train_fm_stacked"),
            ),
            Evidence("the third projection", ("projection/heldout_mse_transposed",)),
        ),
    ),
    Claim(
        "DisCoRD",
        "Fig. 4",
        "Frame-wise Gaussian noise shows up as Noise sJPE, not Static sJPE.",
        "Noise sJPE rises steeply with σ; Static sJPE stays low (plot)",
        Greater("sjpe/noise_sjpe_high", "sjpe/static_sjpe_high"),
    ),
    Claim(
        "DisCoRD",
        "Fig. 4",
        "Noise sJPE grows with the noise level.",
        "monotone curve over σ (plot)",
        Increasing(("sjpe/noise_sjpe_low", "sjpe/noise_sjpe_mid", "sjpe/noise_sjpe_high")),
    ),
    # --- M2D2M (Chi et al.) --------------------------------------------------------------------
    Claim(
        "M2D2M",
        "Table 1, Fig. 5",
        "Concatenating real motions makes a jerky transition.",
        "Jerk: GT concat 1.371 vs GT single 1.192",
        Greater("tps/jerk_gt_concat", "tps/jerk_gt_single"),
        mechanism=(
            Evidence(
                "paired per boundary: the cut against windows inside the two clips it joins",
                ("tps/jerk_concat_minus_inside",),
            ),
        ),
    ),
    Claim(
        "M2D2M",
        "Table 1",
        "TPS transitions are smoother than concatenated real motions but not over-smoothed.",
        "Jerk: GT single 1.192 < M2D2M 1.238 < GT concat 1.371",
        Between("tps/jerk_tps", "tps/jerk_gt_single", "tps/jerk_gt_concat"),
        mechanism=_SEAMS,
    ),
    Claim(
        "M2D2M",
        "Supp. Table 5",
        "Joint denoising steps smooth the transition compared with independent sampling.",
        "Jerk: w/o TPS 1.402 → T_s = 90: 1.238",
        Less("tps/jerk_tps", "tps/jerk_independent"),
        mechanism=(
            Evidence("paired per boundary", ("tps/jerk_tps_minus_independent",)),
            Evidence("how much the joint phase changes", ("tps/tokens_changed_ts90",)),
            *_SEAMS,
        ),
    ),
    Claim(
        "M2D2M",
        "Supp. Table 5",
        "Fidelity trade-off: individual-motion FID rises as T_s shrinks (keys: T_s = 100%, 90%, 50% of T).",
        "FID 0.196 (T_s=100) < 0.254 (90) < 0.371 (50), T = 100",
        Increasing(("tps/fid_ts100", "tps/fid_ts90", "tps/fid_ts50")),
        mechanism=(
            Evidence("how much the joint phase changes", ("tps/tokens_changed_ts90", "tps/tokens_changed_ts50")),
        ),
    ),
    Claim(
        "M2D2M",
        "Table 6",
        "Handshake over-smooths: its transition Jerk falls below real single motions.",
        "Jerk: Handshake 1.097 vs GT single 1.192",
        Less("tps/jerk_handshake", "tps/jerk_gt_single"),
        mechanism=_SEAMS,
    ),
    Claim(
        "M2D2M",
        "Table 6",
        "SLERP over-smooths even more: transition Jerk below real single motions.",
        "Jerk: SLERP −3.554 vs GT single 1.192",
        Less("tps/jerk_slerp", "tps/jerk_gt_single"),
        mechanism=_SEAMS,
    ),
    Claim(
        "M2D2M",
        "Table 6",
        "TPS keeps individual motions more faithful than Handshake.",
        "individual FID: TPS 0.254 vs Handshake 1.279 (SLERP 1.402)",
        Less("tps/fid_ts90", "tps/fid_handshake"),
        mechanism=(
            Evidence(
                "what the evaluator sees: actions decoded alone (as Handshake's are) vs cut from one "
                "decoded sequence (TPS, independent)",
                ("tps/fid_separate", "tps/fid_ts100"),
            ),
        ),
    ),
    Claim(
        "M2D2M",
        "Table 5",
        "With TPS, dynamic β(t,d) gives smoother transitions than uniform β_t.",
        "Jerk 1.238 vs 1.265 (T_s = 90)",
        Less("tps/jerk_tps", "tps/jerk_tps_uniform"),
        mechanism=(
            Evidence("paired per boundary", ("tps/jerk_tps_minus_uniform",)),
            Evidence(
                "largest TV between rows of the dynamic and uniform forward processes (η = 0.25, the "
                "multi-motion model's)",
                ("transitions/max_tv_eta0.25",),
            ),
        ),
    ),
    Claim(
        "M2D2M",
        "Table 3",
        "Dynamic transition probabilities improve single-motion FID over uniform ones.",
        "FID 0.087 (β(t,d)) vs 0.115 (β_t); KIT-ML 0.378 vs 0.404",
        Less("transitions/fid_dynamic", "transitions/fid_uniform"),
        mechanism=(
            Evidence(
                "largest TV between rows of the dynamic and the uniform forward process Q̄_t (η = 0.25, 0.5, 2; "
                "at most K·β̄_T)",
                (
                    "transitions/max_tv_eta0.25",
                    "transitions/max_tv_eta0.5",
                    "transitions/max_tv_eta2",
                    "transitions/kbeta_bar_t",
                ),
            ),
            Evidence(
                "FID dynamic − uniform over training runs (t over the training seeds, or training seed 0 averaged "
                "with the training-seed study's other runs)",
                ("transitions/fid_dynamic_minus_uniform",),
            ),
            Evidence(
                "FID gap between two training seeds of the same model (paired over repeats, or the study's numbers)",
                ("transitions/fid_seed_gap_dynamic", "transitions/fid_seed_gap_uniform"),
            ),
        ),
    ),
    Claim(
        "M2D2M",
        "Supp. Table 2",
        "Classifier-free guidance improves single-motion fidelity.",
        "FID 0.107 (s = 0) → 0.087 (s = 4)",
        Less("diffusion/fid_guided", "diffusion/fid_unguided"),
        mechanism=(
            Evidence(
                "NLL of the true code at t = T: unconditional branch vs the code frequencies' entropy",
                ("diffusion/nll_uncond_xt", "diffusion/unigram_entropy"),
            ),
            Evidence(
                "entropy of p(x0 | x_T) (nats), s = 0 → 4", ("diffusion/entropy_xt_s0", "diffusion/entropy_xt_s4")
            ),
            Evidence(
                "code-histogram TV to the real tokens, s = 0 → 4", ("diffusion/hist_tv_s0", "diffusion/hist_tv_s4")
            ),
            Evidence(
                "adjacent repeats: real, s = 0, s = 4",
                ("diffusion/repeat_rate_real", "diffusion/repeat_rate_s0", "diffusion/repeat_rate_s4"),
            ),
            Evidence("R-Top3, s = 0 → 4", ("diffusion/top3_unguided", "diffusion/top3_guided")),
        ),
    ),
)


def paper_results() -> dict[str, Result]:
    """:data:`PAPER_NUMBERS` as results (no intervals), to judge the claims on the papers' own numbers."""
    out = {}
    for name, (value, source) in PAPER_NUMBERS.items():
        chapter, key = name.split("/", 1)
        out[name] = Result(chapter, key, value, None, None, source, "full", "")
    return out


def claim_keys(claims: Sequence[Claim] = CLAIMS) -> tuple[str, ...]:
    """Every ``chapter/key`` the claims read, in first-use order: the keys chapters must record."""
    return tuple(dict.fromkeys(k for c in claims for k in c.keys))


# ----------------------------------------------------------------------------------------------
# What a chapter found: the box near each chapter's top


@dataclass(frozen=True)
class Finding:
    """A chapter's own result (not a paper's claim), judged like a claim on the chapter's recorded numbers."""

    statement: str
    rule: Rule

    @property
    def keys(self) -> tuple[str, ...]:
        return self.rule.keys


# Per chapter prefix: what the chapter shows besides the papers' claims (chapters 01-03 test no claim of a paper).
FINDINGS: dict[str, tuple[Finding, ...]] = {
    "motion_data": (
        Finding(
            "HumanML3D's features give the joints back exactly (up to canonicalisation).",
            AtMost("motion_data/roundtrip_error", 1e-5),
        ),
        Finding(
            "Frame-wise noise too small to see in a trajectory multiplies the jerk.",
            Less("motion_data/wrist_jerk_slow", "motion_data/wrist_jerk_noisy"),
        ),
    ),
    "vq": (
        Finding(
            "Residual quantization reconstructs positions more closely than one codebook.",
            Less("vq/mpjpe_rvq", "vq/mpjpe_vq"),
        ),
        Finding(
            "It also keeps more of the fast motion: less jerk lost (Static sJPE).",
            Less("vq/static_sjpe_ff_rvq", "vq/static_sjpe_ff_vq"),
        ),
        Finding(
            "Residual layers refine: decoding from all of them reconstructs closer than from the first alone.",
            Less("vq/mpjpe_rvq", "vq/mpjpe_rvq_layers1"),
        ),
    ),
    "flow": (
        Finding(
            "A condition (the class) straightens the learned paths.",
            Greater("flow/straightness_conditional", "flow/straightness_unconditional"),
        ),
        Finding(
            "With a condition, one network evaluation already lands near the data.",
            Less("flow/energy_conditional_euler_nfe1", "flow/energy_unconditional_euler_nfe1"),
        ),
        Finding(
            "Without one, more evaluations are needed: 16 Euler steps beat 1.",
            Less("flow/energy_unconditional_euler_nfe16", "flow/energy_unconditional_euler_nfe1"),
        ),
    ),
}
