"""Default FN with and without a start-plan rule on the same bench_obstacles targets.

``python benchmarks/spatial_clear_compare.py WITHOUT.csv WITH.csv`` (two
``obstacle_bench.csv`` of one seed and cases): per case, how many default poses are within
0.5 % of the joint best known (the least of both files' ``best``), and on which targets the
rule's pose is worse or better (% FN, relative to the pose without it).
"""

from __future__ import annotations

import csv
import sys
from pathlib import Path


def load(path: Path) -> dict[tuple[str, str], dict[str, str]]:
    with path.open() as f:
        return {(r["case"], r["k"]): r for r in csv.DictReader(f)}


def compare(without: Path, with_rule: Path) -> list[str]:
    a, b = load(without), load(with_rule)
    lines = []
    for case in sorted({c for c, _ in a} & {c for c, _ in b}):
        ks = sorted({k for c, k in a if c == case}, key=int)
        wa = wb = 0
        worse: list[tuple[str, float]] = []
        better: list[tuple[str, float]] = []
        for k in ks:
            ra, rb = a[(case, k)], b[(case, k)]
            best = min(float(ra["best"]), float(rb["best"]))
            fa, fb = float(ra["default_fn"]), float(rb["default_fn"])
            wa += fa <= best * 1.005
            wb += fb <= best * 1.005
            if fb > fa * (1 + 1e-6):
                worse.append((k, round(100 * (fb / fa - 1), 3)))
            if fb < fa * (1 - 1e-6):
                better.append((k, round(100 * (1 - fb / fa), 3)))
        lines.append(
            f"{case}: within 0.5 % of the joint best without {wa}/{len(ks)}, with {wb}/{len(ks)};"
            f" worse (k, %) {worse}; better (k, %) {better}"
        )
    return lines


if __name__ == "__main__":
    print("\n".join(compare(Path(sys.argv[1]), Path(sys.argv[2]))))
