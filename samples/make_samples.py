"""Regenerate the bundled samples: ``python samples/make_samples.py [OUTDIR]``."""

import sys
from pathlib import Path

from analyzer.samples import make_samples

if __name__ == "__main__":
    out = Path(sys.argv[1]) if len(sys.argv) > 1 else Path(__file__).resolve().parent
    for entry in make_samples(out):
        print(entry["file"], entry["faults"])
