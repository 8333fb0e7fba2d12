"""Chapter 07-08's diagrams: mask-and-replace, the blocks of Q_t and β(t, d) draw what the library computes."""

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pytest  # noqa: E402
import torch  # noqa: E402

from motionlab.diffusion import get_schedule, uniform_matrix, vqdiffusion_paper_schedule  # noqa: E402
from motionlab.diffusion.transitions import codebook_distance  # noqa: E402
from motionlab.viz import diagrams  # noqa: E402
from motionlab.viz.diagrams import m2d2m  # noqa: E402


@pytest.fixture(autouse=True)
def close_figures():
    yield
    plt.close("all")


def texts(fig) -> list[str]:
    return [t.get_text() for ax in fig.axes for t in ax.texts] + [ax.get_title() for ax in fig.axes]


def test_the_part_is_reachable_from_the_package():
    assert diagrams.m2d2m is m2d2m


def test_fate_counts_follow_the_schedule_and_never_undo_a_mask():
    schedule = get_schedule()
    for t in range(1, schedule.T + 1):
        c = m2d2m.fate_counts(schedule, t, 12)
        assert sum(c.values()) == 12 and min(c.values()) >= 0
        assert abs(c["kept"] - 12 * float(schedule.alpha_bar[t])) <= 0.5 + 1e-9  # the expected count, rounded
        assert abs(c["masked"] - 12 * float(schedule.gamma_bar[t])) <= 0.5 + 1e-9
    counts = [m2d2m.fate_counts(schedule, t, 12) for t in range(1, schedule.T + 1)]
    assert all(a["masked"] <= b["masked"] and a["kept"] >= b["kept"] for a, b in zip(counts, counts[1:]))
    assert m2d2m.fate_counts(schedule, schedule.T, 20) == {"kept": 0, "replaced": 2, "masked": 18}  # ᾱ_T=0, γ̄_T=.9
    with pytest.raises(ValueError, match="num_tokens"):
        m2d2m.fate_counts(schedule, 5, 0)


def test_mask_and_replace_draws_three_rows_with_the_schedules_probabilities():
    schedule = get_schedule()
    fig = m2d2m.mask_and_replace(schedule, 60, num_tokens=12)
    assert fig.get_size_inches()[0] <= 7.4 + 1e-9
    ax = fig.axes[0]
    cells = [t.get_text() for t in ax.texts if t.get_text().isdigit() or t.get_text() == m2d2m.MASK_LABEL]
    rows = [cells[:12], cells[12:24], cells[24:36]]
    assert len(cells) == 36 and m2d2m.MASK_LABEL not in rows[0]
    c60, cT = m2d2m.fate_counts(schedule, 60, 12), m2d2m.fate_counts(schedule, schedule.T, 12)
    assert rows[1].count(m2d2m.MASK_LABEL) == c60["masked"] and rows[2].count(m2d2m.MASK_LABEL) == cT["masked"]
    assert sum(a == b for a, b in zip(rows[0], rows[1])) == c60["kept"]
    for first, second in zip(rows[1], rows[2]):  # the mask is absorbing
        assert first != m2d2m.MASK_LABEL or second == m2d2m.MASK_LABEL
    joined = "\n".join(texts(fig))
    assert f"= {float(schedule.gamma_bar[60]):.2f}" in joined and f"= {float(schedule.kbeta_bar[100]):.2f}" in joined
    assert [t.get_text() for t in ax.get_legend().get_texts()][2].startswith("masked")


def test_mask_and_replace_rejects_bad_input():
    with pytest.raises(ValueError, match="t must"):
        m2d2m.mask_and_replace(t=0)
    with pytest.raises(ValueError, match="before T"):
        m2d2m.mask_and_replace(t=100)
    with pytest.raises(ValueError, match="num_codes"):
        m2d2m.mask_and_replace(num_codes=1)
    with pytest.raises(ValueError, match="Schedule"):
        m2d2m.mask_and_replace(schedule="paper")


def test_transition_matrix_shows_the_librarys_q_t_cell_by_cell():
    schedule = vqdiffusion_paper_schedule(T=20)
    fig = m2d2m.transition_matrix(schedule, 7, num_codes=3)
    ax = fig.axes[0]
    shown = ax.images[0].get_array()
    Q = uniform_matrix(schedule, 7, 3).numpy()
    assert shown.shape == (4, 4) and np.allclose(shown.filled(0.0), Q)
    assert np.ma.is_masked(shown[3, 0]) and shown[3, 3] == 1.0  # the absorbing mask row: zeros, then 1
    cell_texts = [t.get_text() for t in ax.texts]
    assert len(cell_texts) == 16
    assert cell_texts[0] == f"$\\alpha_t{{+}}\\beta_t$\n{Q[0, 0]:.2g}" and cell_texts[3].startswith("$\\gamma_t$")
    assert cell_texts[-4:] == ["0", "0", "0", "1"]
    assert len(ax.patches) == 3  # the three blocks outlined
    assert any("absorbing" in t for t in texts(fig)) and any("t = 7 of T = 20" in t for t in texts(fig))


def test_transition_matrix_with_a_codebook_is_the_dynamic_one():
    codebook = m2d2m.ring_codebook(4)
    fig = m2d2m.transition_matrix(codebook=codebook, eta=8.0)
    shown = fig.axes[0].images[0].get_array().filled(0.0)
    off = shown[0, 1:4]
    assert off[0] < off[1] < off[2]  # farther codes get more with η > 0
    assert np.allclose(shown.sum(1), 1.0)


def test_transition_matrix_rejects_bad_input():
    with pytest.raises(ValueError, match="num_codes"):
        m2d2m.transition_matrix(num_codes=40)
    with pytest.raises(ValueError, match="needs a codebook"):
        m2d2m.transition_matrix(eta=0.5)
    with pytest.raises(ValueError, match="codebook"):
        m2d2m.transition_matrix(codebook=torch.zeros(20, 2), eta=0.5)
    with pytest.raises(ValueError, match="t must"):
        m2d2m.transition_matrix(t=101)


def test_ring_codebook_puts_code_j_at_rank_j():
    ranks = codebook_distance(m2d2m.ring_codebook(7), "l2_rank")
    assert ranks[0].tolist() == list(range(7))
    with pytest.raises(ValueError):
        m2d2m.ring_codebook(2)


def test_dynamic_beta_plots_the_shares_of_the_dynamic_matrix():
    schedule = get_schedule()
    fig = m2d2m.dynamic_beta(schedule, eta=4.0, etas=(0.0, 0.5, 4.0), num_codes=6)
    assert fig.get_size_inches()[0] <= 7.4 + 1e-9
    curves = fig.axes[2].lines[:3]
    flat, paper, strong = (line.get_ydata() for line in curves)
    assert np.allclose(flat, 1.0)
    assert np.all(np.diff(strong) > 0) and np.all(np.diff(paper) > 0)  # η > 0: far codes get more
    K = 6
    assert np.isclose(strong[-1] / strong[0], np.exp(4.0 * (K - 1) / K))  # e^{η (K-1)/K} at t = T
    assert np.isclose(np.mean(strong), 1.0)  # the replaced mass is VQ-Diffusion's
    uniform_widths, widths = (
        [a.arrow_patch.get_linewidth() for a in ax.texts if getattr(a, "arrow_patch", None)] for ax in fig.axes[:2]
    )
    assert len(widths) == K - 1 and len(set(np.round(uniform_widths, 6))) == 1 and max(widths) > max(uniform_widths)
    assert fig.axes[0].get_title().startswith("uniform") and "η = 4" in fig.axes[1].get_title()


def test_dynamic_beta_rejects_bad_input():
    with pytest.raises(ValueError, match=r"\(K, 2\)"):
        m2d2m.dynamic_beta(codebook=torch.zeros(5, 3))
    with pytest.raises(ValueError, match="finite"):
        m2d2m.dynamic_beta(etas=())
    with pytest.raises(ValueError, match="finite"):
        m2d2m.dynamic_beta(eta=float("nan"))
