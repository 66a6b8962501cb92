"""stackik.clearance.contact_points: the closest points of each contact, against the
clearance values and brute-force sampling of the bodies."""

from __future__ import annotations

import numpy as np
import pytest

from stackik import Box, Capsule, HalfSpace, PlatformGeometry, Sphere, Stack, clearances
from stackik import distance as dist
from stackik.clearance import Body, Contact, _layout, contact_points, plate_frames
from stackik.sampling import random_feasible_poses

PHI = 0.3
GEOM = PlatformGeometry.hexagonal(leg_radius=12.0, plate_thickness=10.0)
OBSTACLES = [
    Sphere([300, 0, 600], 50),
    Box([0, 300, 500], [50, 50, 50]),
    HalfSpace([0, 0, -20], [0, 0, 1]),
    Capsule([-500, 0, 300], [-500, 0, 900], 20),
    Box([40, 0, 650], [60, 400, 30]),  # across the stack: legs or plates enter it
]


def _cores(stack, q, phi):
    """Sample points of every body's core, by body: legs (400 points), plates (a grid)."""
    lay = _layout(stack)
    A, O = plate_frames(stack, q, phi)
    B = O[:-1, None] + np.einsum("nij,nkj->nki", A[:-1], stack.base_nodes)
    T = O[1:, None] + np.einsum("nij,nkj->nki", A[1:], stack.top_nodes)
    t = np.linspace(0.0, 1.0, 401)[:, None]

    def sample(body):
        if body.kind == "leg":
            i, k = body.index - 1, body.leg
            return B[i, k] + t * (T[i, k] - B[i, k]), lay.radius[i]
        j = body.index
        poly = dist.Polygon(O[j], A[j], lay.uv[j])
        lo, hi = lay.uv[j].min(0), lay.uv[j].max(0)
        g = np.stack(np.meshgrid(*np.linspace(lo, hi, 41).T), -1).reshape(-1, 2)
        g = g[poly.inside(g)]
        return O[j] + g @ A[j][:, :2].T, lay.half_t[j]

    return sample


def _on_body(point, sample, body, tol):
    pts, r = sample(body)
    assert np.min(np.linalg.norm(pts - point, axis=1)) <= r + tol


@pytest.mark.parametrize("n", [1, 3])
def test_points_are_the_contacts_distances_and_beat_sampling(n):
    stack = Stack.uniform(GEOM, n)
    for q in random_feasible_poses(stack, 3, rng=10 + n, phi=PHI):
        c = clearances(stack, q, OBSTACLES, phi=PHI)
        sample = _cores(stack, q, PHI)
        for contact in c.contacts:
            cp = contact_points(stack, q, contact, OBSTACLES, phi=PHI)
            gap = float(np.linalg.norm(cp.b - cp.a))
            assert gap == pytest.approx(abs(contact.distance), abs=1e-6)
            pa, ra = sample(contact.a)
            _on_body(cp.a, sample, contact.a, 1e-6 + 8.0)  # a surface point of body a
            if contact.b is None:
                ob = OBSTACLES[contact.obstacle]
                assert float(ob.point_distance(cp.b)) == pytest.approx(0.0, abs=1e-6)
                brute = float(np.min(ob.point_distance(pa))) - ra
            else:
                _on_body(cp.b, sample, contact.b, 1e-6 + 8.0)
                pb, rb = sample(contact.b)
                brute = float(np.linalg.norm(pa[:, None] - pb[None], axis=-1).min()) - ra - rb
            # sampling can only find a pair as close or farther, and a close one (plates are
            # sampled every ~8 mm)
            assert brute >= contact.distance - 1e-6
            assert brute <= contact.distance + 8.0


def test_an_obstacle_contact_points_into_the_obstacle_when_it_penetrates():
    stack = Stack.uniform(GEOM, 2)
    q = random_feasible_poses(stack, 1, rng=3, phi=0.0)[0]
    A, O = plate_frames(stack, q, 0.0)
    ob = Sphere(O[1] + 30.0 * A[1][:, 2], 40.0)  # over the middle plate
    c = clearances(stack, q, [ob], phi=0.0)
    hit = c.contacts[-1]
    assert hit.distance < 0
    cp = contact_points(stack, q, hit, [ob], phi=0.0)
    assert np.linalg.norm(cp.b - cp.a) == pytest.approx(-hit.distance, abs=1e-6)
    assert float(ob.point_distance(cp.a)) < 0  # the body's deepest point is inside
    assert cp.label() == f"{hit.distance:.1f} mm"


def test_a_contact_with_an_unknown_obstacle_is_refused():
    stack = Stack.uniform(GEOM, 2)
    q = random_feasible_poses(stack, 1, rng=3, phi=0.0)[0]
    with pytest.raises(ValueError, match="obstacle 3"):
        contact_points(stack, q, Contact(1.0, Body("leg", 1, 0), obstacle=3), (), phi=0.0)
