"""The papers' printed numbers for the book's claim keys, with the table each comes from.

An evaluation sets some of them beside its own rows (DisCoRD's Table 1,
:data:`~motionlab.evaluation.reconstruction.PAPER_TABLE_1`); :mod:`motionlab.report.claims` judges its claims on them
as well, which checks that every rule points the way its paper's conclusion does.
"""

from __future__ import annotations

# The papers' own numbers for our keys (HumanML3D; DisCoRD rows use MoMask's tokenizer). Judging
# them with the rules above must reproduce each paper's conclusion: a check that every rule points
# the way its claim does. Keys whose quantity the paper only plots are absent.
PAPER_NUMBERS: dict[str, tuple[float, str]] = {
    "discord/sjpe_ff": (0.512, "DisCoRD Table 1"),
    "discord/sjpe_rf": (0.385, "DisCoRD Table 1"),
    "discord/fid_ff": (0.019, "DisCoRD Table 1"),
    "discord/fid_rf": (0.011, "DisCoRD Table 1"),
    "discord/mpjpe_ff": (29.5, "DisCoRD Table 1"),
    "discord/mpjpe_rf": (33.3, "DisCoRD Table 1"),
    "discord/fid_steps2": (0.034, "DisCoRD Table E"),
    "discord/fid_steps16": (0.032, "DisCoRD Table E"),
    "discord/time_steps2": (0.016, "DisCoRD Table E"),
    "discord/time_steps16": (0.221, "DisCoRD Table E"),
    "discord/time_ff": (0.244, "DisCoRD Table E"),
    "tps/jerk_gt_single": (1.192, "M2D2M Table 1"),
    "tps/jerk_gt_concat": (1.371, "M2D2M Table 1"),
    "tps/jerk_tps": (1.238, "M2D2M Table 1"),
    "tps/jerk_independent": (1.402, "M2D2M Supp. Table 5"),
    "tps/fid_ts100": (0.196, "M2D2M Supp. Table 5"),
    "tps/fid_ts90": (0.254, "M2D2M Supp. Table 5"),
    "tps/fid_ts50": (0.371, "M2D2M Supp. Table 5"),
    "tps/jerk_handshake": (1.097, "M2D2M Table 6"),
    "tps/jerk_slerp": (-3.554, "M2D2M Table 6"),
    "tps/fid_handshake": (1.279, "M2D2M Table 6"),
    "tps/jerk_tps_uniform": (1.265, "M2D2M Table 5"),
    "transitions/fid_dynamic": (0.087, "M2D2M Table 3"),
    "transitions/fid_uniform": (0.115, "M2D2M Table 3"),
    "diffusion/fid_guided": (0.087, "M2D2M Supp. Table 2"),
    "diffusion/fid_unguided": (0.107, "M2D2M Supp. Table 2"),
}
