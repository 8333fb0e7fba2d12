"""The standard T2M evaluator: a text encoder and a motion encoder trained into one 512-d space.

FID, R-precision, MM-Dist, Diversity and MultiModality are all computed on these embeddings. Pipeline::

    motion (B, T, D) normalised  --drop 4 foot contacts-->  (B, T, D-4)
      -> MovementConvEncoder: 2x [Conv1d k4 s2 p1, Dropout 0.2, LeakyReLU 0.2] + Linear   (B, T/4, 512)
      -> MotionEncoderBiGRUCo: Linear -> biGRU(1024, learned h0) -> [h_fwd, h_bwd] -> MLP   (B, 512)
    caption: GloVe (B, L, 300) + Linear(POS one-hot 15 -> 300)
      -> TextEncoderBiGRUCo: Linear -> biGRU(512, learned h0) -> [h_fwd, h_bwd] -> MLP     (B, 512)

The MLP is Linear(2h, h) -> LayerNorm -> LeakyReLU(0.2) -> Linear(h, 512). Module attribute names
(``main``, ``out_net``, ``pos_emb``, ``input_emb``, ``gru``, ``output_net``, ``hidden``) follow the
official checkpoint ``finest.tar`` so its state dicts load unchanged.

Variable lengths are packed (``pack_padded_sequence``); the GRU's last states therefore belong to each
sequence's true last step. The official wrapper sorted the batch by motion length because packing
required it and returned the embeddings *in sorted order*; here packing is told the batch is unsorted,
PyTorch sorts and unsorts internally, and every embedding comes back in the caller's order.
"""

from __future__ import annotations

from dataclasses import dataclass

import torch
import torch.nn.functional as F
from torch import nn
from torch.nn.utils.rnn import pack_padded_sequence

from ..precision import in_fp32


@dataclass(frozen=True)
class EvaluatorConfig:
    """Sizes of the evaluator; the defaults are the official HumanML3D (t2m) ones."""

    dim_pose: int = 263  # feature size (251 for KIT); the movement encoder sees dim_pose - 4
    dim_word: int = 300
    dim_pos_ohot: int = 15
    dim_text_hidden: int = 512
    dim_motion_hidden: int = 1024
    dim_coemb: int = 512
    dim_movement_hidden: int = 512
    dim_movement_latent: int = 512
    unit_length: int = 4  # the movement encoder downsamples time by 4

    @classmethod
    def official(cls, dataset: str = "t2m") -> EvaluatorConfig:
        dims = {"t2m": 263, "kit": 251}
        if dataset not in dims:
            raise ValueError(f"dataset must be 't2m' or 'kit', got {dataset!r}")
        return cls(dim_pose=dims[dataset])

    @classmethod
    def from_state_dicts(cls, checkpoint: dict) -> EvaluatorConfig:
        """Read the sizes off a checkpoint with ``text_encoder``/``motion_encoder``/``movement_encoder``."""
        mov, txt, mot = checkpoint["movement_encoder"], checkpoint["text_encoder"], checkpoint["motion_encoder"]
        return cls(
            dim_pose=mov["main.0.weight"].shape[1] + 4,
            dim_word=txt["pos_emb.weight"].shape[0],
            dim_pos_ohot=txt["pos_emb.weight"].shape[1],
            dim_text_hidden=txt["hidden"].shape[-1],
            dim_motion_hidden=mot["hidden"].shape[-1],
            dim_coemb=txt["output_net.3.weight"].shape[0],
            dim_movement_hidden=mov["main.0.weight"].shape[0],
            dim_movement_latent=mov["main.3.weight"].shape[0],
        )


def init_weights(module: nn.Module, generator: torch.Generator | None = None) -> None:
    """Xavier-normal weights and zero biases for Linear/Conv1d (the official init); PyTorch's own
    uniform(+-1/sqrt(h)) for GRUs and N(0, 1) for the learned initial states, all from ``generator``."""
    for m in module.modules():
        if isinstance(m, (nn.Linear, nn.Conv1d)):
            nn.init.xavier_normal_(m.weight, generator=generator)
            nn.init.zeros_(m.bias)
        elif isinstance(m, nn.GRU):
            bound = m.hidden_size**-0.5
            for p in m.parameters():
                nn.init.uniform_(p, -bound, bound, generator=generator)
        elif isinstance(m, _BiGRUEncoder):
            with torch.no_grad():
                m.hidden.copy_(torch.randn(m.hidden.shape, generator=generator))


class MovementConvEncoder(nn.Module):
    """``(B, T, D_in) -> (B, T // 4, out)``: local motion features, time downsampled by 4."""

    def __init__(self, input_size: int, hidden_size: int = 512, output_size: int = 512):
        super().__init__()
        self.main = nn.Sequential(
            nn.Conv1d(input_size, hidden_size, 4, 2, 1),
            nn.Dropout(0.2),
            nn.LeakyReLU(0.2),
            nn.Conv1d(hidden_size, output_size, 4, 2, 1),
            nn.Dropout(0.2),
            nn.LeakyReLU(0.2),
        )
        self.out_net = nn.Linear(output_size, output_size)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        h = self.main(x.transpose(1, 2)).transpose(1, 2)  # (B, T/4, out)
        return self.out_net(h)


class _BiGRUEncoder(nn.Module):
    """Shared core: project, run a bidirectional GRU from a learned h0, embed the two final states."""

    def __init__(self, input_size: int, hidden_size: int, output_size: int):
        super().__init__()
        self.input_emb = nn.Linear(input_size, hidden_size)
        self.gru = nn.GRU(hidden_size, hidden_size, batch_first=True, bidirectional=True)
        self.output_net = nn.Sequential(
            nn.Linear(hidden_size * 2, hidden_size),
            nn.LayerNorm(hidden_size),
            nn.LeakyReLU(0.2),
            nn.Linear(hidden_size, output_size),
        )
        self.hidden = nn.Parameter(torch.randn(2, 1, hidden_size))  # (directions, 1, h), learned

    def _encode(self, x: torch.Tensor, lengths: torch.Tensor) -> torch.Tensor:
        h = self.input_emb(x)  # (B, T, h)
        packed = pack_padded_sequence(h, lengths.to("cpu", torch.int64), batch_first=True, enforce_sorted=False)
        h0 = self.hidden.expand(-1, x.shape[0], -1).contiguous()  # (2, B, h)
        _, last = self.gru(packed, h0)  # (2, B, h), already back in the caller's order
        return self.output_net(torch.cat((last[0], last[1]), dim=-1))  # (B, out)


class TextEncoderBiGRUCo(_BiGRUEncoder):
    """Word vectors ``(B, L, 300)`` + POS one-hots ``(B, L, 15)`` + lengths ``(B,)`` -> ``(B, 512)``."""

    def __init__(self, word_size: int = 300, pos_size: int = 15, hidden_size: int = 512, output_size: int = 512):
        super().__init__(word_size, hidden_size, output_size)
        self.pos_emb = nn.Linear(pos_size, word_size)

    def forward(self, word_embs: torch.Tensor, pos_onehot: torch.Tensor, cap_lens: torch.Tensor) -> torch.Tensor:
        return self._encode(word_embs + self.pos_emb(pos_onehot), cap_lens)


class MotionEncoderBiGRUCo(_BiGRUEncoder):
    """Movement features ``(B, T', 512)`` + lengths in T' units ``(B,)`` -> ``(B, 512)``."""

    def __init__(self, input_size: int = 512, hidden_size: int = 1024, output_size: int = 512):
        super().__init__(input_size, hidden_size, output_size)

    def forward(self, movements: torch.Tensor, m_lens: torch.Tensor) -> torch.Tensor:
        return self._encode(movements, m_lens)


class TextMotionEvaluator(nn.Module):
    """The three networks together; every method returns embeddings in the caller's order.

    Motions must be normalised with the *evaluator's* mean/std; how they are padded does not matter
    (:func:`official_motion_batch` crops, zeroes and pads each batch the official way). Call ``.eval()``
    before measuring: the movement encoder has dropout.
    """

    def __init__(self, config: EvaluatorConfig | None = None, generator: torch.Generator | None = None):
        super().__init__()
        self.config = c = config or EvaluatorConfig()
        self.movement_encoder = MovementConvEncoder(c.dim_pose - 4, c.dim_movement_hidden, c.dim_movement_latent)
        self.text_encoder = TextEncoderBiGRUCo(c.dim_word, c.dim_pos_ohot, c.dim_text_hidden, c.dim_coemb)
        self.motion_encoder = MotionEncoderBiGRUCo(c.dim_movement_latent, c.dim_motion_hidden, c.dim_coemb)
        init_weights(self, generator)

    def encode_text(self, words: torch.Tensor, pos_onehot: torch.Tensor, lengths: torch.Tensor) -> torch.Tensor:
        """``(B, L, dim_word)``, ``(B, L, 15)``, ``(B,)`` -> ``(B, dim_coemb)``."""
        c = self.config
        if words.dim() != 3 or words.shape[-1] != c.dim_word or pos_onehot.shape != (*words.shape[:2], c.dim_pos_ohot):
            raise ValueError(
                f"expected words (B, L, {c.dim_word}) and pos_onehot (B, L, {c.dim_pos_ohot}), "
                f"got {tuple(words.shape)} and {tuple(pos_onehot.shape)}"
            )
        lengths = _check_lengths(lengths, words.shape[0], words.shape[1], "lengths")
        device = next(self.parameters()).device  # the embeddings live here
        return self.text_encoder(words.float().to(device), pos_onehot.float().to(device), lengths)

    def encode_motion(self, motions: torch.Tensor, lengths: torch.Tensor) -> torch.Tensor:
        """Normalised features ``(B, T, dim_pose)`` and lengths in frames ``(B,)`` -> ``(B, dim_coemb)``.

        A clip's embedding is the official evaluation's embedding of its first ``lengths[i] // 4 * 4`` frames,
        never dependent on how the caller padded it or on its batch-mates (:func:`official_motion_batch`: crop,
        zero the rest, and a batch width equivalent to the official 196-frame window). Floored lengths must
        lie in ``[4, 196]``. The four foot-contact channels are dropped; the GRU runs over ``lengths // 4``
        movement steps.
        """
        c = self.config
        if motions.dim() != 3 or motions.shape[-1] != c.dim_pose:
            raise ValueError(f"motions must have shape (B, T, {c.dim_pose}), got {tuple(motions.shape)}")
        lengths = _check_lengths(lengths, motions.shape[0], motions.shape[1], "lengths")
        motions, lengths = official_motion_batch(motions, lengths, c.unit_length)
        motions = motions.to(next(self.parameters()).device)  # the embeddings live on the evaluator's device
        movements = self.movement_encoder(motions[..., :-4].float())  # (B, T'/4, latent)
        return self.motion_encoder(movements, lengths // c.unit_length)

    def forward(self, words, pos_onehot, text_lengths, motions, motion_lengths) -> tuple[torch.Tensor, torch.Tensor]:
        """Aligned pairs: ``(text_emb (B, d), motion_emb (B, d))``."""
        return self.encode_text(words, pos_onehot, text_lengths), self.encode_motion(motions, motion_lengths)

    def official_state(self) -> dict[str, dict[str, torch.Tensor]]:
        """State dicts under the keys of ``finest.tar``."""
        return {name: getattr(self, name).state_dict() for name in OFFICIAL_PARTS}

    def load_official_state(self, checkpoint: dict) -> None:
        missing = [name for name in OFFICIAL_PARTS if name not in checkpoint]
        if missing:
            raise KeyError(f"checkpoint lacks {missing}; expected keys {OFFICIAL_PARTS}")
        for name in OFFICIAL_PARTS:
            getattr(self, name).load_state_dict(checkpoint[name])


OFFICIAL_PARTS = ("text_encoder", "motion_encoder", "movement_encoder")


MAX_MOTION_LENGTH = 196  # frames in every official evaluation batch (``max_motion_length``, HumanML3D and KIT-ML)


def official_motion_batch(
    motions: torch.Tensor, lengths: torch.Tensor, unit_length: int = 4
) -> tuple[torch.Tensor, torch.Tensor]:
    """A padded batch ``(B, T, D)`` as the official evaluation feeds it to the motion encoder, and its lengths.

    **Invariant:** every clip's embedding is the one it gets in the official evaluation (MoMask /
    text-to-motion: ``Text2MotionDatasetEval`` batches encoded by ``EvaluatorModelWrapper.get_co_embeddings``),
    whatever padding the caller used. There each clip is cropped to ``length // 4 * 4`` frames, normalised,
    zero-padded to exactly ``MAX_MOTION_LENGTH = 196`` frames, the movement encoder runs over all 196
    frames and the GRU over the first ``length // 4`` movement steps. Here:

    - Each length is floored to a multiple of ``unit_length`` (a clip keeps its first frames; the official
      loader draws a random start for the crop, so here the embedding is a function of the clip).
    - A floored length must lie in ``[unit_length, 196]``: shorter clips give the GRU no step, and the
      official loaders drop clips of 200 frames or more (197-199 are floored to 196, as here).
    - Every frame past a clip's (floored) length becomes 0: the official padding, in normalised space.
    - The time axis becomes ``T = min(max(length) + 2, 196)`` frames rather than 196, which is faster for
      short batches and gives the same embeddings. Why: both convolutions are (kernel 4, stride 2,
      padding 1), so movement step ``k`` reads first-convolution outputs ``2k-1 .. 2k+2`` and output ``j``
      reads frames ``2j-1 .. 2j+2``. The GRU reads steps ``k < L/4``, i.e. outputs ``j <= L/2`` and frames
      up to ``L + 2``, all zero past ``L``. The only thing the batch width decides is whether output
      ``L/2`` exists (``L + 2 <= T``) or is replaced by the second convolution's zero padding. In the
      196-frame window it exists for every ``L`` up to 192 and not for ``L = 196``; ``T`` above gives
      the same for every clip of the batch (``max(length) + 2`` frames alone would give a 196-frame clip an
      output ``98`` computed over its last real frame, where the official one reads zero padding).
    """
    floored = lengths // unit_length * unit_length  # (B,)
    if (floored < unit_length).any() or (floored > MAX_MOTION_LENGTH).any():
        raise ValueError(
            f"every motion needs at least unit_length={unit_length} frames and at most {MAX_MOTION_LENGTH} once "
            f"floored to a multiple of {unit_length} (the official loaders drop longer clips), got {lengths.tolist()}"
        )
    lengths = floored
    frames = min(int(lengths.max()) + 2, MAX_MOTION_LENGTH)
    if motions.shape[1] < frames:
        motions = F.pad(motions, (0, 0, 0, frames - motions.shape[1]))
    motions = motions[:, :frames]
    keep = torch.arange(frames, device=motions.device) < lengths.to(motions.device)[:, None]  # (B, T)
    return torch.where(keep[..., None], motions, torch.zeros((), dtype=motions.dtype, device=motions.device)), lengths


def _check_lengths(lengths, batch: int, max_len: int, name: str) -> torch.Tensor:
    lengths = torch.as_tensor(lengths, dtype=torch.int64)
    if lengths.shape != (batch,):
        raise ValueError(f"{name} must have shape ({batch},), got {tuple(lengths.shape)}")
    if (lengths < 1).any() or (lengths > max_len).any():
        raise ValueError(f"{name} must lie in [1, {max_len}], got {lengths.tolist()}")
    return lengths


@dataclass
class ContrastiveLosses:
    total: torch.Tensor
    positive: torch.Tensor
    negative: torch.Tensor


@in_fp32  # a loss: its similarities stay fp32 under bf16 autocast
def contrastive_loss(
    text_emb: torch.Tensor,
    motion_emb: torch.Tensor,
    margin: float = 10.0,
    shift: int | None = None,
    generator: torch.Generator | None = None,
) -> ContrastiveLosses:
    """The evaluator's training loss (Hadsell et al. contrastive loss, margin 10)::

        positive = mean_i d(t_i, m_i)^2
        negative = mean_i max(0, margin - d(t_i, m_{(i + s) mod B}))^2
        total    = positive + negative

    ``d`` is ``F.pairwise_distance`` (Euclidean, with its 1e-6 offset). Negatives pair every text with
    the motion ``s`` places further in the batch, one random cyclic shift ``s`` per batch. The reference
    draws ``s`` from ``[0, B-2]``, which includes the degenerate ``s = 0`` (negatives = positives); we
    draw it from ``[1, B-1]`` with ``generator`` unless ``shift`` is given.
    """
    if text_emb.shape != motion_emb.shape or text_emb.dim() != 2:
        raise ValueError(f"text_emb {tuple(text_emb.shape)} and motion_emb {tuple(motion_emb.shape)} must be (B, d)")
    b = text_emb.shape[0]
    if b < 2:
        raise ValueError(f"the contrastive loss needs a batch of at least 2 pairs, got {b}")
    if shift is None:
        draw_on = generator.device if generator is not None else None
        shift = int(torch.randint(1, b, (1,), generator=generator, device=draw_on))
    if not 1 <= shift < b:
        raise ValueError(f"shift must lie in [1, {b - 1}], got {shift}")
    pos = F.pairwise_distance(text_emb, motion_emb).pow(2).mean()
    shuffled = motion_emb.roll(-shift, dims=0)  # row i holds motion (i + shift) mod B
    neg = (margin - F.pairwise_distance(text_emb, shuffled)).clamp(min=0).pow(2).mean()
    return ContrastiveLosses(pos + neg, pos, neg)
