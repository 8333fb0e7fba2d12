"""How much of ``motionlab evaluate reconstruction`` is the networks, and how much is everything else.

Issue #16 asks that the metrics be the fast part: the non-model share of a whole reconstruction evaluation
(start-up, imports, loading, metrics, Python glue) should be small. A profiler inflates Python-heavy code
more than the C++ kernels of the networks, so this measures without one:

- each round runs the command in a fresh Python process (imports and loading count, as they do for a user),
  one torch thread unless ``--threads``, and with ``MOTIONLAB_NO_TRAIN=1`` (a model missing from the cache
  is an error, not an hour of training);
- inside that process, global module hooks time every *outermost* ``nn.Module`` call (wall and CPU): that
  is the model time; the rest of the process's wall and CPU time is the non-model time;
- a fixed number of rounds (``--repeats``); the table gives the median and min–max of each quantity.

    MOTIONLAB_HOME=... .venv/bin/python benchmarks/bench_evaluate.py --profile laptop --repeats 3
    (extra arguments after ``--`` go to ``evaluate reconstruction``, e.g. ``-- --decoder rvq``)
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from _timing import spread


def _child(argv: list[str], report: Path) -> int:
    """Run the command here with model calls timed; write the times to ``report``."""
    import torch

    from motionlab import cli

    depth, started, totals = [0], [0.0, 0.0], {"model_wall": 0.0, "model_cpu": 0.0, "model_calls": 0}

    def before(module, args):
        if depth[0] == 0:
            started[:] = [time.perf_counter(), time.process_time()]
        depth[0] += 1

    def after(module, args, output):
        depth[0] -= 1
        if depth[0] == 0:
            totals["model_wall"] += time.perf_counter() - started[0]
            totals["model_cpu"] += time.process_time() - started[1]
            totals["model_calls"] += 1

    torch.nn.modules.module.register_module_forward_pre_hook(before)
    torch.nn.modules.module.register_module_forward_hook(after)
    code = cli.main(argv)
    report.write_text(json.dumps(totals))
    return code


def _round(command: list[str], threads: int) -> dict[str, float]:
    """One fresh process: its wall and CPU time and the model time it measured."""
    with tempfile.TemporaryDirectory() as tmp:
        report = Path(tmp) / "times.json"
        env = {
            **os.environ,
            "MOTIONLAB_NO_TRAIN": "1",
            "OMP_NUM_THREADS": str(threads),
            "OPENBLAS_NUM_THREADS": str(threads),
            "MKL_NUM_THREADS": str(threads),
        }
        before = resource.getrusage(resource.RUSAGE_CHILDREN)
        wall = time.perf_counter()
        done = subprocess.run(
            [sys.executable, __file__, "--child", str(report), "--", *command], env=env, capture_output=True, text=True
        )
        wall = time.perf_counter() - wall
        after = resource.getrusage(resource.RUSAGE_CHILDREN)
        if done.returncode != 0 or not report.is_file():
            raise SystemExit(f"the evaluation failed (exit {done.returncode}):\n{done.stderr[-3000:]}")
        model = json.loads(report.read_text())
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return {"wall": wall, "cpu": cpu, **model}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--profile", default="laptop")
    parser.add_argument("--repeats", type=int, default=3, help="rounds, each a fresh process (default 3)")
    parser.add_argument("--threads", type=int, default=1, help="torch CPU threads (default 1)")
    parser.add_argument("--child", type=Path, help=argparse.SUPPRESS)
    parser.add_argument("--json", type=Path, default=Path("_build/benchmarks/evaluate.json"))
    parser.add_argument("rest", nargs="*", help="after --: more arguments of evaluate reconstruction")
    args = parser.parse_args()
    if args.child is not None:
        sys.exit(_child(args.rest, args.child))
    if args.repeats < 1 or args.threads < 1:
        raise SystemExit("--repeats and --threads must be >= 1")
    command = ["--threads", str(args.threads), "evaluate", "reconstruction", "--profile", args.profile, *args.rest]
    rounds = []
    for r in range(args.repeats):
        rounds.append(_round(command, args.threads))
        print(f"round {r + 1}/{args.repeats}: {rounds[-1]['wall']:.1f} s wall", file=sys.stderr, flush=True)
    col = {key: np.array([x[key] for x in rounds]) for key in rounds[0]}
    share_wall = 1 - col["model_wall"] / col["wall"]
    share_cpu = 1 - col["model_cpu"] / col["cpu"]
    print(f"motionlab {' '.join(command)}: {args.repeats} rounds, each a fresh process; median (min–max)")
    print("| | wall (s) | CPU (s) |\n|---|---:|---:|")
    print(f"| whole command | {spread(col['wall'], digits=1)} | {spread(col['cpu'], digits=1)} |")
    print(
        f"| model calls ({int(np.median(col['model_calls']))} outermost) | {spread(col['model_wall'], digits=1)} | "
        f"{spread(col['model_cpu'], digits=1)} |"
    )
    print(
        f"| everything else | {spread(col['wall'] - col['model_wall'], digits=1)} | "
        f"{spread(col['cpu'] - col['model_cpu'], digits=1)} |"
    )
    print(f"| non-model share | {spread(share_wall * 100, digits=1)} % | {spread(share_cpu * 100, digits=1)} % |")
    args.json.parent.mkdir(parents=True, exist_ok=True)
    args.json.write_text(json.dumps({"command": command, "rounds": rounds}, indent=1))


if __name__ == "__main__":
    main()
