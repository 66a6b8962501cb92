"""Solver-comparison benchmark; same as ``stackik bench`` (see ``stackik.bench``).

Usage: ``python benchmarks/bench_ik.py [--quick] [--out benchmarks/results]``.
"""

from stackik.bench import main

if __name__ == "__main__":
    raise SystemExit(main())
