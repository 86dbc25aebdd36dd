"""Bounded caches for the tables that many shapes of one grid share.

Spherical-harmonic transforms, singular-quadrature tables (their Wigner blocks are ~34 MB at 32
rings, ~170 MB at 48 and ~540 MB at 64) and the quarter-turn rotation factors are built once per
grid and shared.  A long-lived process (a sweep worker) may meet several grids; each cache keeps
only its most recently used entries, so memory stays bounded:

======================== ======= =============================================================
cache                    entries what one entry holds
======================== ======= =============================================================
``transform``            32      Legendre tables of one (n_theta, lmax): < 10 MB at 64 rings
``singular_quadrature``  2       rotated-grid tables of one (n_theta, n_rot), Wigner included
``quarter_turns``        4       rotation factors of one degree: ~2 MB at degree 63
======================== ======= =============================================================

:func:`clear_caches` empties them all (e.g. between the stages of a sweep at different grids);
:func:`cache_info` reports their use.
"""

from __future__ import annotations

from collections.abc import Callable
from functools import lru_cache
from typing import TypeVar

__all__ = ["CACHE_SIZES", "bounded_cache", "cache_info", "clear_caches"]

F = TypeVar("F", bound=Callable)

#: Largest number of entries kept per cache (see the module docstring).
CACHE_SIZES = {"transform": 32, "singular_quadrature": 2, "quarter_turns": 4}

_REGISTRY: dict[str, Callable] = {}


def bounded_cache(name: str) -> Callable[[F], F]:
    """An LRU cache of ``CACHE_SIZES[name]`` entries, registered for :func:`clear_caches`."""
    if name not in CACHE_SIZES:
        raise KeyError(f"no size is set for cache {name!r}; add it to CACHE_SIZES")

    def wrap(fn: F) -> F:
        cached = lru_cache(maxsize=CACHE_SIZES[name])(fn)
        _REGISTRY[name] = cached
        return cached  # type: ignore[return-value]

    return wrap


def clear_caches() -> None:
    """Drop every cached table (they are rebuilt on next use)."""
    for fn in _REGISTRY.values():
        fn.cache_clear()


def cache_info() -> dict[str, dict[str, int]]:
    """``{name: {"entries", "maxsize", "hits", "misses"}}`` for each registered cache."""
    out = {}
    for name, fn in _REGISTRY.items():
        info = fn.cache_info()
        out[name] = {
            "entries": info.currsize,
            "maxsize": info.maxsize,
            "hits": info.hits,
            "misses": info.misses,
        }
    return out
