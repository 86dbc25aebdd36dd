"""Memory of a long-lived process that builds layer potentials at several grids in turn.

A sweep worker meets shapes at 24, 32 and 48 rings; the quadrature tables (Wigner blocks, ~34 MB
at 32 rings, ~170 MB at 48) are shared between shapes of one grid and kept in bounded caches
(:mod:`vesicle.caches`).  Reported: the resident memory kept after each build once the operators
are released, the process's peak, and what :func:`vesicle.caches.clear_caches` gives back.
"""

from __future__ import annotations

import gc
import resource
from pathlib import Path

import vesicle as vs


def _rss_mb() -> float:
    for line in Path("/proc/self/status").read_text().splitlines():
        if line.startswith("VmRSS:"):
            return int(line.split()[1]) / 1024.0
    return float("nan")


def _peak_mb() -> float:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


def _tables(grids=(24, 32, 48, 64, 24, 32)) -> list[dict]:
    """Only the quadrature tables (Wigner blocks included), no operators: what a worker keeps."""
    from vesicle.stokes import singular_quadrature

    rows = []
    print(f"{'tables':>6} {'kept MB':>9}")
    for n in grids:
        singular_quadrature(n).wigner  # noqa: B018
        gc.collect()
        rows.append({"grid": n, "kept_mb": _rss_mb()})
        print(f"{n:>6} {rows[-1]['kept_mb']:9.0f}")
    return rows


def run(grids=(24, 32, 48, 24, 32, 48)) -> dict:
    rows = []
    print(f"{'grid':>6} {'kept MB':>9} {'peak MB':>9}")
    for n in grids:
        lp = vs.LayerPotentials(vs.Shape.spheroid(0.95, grid=n, degree=8))
        lp.single_matrix, lp.double_matrix  # noqa: B018
        del lp
        gc.collect()
        rows.append({"grid": n, "kept_mb": _rss_mb(), "peak_mb": _peak_mb()})
        print(f"{n:>6} {rows[-1]['kept_mb']:9.0f} {rows[-1]['peak_mb']:9.0f}")
    out = {"builds": rows, "tables": _tables()}
    try:
        from vesicle.caches import cache_info, clear_caches
    except ImportError:  # the code before the bounded caches
        return out
    out["caches"] = cache_info()
    print("cache entries:", {k: v["entries"] for k, v in out["caches"].items()})
    clear_caches()
    gc.collect()
    out["kept_after_clear_mb"] = _rss_mb()
    print(f"after clear_caches(): kept {out['kept_after_clear_mb']:.0f} MB")
    return out


if __name__ == "__main__":
    import os

    os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
    run()
