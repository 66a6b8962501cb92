"""First run: what a fresh process pays, and when.

After :func:`stackik.warm_up` a first solve compiles and imports nothing (the first solve's
clock used to include the interior point's object-mode clock, compiled in every process,
and threadpoolctl's first scan: 31-39 ms against 0.6-0.9 ms later); a spatial solve loads
no planar kernel unless its target turns out unreachable, and then off the clock; a
compilation shows its progress per kernel family; a solve compiles no path kernel (the
path families compile on the first path). Processes are spawned, so that what
this test process has loaded does not hide a cost; nothing here asserts a time.
"""

from __future__ import annotations

import io
import multiprocessing as mp
import sys
from concurrent.futures import ProcessPoolExecutor

import numpy as np
import pytest

import stackik as sk
from stackik.solve import warmup


def _in_fresh_process(fn, *args):
    with ProcessPoolExecutor(1, mp_context=mp.get_context("spawn")) as pool:
        return pool.submit(fn, *args).result(timeout=900)


def _spatial_target(n: int) -> sk.SpatialTarget:
    q = np.array([[10.0, -5.0, 330.0, 0.05, 0.02, -0.03]] * n)
    return sk.SpatialTarget(*sk.spatial_forward(q))


def _what_first_calls_cost() -> dict[str, tuple[list[str], list[str]]]:
    """Runs in a fresh process: warm up, then record the numba compilations and the new
    modules of each first call (planar n = 4 paper target as the issue measured it,
    spatial, an unreachable spatial target, the SQP engine's first solves (its QP
    backends imported by the warm-up), a scipy baseline's, a planar and a spatial path;
    then with rows beyond the limits: obstacles, a margin, force limits, legs of a
    radius, in solves and paths)."""
    import sys

    from numba.core import event

    from stackik.sampling import random_reachable_targets

    sk.warm_up()
    solve_path, interpolate = sk.solve_path, sk.interpolate_targets  # (lazy attributes)
    stack = sk.Stack.reference(4, leg_radius=0.0)
    fat = sk.Stack.uniform(sk.PlatformGeometry.hexagonal(leg_radius=12.0), 4)
    keys = [sk.PlanarTarget(0.0, 1000.0, 0.0), sk.PlanarTarget(150.0, 950.0, 0.2)]
    paper = sk.PlanarTarget(600.0, 1000.0, -1.57)
    sphere = sk.Sphere((300.0, 0.0, 500.0), 50.0)
    limited = sk.Stack.uniform(sk.PlatformGeometry.hexagonal(plate_mass=5.0, force_max=150.0), 4)
    tall = sk.Stack.reference(8, leg_radius=12.0)
    tall_target = random_reachable_targets(tall, 1, rng=51, phi=0.3)[0]
    calls = {
        "planar": lambda: sk.solve_ik(stack, sk.PlanarTarget(600.0, 1000.0, -1.57)),
        "spatial": lambda: sk.solve_ik(stack, _spatial_target(4)),
        "spatial unreachable": lambda: sk.solve_ik(
            sk.Stack.reference(3, leg_radius=0.0), sk.SpatialTarget([0.0, 0.0, 200.0], np.eye(3))
        ),
        "planar sqp": lambda: sk.solve_ik(stack, keys[0], method="sqp", starts=1),
        "spatial sqp": lambda: sk.solve_ik(
            sk.Stack.reference(3, leg_radius=0.0), _spatial_target(3), method="sqp", starts=1
        ),
        "planar slsqp": lambda: sk.solve_ik(stack, keys[1], method="slsqp", starts=1),
        "planar path": lambda: solve_path(stack, interpolate(keys, steps=3)),
        "spatial path": lambda: solve_path(
            stack, interpolate([t.to_spatial() for t in keys], steps=3)
        ),
        "spatial, 12 mm legs": lambda: sk.solve_ik(fat, _spatial_target(4)),
        "spatial sqp, 12 mm legs": lambda: sk.solve_ik(
            fat, _spatial_target(4), method="sqp", starts=1
        ),
        "spatial, an obstacle": lambda: sk.solve_ik(
            stack, _spatial_target(4), obstacles=[sk.Sphere((0.0, 0.0, 700.0), 20.0)]
        ),
        # the kernels for problem data with rows beyond the limits (the _rows families)
        "planar, an obstacle": lambda: sk.solve_ik(stack, paper, obstacles=[sphere]),
        "planar sqp, an obstacle": lambda: sk.solve_ik(
            stack, paper, obstacles=[sphere], method="sqp", starts=1
        ),
        "planar, a margin": lambda: sk.solve_ik(stack, paper, clearance=5.0),
        "planar, force limits": lambda: sk.solve_ik(limited, paper),
        "spatial, force limits": lambda: sk.solve_ik(limited, _spatial_target(4)),
        "planar n = 8, 12 mm legs": lambda: sk.solve_ik(tall, tall_target),
        "planar path, an obstacle": lambda: solve_path(
            stack, interpolate(keys, steps=3), obstacles=[sphere]
        ),
        "spatial path, 12 mm legs": lambda: solve_path(
            fat, interpolate([t.to_spatial() for t in keys], steps=3)
        ),
    }
    out = {}
    for name, call in calls.items():
        before = set(sys.modules)
        with event.install_recorder("numba:compile") as rec:
            call()
        compiled = [e.data["dispatcher"].py_func.__qualname__ for _, e in rec.buffer if e.is_start]
        out[name] = (compiled, sorted(set(sys.modules) - before))
    return out


def test_after_warm_up_a_first_solve_compiles_and_imports_nothing():
    costs = _in_fresh_process(_what_first_calls_cost)
    assert costs == {name: ([], []) for name in costs}


def _kernels_a_spatial_solve_loads() -> dict[str, object]:
    """Runs in a fresh process: one reachable spatial solve (no warm-up); which kernel
    families are loaded and which planar entry points got a specialisation."""

    r = sk.solve_ik(sk.Stack.reference(3, leg_radius=0.0), _spatial_target(3))
    from stackik._compiled import planar as ipm
    from stackik._compiled.spatial import SpatialData

    # the planar entry points and every compiled function of the planar kernels' module;
    # of an entry point both modes share (the barrier method), its planar specialisations
    # (less the check's body distances, which both solver families compile)
    planar = [
        d
        for d in warmup._dispatchers("planar")
        if d.py_func.__module__ != "stackik._compiled.body_distances"
    ]
    planar += [d for d in vars(ipm).values() if hasattr(d, "signatures")]

    def not_spatial(sig: tuple) -> bool:
        return not any(getattr(t, "instance_class", None) is SpatialData for t in sig)

    return {
        "status": r.status.value,
        "ready": sorted(warmup._READY),
        "planar specialisations": sum(sum(map(not_spatial, d.signatures)) for d in planar),
    }


def test_a_spatial_solve_loads_no_planar_kernel():
    # (on an empty cache the same rule means it compiles none: benchmarks/first_run.py
    # records the compilations of a first spatial solve there)
    out = _in_fresh_process(_kernels_a_spatial_solve_loads)
    assert out == {"status": "success", "ready": ["spatial"], "planar specialisations": 0}


def _families_a_reference_planar_solve_loads() -> list[str]:
    """Runs in a fresh process: the README's first solve on the reference stack (12 mm
    legs), no warm-up; the kernel families it loaded."""
    assert sk.solve_ik(sk.Stack.reference(4), sk.PlanarTarget(600.0, 1000.0, -1.57)).success
    return sorted(warmup._READY)


def test_a_planar_solve_on_legs_of_a_size_loads_the_planar_family_alone():
    # its self-leg rows are lazy and outside the interior point: no _rows twin compiled
    # for a newcomer's first solve (rows_needed(..., planar_solve=True))
    assert _in_fresh_process(_families_a_reference_planar_solve_loads) == ["planar"]


def test_a_folded_planar_solve_loads_the_rows_family_off_the_clock(monkeypatch):
    # a tall stack's batch folds; the unfold's rows beyond the limits load their family
    # through Request.load_kernels (whose seconds move the solve's clock on)
    from stackik.sampling import random_reachable_targets
    from stackik.solve.request import Request

    loaded: list[str] = []
    load = Request.load_kernels
    monkeypatch.setattr(
        Request, "load_kernels", lambda self, kind: (loaded.append(kind), load(self, kind))[1]
    )
    stack = sk.Stack.reference(16)
    assert sk.solve_ik(stack, random_reachable_targets(stack, 1, rng=1)[0]).success
    assert "planar_rows" in loaded


def _families_solves_and_paths_load() -> dict[str, object]:
    """Runs in a fresh process: a planar solve, then a planar path, then a spatial path
    (no warm-up); after each, the families loaded and how many specialisations the
    path families' entry points got."""
    solve_path, interpolate = sk.solve_path, sk.interpolate_targets  # (lazy attributes)
    stack = sk.Stack.reference(3, leg_radius=0.0)
    keys = [sk.PlanarTarget(0.0, 800.0, 0.0), sk.PlanarTarget(100.0, 780.0, 0.1)]
    steps = {
        "planar solve": lambda: sk.solve_ik(stack, keys[0]),
        "planar path": lambda: solve_path(stack, interpolate(keys, steps=3)),
        "spatial path": lambda: solve_path(
            stack, interpolate([t.to_spatial() for t in keys], steps=3)
        ),
    }
    out: dict[str, object] = {}
    for name, step in steps.items():
        ok = bool(step().success)
        out[name] = {
            "success": ok,
            "ready": sorted(warmup._READY),
            "specialisations": {
                kind: sum(len(d.signatures) for d in warmup._dispatchers(kind))
                for kind in ("planar_path", "spatial_path")
            },
        }
    return out


def test_a_solve_compiles_no_path_kernel_and_a_path_its_own_modes():
    out = _in_fresh_process(_families_solves_and_paths_load)
    assert out == {
        "planar solve": {
            "success": True,
            "ready": ["planar"],
            "specialisations": {"planar_path": 0, "spatial_path": 0},
        },
        "planar path": {
            "success": True,
            "ready": ["planar", "planar_path"],
            "specialisations": {"planar_path": 3, "spatial_path": 0},
        },
        "spatial path": {
            "success": True,
            "ready": ["planar", "planar_path", "spatial", "spatial_path"],
            "specialisations": {"planar_path": 3, "spatial_path": 2},
        },
    }


def test_a_path_family_loads_its_modes_solver_family_first(monkeypatch):
    order: list[str] = []
    monkeypatch.setattr(warmup, "_READY", set())
    monkeypatch.setattr(warmup, "kernels_cached", lambda kind: True)
    monkeypatch.setattr(warmup, "_warm", order.append)
    assert warmup.ensure_kernels("spatial_path") >= 0.0
    assert order == ["spatial", "spatial_path"]
    warmup.ensure_kernels("spatial")  # loaded once
    warmup.ensure_kernels("planar_path")
    assert order == ["spatial", "spatial_path", "planar", "planar_path"]
    with pytest.raises(ValueError, match="unknown 'paths'"):
        warmup.ensure_kernels("paths")


def test_warm_up_with_jobs_compiles_each_modes_families_in_a_child_then_loads_them(monkeypatch):
    groups_seen: list[list[tuple[str, ...]]] = []
    loaded: list[str] = []
    monkeypatch.setattr(warmup, "_READY", {"spatial"})  # this process has it already
    monkeypatch.setattr(warmup, "kernels_cached", lambda kind: kind == "planar_rows")
    monkeypatch.setattr(warmup, "_compile_apart", lambda g, jobs, notice: groups_seen.append(g))
    monkeypatch.setattr(warmup, "_warm", loaded.append)
    kinds = ("planar", "spatial", "planar_rows", "spatial_path", "planar_path")
    warmup.warm_up(kinds, jobs=2, notice=False)
    # the uncached families by mode, in the order asked; then all loaded here
    assert groups_seen == [[("planar", "planar_path"), ("spatial_path",)]]
    assert loaded == ["planar", "planar_rows", "spatial_path", "planar_path"]
    monkeypatch.setattr(warmup, "_READY", set())
    warmup.warm_up(("planar",), jobs=1, notice=False)  # one job: no child
    assert len(groups_seen) == 1
    monkeypatch.setattr(warmup, "_READY", set())
    warmup.warm_up(("planar",), jobs=np.int64(2), notice=False)  # any integer type
    assert groups_seen[1] == [("planar",)]


@pytest.mark.parametrize("jobs", [0, -1, 1.5, True, "2"])
def test_warm_up_refuses_a_bad_jobs_or_kind(jobs):
    with pytest.raises(ValueError, match="jobs"):
        warmup.warm_up(("planar",), jobs=jobs)
    with pytest.raises(ValueError, match="unknown 'paths'"):
        warmup.warm_up(("planar", "paths"), jobs=2)


@pytest.mark.skipif(sys.platform == "win32", reason="the children need POSIX file locks")
def test_the_children_of_a_parallel_warm_up_load_or_compile_and_report(capfd):
    # the session's warm-up filled the cache, so the children only load (a few seconds)
    codes = warmup._compile_apart([("planar",), ("spatial",)], 2, notice=True)
    assert codes == [0, 0]
    assert warmup._compile_apart([("planar",)], 2, notice=True) == []  # one group: here
    bad = warmup._compile_apart([("planar",), ("no such kind",)], 2, notice=True)
    assert sorted(bad) == [0, 1]  # a failing child is reported, not raised
    assert "unknown 'no such kind'" in capfd.readouterr().err
    # a child past its time is stopped (a signal: a negative code), not waited for
    late = warmup._compile_apart([("planar",), ("spatial",)], 2, notice=False, timeout=0.0)
    assert len(late) == 2 and all(code < 0 for code in late)


def test_the_warm_up_compiles_at_its_own_opt_level_unless_the_user_set_one(monkeypatch):
    from numba.core import config

    seen: list[int] = []
    monkeypatch.setattr(warmup, "_READY", set())
    monkeypatch.setattr(warmup, "kernels_cached", lambda kind: True)
    monkeypatch.setattr(warmup, "_warm", lambda kind: seen.append(int(config.OPT)))
    monkeypatch.delenv("NUMBA_OPT", raising=False)
    before = config.OPT
    warmup.ensure_kernels("spatial")
    assert seen == [warmup.COMPILE_OPT] and config.OPT is before  # restored afterwards
    warmup.ensure_kernels("planar")  # one of the families compiled at level 3
    assert "planar" in warmup.FAST_KINDS and seen[1:] == [3] and config.OPT is before
    monkeypatch.setenv("NUMBA_OPT", "2")  # the user's choice wins
    warmup.ensure_kernels("planar_path")
    assert seen[2:] == [int(before)] and config.OPT is before


def test_an_unreachable_spatial_target_loads_the_planar_kernels_off_the_clock(monkeypatch):
    from stackik.solve import request

    loaded: list[str] = []

    def fake(kind: str) -> float:  # as if loading took 1000 s
        loaded.append(kind)
        return 1000.0

    monkeypatch.setattr(request, "ensure_kernels", fake)
    stack = sk.Stack.reference(3, leg_radius=0.0)
    r = sk.solve_ik(stack, _spatial_target(3))
    assert r.success and loaded == []  # reachable: no planar kernel needed
    r = sk.solve_ik(stack, sk.SpatialTarget([0.0, 0.0, 200.0], np.eye(3)))  # stalls
    assert r.status is sk.IKStatus.INFEASIBLE and r.message.startswith("Unreachable")
    assert loaded == ["planar"]
    assert r.time < -900.0  # the 1000 s said spent loading are not on the solve's clock


# -----------------------------------------------------------------------------------------
# Progress of a compilation
# -----------------------------------------------------------------------------------------
def _fake_family(monkeypatch: pytest.MonkeyPatch, names: list[str]) -> None:
    """The planar family replaced by fresh (uncompiled, uncached) numba functions."""
    import numba

    funcs = []
    for k, name in enumerate(names):
        ns: dict[str, object] = {}
        exec(f"def {name}(x):\n    return x + {k}", ns)  # noqa: S102 - a fresh function
        funcs.append(numba.njit(ns[name]))
    monkeypatch.setattr(warmup, "_dispatchers", lambda kind: funcs)
    monkeypatch.setattr(warmup, "kernels_cached", lambda kind: False)
    monkeypatch.setattr(warmup, "_warm", lambda kind: [f(1.0) for f in funcs])
    monkeypatch.setattr(warmup, "_READY", set())


def test_a_compilation_says_when_it_starts_and_how_long_it_took(monkeypatch, capsys):
    _fake_family(monkeypatch, ["first_kernel", "second_kernel"])
    warmup.ensure_kernels("planar")
    err = capsys.readouterr().err.splitlines()
    assert err[0] == (
        "stackik: compiling the planar solver kernels (2 entry points; first run on this "
        "machine only, cached afterwards)"
    )
    assert err[1].startswith("stackik: compiled the planar solver kernels in ")
    assert err[1].endswith(" s (2 of 2 entry points, 2 functions in all)")
    assert len(err) == 2
    warmup.ensure_kernels("planar")  # once per process
    assert capsys.readouterr().err == ""


def test_a_compilation_on_a_terminal_ticks_a_bar_per_entry_point(monkeypatch):
    _fake_family(monkeypatch, ["alpha_kernel", "beta_kernel", "gamma_kernel"])

    class Terminal(io.StringIO):
        def isatty(self) -> bool:
            return True

    term = Terminal()
    with warmup._progress("planar", term) as progress:
        for f in warmup._dispatchers("planar"):
            f(2.0)
        assert progress.bar.n == 3 and progress.done == {id(f) for f in warmup._dispatchers("")}
    text = term.getvalue()
    assert "stackik: planar kernels 0/3" in text and "stackik: planar kernels 3/3" in text
    assert "gamma_kernel" in text  # the function being compiled, on the bar
    assert text.rstrip().splitlines()[-1].endswith("(3 of 3 entry points, 3 functions in all)")


def _rows_code_a_plain_solve_compiles() -> dict[str, object]:
    """Runs in a fresh process: a planar solve without dense rows, then one with an
    obstacle across its legs (no warm-up); after each, the families loaded and the
    specialisations of the dense rows' kernels (none until a problem has such rows)."""
    import numpy as np

    from stackik._compiled import dense_rows, obstacle_rows

    stack = sk.Stack.reference(4, leg_radius=0.0)
    target = sk.PlanarTarget(600.0, 1000.0, -1.57)
    sphere = sk.Sphere(np.array([300.0, 0.0, 500.0]), 50.0)
    out: dict[str, object] = {}
    for name, kw in (("plain", {}), ("obstacle", {"obstacles": [sphere]})):
        r = sk.solve_ik(stack, target, **kw)
        out[name] = {
            "success": bool(r.success),
            "ready": sorted(warmup._READY),
            # compiled or loaded: the rows' kernel the NumPy evaluation calls (a callee
            # loaded from the cache inside its caller gets no signature of its own)
            "rows code": len(dense_rows._with_rows.signatures)
            + len(obstacle_rows.obstacle_rows.signatures),
        }
    return out


def test_a_solve_without_dense_rows_compiles_none_of_their_code():
    # the problem data's n_dense is None without dense rows: numba compiles the kernels for
    # that type without the rows' code; a request that can carry rows loads the _rows twin
    out = _in_fresh_process(_rows_code_a_plain_solve_compiles)
    assert out["plain"] == {"success": True, "ready": ["planar"], "rows code": 0}
    assert out["obstacle"]["success"] is True
    assert out["obstacle"]["ready"] == ["planar", "planar_rows"]
    assert out["obstacle"]["rows code"] >= 1


def test_rows_needed_names_every_source_of_dense_rows():
    import numpy as np

    ref = sk.Stack.reference(3, leg_radius=0.0)
    assert not warmup.rows_needed(ref)
    assert warmup.rows_needed(ref, obstacles=sk.Sphere(np.zeros(3) + 500.0, 10.0))
    assert warmup.rows_needed(ref, clearance=5.0)
    assert warmup.rows_needed(sk.Stack.reference(3, leg_radius=12.0))
    # a planar solve's body rows are lazy: their family loads with the first fold
    assert not warmup.rows_needed(sk.Stack.reference(3), planar_solve=True)
    assert warmup.rows_needed(sk.Stack.reference(3), clearance=5.0, planar_solve=True)
    assert warmup.rows_needed(ref, force_weight=1.0)
    assert warmup.rows_needed(ref, objective="force")
    limited = sk.Stack.uniform(sk.PlatformGeometry.hexagonal(force_max=1e3), 3)
    assert warmup.rows_needed(limited)
    assert not warmup.rows_needed(ref, clearance="bad")  # the request's validation says so


def test_no_dense_rows_is_none_or_zero_dense_rows():
    from stackik._compiled.core import no_dense_rows

    class P:
        def __init__(self, n: int | None) -> None:
            self.n_dense = n

    assert no_dense_rows(P(None)) and no_dense_rows(P(0)) and not no_dense_rows(P(3))


def test_the_lean_type_is_the_problem_data_without_rows_beyond_the_limits():
    import numba
    import numpy as np

    from stackik._compiled.core import lean_type
    from stackik.formulation import Problem
    from stackik.methods.ip import problem_arrays, spatial_problem_arrays

    st = sk.Stack.reference(3, leg_radius=0.0)
    fat = sk.Stack.reference(3, leg_radius=12.0)
    pt = sk.PlanarTarget(0.0, 900.0, 0.0)
    sphere = sk.Sphere(np.array([0.0, 0.0, 500.0]), 20.0)

    def lean(arrays, stack, target, **kw) -> bool:
        return lean_type(numba.typeof(arrays(Problem(stack, target, "frobenius", None, **kw))))

    assert lean(problem_arrays, st, pt)
    assert not lean(problem_arrays, st, pt, obstacles=[sphere])
    assert lean(spatial_problem_arrays, st, pt.to_spatial())
    # self-leg rows alone (no dense row): not lean either
    assert not lean(spatial_problem_arrays, fat, pt.to_spatial())
    assert not lean(spatial_problem_arrays, st, pt.to_spatial(), obstacles=[sphere])
