"""Run every benchmark in this folder: ``python benchmarks/run.py [NAME ...]``.

Absolute times drift on shared machines, so each benchmark reports ratios measured in the same
run: against a reference implementation, or against this machine's DGEMM rate (measured here).
BLAS is pinned to one thread before NumPy is imported; parallelism, where used, is at the
Python level.
"""

from __future__ import annotations

import os

for var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(var, "1")

import importlib  # noqa: E402
import json  # noqa: E402
import pathlib  # noqa: E402
import sys  # noqa: E402

HERE = pathlib.Path(__file__).parent
sys.path.insert(0, str(HERE))


def main(argv: list[str]) -> None:
    available = sorted(p.stem for p in HERE.glob("bench_*.py"))
    if any(a in ("-h", "--help") for a in argv):
        print(__doc__.strip())
        print("\nbenchmarks: " + ", ".join(n.removeprefix("bench_") for n in available))
        return
    names = [a if a.startswith("bench_") else f"bench_{a}" for a in argv] or available
    unknown = [n for n in names if n not in available]
    if unknown:
        raise SystemExit(
            f"unknown benchmark(s) {', '.join(unknown)}; choose from "
            + ", ".join(n.removeprefix("bench_") for n in available)
        )
    results = {}
    for name in names:
        module = importlib.import_module(name)
        print(f"== {module.__name__}: {module.__doc__.strip().splitlines()[0]}")
        results[module.__name__] = module.run()
    out = HERE / "results"
    out.mkdir(exist_ok=True)
    latest = out / "latest.json"
    merged = json.loads(latest.read_text()) if latest.exists() else {}
    merged.update(results)  # a run of some benchmarks keeps the others' last results
    latest.write_text(json.dumps(merged, indent=2))
    print(f"results written to {out / 'latest.json'}")


if __name__ == "__main__":
    main(sys.argv[1:])
