"""What a user's constraint family costs the default solve (stackik.families, issue 25).

Run: ``python benchmarks/bench_families.py [--count 10] [--repeats 3] [--seed 25]
[--out benchmarks/results]``; writes ``families.{json,md}``.

Per mode (planar and spatial, ``Stack.reference(4)``), ``--count`` random reachable
targets (:func:`stackik.sampling.random_planar_targets` / ``random_spatial_targets``,
``rng = seed``), each solved by the default ``solve_ik`` in four variants, interleaved
target by target, ``--repeats`` times (process CPU time, median per target):

* ``plain``: no family;
* ``trivial``: a family whose rows are constant (1 mm, zero Jacobian): what the
  mechanism itself costs (the interior point's dense rows and its Python call back, the
  full check);
* ``far``: the test-only family of ``tests/plate_height.py`` (every plate above ``h``) with
  ``h`` 200 mm below the plain pose's lowest plate: it never binds, but its rows cost
  eight kinematics calls in NumPy per evaluation;
* ``held``: the same family 10 mm above the plain pose's lowest plate: it binds.

Columns: successes, median time per variant and the median of per-target time ratios
against ``plain`` (``held``: over the targets it solved); the share of ``held`` poses
whose lowest plate sits at ``h`` (binding, to 1e-3 mm). Outside reference for ``held``:
SciPy's SLSQP from ``--ref-starts`` starts with the same family (``method="slsqp"``):
the targets it solves (a pose exists) and those where the default is within 0.5 % of the
better FN of the two.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

from stackik import ConstraintFamily, Stack, solve_ik
from stackik.bench import machine_info
from stackik.kinematics import planar_plate_origins, spatial_plate_origins
from stackik.sampling import random_planar_targets, random_spatial_targets

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
from plate_height import PlateHeight  # noqa: E402  (the test-only family)


class Constant(ConstraintFamily):
    """Rows that never bind: ``c = 1`` mm a platform, zero Jacobian."""

    def planar_rows(self, stack: Any, q: Any, phi: float) -> tuple[Any, Any]:
        return np.ones(q.shape[0]), np.zeros((q.shape[0], q.size))

    def spatial_rows(self, stack: Any, q: Any) -> tuple[Any, Any]:
        return np.ones(q.shape[0]), np.zeros((q.shape[0], q.size))


def _lowest(q: Any, planar: bool) -> float:
    z = planar_plate_origins(q)[1:, 1] if planar else spatial_plate_origins(q)[1:, 2]
    return float(z.min())


def run_mode(mode: str, count: int, repeats: int, seed: int, ref_starts: int) -> dict[str, Any]:
    planar = mode == "planar"
    stack = Stack.reference(4)
    rng = np.random.default_rng(seed)
    draw = random_planar_targets if planar else random_spatial_targets
    targets = draw(stack, count, rng=rng)
    names = ("plain", "trivial", "far", "held")
    times: dict[str, list[list[float]]] = {v: [[] for _ in targets] for v in names}
    ok = {v: np.zeros(len(targets), dtype=bool) for v in names}
    binds = np.zeros(len(targets), dtype=bool)
    ref_ok = np.zeros(len(targets), dtype=bool)
    within = np.zeros(len(targets), dtype=bool)
    for k, t in enumerate(targets):
        plain = solve_ik(stack, t)  # untimed: code paths loaded, the lowest plate found
        z0 = _lowest(plain.q, planar)
        fams = {"plain": [], "trivial": [Constant()], "far": [PlateHeight(z0 - 200.0)],
                "held": [PlateHeight(z0 + 10.0)]}  # fmt: skip
        for _ in range(repeats):
            for name in names:
                t0 = time.process_time()
                r = solve_ik(stack, t, constraints=fams[name])
                times[name][k].append(time.process_time() - t0)
                ok[name][k] = r.success
                if name == "held" and r.success:
                    binds[k] = abs(_lowest(r.q, planar) - (z0 + 10.0)) < 1e-3
                    fn_held = r.frobenius_norm
        ref = solve_ik(stack, t, method="slsqp", starts=ref_starts, constraints=fams["held"])
        ref_ok[k] = ref.success
        if ok["held"][k]:
            best = min(fn_held, ref.frobenius_norm) if ref.success else fn_held
            within[k] = fn_held <= best * 1.005
    med = {v: np.array([float(np.median(ts)) for ts in times[v]]) for v in names}
    keep = {v: ok[v] & ok["plain"] for v in names}
    return {
        "mode": mode,
        "targets": count,
        "repeats": repeats,
        "success": {v: int(ok[v].sum()) for v in names},
        "held_binding": int(binds.sum()),
        "ref_starts": ref_starts,
        "held_slsqp_success": int(ref_ok.sum()),
        "held_within_0p5": int(within.sum()),
        "median_ms": {v: 1e3 * float(np.median(med[v][keep[v]])) for v in names},
        "ratio_vs_plain": {
            v: float(np.median(med[v][keep[v]] / med["plain"][keep[v]])) for v in names
        },
    }


def markdown(rows: list[dict[str, Any]], meta: dict[str, Any]) -> str:
    lines = [
        "# What a constraint family costs (benchmarks/bench_families.py)",
        "",
        f"`{meta['command']}` on {meta['machine']}, {meta['date']}. The default `solve_ik` on "
        "`Stack.reference(4)`; process CPU time, the median over repeats per target, then "
        "the median over targets of the ratio against the solve without a family. "
        "`trivial`: constant rows (the mechanism's cost); `far`: the test-only plate-height "
        "family 200 mm below the plain pose's lowest plate (never binds, its rows cost "
        "NumPy kinematics); `held`: 10 mm above it (binds).",
        "",
        "| mode | targets x repeats | success plain / trivial / far / held | plain ms "
        "| trivial ms (ratio) | far ms (ratio) | held ms (ratio) | held binding "
        "| held: SLSQP-k success | held: default within 0.5 % |",
        "|---|---|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        m, q, s = r["median_ms"], r["ratio_vs_plain"], r["success"]
        lines.append(
            f"| {r['mode']} 4 | {r['targets']} x {r['repeats']} | {s['plain']} / "
            f"{s['trivial']} / {s['far']} / {s['held']} | {m['plain']:.2f} | "
            f"{m['trivial']:.2f} ({q['trivial']:.1f}x) | {m['far']:.2f} ({q['far']:.1f}x) | "
            f"{m['held']:.2f} ({q['held']:.1f}x) | {r['held_binding']} | "
            f"{r['held_slsqp_success']} (k = {r['ref_starts']}) | {r['held_within_0p5']} |"
        )
    return "\n".join(lines) + "\n"


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=(__doc__ or "").splitlines()[0])
    ap.add_argument("--count", type=int, default=10)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--seed", type=int, default=25)
    ap.add_argument("--ref-starts", type=int, default=16)
    ap.add_argument("--out", type=Path, default=Path(__file__).parent / "results")
    args = ap.parse_args(argv)
    rows = [
        run_mode(m, args.count, args.repeats, args.seed, args.ref_starts)
        for m in ("planar", "spatial")
    ]
    info = machine_info()
    meta = {
        "command": "python benchmarks/bench_families.py "
        f"--count {args.count} --repeats {args.repeats} --seed {args.seed} "
        f"--ref-starts {args.ref_starts}",
        "machine": f"{info.get('cpus', '?')} CPUs ({info.get('cpu', '?')})",
        "date": time.strftime("%Y-%m-%d %H:%M:%S UTC", time.gmtime()),
    }
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "families.json").write_text(json.dumps({"meta": meta, "rows": rows}, indent=1))
    text = markdown(rows, meta)
    (args.out / "families.md").write_text(text)
    print(text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
