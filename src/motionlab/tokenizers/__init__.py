"""Motion tokenizers: conv encoder/decoder, EMA-reset VQ, residual VQ, and the ``Tokenizer`` interface.

Typical use in a chapter::

    model = tokenizer_for_dataset("rvq", load_dataset(profile=profile), profile)   # trained once, then cached
    ids = model.encode(motion)          # (B, T, 263) normalised → (B, T/4, R) token ids
    z = model.embed(ids)                # (B, T/4, code_dim): what the DisCoRD decoder is conditioned on
    recon = model.decode(ids)           # (B, T, 263)
"""

from .base import Tokenizer, check_ids, check_motion
from .config import RVQConfig, VQConfig, rvq_config, vq_config
from .encdec import Decoder, Encoder, ResConv1DBlock, Resnet1D
from .losses import ric_slice, tokenizer_loss
from .models import RVQVAE, VQVAE, ConvTokenizer, TokenizerOutput, build_tokenizer
from .quantizer import QuantizeOutput, QuantizerEMAReset, perplexity_of
from .residual_vq import ResidualVQ
from .training import (
    load_tokenizer,
    tokenizer_for_dataset,
    tokenizer_loss_fn,
    train_or_load_tokenizer,
    train_tokenizer,
    window_validation,
)

__all__ = [
    "RVQVAE",
    "VQVAE",
    "ConvTokenizer",
    "Decoder",
    "Encoder",
    "QuantizeOutput",
    "QuantizerEMAReset",
    "RVQConfig",
    "ResConv1DBlock",
    "Resnet1D",
    "ResidualVQ",
    "Tokenizer",
    "TokenizerOutput",
    "VQConfig",
    "build_tokenizer",
    "check_ids",
    "check_motion",
    "load_tokenizer",
    "perplexity_of",
    "ric_slice",
    "rvq_config",
    "tokenizer_for_dataset",
    "tokenizer_loss",
    "tokenizer_loss_fn",
    "train_or_load_tokenizer",
    "train_tokenizer",
    "vq_config",
    "window_validation",
]
