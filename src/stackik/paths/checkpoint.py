"""Checkpoint of a path solve: finished waypoints survive an interruption.

A JSON-lines file, as :func:`stackik.solve.solve_many`'s checkpoints: a header line with a
fingerprint of the problem (stack, waypoints, options), then one record per finished
piece of work (``{"stage": ..., "index": ..., "value": ...}``, or several at once in one
line, ``{"stage": ..., "many": [[index, value], ...]}``; later lines replace earlier
records), appended and flushed as it finishes. A path is sequential, so a resumed solve
reads the records in order and continues after the last one; floats round-trip exactly
through JSON, so the resumed result equals an uninterrupted one, but for what the
records do not hold (:mod:`stackik.paths.replay`: spatial fast mode's carried
multipliers). A torn last line (the
process died while writing) is dropped; a file written for another problem is refused.
"""

from __future__ import annotations

import hashlib
import json
from pathlib import Path
from typing import Any

__all__ = ["PathCheckpoint"]

FORMAT = "stackik-path-checkpoint"


class PathCheckpoint:
    """Records of one path solve, loaded from and appended to a JSON-lines file.

    Parameters
    ----------
    path : str or Path or None
        The file; None keeps nothing (every ``get`` misses, ``put`` is a no-op).
    key : dict
        JSON-ready identity of the problem; a file with another key raises ValueError.
    """

    def __init__(self, path: str | Path | None, key: dict[str, Any]) -> None:
        self.path = None if path is None else Path(path)
        self.records: dict[tuple[str, int], Any] = {}
        if self.path is None:  # nothing to match: no fingerprint (its JSON costs ~0.5 ms)
            self.fingerprint = ""
            return
        text = json.dumps(key, sort_keys=True)
        self.fingerprint = hashlib.sha256(text.encode()).hexdigest()
        if self.path.exists():
            self._load()
        else:
            self.path.parent.mkdir(parents=True, exist_ok=True)
            self._append({"format": FORMAT, "fingerprint": self.fingerprint})

    def _load(self) -> None:
        assert self.path is not None
        raw = self.path.read_bytes()
        if raw and not raw.endswith(b"\n"):  # died while writing: keep whole lines only
            raw = raw[: raw.rfind(b"\n") + 1]
            self.path.write_bytes(raw)
        lines = [ln for ln in raw.decode().splitlines() if ln.strip()]
        if not lines:
            self._append({"format": FORMAT, "fingerprint": self.fingerprint})
            return
        try:
            head = json.loads(lines[0])
        except ValueError:
            head = {}
        if not isinstance(head, dict) or head.get("format") != FORMAT:
            raise ValueError(f"checkpoint {self.path}: not a stackik path checkpoint")
        if head.get("fingerprint") != self.fingerprint:
            raise ValueError(
                f"checkpoint {self.path}: written for a different path or options; "
                "use another checkpoint file"
            )
        for k, line in enumerate(lines[1:], start=2):
            try:
                rec = json.loads(line)
                items = rec["many"] if "many" in rec else [[rec["index"], rec["value"]]]
                for index, value in items:
                    self.records[(str(rec["stage"]), int(index))] = value
            except (ValueError, KeyError, TypeError) as exc:
                raise ValueError(
                    f"checkpoint {self.path}: line {k} is not a stackik record ({exc})"
                ) from None

    def _append(self, obj: dict[str, Any]) -> None:
        assert self.path is not None
        with self.path.open("a") as fh:
            fh.write(json.dumps(obj) + "\n")
            fh.flush()

    def get(self, stage: str, index: int) -> Any:
        """The recorded value, or None."""
        return self.records.get((stage, index))

    def put(self, stage: str, index: int, value: Any) -> None:
        """Record a finished piece of work (appended and flushed at once)."""
        self.records[(stage, index)] = value
        if self.path is not None:
            self._append({"stage": stage, "index": index, "value": value})

    def put_many(self, stage: str, items: list[tuple[int, Any]]) -> None:
        """Record (or replace) several pieces at once, in one line: an interruption keeps
        all of them or none."""
        for index, value in items:
            self.records[(stage, index)] = value
        if self.path is not None:
            self._append({"stage": stage, "many": [[i, v] for i, v in items]})
