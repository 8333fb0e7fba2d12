"""DisCoRD: decode discrete motion tokens by solving a token-conditioned rectified-flow ODE.

    ids (B, N[, R]) --tokenizer.embed--> code vectors Z (B, N, d)          (RVQ: summed over layers)
    Z --condition projection--> frame features C (B, T = q·N, c)           (once per clip)
    x0 ~ N(0, I) (B, T, D) --ODE dx/dt = v(x, t, C), t: 0 → 1--> x1 = motion (B, T, D)

Training regresses ``v`` on ``x1 − x0`` along ``x_t = t·x1 + (1 − t)·x0`` for windows of real motion
``x1`` and the code vectors of their own tokens (the tokenizer stays frozen; see :meth:`DisCoRDDecoder.loss`).
The output lives where the tokenizer's inputs live (normalised features): ``decode`` is a drop-in
replacement for the tokenizer's feed-forward ``decode(ids) -> (B, T, D)``.

The flow itself runs in the decoder's *model space*: the tokenizer's normalised features, with the root and
foot-contact dims scaled ×25 when ``config.normalization == "feat_bias"`` (the public code's weighting).
What the network outputs (velocity or clean motion) is ``config.prediction``; the weights record both, and
loading them into a decoder configured otherwise raises instead of decoding garbage.
"""

from __future__ import annotations

import contextlib
import copy
from collections.abc import Iterator
from dataclasses import replace
from typing import Any

import torch
from torch import Tensor, nn

from motionlab.flow.condition import make_condition_projection
from motionlab.flow.config import FEAT_BIAS, DisCoRDConfig, check_temperature, discord_config
from motionlab.flow.rectified_flow import VelocityFn, as_velocity_fn, flow_matching_loss, sample, sample_noise
from motionlab.flow.unet1d import UNet1D
from motionlab.precision import in_precision, network_precision
from motionlab.train import seeded


class DisCoRDDecoder(nn.Module):
    """Condition projection + 1D U-Net vector field, with seeded ODE decoding of token ids."""

    def __init__(self, config: DisCoRDConfig | None = None) -> None:
        super().__init__()
        self.config = cfg = config if config is not None else DisCoRDConfig()
        with seeded(cfg.seed):  # initial weights depend on the config alone
            self.projection = make_condition_projection(cfg.projection, cfg.code_dim, cfg.cond_dim, q=cfg.q)
            self.unet = UNet1D(cfg.unet)
        self.register_buffer("feature_scale", feature_scale(cfg), persistent=False)  # (D,)
        # Kept out of nn.Module's registry on purpose: the tokenizer's weights must not appear in this
        # module's parameters() (an optimizer over them would update it) nor in its state_dict (checkpoints).
        self.__dict__["_tokenizer"] = None

    @classmethod
    def from_tokenizer(cls, tokenizer: Any, profile: str | None = None, **overrides: Any) -> DisCoRDDecoder:
        """A decoder sized for ``tokenizer`` (widths, stride) in ``profile``, already attached to it."""
        return cls(discord_config(profile, tokenizer=tokenizer, **overrides)).attach(tokenizer)

    SAMPLING_FIELDS = ("sample_steps", "solver", "spacing", "temperature", "final_prediction")

    @property
    def deterministic(self) -> bool:
        """Whether its default decode ignores the seed: temperature 0 starts every decode from the same zero noise."""
        return self.config.temperature == 0

    def with_sampling(self, **options: Any) -> DisCoRDDecoder:
        """The same weights with other sampling defaults (``sample_steps``, ``solver``, ``spacing``,
        ``temperature``, ``final_prediction``); shares parameters with ``self`` and its tokenizer."""
        unknown = set(options) - set(self.SAMPLING_FIELDS)
        if unknown:
            raise ValueError(f"with_sampling sets only {self.SAMPLING_FIELDS}, got {sorted(unknown)}")
        other = copy.copy(self)  # shares the submodules, buffers and tokenizer; only the config differs
        other.config = replace(self.config, **options)
        return other

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

    # ------------------------------------------------------------------ parameterisation record

    def get_extra_state(self) -> Tensor:
        """What the weights mean, saved beside them: ``"prediction=v;normalization=std"`` as bytes."""
        return torch.tensor(list(self._interpretation().encode()), dtype=torch.uint8)

    def set_extra_state(self, state: Any) -> None:
        saved = bytes(torch.as_tensor(state, dtype=torch.uint8).tolist()).decode()
        if saved != self._interpretation():
            raise ValueError(
                f"these DisCoRD weights were trained with {saved!r} but the decoder is configured "
                f"with {self._interpretation()!r}: load them with the config they were trained with"
            )

    def _interpretation(self) -> str:
        return f"prediction={self.config.prediction};normalization={self.config.normalization}"

    # ------------------------------------------------------------------ spaces

    def to_model_space(self, motion: Tensor) -> Tensor:
        """Tokenizer-normalised features → the flow's space (× 25 on root/contact dims under ``feat_bias``)."""
        return motion * self.feature_scale.to(motion.device, motion.dtype)  # on motion's device

    def from_model_space(self, x: Tensor) -> Tensor:
        """The inverse of :meth:`to_model_space`."""
        return x / self.feature_scale.to(x.device, x.dtype)

    # ------------------------------------------------------------------ network

    def condition(self, code_vectors: Tensor) -> Tensor:
        """Frame-wise condition features: ``(B, N, d) -> (B, q·N, c)``, on the decoder's device."""
        (code_vectors,) = self._on_device(code_vectors)
        return self.projection(code_vectors)

    @property
    def velocity_field(self):
        """The U-Net as a velocity function ``(x_t, t, cond) -> v`` whatever it predicts (model space)."""
        return as_velocity_fn(self.unet, self.config.prediction)

    def velocity(self, x_t: Tensor, t: Tensor, code_vectors: Tensor) -> Tensor:
        """``v(x_t, t, C(Z))`` in model space: ``(B, T, D), (B,), (B, T/q, d) -> (B, T, D)``, on the decoder's device
        (the inputs are moved there)."""
        self._check_pair(x_t, code_vectors, "x_t")
        x_t, t, code_vectors = self._on_device(x_t, t, code_vectors)
        return self.velocity_field(x_t, t, self.condition(code_vectors))

    forward = velocity

    def loss(self, motion: Tensor, code_vectors: Tensor, generator: torch.Generator) -> Tensor:
        """Rectified-flow MSE on a batch of windows ``motion (B, T, D)`` with their codes ``(B, T/q, d)``.

        ``motion`` is tokenizer-normalised; the loss is taken in model space, on the velocity. The inputs are moved
        to the decoder's device, where the loss lives; noise is drawn on ``generator``'s device.
        """
        self._check_pair(motion, code_vectors, "motion")
        motion, code_vectors = self._on_device(motion, code_vectors)
        cfg = self.config
        cond = self.condition(code_vectors)  # (B, T, c)
        return flow_matching_loss(
            self.unet,
            self.to_model_space(motion),
            cond,
            generator,
            prediction=cfg.prediction,
            time_distribution=cfg.time_distribution,
            time_loc=cfg.time_loc,
            time_scale=cfg.time_scale,
        )

    # ------------------------------------------------------------------ sampling

    @torch.no_grad()
    def sample(
        self,
        code_vectors: Tensor,
        steps: int | None = None,
        solver: str | None = None,
        generator: torch.Generator | None = None,
        seed: int | None = None,
        temperature: float | None = None,
    ) -> Tensor:
        """Solve the ODE from seeded noise: code vectors ``(B, N, d)`` -> motion ``(B, q·N, D)``.

        ``steps`` integration intervals of ``solver`` on the config's grid (defaults from the config: for
        ``full`` 15 midpoint intervals = the public code's 16-point grid). The start noise is
        ``temperature · N(0, I)`` (default: the config's; the paper's 1). Pass ``generator`` or ``seed``
        (default seed 0): the same seed gives the same motion. A seed's noise is drawn where the decoder lives (on a
        GPU, from a GPU generator: no host work per call), so a seed's motion on a GPU differs from the CPU's; a
        ``generator`` draws on its own device. The motion is returned on the decoder's device.

        The algorithm is :meth:`integrate`; this wrapper fills in the defaults, checks the inputs, moves them to the
        decoder, turns dropout off and runs the U-Net in the run's precision.
        """
        cfg = self.config
        steps = cfg.sample_steps if steps is None else steps
        solver = cfg.solver if solver is None else solver
        temperature = cfg.temperature if temperature is None else check_temperature(temperature)
        param = next(self.parameters())
        generator = _resolve_generator(generator, seed, param.device)
        self._check_code_vectors(code_vectors)
        code_vectors = code_vectors.to(device=param.device, dtype=param.dtype)
        # the U-Net in the run's precision; the ODE state x stays fp32 between its evaluations
        unet = in_precision(self.unet, network_precision(param.device), param.device)
        with _evaluating(self):  # dropout off while sampling
            return self.integrate(code_vectors, generator, steps, solver, temperature, unet=unet)

    @torch.no_grad()
    def integrate(
        self,
        code_vectors: Tensor,
        generator: torch.Generator,
        steps: int,
        solver: str,
        temperature: float = 1.0,
        unet: VelocityFn | None = None,
    ) -> Tensor:
        """DisCoRD's decoding, the algorithm alone: code vectors ``(B, N, d)`` -> motion ``(B, q·N, D)``.

        Project the codes once to frame-wise conditions ``C``, draw ``x_0 = temperature · N(0, I)``, integrate
        ``dx/dt = v_θ(x, t, C)`` from ``t = 0`` to ``1`` in ``steps`` intervals of ``solver``. ``unet`` defaults to
        ``self.unet``; :meth:`sample` passes it wrapped in the run's precision, and calls this in eval mode.
        """
        cfg = self.config
        unet = self.unet if unet is None else unet
        cond = self.projection(code_vectors)  # (B, T, c): computed once, reused at every evaluation
        B, N, _ = code_vectors.shape
        x0 = temperature * sample_noise((B, N * cfg.q, cfg.feature_dim), generator, like=cond)  # (B, T, D)
        velocity = as_velocity_fn(unet, cfg.prediction)  # "x": v = (x̂_1 − x_t) / (1 − t)
        final_fn = unet if cfg.final_prediction else None  # "x" only: the last interval returns x̂_1 itself
        x1 = sample(velocity, x0, steps, solver, cond, spacing=cfg.spacing, final_fn=final_fn)
        return self.from_model_space(x1)  # back to the tokenizer's normalised features

    def _check_code_vectors(self, code_vectors: Tensor) -> None:
        """Reject code vectors that are not ``(B, N, d)`` with the config's ``d``."""
        d = self.config.code_dim
        if not isinstance(code_vectors, Tensor) or code_vectors.dim() != 3 or code_vectors.shape[-1] != d:
            raise ValueError(f"code_vectors must have shape (B, N, {d}), got {_shape(code_vectors)}")

    def _check_decode_inputs(self, ids: Tensor, tokenizer: Any) -> None:
        """Reject a missing or mismatched tokenizer and ids that are not ``(B, N)`` / ``(B, N, R)`` integers."""
        if tokenizer is None:
            raise ValueError("no tokenizer: pass tokenizer=... or call DisCoRDDecoder.attach(tokenizer) first")
        self._check_tokenizer(tokenizer)
        if not isinstance(ids, Tensor) or ids.dim() not in (2, 3) or ids.dtype.is_floating_point:
            raise ValueError(f"ids must be an integer tensor of shape (B, N) or (B, N, R), got {_shape(ids)}")
        if ids.shape[0] < 1 or ids.shape[1] < 1:
            raise ValueError(f"ids must hold at least one clip and one token, got {tuple(ids.shape)}")

    @torch.no_grad()
    def decode(
        self,
        ids: Tensor,
        tokenizer: Any = None,
        steps: int | None = None,
        solver: str | None = None,
        generator: torch.Generator | None = None,
        seed: int | None = None,
        temperature: float | None = None,
    ) -> Tensor:
        """Token ids ``(B, N)`` (VQ) or ``(B, N, R)`` (RVQ, −1 = absent layer) -> motion ``(B, q·N, D)``.

        Uses ``tokenizer`` if given, else the one from :meth:`attach`; only its ``embed`` is called. The ids may live
        on any device (their range is checked where that reads nothing back: on the CPU); the motion is returned on
        the decoder's device.
        """
        tokenizer = tokenizer if tokenizer is not None else self.tokenizer
        self._check_decode_inputs(ids, tokenizer)
        code_vectors = tokenizer.embed(ids)  # (B, N, d)
        expected = (ids.shape[0], ids.shape[1], self.config.code_dim)
        if not isinstance(code_vectors, Tensor) or tuple(code_vectors.shape) != expected:
            raise ValueError(f"tokenizer.embed returned {_shape(code_vectors)}, expected {expected}")
        return self.sample(
            code_vectors, steps=steps, solver=solver, generator=generator, seed=seed, temperature=temperature
        )

    # ------------------------------------------------------------------ checks

    def _on_device(self, *tensors: Tensor) -> tuple[Tensor, ...]:
        device = next(self.parameters()).device
        return tuple(t.to(device) if isinstance(t, Tensor) else t for t in tensors)

    def _check_pair(self, x: Tensor, code_vectors: Tensor, name: str) -> None:
        cfg = self.config
        if not isinstance(x, Tensor) or x.dim() != 3 or x.shape[-1] != cfg.feature_dim:
            raise ValueError(f"{name} must have shape (B, T, {cfg.feature_dim}), got {_shape(x)}")
        B, T, _ = x.shape
        if T % cfg.q:
            raise ValueError(f"{name} length T={T} must be a multiple of q={cfg.q} (whole tokens)")
        expected = (B, T // cfg.q, cfg.code_dim)
        if not isinstance(code_vectors, Tensor) or tuple(code_vectors.shape) != expected:
            raise ValueError(
                f"code_vectors must have shape {expected} for {name} {tuple(x.shape)}, got {_shape(code_vectors)}"
            )


def feature_scale(config: DisCoRDConfig) -> Tensor:
    """Per-feature factor from the tokenizer's space to the flow's: ``(D,)`` ones, or 25 on the root (dims 0–3)
    and foot-contact (last 4) dims under ``normalization="feat_bias"`` (their std divided by 25, as in MoMask)."""
    scale = torch.ones(config.feature_dim)
    if config.normalization == "feat_bias":
        scale[:4] = FEAT_BIAS
        scale[-4:] = FEAT_BIAS
    return scale


def discord_loss_fn(model: DisCoRDDecoder, batch: tuple[Tensor, Tensor], generator: torch.Generator) -> dict:
    """The shared trainer's ``loss_fn``: ``batch = (motion (B, T, D), code_vectors (B, T/q, d))``.

    Code vectors come from the frozen tokenizer (``tokenizer.embed(tokenizer.encode(motion))``), computed
    once per window outside the loop, as in the public code.
    """
    motion, code_vectors = batch
    return {"loss": model.loss(motion, code_vectors, generator)}


@contextlib.contextmanager
def _evaluating(module: nn.Module) -> Iterator[None]:
    """``module`` in eval mode (dropout off) inside the block, then back in the mode it was in."""
    was_training = module.training
    module.eval()
    try:
        yield
    finally:
        module.train(was_training)


def _resolve_generator(
    generator: torch.Generator | None, seed: int | None, device: torch.device | str = "cpu"
) -> torch.Generator:
    """``generator``, or a new one on ``device`` seeded with ``seed`` (default 0)."""
    if generator is not None and seed is not None:
        raise ValueError("pass either generator or seed, not both")
    if generator is not None:
        return generator
    return torch.Generator(device=device).manual_seed(0 if seed is None else int(seed))


def _shape(x: Any) -> str:
    return str(tuple(x.shape)) if isinstance(x, Tensor) else type(x).__name__
