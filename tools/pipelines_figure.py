"""Draw the intro's picture: the two papers' pipelines from one tokenizer, with the chapters that build each piece.

    python tools/pipelines_figure.py [--out book/images/pipelines.png]

Drawn with the library's diagram primitives (:mod:`motionlab.viz.diagrams._draw`), so its boxes, arrows and colours
are the chapters' own: data blue, tokens orange, networks green, noise and ``[MASK]`` violet, conditions pink. The
image is committed; run this again when the picture changes.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")  # files only, no display

from motionlab.viz.diagrams._draw import Canvas  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
OUT = ROOT / "book" / "images" / "pipelines.png"
WIDTH, HEIGHT = 14.0, 7.2  # canvas units; 0.52 inch each: 7.3 × 3.7 inches


def draw():
    """The figure: a shared tokenizer row, then DisCoRD's decoder and M2D2M's generator, left to right."""
    c = Canvas(WIDTH, HEIGHT, inches_per_unit=0.52)
    h, fs, title = 0.7, 8, {"ha": "left", "fontsize": 9, "weight": "bold"}
    tokens = ["17", "4", "4", "9"]

    # both papers: the VQ-VAE (chapters 01-02)
    c.text(0.05, 6.75, "Both papers: motion as tokens (01–02)", **title)
    motion = c.box(0.1, 5.6, 1.6, h, "motion $\\mathbf{X}$\n$T \\times D$", "data", fontsize=fs)
    encoder = c.box(2.4, 5.6, 2.2, h, "encoder $\\mathcal{E}$ +\nquantizer $\\mathcal{Q}$", "network", fontsize=fs)
    strip = c.strip(5.3, 5.7, tokens, cell=0.5, kinds="token", fontsize=fs)
    c.text(6.3, 5.42, "tokens $\\mathbf{S}$: one per $q$ frames", fontsize=7)
    ff = c.box(8.0, 5.6, 2.4, h, "feed-forward\ndecoder $\\mathcal{D}$", "network", fontsize=fs)
    out = c.box(11.2, 5.6, 1.6, h, "motion $\\hat{\\mathbf{X}}$", "data", fontsize=fs)
    c.arrow(motion, encoder)
    c.arrow(encoder, strip[0])
    c.arrow(strip[-1], ff)
    c.arrow(ff, out)

    # DisCoRD (chapters 03-06): tokens -> frame-wise conditions -> a rectified flow from noise to motion
    c.text(0.05, 4.75, "DisCoRD: decode the tokens with a rectified flow (03–06)", **title)
    d_tokens = c.strip(0.3, 3.6, tokens, cell=0.5, kinds="token", fontsize=fs)
    projection = c.box(
        2.6, 3.5, 2.95, h, "condition projection (04)\n$\\mathbf{C}$: $T \\times d_{feat}$", "condition", fontsize=fs
    )
    noise = c.box(6.05, 2.55, 1.6, 0.6, "noise $\\mathbf{x}_0$", "noise", fontsize=fs)
    unet = c.box(6.1, 3.5, 2.4, h, "U-Net $v_\\theta(\\mathbf{x}_t, t, \\mathbf{C})$\n(05)", "network", fontsize=fs)
    ode = c.box(8.95, 3.5, 2.2, h, "Euler / midpoint\nstep, $t: 0 \\to 1$ (03)", "operation", fontsize=fs)
    d_out = c.box(11.7, 3.5, 1.6, h, "motion $\\mathbf{x}_1$", "data", fontsize=fs)
    c.arrow(d_tokens[-1], projection)
    c.arrow(projection, unet)
    c.arrow(noise, unet, start_side="top", end_side="bottom")
    c.arrow(unet, ode)
    c.arrow(ode, unet, start_side="bottom", end_side="bottom", curve=-0.45, text="$N$ steps", text_offset=(0.35, -0.78))
    c.arrow(ode, d_out)
    c.text(12.5, 3.2, "scored by sJPE (06)", fontsize=7, style="italic")

    # M2D2M (chapters 07-09): text -> discrete diffusion over tokens -> the tokenizer's decoder
    c.text(0.05, 2.35, "M2D2M: generate the tokens by discrete diffusion (07–09)", **title)
    masked = c.strip(0.3, 1.05, ["M"] * 4, cell=0.5, kinds="noise", fontsize=fs)
    c.text(1.3, 0.78, "$z_{T_d}$: all [MASK]", fontsize=7)
    denoiser = c.box(
        2.9, 0.95, 3.4, h, "denoising transformer (07)\n$\\beta(t, d)$ transitions (08)", "network", fontsize=fs
    )
    text = c.box(3.7, 0.0, 1.8, 0.55, "text $y$", "condition", fontsize=fs)
    c.arrow((5.9, 1.68), (3.3, 1.68), curve=0.25, text="$T_d$ reverse steps", text_offset=(0.0, 0.28))
    m_tokens = c.strip(7.0, 1.05, tokens, cell=0.5, kinds="token", fontsize=fs)
    c.text(8.0, 0.78, "$z_0$; TPS: several actions (09)", fontsize=7)
    decoder = c.box(9.7, 0.95, 1.3, h, "$\\mathcal{D}$", "network", fontsize=fs)
    m_out = c.box(11.7, 0.95, 1.6, h, "motion", "data", fontsize=fs)
    c.arrow(masked[-1], denoiser)
    c.arrow(text, denoiser, start_side="top", end_side="bottom")
    c.arrow(denoiser, m_tokens[0])
    c.arrow(m_tokens[-1], decoder)
    c.arrow(decoder, m_out)
    return c.finish()


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=OUT)
    args = parser.parse_args(argv)
    figure = draw()
    args.out.parent.mkdir(parents=True, exist_ok=True)
    figure.savefig(args.out, dpi=150)
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
