"""Figures of the hostile-input suite: run with ``make bench-hostile`` (or this script).

Prints, with the machine's load beside them:

1. the number of hostile cases the suite holds, by class (collected by pytest);
2. the example count and wall time of ``make fuzz`` (``--examples``, default 20000;
   ``--examples 0`` skips it);
3. the peak RSS of ``napari-labyrinth render`` refusing a 21 KB TIFF that declares
   100000 x 100000 pixels (measured in a child process);
4. the time from start to exit of ``napari-labyrinth render --scheduler`` pointed at a
   socket that never answers, with the default timeout.
"""

from __future__ import annotations

import argparse
import collections
import os
import re
import socket
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path[:0] = [str(ROOT / "src"), str(ROOT)]

SUITE = [
    "tests/test_hostile.py",
    "tests/test_hostile_properties.py",
    "tests/cli/test_cli_hostile.py",
]

#: Test function name (pattern) -> class of the issue's list.
CLASSES = [
    (r"huge|memory|budget|sizes_parse", "1 memory bombs"),
    (r"scheduler", "2 unbounded waits"),
    (r"extreme_parameter|plane_offset|bounds|largest_value", "3 extreme parameter values"),
    (r"names_it|zero_d", "4 errors that name the problem"),
    (r"big_endian", "5 valid input refused (byte order)"),
    (r"float16|alpha", "6 silent garbage"),
    (r"constant|float64|unforeseen|corrupt", "7 valid extreme data, batch isolation, bad files"),
    (r"temporar|sigint", "8 leftovers"),
    (r"any_small_image|every_dtype", "property over random images"),
]


def _load() -> str:
    return "load average %.2f %.2f %.2f" % os.getloadavg()


def _env() -> dict:
    return dict(os.environ, PYTHONPATH=os.pathsep.join([str(ROOT / "src"), str(ROOT)]))


def count_cases() -> None:
    listing = subprocess.run(
        [sys.executable, "-m", "pytest", "--collect-only", "-q", "-p", "no:cacheprovider", *SUITE],
        cwd=ROOT, capture_output=True, text=True, env=_env(),
    ).stdout
    ids = [line for line in listing.splitlines() if "::" in line]
    counts: collections.Counter = collections.Counter()
    for test_id in ids:
        name = test_id.split("::")[-1]
        label = next((c for pattern, c in CLASSES if re.search(pattern, name)), "other")
        counts[label] += 1
    print(f"hostile cases collected: {len(ids)} test cases ({_load()})")
    for label in sorted(counts):
        print(f"  {label:<50} {counts[label]:>4}")


def fuzz(examples: int) -> None:
    started = time.perf_counter()
    done = subprocess.run(
        [sys.executable, "-m", "pytest", "tests/test_hostile_properties.py", "-q",
         "-p", "no:cacheprovider", "-W", "ignore::RuntimeWarning"],
        cwd=ROOT, capture_output=True, text=True,
        env=dict(_env(), HOSTILE_EXAMPLES=str(examples), HOSTILE_SEED="random"),
    )
    elapsed = time.perf_counter() - started
    summary = done.stdout.strip().splitlines()[-1] if done.stdout.strip() else done.stderr[-300:]
    print(f"make fuzz: {examples} examples in {elapsed:.0f} s wall ({_load()}): {summary}")


def peak_rss() -> None:
    from tests.cli.test_cli_hostile import declared_huge_tiff, run_measured

    with tempfile.TemporaryDirectory() as directory:
        bomb = declared_huge_tiff(Path(directory) / "bomb.tif")
        for limit in (None, "2G"):
            env = _env()
            env.pop("NAPARI_LABYRINTH_MEMORY", None)
            if limit:
                env["NAPARI_LABYRINTH_MEMORY"] = limit
            started = time.perf_counter()
            code, err, peak = run_measured(
                ["render", str(bomb), "-o", str(Path(directory) / "out.tif")], env
            )
            elapsed = time.perf_counter() - started
            line = next((x for x in err.splitlines() if "error" in x), "").split(": error: ")[-1]
            print(
                f"declared-huge TIFF ({bomb.stat().st_size} B, 100000 x 100000 uint8), "
                f"limit {limit or 'memory available'}: exit {code} after {elapsed:.1f} s, "
                f"peak RSS {peak:.0f} MiB ({_load()})\n  {line}"
            )


def unanswering_scheduler() -> None:
    from napari_labyrinth.cli.render import SCHEDULER_TIMEOUT

    with tempfile.TemporaryDirectory() as directory:
        image = Path(directory) / "in.tif"
        import numpy as np
        import tifffile

        tifffile.imwrite(image, np.zeros((8, 8), np.uint8))
        listener = socket.socket()
        listener.bind(("127.0.0.1", 0))
        listener.listen(8)
        address = f"tcp://127.0.0.1:{listener.getsockname()[1]}"
        started = time.perf_counter()
        done = subprocess.run(
            [sys.executable, "-m", "napari_labyrinth.cli", "render", str(image), "-o",
             str(Path(directory) / "out.tif"), "--scheduler", address],
            capture_output=True, text=True, env=_env(), timeout=300,
        )
        elapsed = time.perf_counter() - started
        listener.close()
    print(
        f"scheduler that never answers (default timeout {SCHEDULER_TIMEOUT:g} s): exit "
        f"{done.returncode} after {elapsed:.1f} s from process start ({_load()})"
    )
    for line in done.stderr.strip().splitlines():
        print(f"  {line}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--examples", type=int, default=20000, help="make fuzz examples (0: skip)")
    args = parser.parse_args()
    count_cases()
    peak_rss()
    unanswering_scheduler()
    if args.examples:
        fuzz(args.examples)


if __name__ == "__main__":
    main()
