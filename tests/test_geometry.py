"""Platform and stack geometry: layouts, validation, file I/O (DESIGN §2)."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
import reference_impl as ref

from stackik import GeometryError, PlatformGeometry, Stack


def to_geometry(g):
    return PlatformGeometry(g["base"], g["top"], g["leg_min"], g["leg_max"], g["joint_min"])


def valid_kwargs():
    g = PlatformGeometry.reference()
    return {
        "base_nodes": g.base_nodes.copy(),
        "top_nodes": g.top_nodes.copy(),
        "leg_min": 250.0,
        "leg_max": 450.0,
        "joint_min": 0.3,
    }


def mixed_stack():
    rng = np.random.default_rng(11)
    return Stack(
        (
            to_geometry(ref.random_geometry(rng)),
            PlatformGeometry.reference(),
            PlatformGeometry.hexagonal(120.0, 90.0, 0.1, 0.3, 200.0, 380.0, 0.2),
            to_geometry(ref.random_geometry(rng)),
        )
    )


# =========================================================================================
# Layouts
# =========================================================================================
def node_angles_deg(nodes):
    return np.degrees(np.arctan2(nodes[:, 1], nodes[:, 0]))


def same_angles(actual_deg, expected_deg):
    diff = (np.asarray(actual_deg) - np.asarray(expected_deg) + 180.0) % 360.0 - 180.0
    return np.all(np.abs(diff) < 1e-12)


@pytest.mark.parametrize(("a", "b"), [(15.0, 15.0), (5.0, 25.0), (-10.0, 40.0), (30.0, 2.0)])
def test_hexagonal_node_angles(a, b):
    g = PlatformGeometry.hexagonal(130.0, 110.0, math.radians(a), math.radians(b))
    assert same_angles(node_angles_deg(g.base_nodes), [-a, a, 120 - a, 120 + a, 240 - a, 240 + a])
    assert same_angles(
        node_angles_deg(g.top_nodes), [-60 + b, 60 - b, 60 + b, 180 - b, 180 + b, 300 - b]
    )
    assert np.allclose(np.linalg.norm(g.base_nodes[:, :2], axis=1), 130.0, rtol=1e-15)
    assert np.allclose(np.linalg.norm(g.top_nodes[:, :2], axis=1), 110.0, rtol=1e-15)
    assert np.all(g.base_nodes[:, 2] == 0) and np.all(g.top_nodes[:, 2] == 0)
    h = ref.hexagonal_geometry(130.0, 110.0, a, b)
    assert np.allclose(g.base_nodes, h["base"], rtol=0, atol=1e-12)
    assert np.allclose(g.top_nodes, h["top"], rtol=0, atol=1e-12)


def test_reference_geometry():
    g = PlatformGeometry.reference()
    assert g == PlatformGeometry.hexagonal(leg_radius=12.0)  # realistic actuators
    assert PlatformGeometry.reference(leg_radius=0.0) == PlatformGeometry.hexagonal()
    assert (g.leg_min, g.leg_max) == (250.0, 450.0)
    assert g.joint_min == pytest.approx(math.radians(20.0), rel=1e-15)
    h = ref.hexagonal_geometry()  # r = 150, a = b = 15 deg
    assert np.allclose(g.base_nodes, h["base"], rtol=0, atol=1e-12)
    assert np.allclose(g.top_nodes, h["top"], rtol=0, atol=1e-12)
    assert np.allclose(np.linalg.norm(g.base_nodes, axis=1), 150.0)
    assert np.allclose(np.linalg.norm(g.top_nodes, axis=1), 150.0)
    assert node_angles_deg(g.base_nodes)[1] == pytest.approx(15.0)


def test_reference_stack():
    s = Stack.reference(4)
    assert s.n == len(s) == 4
    assert all(p == PlatformGeometry.reference() for p in s)
    assert Stack.reference() == s
    assert Stack.reference(1).n == 1
    assert s.base_nodes.shape == s.top_nodes.shape == (4, 6, 3)
    assert np.array_equal(s.leg_min, [250.0] * 4)
    assert np.array_equal(s.leg_max, [450.0] * 4)
    assert np.allclose(s.sin_joint_min, math.sin(math.radians(20.0)))


def test_mixed_stack_arrays():
    s = mixed_stack()
    assert s.n == 4
    for i, p in enumerate(s):
        assert s[i] is p
        assert np.array_equal(s.base_nodes[i], p.base_nodes)
        assert np.array_equal(s.top_nodes[i], p.top_nodes)
        assert s.leg_min[i] == p.leg_min and s.leg_max[i] == p.leg_max
        assert s.sin_joint_min[i] == pytest.approx(math.sin(p.joint_min))
    assert s != Stack.reference(4)


def test_explicit_asymmetric_nodes_accepted_and_read_only():
    g = to_geometry(ref.random_geometry(np.random.default_rng(3)))
    assert g.base_nodes.shape == g.top_nodes.shape == (6, 3)
    with pytest.raises(ValueError):
        g.base_nodes[0, 0] = 1.0
    nodes = np.array(g.base_nodes)
    g2 = PlatformGeometry(nodes, g.top_nodes, g.leg_min, g.leg_max, g.joint_min)
    nodes[0, 0] += 1.0  # the geometry keeps its own copy
    assert g2 == g
    assert hash(g2) == hash(g)
    assert g2 != PlatformGeometry.reference()


def test_integer_inputs_are_converted():
    kw = valid_kwargs()
    kw["base_nodes"] = np.rint(kw["base_nodes"]).astype(int).tolist()
    g = PlatformGeometry(**{**kw, "leg_min": 250, "leg_max": 450, "joint_min": 0})
    assert g.base_nodes.dtype == float and isinstance(g.leg_min, float)


# =========================================================================================
# PlatformGeometry validation: one test per error
# =========================================================================================
def check_error(field, **changes):
    kw = {**valid_kwargs(), **changes}
    with pytest.raises(GeometryError, match=field) as info:
        PlatformGeometry(**kw)
    assert isinstance(info.value, ValueError)
    assert str(info.value).startswith(field)


@pytest.mark.parametrize("field", ["base_nodes", "top_nodes"])
@pytest.mark.parametrize("shape", [(5, 3), (6, 2), (18,), (6, 3, 1)])
def test_nodes_wrong_shape(field, shape):
    check_error(field, **{field: np.ones(shape)})


@pytest.mark.parametrize("field", ["base_nodes", "top_nodes"])
@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
def test_nodes_not_finite(field, bad):
    nodes = valid_kwargs()[field]
    nodes[2, 1] = bad
    check_error(field, **{field: nodes})


@pytest.mark.parametrize("field", ["base_nodes", "top_nodes"])
def test_nodes_not_numbers(field):
    check_error(field, **{field: [["a", "b", "c"]] * 6})
    valid = valid_kwargs()[field]
    check_error(field, **{field: [[str(v) for v in row] for row in valid]})
    check_error(field, **{field: valid > 0})  # booleans
    check_error(field, **{field: [[1, 2], [3]] * 3})  # ragged
    check_error(field, **{field: None})


@pytest.mark.parametrize("field", ["base_nodes", "top_nodes"])
def test_duplicate_nodes(field):
    nodes = valid_kwargs()[field]
    nodes[4] = nodes[1]
    check_error(field, **{field: nodes})


@pytest.mark.parametrize("field", ["base_nodes", "top_nodes"])
def test_collinear_nodes(field):
    nodes = np.column_stack(
        [np.linspace(-100, 100, 6), 0.5 * np.linspace(-100, 100, 6), 3.0 + 0 * np.arange(6)]
    )
    check_error(field, **{field: nodes})


@pytest.mark.parametrize("value", [0.0, -10.0])
def test_leg_min_not_positive(value):
    check_error("leg_min", leg_min=value)


@pytest.mark.parametrize("value", [250.0, 200.0])
def test_leg_max_not_above_leg_min(value):
    check_error("leg_max", leg_max=value)


@pytest.mark.parametrize("value", [-0.01, math.pi / 2, 2.0])
def test_joint_min_out_of_range(value):
    check_error("joint_min", joint_min=value)


@pytest.mark.parametrize("field", ["leg_min", "leg_max", "joint_min"])
@pytest.mark.parametrize("bad", [np.nan, np.inf, "300", None, [1.0], True])
def test_scalar_not_a_finite_number(field, bad):
    check_error(field, **{field: bad})


def test_joint_min_zero_allowed():
    assert PlatformGeometry(**{**valid_kwargs(), "joint_min": 0.0}).joint_min == 0.0


@pytest.mark.parametrize(
    ("kwargs", "field"),
    [
        ({"base_radius": 0.0}, "base_radius"),
        ({"top_radius": -1.0}, "top_radius"),
        ({"base_half_angle": np.nan}, "base_half_angle"),
        ({"top_half_angle": "x"}, "top_half_angle"),
        ({"leg_min": -1.0}, "leg_min"),
        ({"base_half_angle": math.radians(60.0)}, "base_nodes"),  # nodes coincide
    ],
)
def test_hexagonal_validation(kwargs, field):
    with pytest.raises(GeometryError, match=field):
        PlatformGeometry.hexagonal(**kwargs)


# =========================================================================================
# Stack validation
# =========================================================================================
def test_stack_empty():
    with pytest.raises(GeometryError, match="platforms"):
        Stack(())
    with pytest.raises(GeometryError, match="platforms"):
        Stack([])


def test_stack_wrong_element_type():
    with pytest.raises(GeometryError, match=r"platforms\[1\]"):
        Stack((PlatformGeometry.reference(), "platform"))
    with pytest.raises(GeometryError, match="platforms"):
        Stack(3)  # type: ignore[arg-type]


@pytest.mark.parametrize("n", [0, -1, 2.5, True, "3", None])
def test_stack_bad_n(n):
    with pytest.raises(GeometryError, match="n"):
        Stack.uniform(PlatformGeometry.reference(), n)
    with pytest.raises(GeometryError):
        Stack.reference(n)


def test_stack_numpy_integer_n():
    assert Stack.reference(np.int64(3)).n == 3


def test_stack_equality_and_hash():
    a, b = mixed_stack(), mixed_stack()
    assert a == b and hash(a) == hash(b)
    assert a != Stack(a.platforms[:3])
    assert Stack(list(a.platforms)) == a


# =========================================================================================
# File I/O
# =========================================================================================
@pytest.mark.parametrize("fmt", ["json", "toml"])
def test_round_trip_files(tmp_path, fmt):
    s = mixed_stack()
    path = tmp_path / f"stack.{fmt}"
    text = getattr(s, f"to_{fmt}")(path)
    assert path.read_text().strip() == text.strip()
    back = Stack.from_file(path)
    assert back == s  # exact: floats are written with repr
    upper = tmp_path / f"stack.{fmt.upper()}"
    upper.write_text(text)
    assert Stack.from_file(upper) == s
    assert Stack.from_file(str(path)) == s


def test_round_trip_dict():
    s = mixed_stack()
    d = s.to_dict()
    assert Stack.from_dict(d) == s
    assert Stack.from_dict(json.loads(json.dumps(d))) == s
    for p in s:
        assert PlatformGeometry.from_dict(p.to_dict()) == p


def test_to_json_to_toml_without_path():
    s = Stack.reference(2)
    assert Stack.from_dict(json.loads(s.to_json())) == s
    import tomllib

    assert Stack.from_dict(tomllib.loads(s.to_toml())) == s


def test_from_dict_uniform_and_hexagonal_forms(tmp_path):
    # a file's hexagonal table: the reference's layout and limits, bodies of no size
    s = Stack.from_dict({"platform": {"hexagonal": {}}, "n": 3})
    assert s == Stack.reference(3, leg_radius=0.0)
    spec = {"base_radius": 120.0, "top_half_angle": 0.2, "leg_max": 500.0}
    s = Stack.from_dict(
        {"platforms": [{"hexagonal": spec}, PlatformGeometry.reference().to_dict()]}
    )
    assert s[0] == PlatformGeometry.hexagonal(**spec)
    assert s[1] == PlatformGeometry.reference()
    path = tmp_path / "hex.toml"
    path.write_text("n = 2\n[platform.hexagonal]\nbase_radius = 140.0\njoint_min = 0.3\n")
    assert Stack.from_file(path) == Stack.uniform(
        PlatformGeometry.hexagonal(base_radius=140.0, joint_min=0.3), 2
    )


def _broken(data, mutate):
    d = json.loads(json.dumps(data))
    mutate(d)
    return d


BASE = {"platforms": [PlatformGeometry.reference().to_dict()] * 3}


@pytest.mark.parametrize(
    ("mutate", "field"),
    [
        (lambda d: d["platforms"][1].pop("leg_max"), r"platforms\[1\]\.leg_max"),
        (lambda d: d["platforms"][2].pop("top_nodes"), r"platforms\[2\]\.top_nodes"),
        (lambda d: d["platforms"][1].update(leg_max="long"), r"platforms\[1\]\.leg_max"),
        (lambda d: d["platforms"][1].update(leg_max="450"), r"platforms\[1\]\.leg_max"),
        (lambda d: d["platforms"][0].update(joint_min=[0.3]), r"platforms\[0\]\.joint_min"),
        (lambda d: d["platforms"][2].update(leg_min=500.0), r"platforms\[2\]\.leg_max"),
        (lambda d: d["platforms"][1].update(base_nodes=[[0, 0, 0]] * 6), r"platforms\[1\]\.base"),
        (lambda d: d["platforms"][1].update(top_nodes="abc"), r"platforms\[1\]\.top_nodes"),
        (lambda d: d["platforms"][1].update(colour="red"), r"platforms\[1\].*colour"),
        (lambda d: d.update(comment="x"), "comment"),
        (lambda d: d.update(platforms=[]), "platforms"),
        (lambda d: d.update(platforms={"a": 1}), "platforms"),
        (lambda d: d["platforms"].__setitem__(1, 7), r"platforms\[1\]"),
        (lambda d: d["platforms"].__setitem__(1, {"hexagonal": {"radius": 1}}), "radius"),
        (
            lambda d: d["platforms"].__setitem__(1, {"hexagonal": {"top_radius": -5.0}}),
            r"platforms\[1\]\.hexagonal\.top_radius",
        ),
        (lambda d: d.pop("platforms"), "platforms"),
    ],
)
def test_malformed_dict_names_field(mutate, field):
    d = _broken(BASE, mutate)
    with pytest.raises(GeometryError, match=field):
        Stack.from_dict(d)


@pytest.mark.parametrize(
    ("data", "field"),
    [
        ({"platform": PlatformGeometry.reference().to_dict()}, "n"),
        ({"platform": PlatformGeometry.reference().to_dict(), "n": 0}, "n"),
        ({"platform": {"hexagonal": {}}, "n": 2, "extra": 1}, "extra"),
        ({"platform": {"leg_min": 1.0}, "n": 2}, r"platform\.base_nodes"),
        ([1, 2], "stack"),
    ],
)
def test_malformed_uniform_dict(data, field):
    with pytest.raises(GeometryError, match=field):
        Stack.from_dict(data)


def test_platform_from_dict_not_a_mapping():
    with pytest.raises(GeometryError, match="platform"):
        PlatformGeometry.from_dict([1, 2, 3])  # type: ignore[arg-type]


@pytest.mark.parametrize("fmt", ["json", "toml"])
def test_file_errors_name_the_field(tmp_path, fmt):
    s = Stack.reference(3)
    path = tmp_path / f"s.{fmt}"
    text = getattr(s, f"to_{fmt}")()
    if fmt == "json":
        d = json.loads(text)
        d["platforms"][1]["leg_max"] = "long"
        path.write_text(json.dumps(d))
    else:
        blocks = text.split("[[platforms]]")
        blocks[2] = blocks[2].replace("leg_max = 450.0", 'leg_max = "long"')
        path.write_text("[[platforms]]".join(blocks))
    with pytest.raises(GeometryError, match=r"platforms\[1\]\.leg_max") as info:
        Stack.from_file(path)
    assert str(path) in str(info.value)


@pytest.mark.parametrize(
    ("name", "content"),
    [
        ("bad.toml", "[[platforms]\nleg_min = 1\n"),
        ("bad.toml", "leg_min = = 3\n"),
        ("bad.json", '{"platforms": [}'),
        ("bad.json", ""),
        ("bad.json", "\xff\xfe"),
    ],
)
def test_file_syntax_errors(tmp_path, name, content):
    path = tmp_path / name
    if content == "\xff\xfe":
        path.write_bytes(b"\xff\xfe\x00")
    else:
        path.write_text(content)
    with pytest.raises(GeometryError, match="not valid"):
        Stack.from_file(path)


def test_file_unknown_suffix(tmp_path):
    path = tmp_path / "stack.yaml"
    path.write_text(Stack.reference(2).to_json())
    with pytest.raises(GeometryError, match="unknown geometry file type"):
        Stack.from_file(path)


def test_file_missing(tmp_path):
    with pytest.raises(GeometryError, match="cannot read"):
        Stack.from_file(tmp_path / "nope.toml")


def test_file_missing_field_and_unknown_field(tmp_path):
    path = tmp_path / "s.json"
    d = Stack.reference(2).to_dict()
    del d["platforms"][0]["joint_min"]
    path.write_text(json.dumps(d))
    with pytest.raises(GeometryError, match=r"platforms\[0\]\.joint_min: missing"):
        Stack.from_file(path)
    d = Stack.reference(2).to_dict()
    d["platforms"][1]["leg_mx"] = 3.0
    path.write_text(json.dumps(d))
    with pytest.raises(GeometryError, match=r"platforms\[1\].*leg_mx"):
        Stack.from_file(path)


def test_derived_cache_is_kept_and_bounded():
    from stackik.geometry import _DERIVED_MAX

    st = Stack.reference(2)
    calls = []

    def make(s):
        calls.append(1)
        return len(calls)

    assert st.derived("k", make) == 1 and st.derived("k", make) == 1
    for i in range(3 * _DERIVED_MAX):  # e.g. many phi values
        st.derived(("phi", i), lambda s: 0)
    assert len(st._derived) <= _DERIVED_MAX
    assert st == Stack.reference(2)  # the cache does not take part in equality


# --- clearance fields (docs/clearance.md) ------------------------------------------------
def test_clearance_fields_default_zero_and_keep_the_old_forms():
    g = PlatformGeometry.hexagonal()
    assert (g.leg_radius, g.plate_thickness) == (0.0, 0.0)
    assert "leg_radius" not in g.to_dict() and "plate_thickness" not in g.to_dict()
    assert "leg_radius" not in Stack.reference(2, leg_radius=0.0).to_toml()
    # the reference's actuators are written, and read back
    assert "leg_radius = 12.0" in Stack.reference(2).to_toml()
    assert Stack.from_dict(Stack.reference(2).to_dict()) == Stack.reference(2)


@pytest.mark.parametrize("field", ["leg_radius", "plate_thickness"])
@pytest.mark.parametrize("bad", [-1.0, math.nan, math.inf, "12", True])
def test_clearance_fields_validated(field, bad):
    with pytest.raises(GeometryError, match=field):
        PlatformGeometry.hexagonal(**{field: bad})


def test_clearance_fields_in_hexagonal_equality_pickle_and_files(tmp_path):
    import pickle

    g = PlatformGeometry.hexagonal(leg_radius=12, plate_thickness=8.5)
    assert (g.leg_radius, g.plate_thickness) == (12.0, 8.5)
    assert isinstance(g.leg_radius, float)
    assert g != PlatformGeometry.reference()
    assert g != PlatformGeometry.hexagonal(leg_radius=12)
    assert g == PlatformGeometry.hexagonal(leg_radius=12.0, plate_thickness=8.5)
    assert hash(g) == hash(PlatformGeometry.hexagonal(leg_radius=12.0, plate_thickness=8.5))
    back = pickle.loads(pickle.dumps(g))
    assert back == g and back.leg_radius == 12.0 and back.plate_thickness == 8.5
    stack = Stack.uniform(g, 3)
    assert pickle.loads(pickle.dumps(stack)) == stack
    for suffix in (".toml", ".json"):
        path = tmp_path / f"g{suffix}"
        stack.to_toml(path) if suffix == ".toml" else stack.to_json(path)
        loaded = Stack.from_file(path)
        assert loaded == stack and loaded[0].leg_radius == 12.0
    spec = {"hexagonal": {"leg_radius": 10, "plate_thickness": 4}}
    assert PlatformGeometry.from_dict(spec) == PlatformGeometry.hexagonal(
        leg_radius=10, plate_thickness=4
    )
    with pytest.raises(GeometryError, match=r"platform\.hexagonal\.leg_radius"):
        PlatformGeometry.from_dict({"hexagonal": {"leg_radius": -2}})
    d = PlatformGeometry.reference().to_dict() | {"plate_thickness": -1}
    with pytest.raises(GeometryError, match=r"platforms\[0\]\.plate_thickness"):
        Stack.from_dict({"platforms": [d]})


def test_geometry_show_names_the_clearance_sizes():
    from stackik.cli.geometry import describe_stack

    text = describe_stack(Stack.uniform(PlatformGeometry.hexagonal(leg_radius=12), 2))
    assert "leg radius 12 mm" in text and "plate thickness" not in text
    assert "radius" not in describe_stack(Stack.reference(2, leg_radius=0.0)).splitlines()[1]


def test_reference_with_a_leg_radius():
    from stackik.geometry import ACTUATOR_RADIUS

    g = PlatformGeometry.reference(leg_radius=ACTUATOR_RADIUS)
    assert g == PlatformGeometry.hexagonal(leg_radius=12.0)
    assert Stack.reference(3, leg_radius=12.0) == Stack.uniform(g, 3)
    assert Stack.reference(2) == Stack.reference(2, leg_radius=ACTUATOR_RADIUS)
    assert Stack.reference(2, leg_radius=0.0) == Stack.uniform(PlatformGeometry.hexagonal(), 2)
    with pytest.raises(GeometryError, match="leg_radius"):
        Stack.reference(2, leg_radius=-1.0)
