"""Obstacles: validation (a ValueError naming the field), files, equality."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from stackik import Box, Capsule, HalfSpace, Sphere, load_obstacles
from stackik.obstacles import as_obstacles, obstacle_from_dict, obstacles_from_data

EXAMPLES = [
    Sphere([0, 0, 900], 50),
    Capsule([-400, 0, 300], [-400, 0, 1200], 20),
    Box([300, 0, 500], [40, 50, 60]),
    Box([300, 0, 500], [40, 50, 60], rotation=[[0, -1, 0], [1, 0, 0], [0, 0, 1]]),
    HalfSpace([0, 0, -30], [0, 0, 2]),
]


@pytest.mark.parametrize(
    ("make", "field"),
    [
        (lambda: Sphere([0, 0, 0], -1), "radius"),
        (lambda: Sphere([0, 0, math.nan], 1), "center"),
        (lambda: Sphere([0, 0], 1), "center"),
        (lambda: Sphere([0, 0, 0], "1"), "radius"),
        (lambda: Capsule([0, 0, 0], [1, 1, 1], -0.5), "radius"),
        (lambda: Capsule([0, 0, 0], [1, math.inf, 1], 1), "b"),
        (lambda: Box([0, 0, 0], [1, -1, 1]), "half_extents"),
        (lambda: Box([0, 0, 0], [1, 1, 1], rotation=2 * np.eye(3)), "rotation"),
        (lambda: Box([0, 0, 0], [1, 1, 1], rotation=-np.eye(3)), "rotation"),
        (lambda: HalfSpace([0, 0, 0], [0, 0, 0]), "normal"),
        (lambda: HalfSpace([0, 0, 0], [0, 0, math.nan]), "normal"),
        (lambda: HalfSpace(["a", 0, 0], [0, 0, 1]), "point"),
    ],
)
def test_bad_obstacles_name_the_field(make, field):
    with pytest.raises(ValueError, match=f"^{field}:"):
        make()


def test_values_frozen_and_normalised():
    h = HalfSpace([0, 0, -30], [0, 0, 2])
    np.testing.assert_array_equal(h.normal, [0, 0, 1])
    with pytest.raises(AttributeError):
        h.point = np.zeros(3)  # type: ignore[misc]
    with pytest.raises(ValueError):
        h.point[0] = 1.0  # read-only
    np.testing.assert_array_equal(Box([0, 0, 0], [1, 1, 1]).rotation, np.eye(3))


@pytest.mark.parametrize("ob", EXAMPLES, ids=lambda o: o.kind)
def test_dict_round_trip_and_equality(ob):
    back = obstacle_from_dict(ob.to_dict())
    assert back == ob and hash(back) == hash(ob)
    assert back != Sphere([1, 2, 3], 4) or ob == Sphere([1, 2, 3], 4)


def test_files_toml_and_json(tmp_path):
    toml = tmp_path / "obs.toml"
    toml.write_text(
        "[[obstacles]]\ntype = 'sphere'\ncenter = [0, 0, 900]\nradius = 50\n\n"
        "[[obstacles]]\ntype = 'capsule'\na = [-400, 0, 300]\nb = [-400, 0, 1200]\nradius = 20\n"
    )
    assert load_obstacles(toml) == tuple(EXAMPLES[:2])
    js = tmp_path / "obs.json"
    js.write_text(json.dumps([o.to_dict() for o in EXAMPLES]))
    assert load_obstacles(js) == tuple(EXAMPLES)
    js.write_text(json.dumps({"obstacles": [o.to_dict() for o in EXAMPLES]}))
    assert load_obstacles(js) == tuple(EXAMPLES)


@pytest.mark.parametrize(
    ("data", "where"),
    [
        ([{"type": "cone"}], r"obstacles\[0\]\.type"),
        ([{"type": "sphere", "center": [0, 0, 0]}], r"obstacles\[0\]\.radius: missing"),
        ([{"type": "sphere", "center": [0, 0, 0], "radius": 1, "r": 2}], "unknown field"),
        ([EXAMPLES[0].to_dict(), {"type": "sphere", "center": [0, 0], "radius": 1}],
         r"obstacles\[1\]\.center"),
        ({"obstacle": []}, "unknown field"),
        ({"obstacles": {}}, "list"),
        ([3], r"obstacles\[0\]: expected a table"),
    ],
)  # fmt: skip
def test_malformed_data_names_the_place(data, where):
    with pytest.raises(ValueError, match=where):
        obstacles_from_data(data)


def test_file_errors(tmp_path):
    with pytest.raises(ValueError, match="cannot read"):
        load_obstacles(tmp_path / "missing.toml")
    bad = tmp_path / "bad.toml"
    bad.write_text("[[obstacles]\n")
    with pytest.raises(ValueError, match="not valid TOML"):
        load_obstacles(bad)
    other = tmp_path / "obs.yaml"
    other.write_text("")
    with pytest.raises(ValueError, match="unknown obstacle file type"):
        load_obstacles(other)
    neg = tmp_path / "neg.json"
    neg.write_text(json.dumps([{"type": "sphere", "center": [0, 0, 0], "radius": -3}]))
    with pytest.raises(ValueError, match=r"neg\.json: obstacles\[0\]\.radius"):
        load_obstacles(neg)


def test_as_obstacles():
    assert as_obstacles(None) == ()
    assert as_obstacles(EXAMPLES[0]) == (EXAMPLES[0],)
    with pytest.raises(ValueError, match=r"obstacles\[1\]"):
        as_obstacles([EXAMPLES[0], "sphere"])
    with pytest.raises(ValueError, match="obstacles"):
        as_obstacles(3)  # type: ignore[arg-type]


def test_point_distances_are_signed():
    p = np.array([[0.0, 0, 900], [0, 0, 1000]])
    np.testing.assert_allclose(EXAMPLES[0].point_distance(p), [-50, 50])
    np.testing.assert_allclose(EXAMPLES[4].point_distance(p[:1] * 0), [30.0])
    np.testing.assert_allclose(EXAMPLES[2].point_distance(np.array([300.0, 0, 500])), -40.0)


@pytest.mark.parametrize("ob", EXAMPLES, ids=lambda o: o.kind)
def test_pickle_through_the_constructor(ob):
    import pickle

    back = pickle.loads(pickle.dumps(ob))
    assert back == ob and type(back) is type(ob)
    arrays = [v for v in vars(back).values() if isinstance(v, np.ndarray)]
    assert arrays and not any(a.flags.writeable for a in arrays)


def test_halfspace_with_any_normal_reads_back_equal():
    import pickle

    rng = np.random.default_rng(0)
    for _ in range(200):
        h = HalfSpace(rng.normal(0, 100, 3), rng.normal(size=3))
        assert abs(np.linalg.norm(h.normal) - 1.0) < 1e-15
        assert pickle.loads(pickle.dumps(h)) == h
        assert obstacle_from_dict(json.loads(json.dumps(h.to_dict()))) == h
