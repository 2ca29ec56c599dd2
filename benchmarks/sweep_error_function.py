"""The error functions (seed 000, direct approach) alone on simulated buildings with a
config of reference and uncertain sensors: false findings on healthy records, and
whether an offset, a gain or a drift on an uncertain sensor is found.

For each seed it simulates the shear building of ``sweep_isolation.py`` (``--floors`` x 2
accelerometers, ``--seconds`` at 100 Hz, the default training window: the first 20 %),
writes it as CSV once healthy and once with each fault on an uncertain sensor (the last
two channels, alternating with the seed) from 60 % of the record (an offset of 1 sd, a
gain of 1.3, a drift of 1 sd per 20 s), and runs ``pipeline.analyze`` with the config's
one ``[[group]]`` (the first ``2 floors - 2`` channels reference, the last two uncertain)
and ``--detectors error_function``. It prints the healthy runs with a finding and their
findings, each fault type's runs where a finding on the faulty sensor begins after 50 %
of the record, and the other findings of the faulty runs (extras). A script, not a timed
test (10 seeds of 6 channels, 2 minutes each: ~1 min)::

    python benchmarks/sweep_error_function.py [--floors 3] [--seeds 0:10] [--seconds 120]
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from analyzer.config import load_config  # noqa: E402
from analyzer.pipeline import RunOptions, analyze  # noqa: E402
from analyzer.simulate import inject_fault, simulate_building  # noqa: E402
from analyzer.writers import write_archive  # noqa: E402

RATE_HZ = 100.0
KINDS = ("additive", "multiplicative", "drift")


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--floors", type=int, default=3, help="floors, 2 sensors each (default 3)")
    ap.add_argument("--seeds", default="0:10", help="first:stop (default 0:10)")
    ap.add_argument("--seconds", type=float, default=120.0, help="record length (default 120)")
    args = ap.parse_args(argv)
    first, stop = (int(x) for x in args.seeds.split(":"))
    m = 2 * args.floors
    names = [f"s{i}" for i in range(m)]
    onset = 0.6 * args.seconds
    healthy_runs = healthy_findings = extras = 0
    found = dict.fromkeys(KINDS, 0)
    with tempfile.TemporaryDirectory() as tmp:
        cfg_path = Path(tmp) / "groups.toml"

        def listed(xs: list[str]) -> str:
            return ", ".join(f'"{x}"' for x in xs)

        cfg_path.write_text(
            f'[[group]]\nname = "building"\nchannels = [{listed(names)}]\n'
            f"reference = [{listed(names[:-2])}]\nuncertain = [{listed(names[-2:])}]\n"
            "inputs = []\n"
        )
        config = load_config(str(cfg_path))
        for seed in range(first, stop):
            j = m - 2 + seed % 2
            for kind in (None, *KINDS):
                t, Y, cols = simulate_building(
                    n_floors=args.floors,
                    duration_s=args.seconds,
                    rate_hz=RATE_HZ,
                    seed=seed,
                    sensors_per_floor=2,
                )
                if kind is not None:
                    sd = Y[: int(0.2 * args.seconds * RATE_HZ)].std(axis=0)
                    size = {"additive": sd[j], "multiplicative": 1.3, "drift": sd[j] / 20.0}
                    Y[:, j] = inject_fault(Y[:, j], RATE_HZ, kind, onset, size[kind])
                path = Path(tmp) / "record.csv"
                t_ns = np.round(t * 1e9).astype(np.int64)
                write_archive(path, "csv", t_ns, {c: Y[:, k] for k, c in enumerate(cols)})
                a = analyze([str(path)], RunOptions(config=config, detectors=["error_function"]))
                fs = a.findings
                if kind is None:
                    healthy_runs += bool(fs)
                    healthy_findings += len(fs)
                    continue
                hit = [f for f in fs if f.channel == cols[j] and f.onset_s > 0.5 * args.seconds]
                found[kind] += bool(hit)
                extras += len(fs) - len(hit)
            print(f"  seed {seed}: done", flush=True)
    n = stop - first
    print(
        f"{m} channels, {n} seeds: healthy runs with a finding {healthy_runs} of {n} "
        f"({healthy_findings} findings); faults found "
        + ", ".join(f"{k} {found[k]} of {n}" for k in KINDS)
        + f"; other findings beside the faults {extras}"
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
