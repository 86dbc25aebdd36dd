"""A folder of evaluations kept by their inputs: the checkpoint of a computation that replays.

A two-parameter continuation (:func:`vesicle.bifurcation.neutral_codim2.neutral_curve_codim2`)
is a deterministic sequence of evaluations of ``F(x, p)``, its Jacobian and their derivatives,
each a few seconds to a minute at N = 8, joined by linear algebra that costs next to nothing.
Its state between two evaluations (curves, tangents, step sizes, test functions) is large and
private to the algorithm; the evaluations are not.  So an interrupted curve is resumed by
running it again from the start with each evaluation it made looked up here: the same inputs
give the same bits (one BLAS thread, the same code), the lookups answer until the point where
it was stopped, and from there it computes.

Each value is an array in its own ``.npy`` file named by the SHA-256 of the evaluation's name
and its inputs' dtypes, shapes and bytes, written to a temporary name and renamed (a crash,
Ctrl-C or a full disk leaves the old set or the new one, never a partial file).  A full disk
stops the saving, with one warning, not the computation.  ``identity.json`` says whose
evaluations the folder holds (the physics, discretisation and options that the values depend
on); a folder of another identity is refused (:class:`MemoMismatch`).
"""

from __future__ import annotations

import hashlib
import json
import logging
import os
import shutil
import uuid
from pathlib import Path

import numpy as np

from vesicle.io.files import plain, stamped, write_text_atomically

__all__ = ["EvaluationMemo", "MemoMismatch"]

log = logging.getLogger(__name__)


class MemoMismatch(ValueError):
    """The folder holds the evaluations of another computation."""


class EvaluationMemo:
    """Arrays kept in ``folder`` by the content of their inputs (see the module notes).

    ``identity``: a JSON-able dict of what the values depend on besides the inputs; written
    with a new folder, compared with an existing one's (:class:`MemoMismatch` if it differs).
    ``hits`` and ``misses`` count the lookups."""

    IDENTITY = "identity.json"

    def __init__(self, folder: str | os.PathLike, identity: dict):
        self.folder = Path(folder)
        self.identity = plain(identity)
        self.hits = 0
        self.misses = 0
        self.saving = True
        path = self.folder / self.IDENTITY
        if path.exists():
            try:
                found = json.loads(path.read_text()).get("identity")
            except (OSError, ValueError) as err:
                raise MemoMismatch(f"{path} cannot be read ({err})") from err
            if found != self.identity:
                differ = sorted(k for k in set(found or {}) | set(self.identity)
                                if (found or {}).get(k) != self.identity.get(k))  # fmt: skip
                raise MemoMismatch(f"{self.folder} holds the evaluations of another computation "
                                   f"(differs in {', '.join(differ)})")  # fmt: skip
        else:
            self.folder.mkdir(parents=True, exist_ok=True)
            write_text_atomically(path, json.dumps(stamped({"identity": self.identity}),
                                                   indent=1))  # fmt: skip

    def __len__(self) -> int:
        return sum(1 for _ in self.folder.glob("*/*.npy"))

    @staticmethod
    def key(name: str, *inputs) -> str:
        """The SHA-256 of ``name`` and each input's dtype, shape and bytes (scalars as
        float64)."""
        h = hashlib.sha256(name.encode())
        for value in inputs:
            a = np.ascontiguousarray(np.asarray(value, dtype=float) if np.isscalar(value)
                                     else np.asarray(value))  # fmt: skip
            h.update(f"|{a.dtype.str}{a.shape}|".encode())
            h.update(a.tobytes())
        return h.hexdigest()

    def _path(self, key: str) -> Path:
        return self.folder / key[:2] / f"{key}.npy"

    def load(self, key: str) -> np.ndarray | None:
        """The array kept under ``key``, or None (counted as a hit or a miss)."""
        path = self._path(key)
        try:
            value = np.load(path, allow_pickle=False)
        except (OSError, ValueError, EOFError):  # none, or unreadable (computed again)
            self.misses += 1
            return None
        self.hits += 1
        return value

    def save(self, key: str, value: np.ndarray) -> None:
        """Keep ``value`` under ``key`` (atomically; once the disk refuses, no more saving)."""
        if not self.saving:
            return
        path = self._path(key)
        # the writer's own temporary name: a worker declared lost may still be writing
        tmp = path.with_name(f"{path.name}.{os.getpid()}.{uuid.uuid4().hex[:8]}.tmp")
        try:
            path.parent.mkdir(exist_ok=True)
            with open(tmp, "wb") as f:
                np.save(f, np.asarray(value), allow_pickle=False)
            os.replace(tmp, path)
        except OSError as err:
            tmp.unlink(missing_ok=True)
            self.saving = False
            log.warning("the evaluations are no longer kept in %s (%s): an interruption from "
                        "here on is resumed from the last one kept", self.folder, err)

    def cached(self, name: str, compute, *inputs) -> np.ndarray:
        """``compute()``, looked up first under ``name`` and ``inputs``, kept when computed."""
        key = self.key(name, *inputs)
        value = self.load(key)
        if value is None:
            value = np.asarray(compute())
            self.save(key, value)
        return value

    def save_record(self, name: str, inputs: tuple, arrays: dict, meta: dict) -> None:
        """Keep a result made of several ``arrays`` and a JSON-able ``meta`` under ``name`` and
        ``inputs``.  The meta is written last: a record whose meta is found is whole."""
        for field, value in arrays.items():
            self.save(self.key(f"{name}/{field}", *inputs), np.asarray(value))
        text = json.dumps({"fields": sorted(arrays), "meta": plain(meta)})
        self.save(self.key(f"{name}/meta", *inputs), np.frombuffer(text.encode(), np.uint8))

    def load_record(self, name: str, inputs: tuple) -> tuple[dict, dict] | None:
        """``(arrays, meta)`` of :meth:`save_record`, or None where any part is missing."""
        raw = self.load(self.key(f"{name}/meta", *inputs))
        if raw is None:
            return None
        try:
            record = json.loads(raw.tobytes().decode())
        except ValueError:
            return None
        arrays = {}
        for field in record["fields"]:
            value = self.load(self.key(f"{name}/{field}", *inputs))
            if value is None:
                return None
            arrays[field] = value
        return arrays, record["meta"]

    def clear(self) -> None:
        """Remove the folder (the computation finished and its result is stored)."""
        shutil.rmtree(self.folder, ignore_errors=True)
