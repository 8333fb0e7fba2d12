"""Transition matrices Q_t: VQ-Diffusion's uniform replacement and M2D2M's dynamic transition probability.

Convention: **row = from, column = to**, so ``Q_t[i, j] = q(x_t = j | x_{t-1} = i)`` and every row sums to
one. States ``0..K-1`` are codes, state ``K`` is the absorbing mask::

    Q_t = [ α_t·I + B_t   γ_t·1 ]        B_t[i, j] = replacement probability i → j, Σ_j B_t[i, j] = K·β_t
          [     0           1   ]

Cumulative products run forward in time, ``Q̄_t = Q_1 Q_2 ⋯ Q_t``, so ``q(x_t = j | x_0 = i) = Q̄_t[i, j]``.

**Uniform (VQ-Diffusion, Eq. 2):** ``B_t[i, j] = β_t`` for every pair, the code itself included.

**Dynamic (M2D2M, Eq. 7–8):** ``B_t[i, j] = (1 − γ_t − α_t) · softmax_j(η · (t/T) · d_ij / K)`` where d_ij is
the distance from code i to code j. Choices fixed here (the paper leaves them implicit):

- *Sign of η.* Eq. 7 as printed, with η > 0, gives larger weight to larger d, and the text says the same:
  the softmax "progressively assigns higher probabilities to greater distances between tokens as the
  diffusion step t advances" (exploration of far codes at large t, uniform as t → 0). So **η > 0 favours
  far codes**; η < 0 favours near codes (a "local replacement" variant, not in the paper); η = 0 is
  VQ-Diffusion. The paper uses η = 0.5 (single motions) and 0.25 (multi-motion); note how mild that is:
  at t = T the farthest code gets e^η ≈ 1.65 times the weight of the nearest.
- *The code itself.* Eq. 8 writes Q̂_t = α_t·I + β(t, d_ij)·11ᵀ, so the diagonal also receives its β share
  (d_ii = 0) on top of α_t, exactly as in VQ-Diffusion; the softmax runs over all K codes, and Eq. 7's
  constraint γ_t + α_t + Σ_d β(t, d) = 1 holds row by row.
- *d.* ``"l2_rank"`` (the paper's choice): the rank of code j when all codes are sorted by L2 distance from
  code i (the code itself has rank 0, ties broken by index); whether ranks start at 0 or 1 does not matter,
  a constant shift cancels in the softmax. ``"cosine_rank"`` ranks by cosine distance. ``"l2"`` and
  ``"cosine"`` use the distances themselves, rescaled to [0, K) by dividing by the largest off-diagonal
  distance, so η means the same range of weights as with ranks.

Because d_ij ≠ d_ji in general, Q_t is **not symmetric** and VQ-Diffusion's closed forms for Q̄_t and for
the posterior no longer apply: we build the dense (K+1)×(K+1) matrices, multiply them in float64, and store
them as float32 (:class:`Transitions`). With η = 0 the dynamic construction reproduces the uniform one
bit for bit (same float64 operations), which the tests check.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import torch

from motionlab.diffusion.schedule import Schedule

DISTANCES = ("l2_rank", "l2", "cosine", "cosine_rank")


def codebook_distance(codebook: torch.Tensor, kind: str = "l2_rank") -> torch.Tensor:
    """(K, K) float64 distance d_ij from code i (row) to code j, on the scale [0, K) of Eq. 7's d.

    Args:
        codebook: (K, D) code vectors (``tokenizer.codebook()``).
        kind: one of :data:`DISTANCES`.
    """
    if kind not in DISTANCES:
        raise ValueError(f"distance must be one of {DISTANCES}, got {kind!r}")
    if not isinstance(codebook, torch.Tensor) or codebook.ndim != 2 or codebook.shape[0] < 2:
        raise ValueError(f"codebook must be a (K, D) tensor with K >= 2, got {getattr(codebook, 'shape', None)}")
    c = codebook.detach().to(torch.float64).cpu()
    K = c.shape[0]
    if kind.startswith("l2"):
        dist = torch.cdist(c, c)  # (K, K)
    else:
        unit = c / c.norm(dim=1, keepdim=True).clamp_min(1e-12)
        dist = (1.0 - unit @ unit.T).clamp_min(0.0)  # (K, K) cosine distance in [0, 2]
    eye = torch.eye(K, dtype=torch.bool)
    dist = dist.masked_fill(eye, 0.0)
    if kind.endswith("rank"):
        # The code itself must come first even when another code sits at distance 0 (duplicate codes).
        order = torch.sort(dist.masked_fill(eye, -1.0), dim=1, stable=True).indices  # (K, K) codes by distance
        ranks = torch.empty_like(order)
        ranks.scatter_(1, order, torch.arange(K).expand(K, K).contiguous())
        return ranks.to(torch.float64)
    largest = dist.max()
    return dist * (K / largest) if largest > 0 else dist


def uniform_matrix(schedule: Schedule, t: int, num_codes: int) -> torch.Tensor:
    """(K+1, K+1) float64 one-step matrix Q_t of VQ-Diffusion: B_t[i, j] = β_t = K·β_t / K."""
    K = num_codes
    Q = torch.zeros(K + 1, K + 1, dtype=torch.float64)
    Q[:K, :K] = schedule.kbeta[t] / K  # every code -> every code (itself included): β_t
    return keep_and_mask(Q, schedule, t)


def dynamic_matrix(schedule: Schedule, t: int, distance: torch.Tensor, eta: float) -> torch.Tensor:
    """(K+1, K+1) float64 one-step matrix Q_t with M2D2M's β(t, d) (Eq. 7–8).

    B_t[i, j] = K·β_t · w_ij / Σ_k w_ik with w_ij = exp(η·(t/T)·d_ij/K − max_k(...)); with η = 0 every w is
    exactly 1 and Σ w exactly K, so the result equals :func:`uniform_matrix` bit for bit.
    """
    K = distance.shape[0]
    logits = eta * (t / schedule.T) * (distance / K)  # (K, K)
    w = torch.exp(logits - logits.max(dim=1, keepdim=True).values)
    Q = torch.zeros(K + 1, K + 1, dtype=torch.float64)
    Q[:K, :K] = (schedule.kbeta[t] * w) / w.sum(dim=1, keepdim=True)
    return keep_and_mask(Q, schedule, t)


def keep_and_mask(Q: torch.Tensor, schedule: Schedule, t: int) -> torch.Tensor:
    """Complete a (K+1, K+1) Q_t whose code block holds the replacement B_t: add α_t on the code diagonal, γ_t into
    the mask column, and make the mask absorbing (in place; returns ``Q``)."""
    K = Q.shape[0] - 1
    idx = torch.arange(K)
    Q[idx, idx] += schedule.alpha[t]  # a code keeps itself: α_t (+ its own share of the replacement)
    Q[:K, K] = schedule.gamma[t]  # every code -> [MASK]: γ_t
    Q[K, K] = 1.0  # [MASK] -> [MASK]: 1, the rest of its row 0 (absorbing)
    return Q


@dataclass
class Transitions:
    """Precomputed one-step and cumulative matrices of one forward process.

    ``one_step[t] = Q_t`` and ``cumulative[t] = Q̄_t`` for t = 0..T, both (T+1, K+1, K+1) float32, with
    ``one_step[0] = cumulative[0] = I``. Products are formed in float64 and rounded once when stored.
    Memory: 2·(T+1)·(K+1)²·4 bytes, e.g. 213 MB for K = 512, T = 100 (:attr:`nbytes`).

    Build with :func:`build_transitions`; pass to the posterior, loss and samplers.
    """

    schedule: Schedule
    num_codes: int
    eta: float
    distance_kind: str | None  # None: uniform VQ-Diffusion replacement
    one_step: torch.Tensor  # (T+1, K+1, K+1) float32
    cumulative: torch.Tensor  # (T+1, K+1, K+1) float32
    distance: torch.Tensor | None = field(default=None, repr=False)  # (K, K) float64
    _intervals: dict[tuple[int, int], torch.Tensor] = field(default_factory=dict, repr=False)

    @property
    def T(self) -> int:
        return self.schedule.T

    @property
    def mask_id(self) -> int:
        return self.num_codes

    @property
    def nbytes(self) -> int:
        """Bytes held by the stored dense matrices."""
        return sum(m.numel() * m.element_size() for m in (self.one_step, self.cumulative))

    def matrix64(self, t: int) -> torch.Tensor:
        """(K+1, K+1) float64 Q_t recomputed from the schedule (exact, not the stored float32 copy)."""
        if self.distance is None:
            return uniform_matrix(self.schedule, t, self.num_codes)
        return dynamic_matrix(self.schedule, t, self.distance, self.eta)

    def interval(self, s: int, t: int) -> torch.Tensor:
        """(K+1, K+1) float32 ``q(x_t | x_s) = Q_{s+1} ⋯ Q_t`` for 0 <= s < t <= T (cached).

        Used by fast sampling to jump from t straight to s. ``interval(t-1, t) = Q_t``.
        """
        if not (0 <= s < t <= self.T):
            raise ValueError(f"need 0 <= s < t <= T={self.T}, got s={s}, t={t}")
        if t == s + 1:
            return self.one_step[t]
        if (s, t) not in self._intervals:
            prod = self.matrix64(s + 1)
            for k in range(s + 2, t + 1):
                prod = prod @ self.matrix64(k)
            self._intervals[(s, t)] = prod.to(torch.float32)
        return self._intervals[(s, t)]

    def to(self, device: torch.device | str) -> Transitions:
        """Move the stored matrices (for GPU sampling); the float64 recomputation stays on CPU."""
        self.one_step = self.one_step.to(device)
        self.cumulative = self.cumulative.to(device)
        self._intervals = {k: v.to(device) for k, v in self._intervals.items()}
        return self


def build_transitions(
    schedule: Schedule,
    num_codes: int | None = None,
    codebook: torch.Tensor | None = None,
    eta: float = 0.0,
    distance: str = "l2_rank",
) -> Transitions:
    """Build Q_t and Q̄_t for t = 0..T.

    Without ``codebook`` the replacement is uniform (VQ-Diffusion) and ``eta`` must be 0. With a (K, D)
    ``codebook`` it is M2D2M's dynamic β(t, d) with scale ``eta`` and distance ``distance``
    (:data:`DISTANCES`); η = 0 then equals the uniform matrices exactly.
    """
    if codebook is None:
        if num_codes is None or int(num_codes) < 2:
            raise ValueError(f"num_codes must be an int >= 2 when no codebook is given, got {num_codes!r}")
        if eta != 0.0:
            raise ValueError("eta != 0 needs a codebook (dynamic transitions depend on code distances)")
        K, dist, kind = int(num_codes), None, None
    else:
        dist = codebook_distance(codebook, distance)
        K, kind = dist.shape[0], distance
        if num_codes is not None and int(num_codes) != K:
            raise ValueError(f"num_codes={num_codes} disagrees with codebook of shape {tuple(codebook.shape)}")
    T = schedule.T
    one_step = torch.empty(T + 1, K + 1, K + 1, dtype=torch.float32)
    cumulative = torch.empty_like(one_step)
    eye = torch.eye(K + 1, dtype=torch.float64)
    one_step[0], cumulative[0] = eye, eye
    running = eye
    for t in range(1, T + 1):
        Q = uniform_matrix(schedule, t, K) if dist is None else dynamic_matrix(schedule, t, dist, float(eta))
        running = running @ Q  # Q̄_t = Q̄_{t-1} Q_t, in float64
        one_step[t], cumulative[t] = Q, running
    return Transitions(schedule, K, float(eta), kind, one_step, cumulative, dist)
