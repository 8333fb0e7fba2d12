"""Measurements that explain a discrete-diffusion result: what guidance does to p_θ(x_0 | x_t), what it does to
the sampled tokens, and how far two forward processes are apart.

Token ids follow the sampler's convention throughout: a (B, L) long tensor padded with −1 (or a list of 1-D
sequences), codes in ``[0, K)``.

**The denoiser's distribution.** :func:`x0_entropy` draws ``x_t ~ q(x_t | x_0)`` for real token sequences and
reports, for each t, the mean entropy of the model's p_θ(x_0 | x_t, y) over the real positions and the mean
negative log-likelihood of the true code. With a guidance scale s it scores the guided distribution exactly
as the sampler forms it (:func:`~motionlab.diffusion.classifier_free_guidance` on p_θ(x_0 | x_t)); with
``condition="null"`` it scores the unconditional branch p_θ(x_0 | x_t, ∅). If that branch is not much
better than the code frequencies (its NLL close to the unigram entropy, :func:`code_entropy`), then
(s+1)·log p_c − s·log p_u ≈ (s+1)·log p_c − s·log(marginal): a temperature 1/(s+1) on p_c plus a tilt away
from frequent codes — guidance *sharpens* rather than adds information about the text.

**The sampled tokens.** :func:`histogram_tv` is the total variation between the code frequencies of two
token sets (0: the same histogram, 1: disjoint); :func:`adjacent_repeat_rate` the fraction of neighbouring
token pairs that hold the same code (a sharpened sampler repeats its favourite codes).

**The forward process.** :func:`forward_tv` is, for each t, the total variation between the rows of Q̄_t of
two processes (row x_0 = the distribution of x_t); :func:`dynamic_uniform_tv` computes it in float64 for
M2D2M's β(t, d) against uniform β_t over a grid of η. Only the replaced mass can move, so under a schedule
with K·β̄_t the distance is at most K·β̄_t (0.1 at t = T for the book's schedule).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import torch
from torch import Tensor, nn

from motionlab.diffusion.posterior import q_sample
from motionlab.diffusion.sampling import _model_log_p_x0, classifier_free_guidance
from motionlab.diffusion.schedule import Schedule
from motionlab.diffusion.transitions import Transitions, codebook_distance, dynamic_matrix, uniform_matrix
from motionlab.train.device import model_device, to_device

CONDITIONS = ("text", "null")
TV_REDUCTIONS = ("max", "mean")


# ------------------------------------------------------------------------------------------ token ids


def token_rows(ids: Tensor | Sequence[Tensor]) -> Tensor:
    """(B, L) long ids padded with −1, from such a tensor or from a list of 1-D sequences."""
    if isinstance(ids, Tensor):
        if ids.ndim != 2 or ids.dtype.is_floating_point:
            raise ValueError(f"ids must be a (B, L) integer tensor padded with -1, got {tuple(ids.shape)} {ids.dtype}")
        return ids.long().cpu()
    seqs = [torch.as_tensor(s).long().flatten().cpu() for s in ids]
    if not seqs:
        raise ValueError("ids is empty: need at least one token sequence")
    out = torch.full((len(seqs), max(1, max(s.numel() for s in seqs))), -1, dtype=torch.long)
    for b, s in enumerate(seqs):
        out[b, : s.numel()] = s
    return out


def code_histogram(ids: Tensor | Sequence[Tensor], num_codes: int) -> Tensor:
    """(K,) float64 frequencies of the codes in ``ids`` (padding ignored); sums to 1."""
    rows = token_rows(ids)
    codes = rows[rows >= 0]
    if codes.numel() == 0:
        raise ValueError("ids hold no codes (only padding)")
    if int(codes.max()) >= num_codes:
        raise ValueError(f"ids hold code {int(codes.max())}, outside [0, num_codes={num_codes})")
    return torch.bincount(codes, minlength=num_codes).double() / codes.numel()


def code_entropy(ids: Tensor | Sequence[Tensor], num_codes: int) -> float:
    """Entropy (nats) of the code frequencies: the NLL a model that ignores context and text would reach."""
    p = code_histogram(ids, num_codes)
    p = p[p > 0]
    return float(-(p * p.log()).sum())


def histogram_tv(ids_a: Tensor | Sequence[Tensor], ids_b: Tensor | Sequence[Tensor], num_codes: int) -> float:
    """Total variation ½·Σ_k |p_a(k) − p_b(k)| between the code frequencies of two token sets, in [0, 1]."""
    return float(0.5 * (code_histogram(ids_a, num_codes) - code_histogram(ids_b, num_codes)).abs().sum())


def adjacent_repeat_rate(ids: Tensor | Sequence[Tensor]) -> float:
    """Fraction of neighbouring token pairs (both real, inside one sequence) that hold the same code."""
    rows = token_rows(ids)
    left, right = rows[:, :-1], rows[:, 1:]
    pairs = (left >= 0) & (right >= 0)
    if not bool(pairs.any()):
        raise ValueError("ids hold no pair of neighbouring codes (every sequence is shorter than 2)")
    return float(((left == right) & pairs).sum() / pairs.sum())


# ------------------------------------------------------------------------------------ p_θ(x_0 | x_t)


@dataclass(frozen=True)
class EntropyCurve:
    """Per step t: mean entropy of p_θ(x_0 | x_t) and mean NLL of the true code (nats, over real tokens)."""

    timesteps: tuple[int, ...]
    entropy: Tensor  # (n_t,) float64
    nll: Tensor  # (n_t,) float64
    guidance_scale: float
    condition: str

    def at(self, t: int) -> tuple[float, float]:
        """(entropy, nll) at step ``t``."""
        i = self.timesteps.index(int(t))
        return float(self.entropy[i]), float(self.nll[i])


@torch.no_grad()
def x0_entropy(
    model: nn.Module,
    transitions: Transitions,
    x0: Tensor | Sequence[Tensor],
    text: Tensor,
    text_padding_mask: Tensor | None = None,
    *,
    timesteps: Sequence[int],
    generator: torch.Generator,
    guidance_scale: float = 0.0,
    condition: str = "text",
) -> EntropyCurve:
    """Entropy of the (guided) p_θ(x_0 | x_t, y) and NLL of the true x_0, for x_t ~ q(x_t | x_0), per t.

    Args:
        x0: real token ids (B, L) padded with −1 (or B sequences); ``text`` (B, S, d) their captions' features.
        timesteps: steps in [1, T] to measure at; one fresh x_t per step from ``generator``.
        guidance_scale: M2D2M's s, applied to p_θ(x_0 | x_t) as the sampler's default ``guidance_on="x0"``.
        condition: ``"text"`` (the captions) or ``"null"`` (the unconditional branch; then s must be 0).

    The network runs on its own device; the curve holds one host number per step, on the CPU.
    """
    if condition not in CONDITIONS:
        raise ValueError(f"condition must be one of {CONDITIONS}, got {condition!r}")
    if condition == "null" and guidance_scale != 0.0:
        raise ValueError("guidance_scale must be 0 with condition='null' (there is no text to guide towards)")
    rows = token_rows(x0)
    steps = [int(t) for t in timesteps]
    if not steps or any(not 1 <= t <= transitions.T for t in steps):
        raise ValueError(
            f"timesteps must be a non-empty list of steps in [1, T={transitions.T}], got {list(timesteps)}"
        )
    if not torch.is_tensor(text) or text.ndim != 3 or text.shape[0] != rows.shape[0]:
        raise ValueError(f"text must be (B={rows.shape[0]}, S, d) features, got {tuple(getattr(text, 'shape', ()))}")
    dev = model_device(model, text.device)  # the network runs where it lives
    text, text_padding_mask = to_device((text, text_padding_mask), dev)
    padding = (rows < 0).to(dev)  # (B, L)
    clean = rows.clamp_min(0).to(dev)
    real = (~padding).double()
    B = rows.shape[0]
    entropy, nll = [], []
    model.eval()
    for t in steps:
        x_t = q_sample(clean, transitions.cumulative[t].to(dev), generator).masked_fill(padding, transitions.mask_id)
        kw = dict(text_padding_mask=text_padding_mask, padding_mask=padding)
        if condition == "null":
            steps_t = torch.full((B,), t, dtype=torch.long, device=dev)
            log_p = model(x_t, steps_t, text, drop_text=torch.ones(B, dtype=torch.bool, device=dev), **kw)
        else:
            log_c, log_u = _model_log_p_x0(model, x_t, t, text, guidance_scale != 0.0, **kw)
            log_p = log_c if log_u is None else classifier_free_guidance(log_c, log_u, guidance_scale)
        log_p = log_p.double()  # (B, L, K)
        h = -(log_p.exp() * log_p).sum(-1)  # (B, L)
        true = -log_p.gather(-1, clean[..., None]).squeeze(-1)  # (B, L)
        entropy.append(float((h * real).sum() / real.sum()))
        nll.append(float((true * real).sum() / real.sum()))
    return EntropyCurve(
        tuple(steps),
        torch.tensor(entropy, dtype=torch.float64),
        torch.tensor(nll, dtype=torch.float64),
        float(guidance_scale),
        condition,
    )


# ------------------------------------------------------------------------------------ forward processes


def _row_tv(a: Tensor, b: Tensor, reduce: str, weights: Tensor | None) -> Tensor:
    """TV between the code rows of two (..., K+1, K+1) matrices, reduced over rows -> (...)."""
    K = a.shape[-1] - 1
    tv = 0.5 * (a[..., :K, :].double() - b[..., :K, :].double()).abs().sum(-1)  # (..., K)
    if reduce == "max":
        return tv.max(dim=-1).values
    return tv @ weights


def _check_reduce(reduce: str, weights: Tensor | None, K: int) -> Tensor | None:
    if reduce not in TV_REDUCTIONS:
        raise ValueError(f"reduce must be one of {TV_REDUCTIONS}, got {reduce!r}")
    if reduce == "max":
        return None
    w = torch.full((K,), 1.0 / K, dtype=torch.float64) if weights is None else torch.as_tensor(weights).double()
    if w.shape != (K,) or bool((w < 0).any()) or float(w.sum()) <= 0:
        raise ValueError(f"weights must be K={K} non-negative numbers with a positive sum")
    return w / w.sum()


def forward_tv(a: Transitions, b: Transitions, reduce: str = "max", weights: Tensor | None = None) -> Tensor:
    """(T+1,) float64 total variation between the rows x_0 of Q̄_t of two processes, for t = 0..T.

    ``reduce="max"``: the largest over the K code rows; ``"mean"``: averaged with ``weights`` (K,), e.g. the code
    frequencies (uniform if None). Both processes must share K and T.
    """
    if a.num_codes != b.num_codes or a.T != b.T:
        raise ValueError(f"processes differ in size: K={a.num_codes}, T={a.T} vs K={b.num_codes}, T={b.T}")
    w = _check_reduce(reduce, weights, a.num_codes)
    return _row_tv(a.cumulative.cpu(), b.cumulative.cpu(), reduce, w)


def dynamic_uniform_tv(
    schedule: Schedule,
    codebook: Tensor,
    etas: Sequence[float],
    distance: str = "l2_rank",
    reduce: str = "max",
    weights: Tensor | None = None,
) -> Tensor:
    """(len(etas), T+1) float64 TV between the rows of Q̄_t with M2D2M's β(t, d) at each η and with uniform β_t.

    The products Q̄_t are formed in float64 step by step (nothing (T+1)·(K+1)² is stored), so even a distance
    of 1e-6 is resolved. η = 0 gives exactly 0.
    """
    dist = codebook_distance(codebook, distance)
    K = dist.shape[0]
    w = _check_reduce(reduce, weights, K)
    if len(etas) == 0:
        raise ValueError("etas is empty")
    out = torch.zeros(len(etas), schedule.T + 1, dtype=torch.float64)
    uniform = torch.eye(K + 1, dtype=torch.float64)
    dynamic = [uniform.clone() for _ in etas]
    for t in range(1, schedule.T + 1):
        uniform = uniform @ uniform_matrix(schedule, t, K)
        for i, eta in enumerate(etas):
            dynamic[i] = dynamic[i] @ dynamic_matrix(schedule, t, dist, float(eta))
            out[i, t] = _row_tv(dynamic[i], uniform, reduce, w)
    return out


# ------------------------------------------------------------------------------------ sampled tokens


class TokenRecorder:
    """A ``generate(texts, lengths, seed=..., **sampling)`` function for the evaluation protocol that also keeps
    the token ids it sampled (:attr:`tokens`, one (B, L) tensor per call), so token statistics and the
    evaluator's scores come from the same samples."""

    def __init__(self, pipe) -> None:
        if not hasattr(pipe, "generate_with_tokens"):
            raise ValueError(f"pipe must be a TextToMotion (with generate_with_tokens), got {type(pipe).__name__}")
        self.pipe = pipe
        self.tokens: list[Tensor] = []

    def __call__(self, texts, lengths_in_frames, *, seed: int = 0, **sampling):
        motions, ids = self.pipe.generate_with_tokens(texts, lengths_in_frames, seed=seed, **sampling)
        self.tokens.append(ids)
        return motions

    def all_tokens(self) -> list[Tensor]:
        """Every sampled sequence (padding removed), over all calls."""
        return [row[row >= 0] for ids in self.tokens for row in ids]


def token_statistics(ids: Tensor | Sequence[Tensor], real_ids: Tensor | Sequence[Tensor], num_codes: int) -> dict:
    """What one set of sampled tokens looks like against the real ones: ``hist_tv`` (:func:`histogram_tv` to
    ``real_ids``) and ``repeat_rate`` (:func:`adjacent_repeat_rate` of ``ids``), as plain floats."""
    return {"hist_tv": histogram_tv(ids, real_ids, num_codes), "repeat_rate": adjacent_repeat_rate(ids)}
