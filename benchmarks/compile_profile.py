"""Where the kernels' compile time goes on an empty numba cache, per function and per pass.

Run with ``python benchmarks/compile_profile.py planar`` (or ``spatial``, ``planar_path``,
``spatial_path``: a path family with its mode's solver family; ``planar_rows`` and the other
``_rows`` twins: with the families they need; a minute or more
each): ``stackik.warm_up((kind,))`` in a fresh subprocess with an empty temporary
``NUMBA_CACHE_DIR``, with a listener on numba's ``numba:compile``, ``numba:run_pass`` and
``numba:llvm_lock`` events. Events nest (typing a caller compiles its callees), so each
event's *exclusive* time is its own span minus its children's. Prints the wall and CPU
(user + system) seconds of the warm-up, the number of functions compiled, the exclusive
seconds per compiler pass (summed over functions) and the functions with the most
exclusive seconds (their own passes and LLVM work, not their callees'). ``--json PATH``
writes the whole table.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import textwrap

_CHILD = textwrap.dedent(
    """
    import json, resource, sys, time
    from collections import defaultdict
    from numba.core import event

    log = []

    def label(kind, data):
        if kind == "numba:compile":
            d = data["dispatcher"]
            f = getattr(d, "py_func", None)
            name = f"{getattr(f, '__module__', '?')}.{getattr(f, '__qualname__', '?')}"
            return name, str(data.get("args"))
        if kind == "numba:run_pass":
            return data["name"].split(" [")[0], data.get("qualname", "")
        return "llvm_lock", ""

    class Rec(event.Listener):
        def __init__(self, kind):
            self.kind = kind

        def on_start(self, e):
            log.append((time.perf_counter(), True, self.kind, label(self.kind, e.data)))

        def on_end(self, e):
            log.append((time.perf_counter(), False, self.kind, None))

    for kind in ("numba:compile", "numba:run_pass", "numba:llvm_lock"):
        event.register(kind, Rec(kind))

    # LLVM's share by stage: function passes (per module added), the final module's
    # passes (the library with every callee linked in), machine code emission
    from numba.core import codegen
    llvm = defaultdict(lambda: [0.0, 0])
    libraries = defaultdict(float)  # final passes + machine code by library name
    defined = []  # functions defined in each finalized library's module

    def timed(cls, meth, key):
        orig = getattr(cls, meth)

        def wrapper(self, *a):
            t = time.perf_counter()
            try:
                return orig(self, *a)
            finally:
                llvm[key][0] += time.perf_counter() - t
                if key != "function passes":
                    libraries[self.name] += time.perf_counter() - t
                llvm[key][1] += 1
                if key == "final module passes":
                    defined.append(sum(1 for f in self._final_module.functions
                                       if not f.is_declaration))

        setattr(cls, meth, wrapper)

    timed(codegen.CPUCodeLibrary, "_optimize_functions", "function passes")
    timed(codegen.CPUCodeLibrary, "_optimize_final_module", "final module passes")
    timed(codegen.JITCodeLibrary, "_finalize_specific", "machine code")
    import stackik
    r0, w0 = resource.getrusage(resource.RUSAGE_SELF), time.perf_counter()
    stackik.warm_up((sys.argv[1],), notice=False)
    r1, w1 = resource.getrusage(resource.RUSAGE_SELF), time.perf_counter()

    # exclusive time of each event: own span minus the spans of the events nested in it
    stack = []  # [kind, label, start, child time]
    passes = defaultdict(float)
    functions = defaultdict(lambda: [0.0, 0, set()])  # exclusive s, compiles, signatures
    fn_stack = []
    for t, start, kind, lab in log:
        if start:
            stack.append([kind, lab, t, 0.0])
            if kind == "numba:compile":
                fn_stack.append(lab)
            continue
        k, lab, t0, child = stack.pop()
        span = t - t0
        if stack:
            stack[-1][3] += span
        own = span - child
        if k == "numba:compile":
            fn_stack.pop()
            name, sig = lab
            functions[name][1] += 1
            functions[name][2].add(sig)
        elif k == "numba:run_pass":
            passes[lab[0]] += own
        else:
            passes["llvm_lock"] += own
        owner = fn_stack[-1][0] if fn_stack else "(outside compile)"
        functions[owner][0] += own
    out = {
        "kind": sys.argv[1],
        "wall_s": w1 - w0,
        "cpu_s": (r1.ru_utime - r0.ru_utime) + (r1.ru_stime - r0.ru_stime),
        "user_s": r1.ru_utime - r0.ru_utime,
        "compiles": sum(v[1] for v in functions.values()),
        "llvm": {k: {"s": v[0], "calls": v[1]} for k, v in llvm.items()},
        "functions_in_final_modules": sum(defined),
        "libraries": dict(sorted(libraries.items(), key=lambda kv: -kv[1])),
        "passes": dict(sorted(passes.items(), key=lambda kv: -kv[1])),
        "functions": {
            k: {"exclusive_s": v[0], "compiles": v[1], "signatures": sorted(v[2])}
            for k, v in sorted(functions.items(), key=lambda kv: -kv[1][0])
        },
    }
    print(json.dumps(out))
    """
)


def profile(kind: str, src: str | None) -> dict:
    """Run the warm-up of ``kind`` on an empty cache in a subprocess; its table."""
    env = dict(os.environ)
    if src:
        env["PYTHONPATH"] = src
    with tempfile.TemporaryDirectory() as cache:
        env["NUMBA_CACHE_DIR"] = cache
        out = subprocess.run(
            [sys.executable, "-c", _CHILD, kind],
            env=env,
            capture_output=True,
            text=True,
            check=False,
        )
    if out.returncode != 0:
        raise RuntimeError(out.stderr)
    return json.loads(out.stdout.strip().splitlines()[-1])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument(
        "kind",
        choices=(
            "planar",
            "spatial",
            "planar_path",
            "spatial_path",
            "planar_rows",
            "spatial_rows",
            "planar_path_rows",
            "spatial_path_rows",
        ),  # fmt: skip
        help="a kernel family (stackik.solve.warmup.KERNEL_KINDS; _rows: since 2026-12-05)",
    )
    ap.add_argument("--src", help="PYTHONPATH of the tree to profile (default: inherited)")
    ap.add_argument("--top", type=int, default=25, help="functions to list")
    ap.add_argument("--json", help="write the whole table here")
    a = ap.parse_args()
    res = profile(a.kind, a.src)
    print(
        f"{a.kind}: wall {res['wall_s']:.1f} s, CPU {res['cpu_s']:.1f} s "
        f"(user {res['user_s']:.1f} s), {res['compiles']} compilations"
    )
    for name, v in res["llvm"].items():
        print(f"  LLVM {name}: {v['s']:.1f} s in {v['calls']} calls")
    print(
        f"  functions defined in the finalized modules, summed: {res['functions_in_final_modules']}"
    )
    print("exclusive seconds per pass:")
    for name, s in list(res["passes"].items())[:12]:
        print(f"  {s:7.2f}  {name}")
    print("exclusive seconds per function (compilations, signatures):")
    for name, v in list(res["functions"].items())[: a.top]:
        print(f"  {v['exclusive_s']:7.2f}  {v['compiles']:3d} {len(v['signatures']):3d}  {name}")
    print("final module passes + machine code per library (seconds):")
    for name, sec in list(res["libraries"].items())[: a.top]:
        print(f"  {sec:7.2f}  {name[:110]}")
    if a.json:
        with open(a.json, "w") as f:
            json.dump(res, f, indent=1)


if __name__ == "__main__":
    main()
