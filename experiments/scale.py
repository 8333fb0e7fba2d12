"""At what scale does each claim hold? Train the models the claims rest on at multiples of the laptop budget, run by
run on a GPU, and score every point with the chapters' own evaluations (issue 47).

A point is one model group at one multiple of the laptop's training samples, at the laptop's widths
(:mod:`motionlab.evaluation.scale`): ``discord`` (the RVQ tokenizer and chapter 05's DisCoRD decoder), ``projection``
(the RVQ tokenizer and chapter 04's three projection decoders) and ``m2d2m`` (the VQ tokenizer and the uniform,
dynamic and multi-motion text-to-motion models). Every point is scored with one evaluator, the laptop's. The work is
ordered so that each run adds the most: every group at 10×, then every group at 30×, then 100×, 300×, ...

A GPU run (a lease of about 15 minutes, the machine's start included, at most 10 minutes a command) from the
repository root, with the records so far copied into ``$OUT/scale`` first (``SCALE_ONLY=1 tools/gpu_lease.sh`` does
both)::

    PYTHONPATH=src python experiments/scale.py --device cuda --minutes 8 --out $OUT/scale

then copy ``$OUT/scale/*.json`` into ``book/data/scale/embedded-v<N>/`` and commit them; the next run (with those
records in place under ``--out``) continues with the first point not yet recorded. Leave the command's own limit a
point's length above ``--minutes``: the time is checked between points, and scoring is not predicted.

``--plan`` prints the plan and exits; every run prints it first, with each point's predicted time: each model's
steps × its step time as an earlier point in ``--out`` measured it on this kind of device at this batch, else as the
GPU benchmark measured the library's training step (``book/data/gpu/*.json``, at the papers' widths and batch, so an
upper bound for the laptop's narrower networks), else "not predicted" (the benchmark did not time the VQ tokenizer);
plus the group's scoring time where an earlier point measured it (the evaluations do not grow with the multiple).
The first GPU run thus predicts from the benchmark and every later one from the points before it. A model the cache
has trained already costs nothing, one with a checkpoint in progress only its steps after it, and a model an earlier
point of the plan trains (the RVQ that DisCoRD's point and the projection point share) is counted once.

Run by run: a point is the unit of work. A finished point is written at once (atomically) and never redone; a run
with ``--minutes N`` always does its first pending point, then starts another only while the time left covers the
point's prediction (or, unpredicted, while any is left), and stops cleanly between points, printing what is left.
The trained models live in the model cache on the leased machine. With ``--carry-out DIR`` a run packs what the
remaining points need into ``DIR`` (at most ``--carry-parts`` files of 15 MiB, :mod:`motionlab.studies.carry`): the
finished models they load (the evaluator, a tokenizer two groups share) and the newest checkpoint of a training cut
off mid-way; ``--carry-in DIR`` on the next lease unpacks it first, so that point resumes from its checkpoint instead
of starting again, and a point longer than one command finishes over several. With ``--carry-out`` a run uses all of
``--minutes`` and is stopped from outside (``timeout -s INT``, as ``tools/gpu_lease.sh`` does); it packs on the way
out. Stopped with SIGINT (Ctrl-C, ``timeout -s INT``) or SIGTERM (a machine's time limit), a training saves the step
it reached first, and the carry is still packed. Without ``--carry-out``, a point cut off on a leased machine is
retrained from the start by the next lease, at the cost of its predicted time again; on a machine that keeps
``$MOTIONLAB_HOME`` (a workstation's CPUs, over several sittings) the next run resumes it from the cache as it is. Each
model's record lists its ``sittings``: every run that trained it (steps, seconds, device), so a resumed model keeps
its whole time; the step times the next plans use come from them.

Each point's record, ``<out>/<group>-x<multiple>.json``, holds the device (the GPU's name, or the CPU's), the
precision, the torch version, the commit, the data, the batch factor, every model's steps × batch and time, the
resolved configs of its models and evaluations (``"configs"``: a record whose configs are no longer the code's is
set aside when the book reads the folder, :func:`motionlab.report.scale.read_scale_records`, and measured again
here), the claim numbers (``"values"``) and the evaluation tables. ``--smoke`` runs the whole pipeline at the smoke
profile with tiny multiples on the CPU in about a minute, into ``$MOTIONLAB_HOME/scale-smoke`` unless ``--out``.
"""

from __future__ import annotations

import argparse
import json
import signal
import sys
import time
import warnings
from pathlib import Path

import torch

from motionlab.build.stamp import machine_stamp
from motionlab.data.embedded.generator import VERSION
from motionlab.evaluation.scale import GROUPS, MULTIPLES, scaled_budgets
from motionlab.io.common import write_text_atomic
from motionlab.paths import cache_dir
from motionlab.report.scale import read_scale_records
from motionlab.studies.carry import cached_progress, carried_folders, pack_cache, unpack_cache
from motionlab.studies.scale import (
    Point,
    Rates,
    auto_batch_factor,
    estimate_json,
    measured_rates,
    plan_lines,
    plan_point,
    point_seconds,
    score_point,
    train_point,
)
from motionlab.train.device import device_name, get_device

ROOT = Path(__file__).resolve().parents[1]
OUT = ROOT / "book" / "data" / "scale" / f"embedded-v{VERSION}"
GPU_RECORDS = ROOT / "book" / "data" / "gpu"
SMOKE_MULTIPLES = (0.5, 1.0)  # of the smoke profile's seconds-long budgets: proves the pipeline, measures nothing


def _log(text: str) -> None:
    print(text, file=sys.stderr, flush=True)


def _precision(device: str) -> str:
    """The precision the points train in on ``device``; planning a GPU run elsewhere, what ``auto`` resolves to on a
    bf16 GPU such as the benchmark's (an explicit ``$MOTIONLAB_PRECISION`` is kept)."""
    from motionlab.precision import requested_precision, resolve_precision

    if device.startswith("cuda") and not torch.cuda.is_available():
        requested = requested_precision(None)
        return "bf16" if requested == "auto" else requested
    return resolve_precision(None, device)


def _gpu_run(path: Path | None):
    """The GPU benchmark run whose step times predict the plan: ``path``, else the newest under book/data/gpu."""
    from motionlab.report.gpu import load_gpu_runs, read_gpu_run

    if path is not None:
        return read_gpu_run(path)
    runs = load_gpu_runs(GPU_RECORDS)
    return runs[-1] if runs else None


def _recorded(out: Path, profile: str) -> dict[str, dict]:
    """The points recorded in ``out`` as the code would measure them now, by key; the book's own reader decides which
    are stale (:func:`motionlab.report.scale.read_scale_records`), and a stale one is measured again."""
    if not out.is_dir():
        return {}
    with warnings.catch_warnings():  # a folder of stale points only means every point is measured again
        warnings.simplefilter("ignore")
        records, set_aside = read_scale_records(out, profile)
    for line in set_aside:
        _log(f"{line}: measuring it again")
    return {Point(r["group"], float(r["multiple"])).key: r for r in records}


def run_point(point: Point, profile: str, device: str, rates: Rates) -> dict:
    """Train and score one point: its record."""
    from motionlab import models

    planned = {m.name: m for m in plan_point(point, profile, rates)}
    dataset = models.load("data", None, profile)
    start = time.perf_counter()
    training = train_point(point, dataset, profile, device)
    scoring_start = time.perf_counter()
    values, tables = score_point(point, dataset, profile, device)
    stamp = machine_stamp()
    return {
        "study": "scale",
        "group": point.group,
        "multiple": point.multiple,
        "batch_factor": point.batch_factor,
        "profile": profile,
        **stamp,
        "device": device_name(get_device(device)),
        "device_type": device.split(":")[0],
        "precision": rates.precision,
        "torch": torch.__version__,
        "data": dataset.key,
        "models": {n: {"steps": m.steps, "batch": m.batch, **training[n]} for n, m in planned.items()},
        "seconds": {
            "training": round(scoring_start - start, 1),
            "scoring": round(time.perf_counter() - scoring_start, 1),
        },
        "configs": _configs(point, profile),
        "values": {key: estimate_json(e) for key, e in values.items()},
        "tables": tables,
    }


def _configs(point: Point, profile: str) -> dict:
    from motionlab.evaluation.scale import point_configs

    return point_configs(point.group, point.multiple, point.batch_factor, profile)


def _parse(argv: list[str] | None) -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--multiples", type=float, nargs="+", help=f"of the laptop budget (default: {MULTIPLES})")
    parser.add_argument("--groups", nargs="+", choices=GROUPS, default=list(GROUPS), help="model groups (default: all)")
    parser.add_argument("--profile", default="laptop", help="whose budget and widths (default: laptop)")
    parser.add_argument("--device", default="auto", help="cpu, cuda, cuda:N or auto (default: cuda when available)")
    parser.add_argument("--minutes", type=float, help="stop between points once this much time is spent")
    parser.add_argument("--batch-factor", type=int, help="batch × this (a power of two; default: chosen per point)")
    parser.add_argument("--gpu-record", type=Path, help="the GPU benchmark run to predict from (default: newest)")
    parser.add_argument("--plan", action="store_true", help="print the plan with predicted times and exit")
    parser.add_argument("--smoke", action="store_true", help="smoke profile, tiny multiples, CPU: the pipeline only")
    parser.add_argument("--out", type=Path, help="where the records go (default: book/data/scale/embedded-v<N>)")
    parser.add_argument("--carry-in", type=Path, help="unpack the model cache a previous run carried out (its folder)")
    parser.add_argument("--carry-out", type=Path, help="pack what the remaining points need here (on exit too)")
    parser.add_argument("--carry-parts", type=int, default=4, help="files of 15 MiB the carried cache may take")
    args = parser.parse_args(argv)
    if args.smoke:
        args.profile, args.multiples = "smoke", args.multiples or list(SMOKE_MULTIPLES)
        args.device = "cpu" if args.device == "auto" else args.device
        if args.out is None:
            from motionlab.paths import cache_dir

            args.out = cache_dir() / "scale-smoke"  # never the book's folder: smoke numbers are not results
    args.multiples = args.multiples or list(MULTIPLES)
    args.out = args.out or OUT
    if any(m <= 0 for m in args.multiples):
        parser.error("--multiples must be > 0")
    if args.minutes is not None and args.minutes <= 0:
        parser.error("--minutes must be > 0")
    if args.batch_factor is not None and (args.batch_factor < 1 or args.batch_factor & (args.batch_factor - 1)):
        parser.error("--batch-factor must be a power of two >= 1")
    if args.device == "auto":
        args.device = "cuda" if torch.cuda.is_available() else "cpu"
    if args.device.startswith("cuda") and not torch.cuda.is_available() and not args.plan:  # a plan trains nothing
        parser.error(f"--device {args.device}: torch sees no CUDA device here")
    if not (args.device == "cpu" or args.device.startswith("cuda")):
        parser.error(f"--device must be cpu, cuda, cuda:N or auto, got {args.device!r}")
    if args.carry_in is not None and not args.carry_in.is_dir():
        parser.error(f"--carry-in {args.carry_in}: no such folder")
    if args.carry_parts < 1:
        parser.error("--carry-parts must be >= 1")
    if args.gpu_record is not None and not args.gpu_record.is_file():
        parser.error(f"--gpu-record {args.gpu_record}: no such file")
    try:  # a profile without budgets of its own (full: the papers') has nothing to multiply
        with scaled_budgets(1, 1, args.profile):
            pass
    except ValueError as err:
        parser.error(f"--profile {args.profile}: {err}")
    return args


def main(argv: list[str] | None = None) -> int:
    args = _parse(argv)
    torch.set_num_threads(1 if args.device == "cpu" else torch.get_num_threads())  # a shared CPU: one thread
    # the GPU benchmark predicts a GPU run only: a CPU's steps are predicted by the points it measured itself
    run = _gpu_run(args.gpu_record) if args.device.startswith("cuda") else None
    precision, device_type = _precision(args.device), args.device.split(":")[0]
    points = []
    for multiple in sorted(args.multiples):  # every group at a multiple before the next multiple
        for group in args.groups:
            factor = args.batch_factor or auto_batch_factor(multiple, group, args.profile, args.device, run)
            points.append(Point(group, multiple, factor))
    records = _recorded(args.out, args.profile)
    done = {p.key for p in points if p.key in records}
    rates = measured_rates(list(records.values()), device_type, precision, run)
    if args.carry_in is not None:  # first: the plan counts the steps its checkpoints have trained
        unpacked = unpack_cache(args.carry_in, cache_dir())
        _log(f"carried in: {', '.join(unpacked) if unpacked else 'nothing'}")
    progress = cached_progress(cache_dir(), precision)
    print("\n".join(plan_lines(points, args.profile, rates, done, args.minutes, progress)), flush=True)
    if args.plan:
        return 0
    args.out.mkdir(parents=True, exist_ok=True)
    # a machine's time limit (SIGTERM) stops a run like the lease's own SIGINT: the training under way checkpoints
    # its step, and what the next run needs is still packed
    previous_sigterm = signal.signal(signal.SIGTERM, _sigterm_as_interrupt)
    try:
        return _run_points(args, points, records, done, rates, run, precision, device_type)
    except KeyboardInterrupt:  # the lease's hard stop: a training checkpoints the step it stopped at
        left = [p.key for p in points if p.key not in done]
        print(f"interrupted: {len(left)} point(s) left ({', '.join(left)}); run again to continue", flush=True)
        return 130
    finally:
        if previous_sigterm is not None:  # None: a handler from outside Python, which cannot be put back
            signal.signal(signal.SIGTERM, previous_sigterm)  # a second SIGTERM while packing ends the run at once
        if args.carry_out is not None:
            pending = [p for p in points if p.key not in done]
            configs = [c for p in pending for c in _configs(p, args.profile)["models"].values()]
            folders = carried_folders(cache_dir(), configs)
            print(pack_cache(cache_dir(), folders, args.carry_out, args.carry_parts)[1], flush=True)


def _run_points(args, points, records, done, rates, run, precision, device_type) -> int:
    """Train and record the pending points in order, until done or out of time (``done`` grows as they finish)."""
    deadline = None if args.minutes is None else time.monotonic() + 60 * args.minutes
    finished = 0
    for point in points:
        if point.key in done:
            _log(f"{point.key}: recorded already")
            continue
        predicted = point_seconds(point, args.profile, rates, cached_progress(cache_dir(), precision))
        if deadline is not None and finished and _no_time(deadline, predicted, args.carry_out is not None):
            left = [p.key for p in points if p.key not in done]
            print(f"stopping: {len(left)} point(s) left ({', '.join(left)}); run again to continue", flush=True)
            return 0
        record = run_point(point, args.profile, args.device, rates)
        write_text_atomic(args.out / f"{point.key}.json", json.dumps(record, indent=1) + "\n")
        records[point.key] = record
        rates = measured_rates(list(records.values()), device_type, precision, run)  # the next points' predictions
        done.add(point.key)
        finished += 1
        seconds = record["seconds"]
        print(f"{point.key}: recorded ({seconds['training']:.0f} s training, {seconds['scoring']:.0f} s scoring)")
    print(f"all {len(points)} point(s) recorded in {args.out}", flush=True)
    return 0


def _no_time(deadline: float, predicted: float | None, carried: bool = False) -> bool:
    """Whether the next point should wait for the next run: past the deadline, or predicted not to fit before it
    (unless the cache is carried out, when a point cut off resumes next run: then any time left is used)."""
    left = deadline - time.monotonic()
    return left <= 0 or (not carried and predicted is not None and predicted > left)


def _sigterm_as_interrupt(signum: int, frame) -> None:
    raise KeyboardInterrupt("SIGTERM")


if __name__ == "__main__":
    sys.exit(main())
