"""Small file helpers shared by the CLI, the reproduction report and the benchmark."""

from __future__ import annotations

import csv
import json
import tomllib
from collections.abc import Sequence
from enum import Enum
from pathlib import Path
from typing import Any

import numpy as np


def write_csv(path: Path, rows: Sequence[dict[str, Any]]) -> Path:
    """Write dict rows (keys of the first row as header) to ``path``; returns ``path``."""
    with Path(path).open("w", newline="") as fh:
        writer = csv.DictWriter(fh, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)
    return Path(path)


def json_default(obj: Any) -> Any:
    """``json.dumps`` default for arrays, NumPy scalars, paths and enums (``TypeError`` else)."""
    if isinstance(obj, np.ndarray):
        return obj.tolist()
    if isinstance(obj, np.generic):
        return obj.item()
    if isinstance(obj, Path):
        return str(obj)
    if isinstance(obj, Enum):
        return obj.value
    raise TypeError(f"not JSON serialisable: {type(obj).__name__}")


def json_default_lenient(obj: Any) -> Any:
    """As :func:`json_default`, but anything else becomes ``str(obj)``."""
    try:
        return json_default(obj)
    except TypeError:
        return str(obj)


def read_data_file(path: Path, what: str, error: type[Exception]) -> Any:
    """The parsed contents of a ``.toml`` or ``.json`` file (``what`` names it in messages:
    "geometry file", "obstacle file"), or ``error`` saying why not: unreadable, an unknown
    suffix, or not valid TOML/JSON."""
    try:
        raw = path.read_bytes()
    except OSError as exc:
        raise error(f"{path}: cannot read {what} ({exc.strerror})") from None
    suffix = path.suffix.lower()
    try:
        if suffix == ".toml":
            return tomllib.loads(raw.decode())
        if suffix == ".json":
            return json.loads(raw.decode())
    except (tomllib.TOMLDecodeError, json.JSONDecodeError, UnicodeDecodeError) as exc:
        raise error(f"{path}: not valid {suffix[1:].upper()} ({exc})") from None
    raise error(f"{path}: unknown {what} type (use .toml or .json)")
