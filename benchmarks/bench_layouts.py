"""Which layout do the laptop models' 1-D convolutions want in bf16? Conv1d as it is, Conv2d (1, k) channels-last,
or one matmul over shifted copies in (B, T, C).

Not a test: prints a table and writes JSON. For each convolution shape of the laptop tokenizers and the DisCoRD
U-Net (batch 32, 64-frame windows), forward + backward (input, weight and bias gradients) of:

- ``conv1d fp32``: ``nn.Conv1d`` on (B, C, T), no autocast: the baseline;
- ``conv1d bf16``: the same under bf16 autocast (PyTorch runs it as a 2-D convolution on an NCHW view, reordered
  by oneDNN at every call);
- ``conv2d-cl bf16``: the same weights as a ``(1, k)`` Conv2d on a channels-last (B, C, 1, T) tensor;
- ``matmul bf16``: the input already in (B, T, C), padded, its ``k`` shifted (strided, dilated) copies side by side,
  one ``F.linear`` with the weight reshaped to (C_out, k·C_in): what a network kept in (B, T, C) would run.

Timing follows ``benchmarks/_timing.py`` (one thread, variants interleaved, median and min–max); the ratio is the
baseline's time over the variant's, per round.

    .venv/bin/python benchmarks/bench_layouts.py --json _build/benchmarks/layouts.json
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
import torch
import torch.nn.functional as F
from _timing import add_timing_arguments, apply_threads, interleaved, ratio, ratio_text, spread, write_records

from motionlab.precision import read_cpu_info

# (model, what, C_in, C_out, kernel, stride, dilation, T): the laptop configs' convolutions that carry the work
SHAPES = [
    ("tokenizer", "input conv", 263, 128, 3, 1, 1, 64),
    ("tokenizer", "downsampling", 128, 128, 4, 2, 1, 64),
    ("tokenizer", "residual, dilation 3", 128, 128, 3, 1, 3, 32),
    ("tokenizer", "residual, dilation 9", 128, 128, 3, 1, 9, 16),
    ("discord", "input 1x1", 327, 128, 1, 1, 1, 64),
    ("discord", "ResNet conv", 128, 128, 3, 1, 1, 64),
    ("discord", "up ResNet conv", 256, 128, 3, 1, 1, 64),
]


def shifted_matmul(
    x: torch.Tensor, weight: torch.Tensor, bias: torch.Tensor, stride: int, dilation: int, padding: int
) -> torch.Tensor:
    """A Conv1d on (B, T, C) as one matmul: ``(B, T, C_in) -> (B, T_out, C_out)``; the weight keeps its (out, in, k)."""
    out_ch, in_ch, k = weight.shape
    span = dilation * (k - 1) + 1
    padded = F.pad(x, (0, 0, padding, padding))  # pad time
    windows = padded.unfold(1, span, stride)[..., ::dilation]  # (B, T_out, C_in, k)
    return F.linear(windows.reshape(*windows.shape[:2], in_ch * k), weight.reshape(out_ch, in_ch * k), bias)


def variants(c_in: int, c_out: int, k: int, stride: int, dilation: int, T: int, batch: int = 32):
    gen = torch.Generator().manual_seed(0)
    padding = dilation * (k - 1) // 2 if stride == 1 else 1
    conv = torch.nn.Conv1d(c_in, c_out, k, stride=stride, padding=padding, dilation=dilation)
    conv2 = torch.nn.Conv2d(c_in, c_out, (1, k), stride=(1, stride), padding=(0, padding), dilation=(1, dilation))
    conv2.weight.data.copy_(conv.weight.data[:, :, None])
    conv2.bias.data.copy_(conv.bias.data)
    conv2 = conv2.to(memory_format=torch.channels_last)
    x = torch.randn(batch, c_in, T, generator=gen)
    x_ncl = x.clone().requires_grad_()
    x_cl = x[:, :, None].contiguous(memory_format=torch.channels_last).requires_grad_()
    x_btc = x.transpose(1, 2).contiguous().requires_grad_()
    with torch.no_grad():  # the three forms compute the same convolution
        reference = conv(x)
        assert torch.allclose(conv2(x[:, :, None]).squeeze(2), reference, atol=1e-4)
        matmul = shifted_matmul(x.transpose(1, 2), conv.weight, conv.bias, stride, dilation, padding)
        assert torch.allclose(matmul.transpose(1, 2), reference, atol=1e-4)

    def step(forward, bf16: bool):
        def run() -> None:
            with torch.autocast("cpu", dtype=torch.bfloat16, enabled=bf16):
                out = forward()
            out.float().sum().backward()

        return run

    return {
        "conv1d fp32": step(lambda: conv(x_ncl), False),
        "conv1d bf16": step(lambda: conv(x_ncl), True),
        "conv2d-cl bf16": step(lambda: conv2(x_cl), True),
        "matmul bf16": step(lambda: shifted_matmul(x_btc, conv.weight, conv.bias, stride, dilation, padding), True),
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--json", type=Path, default=None, help="write the records here")
    add_timing_arguments(parser, repeats=15)
    args = parser.parse_args()
    threads = apply_threads(args.threads)
    cpu = read_cpu_info().summary
    print(
        f"{cpu}; {threads} thread(s); {args.repeats} rounds; ms forward + backward, median (min–max); "
        "speed-up over conv1d fp32 per round\n"
    )
    names = ["conv1d fp32", "conv1d bf16", "conv2d-cl bf16", "matmul bf16"]
    print("| model | convolution | " + " | ".join(names) + " |\n|---|---|" + "---|" * len(names))
    records = []
    for model, what, c_in, c_out, k, stride, dilation, T in SHAPES:
        timings = interleaved(variants(c_in, c_out, k, stride, dilation, T), repeats=args.repeats, warmup=2)
        base = timings["conv1d fp32"]
        cells = [spread(base.wall, 1000, 2)]
        for name in names[1:]:
            speedup = ratio(base, timings[name])
            cells.append(f"{np.median(timings[name].wall) * 1000:.2f} ({ratio_text(speedup, 'wall')})")
        for name, t in timings.items():
            records.append(
                {
                    "model": model,
                    "conv": what,
                    "shape": [c_in, c_out, k, stride, dilation, T],
                    "layout": name,
                    "median_s": float(np.median(t.wall)),
                    "min_s": float(t.wall.min()),
                    "max_s": float(t.wall.max()),
                    "cpu_median_s": float(np.median(t.cpu)),
                    "cpu": cpu,
                }
            )
        print(
            f"| {model} | {what} ({c_in}→{c_out}, k{k}"
            + (f" s{stride}" if stride > 1 else "")
            + (f" d{dilation}" if dilation > 1 else "")
            + f", T {T}) | "
            + " | ".join(cells)
            + " |",
            flush=True,
        )
    write_records(args.json, records)


if __name__ == "__main__":
    main()
