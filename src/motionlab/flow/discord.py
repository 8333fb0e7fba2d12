"""DisCoRD: decode discrete motion tokens by solving a token-conditioned rectified-flow ODE.

    ids (B, N[, R]) --tokenizer.embed--> code vectors Z (B, N, d)          (RVQ: summed over layers)
    Z --condition projection--> frame features C (B, T = q·N, c)           (once per clip)
    x0 ~ N(0, I) (B, T, D) --ODE dx/dt = v(x, t, C), t: 0 → 1--> x1 = motion (B, T, D)

Training regresses ``v`` on ``x1 − x0`` along ``x_t = t·x1 + (1 − t)·x0`` for windows of real motion
``x1`` and the code vectors of their own tokens (the tokenizer stays frozen; see :meth:`DisCoRDDecoder.loss`).
The output lives where the tokenizer's inputs live (normalised features): ``decode`` is a drop-in
replacement for the tokenizer's feed-forward ``decode(ids) -> (B, T, D)``.
"""

from __future__ import annotations

from typing import Any

import torch
from torch import Tensor, nn

from motionlab.flow.condition import make_condition_projection
from motionlab.flow.config import DisCoRDConfig, discord_config
from motionlab.flow.rectified_flow import flow_matching_loss, sample, sample_noise
from motionlab.flow.unet1d import UNet1D
from motionlab.train import seeded


class DisCoRDDecoder(nn.Module):
    """Condition projection + 1D U-Net vector field, with seeded ODE decoding of token ids."""

    def __init__(self, config: DisCoRDConfig | None = None) -> None:
        super().__init__()
        self.config = cfg = config if config is not None else DisCoRDConfig()
        with seeded(cfg.seed):  # initial weights depend on the config alone
            self.projection = make_condition_projection(cfg.projection, cfg.code_dim, cfg.cond_dim, q=cfg.q)
            self.unet = UNet1D(cfg.unet)
        # Kept out of nn.Module's registry on purpose: the tokenizer's weights must not appear in this
        # module's parameters() (an optimizer over them would update it) nor in its state_dict (checkpoints).
        self.__dict__["_tokenizer"] = None

    @classmethod
    def from_tokenizer(cls, tokenizer: Any, profile: str | None = None, **overrides: Any) -> DisCoRDDecoder:
        """A decoder sized for ``tokenizer`` (widths, stride) in ``profile``, already attached to it."""
        return cls(discord_config(profile, tokenizer=tokenizer, **overrides)).attach(tokenizer)

    # ------------------------------------------------------------------ tokenizer

    @property
    def tokenizer(self) -> Any:
        return self.__dict__["_tokenizer"]

    def attach(self, tokenizer: Any) -> DisCoRDDecoder:
        """Use ``tokenizer.embed`` in :meth:`decode`; checks widths and stride match. Returns ``self``."""
        self._check_tokenizer(tokenizer)
        self.__dict__["_tokenizer"] = tokenizer
        return self

    def _check_tokenizer(self, tokenizer: Any) -> None:
        cfg = self.config
        if not callable(getattr(tokenizer, "embed", None)):
            raise ValueError(f"tokenizer must have an .embed(ids) method; got {type(tokenizer).__name__}")
        for attr, want in (("code_dim", cfg.code_dim), ("downsample", cfg.q), ("feature_dim", cfg.feature_dim)):
            if not hasattr(tokenizer, attr):
                raise ValueError(f"tokenizer must have a .{attr} attribute; got {type(tokenizer).__name__}")
            if int(getattr(tokenizer, attr)) != want:
                raise ValueError(
                    f"tokenizer.{attr}={getattr(tokenizer, attr)} does not match the decoder config ({want})"
                )

    # ------------------------------------------------------------------ network

    def condition(self, code_vectors: Tensor) -> Tensor:
        """Frame-wise condition features: ``(B, N, d) -> (B, q·N, c)``."""
        return self.projection(code_vectors)

    def velocity(self, x_t: Tensor, t: Tensor, code_vectors: Tensor) -> Tensor:
        """``v(x_t, t, C(Z))``: ``(B, T, D), (B,), (B, T/q, d) -> (B, T, D)``."""
        self._check_pair(x_t, code_vectors, "x_t")
        return self.unet(x_t, t, self.condition(code_vectors))

    forward = velocity

    def loss(self, motion: Tensor, code_vectors: Tensor, generator: torch.Generator) -> Tensor:
        """Rectified-flow MSE on a batch of windows ``motion (B, T, D)`` with their codes ``(B, T/q, d)``."""
        self._check_pair(motion, code_vectors, "motion")
        cond = self.condition(code_vectors)  # (B, T, c)
        return flow_matching_loss(self.unet, motion, cond, generator)

    # ------------------------------------------------------------------ sampling

    @torch.no_grad()
    def sample(
        self,
        code_vectors: Tensor,
        steps: int | None = None,
        solver: str | None = None,
        generator: torch.Generator | None = None,
        seed: int | None = None,
    ) -> Tensor:
        """Solve the ODE from seeded noise: code vectors ``(B, N, d)`` -> motion ``(B, q·N, D)``.

        ``steps`` integration intervals of ``solver`` (defaults from the config: for ``full`` 15 midpoint
        intervals = the public code's 16-point grid). Pass ``generator`` or ``seed`` (default seed 0): the
        same seed gives the same motion.
        """
        cfg = self.config
        steps = cfg.sample_steps if steps is None else steps
        solver = cfg.solver if solver is None else solver
        generator = _resolve_generator(generator, seed)
        if not isinstance(code_vectors, Tensor) or code_vectors.dim() != 3 or code_vectors.shape[-1] != cfg.code_dim:
            raise ValueError(f"code_vectors must have shape (B, N, {cfg.code_dim}), got {_shape(code_vectors)}")
        B, N, _ = code_vectors.shape
        param = next(self.parameters())
        code_vectors = code_vectors.to(device=param.device, dtype=param.dtype)

        was_training = self.training
        self.eval()  # dropout off while sampling
        try:
            cond = self.condition(code_vectors)  # (B, T, c): computed once, reused at every evaluation
            x0 = sample_noise((B, N * cfg.q, cfg.feature_dim), generator, like=cond)  # (B, T, D)
            return sample(self.unet, x0, steps, solver, cond)
        finally:
            self.train(was_training)

    @torch.no_grad()
    def decode(
        self,
        ids: Tensor,
        tokenizer: Any = None,
        steps: int | None = None,
        solver: str | None = None,
        generator: torch.Generator | None = None,
        seed: int | None = None,
    ) -> Tensor:
        """Token ids ``(B, N)`` (VQ) or ``(B, N, R)`` (RVQ, −1 = absent layer) -> motion ``(B, q·N, D)``.

        Uses ``tokenizer`` if given, else the one from :meth:`attach`; only its ``embed`` is called.
        """
        tokenizer = tokenizer if tokenizer is not None else self.tokenizer
        if tokenizer is None:
            raise ValueError("no tokenizer: pass tokenizer=... or call DisCoRDDecoder.attach(tokenizer) first")
        self._check_tokenizer(tokenizer)
        if not isinstance(ids, Tensor) or ids.dim() not in (2, 3) or ids.dtype.is_floating_point:
            raise ValueError(f"ids must be an integer tensor of shape (B, N) or (B, N, R), got {_shape(ids)}")
        if ids.shape[0] < 1 or ids.shape[1] < 1:
            raise ValueError(f"ids must hold at least one clip and one token, got {tuple(ids.shape)}")
        code_vectors = tokenizer.embed(ids)  # (B, N, d)
        expected = (ids.shape[0], ids.shape[1], self.config.code_dim)
        if not isinstance(code_vectors, Tensor) or tuple(code_vectors.shape) != expected:
            raise ValueError(f"tokenizer.embed returned {_shape(code_vectors)}, expected {expected}")
        return self.sample(code_vectors, steps=steps, solver=solver, generator=generator, seed=seed)

    # ------------------------------------------------------------------ checks

    def _check_pair(self, x: Tensor, code_vectors: Tensor, name: str) -> None:
        cfg = self.config
        if not isinstance(x, Tensor) or x.dim() != 3 or x.shape[-1] != cfg.feature_dim:
            raise ValueError(f"{name} must have shape (B, T, {cfg.feature_dim}), got {_shape(x)}")
        B, T, _ = x.shape
        if T % cfg.q:
            raise ValueError(f"{name} length T={T} must be a multiple of q={cfg.q} (whole tokens)")
        expected = (B, T // cfg.q, cfg.code_dim)
        if not isinstance(code_vectors, Tensor) or tuple(code_vectors.shape) != expected:
            raise ValueError(f"code_vectors must have shape {expected} for {name} {tuple(x.shape)}, "
                             f"got {_shape(code_vectors)}")


def discord_loss_fn(model: DisCoRDDecoder, batch: tuple[Tensor, Tensor], generator: torch.Generator) -> dict:
    """The shared trainer's ``loss_fn``: ``batch = (motion (B, T, D), code_vectors (B, T/q, d))``.

    Code vectors come from the frozen tokenizer (``tokenizer.embed(tokenizer.encode(motion))``), computed
    once per window outside the loop, as in the public code.
    """
    motion, code_vectors = batch
    return {"loss": model.loss(motion, code_vectors, generator)}


def _resolve_generator(generator: torch.Generator | None, seed: int | None) -> torch.Generator:
    if generator is not None and seed is not None:
        raise ValueError("pass either generator or seed, not both")
    if generator is not None:
        return generator
    return torch.Generator().manual_seed(0 if seed is None else int(seed))


def _shape(x: Any) -> str:
    return str(tuple(x.shape)) if isinstance(x, Tensor) else type(x).__name__
