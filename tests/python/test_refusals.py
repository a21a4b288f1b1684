"""Every refusal: a Python exception naming the argument (and for a parameter, its range)."""

import numpy as np
import pytest

import lobe

UP = [0.0, 0.0, 1.0]


@pytest.mark.parametrize("wi,wo,kind,words", [
    (np.zeros((4, 2)), [UP], ValueError, ["wi", "(..., 3)"]),
    ([UP], np.array([[0, 0, 1j]]), TypeError, ["wo", "real numbers", "complex"]),
    (np.array([["0", "0", "1"]]), [UP], TypeError, ["wi", "real numbers"]),
    ([UP], [[0, 0, 1], [0, 1]], TypeError, ["wo", "real numbers"]),
    ([UP], [[0, 0, "up"]], TypeError, ["wo", "real numbers"]),
    ([[0.0, np.nan, 1.0]], [UP], ValueError, ["wi", "NaN"]),
    ([UP], [[0.0, 0.0, np.inf]], ValueError, ["wo", "infinit"]),
    ([[0.0, 0.0, 2.0]], [UP], ValueError, ["wi", "unit"]),
    (np.zeros((2, 3)) + UP, np.zeros((3, 3)) + UP, ValueError, ["wi, wo", "broadcast"]),
])
def test_bad_direction_arrays_are_refused_naming_the_argument(cpu, wi, wo, kind, words):
    with pytest.raises(kind) as e:
        cpu.eval("lambert", wi, wo)
    for w in words:
        assert w in str(e.value)


def test_float32_directions_are_taken(cpu):
    f = cpu.eval("lambert", np.array(UP, dtype=np.float32), np.array(UP, dtype=np.float32))
    assert f.dtype == np.float64 and f.shape == (3,)


@pytest.mark.parametrize("up", [
    [0, 0, 1],
    np.array([[0, 0, 1]]),
    np.array([[0, 0, 1]], dtype=np.int32),
    np.array([0, 0, 1], dtype=np.uint8),
    np.array([False, False, True]),
], ids=["int list", "int64 array", "int32 array", "uint8 array", "bool array"])
def test_what_asarray_reads_as_float_is_taken(cpu, up):
    """Directions are taken as np.asarray(x, dtype=float) reads them, and give the values of
    the same float64 directions."""
    want = cpu.eval("lambert", np.asarray(up, dtype=float), np.asarray(up, dtype=float))
    got = cpu.eval("lambert", up, up)
    assert got.dtype == np.float64
    np.testing.assert_array_equal(got, want)
    mu = cpu.albedo("lambert", np.array([1]))
    np.testing.assert_array_equal(mu.albedo, cpu.albedo("lambert", [1.0]).albedo)


def test_mu_that_is_not_a_real_number_is_refused_naming_it(cpu):
    for bad in ["0.5", [0.5j], [[0.5], [0.5, 0.6]]]:
        with pytest.raises(TypeError) as e:
            cpu.albedo("lambert", bad)
        assert "mu" in str(e.value)


def test_a_table_is_an_array(cpu):
    t = cpu.table("lambert", grid="isotropic", res=(2, 3, 4))
    a = np.asarray(t)
    assert a is t.values and a.shape == (2, 3, 4, 3)
    assert np.asarray(t, dtype=np.float64).dtype == np.float64
    assert np.array(t) is not t.values and np.array_equal(np.array(t), t.values)


@pytest.mark.parametrize("params,words", [
    ({"alpha": 7}, ["alpha", "out of range", "(0, 1]"]),
    ({"alpha": float("nan")}, ["alpha"]),
    ({"shininess": 3}, ["unknown parameter 'shininess'", "alpha"]),
    ({"distribution": "gaussian"}, ["distribution", "one of", "ggx"]),
    ({"specular": (1, 2)}, ["specular"]),
    ({"specular": None}, ["specular"]),
])
def test_bad_parameters_are_refused_naming_key_and_range(session, params, words):
    with pytest.raises(ValueError) as e:
        session.eval("microfacet", [UP], [UP], params=params)
    for w in words:
        assert w in str(e.value), str(e.value)


def test_an_unknown_model_or_material_is_refused_with_the_names(cpu):
    with pytest.raises(ValueError, match="unknown model 'blinn'.*blinn_phong"):
        cpu.eval("blinn", [UP], [UP])
    with pytest.raises(ValueError, match="unobtainium"):
        cpu.eval("cook_torrance", [UP], [UP], material="unobtainium")
    with pytest.raises(ValueError, match="phong"):
        cpu.eval("phong{shininess=50", [UP], [UP])


@pytest.mark.parametrize("path", ["no/such/model.brdf", "no/such/measured.binary"])
def test_a_missing_model_file_is_file_not_found(cpu, path):
    with pytest.raises(FileNotFoundError, match=path):
        cpu.eval(path, [UP], [UP])


def test_bad_session_arguments():
    with pytest.raises(ValueError, match="backend.*'metal'.*gpu.*cpu"):
        lobe.Session(backend="metal")
    with pytest.raises(lobe.GpuError):
        lobe.Session(backend="gpu", device="no device has this name")


def test_bad_table_requests(cpu):
    with pytest.raises(ValueError, match="res"):
        cpu.table("lambert", grid="isotropic", res=(4, 4))
    with pytest.raises(ValueError, match="res"):
        cpu.table("lambert", grid="isotropic", res=(4, 0, 4))
    with pytest.raises(ValueError, match="res"):
        cpu.table("lambert", grid="spherical", res=(4, 4, 4))
    with pytest.raises(ValueError, match="anisotropic"):
        cpu.table("ashikhmin_shirley", grid="isotropic", res=(2, 2, 2), params={"nu": 10, "nv": 1000})
    with pytest.raises(ValueError, match="cells"):
        cpu.table("lambert", grid="full", res=(64, 64, 64, 64), max_cells=1000)


def test_bad_albedo_requests(cpu):
    with pytest.raises(ValueError, match=r"mu: 0.0 at index \(1,\) is out of range.*\(0, 1\]"):
        cpu.albedo("lambert", mu=[0.5, 0.0])
    with pytest.raises(ValueError, match="mu"):
        cpu.albedo("lambert", mu=[np.nan])
    with pytest.raises(ValueError, match="method.*'simpson'.*peak"):
        cpu.albedo("lambert", mu=[0.5], method="simpson")
    with pytest.raises(ValueError, match="samples"):
        cpu.albedo("lambert", mu=[0.5], samples=0)
    with pytest.raises(ValueError, match="phi"):
        cpu.albedo("lambert", mu=[0.5], phi=float("inf"))
    with pytest.raises(ValueError, match="params: an empty list"):
        cpu.albedo("lambert", mu=[0.5], params=[])


def test_bad_lut_requests(cpu):
    with pytest.raises(ValueError, match="kind.*'ggx'.*dfg"):
        cpu.engine_lut("ggx")
    with pytest.raises(ValueError, match="res"):
        cpu.engine_lut("dfg", res=(8,))
    with pytest.raises(ValueError, match="param"):
        cpu.albedo_lut("microfacet", param="shininess", res=(4, 4))
    with pytest.raises(ValueError, match="mapping"):
        cpu.albedo_lut("microfacet", mapping="cubic", res=(4, 4))


def test_bad_fit_requests(cpu):
    with pytest.raises(ValueError, match="free.*also given a value"):
        cpu.fit("microfacet", "microfacet", free=["alpha"], params={"alpha": 0.3})
    with pytest.raises(ValueError, match="free.*shininess"):
        cpu.fit("microfacet", "microfacet", free=["shininess"])
    with pytest.raises(ValueError, match="loss.*'l1'"):
        cpu.fit("microfacet", "microfacet", free=["alpha"], loss="l1")
    with pytest.raises(FileNotFoundError, match="missing.binary"):
        cpu.fit("missing.binary", "microfacet", free=["alpha"])
