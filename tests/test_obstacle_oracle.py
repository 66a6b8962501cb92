"""The soak's obstacle oracle (``reference_impl.obstacle_body_gaps``, written apart from
stackik's clearance code) against ``stackik.clearances`` on random poses and obstacles:
two implementations of the same exact distances agree."""

from __future__ import annotations

import fuzz_cases as fc
import numpy as np
import pytest
import reference_impl as ref

import stackik as sk


@pytest.mark.parametrize("planar", [False, True])
def test_the_oracle_and_stackik_measure_the_same_obstacle_distances(planar: bool) -> None:
    rng = np.random.default_rng(2912 + planar)
    for _ in range(12):
        n = int(rng.integers(1, 4))
        radius = float(rng.choice([0.0, rng.uniform(1.0, 12.0)]))
        stack = sk.Stack.reference(n, leg_radius=radius)
        if planar:
            phi = float(rng.uniform(-np.pi, np.pi))
            q = fc.feasible_planar_pose(stack, rng, phi)
            poses = [ref.planar_platform_pose(row, phi) for row in q]
        else:
            phi = None
            q = fc.feasible_spatial_pose(stack, rng)
            poses = [ref.spatial_platform_pose(row) for row in q]
        O, A = ref.chain(poses)
        obstacles = [fc._random_obstacle(rng, stack, poses, k) for k in fc.OBSTACLE_KINDS]
        base = stack.base_nodes[0]
        obstacles = [ob for ob in obstacles if np.min(ob.point_distance(base)) > radius + 1.0]
        got = sk.clearances(stack, q, obstacles, phi=phi).obstacles
        geoms = fc.geometry_dicts(stack)
        for ob, d in zip(obstacles, got, strict=True):
            g = ref.obstacle_body_gaps(geoms, O, A, ob.to_dict())
            want = min(float(g["leg"].min()) - radius, float(g["plate"].min()))
            if want > 0.0 or d > 0.0:  # disjoint: exact distances (a box's depth inside
                # is only bounded by the oracle's line search, so compare signs there)
                assert d == pytest.approx(want, abs=1e-6), (ob, d, want)
            else:
                assert d <= 1e-6 and want <= 1e-6
