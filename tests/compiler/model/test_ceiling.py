"""A robot too large for dense Jacobians is refused at once, with the figure and the way out
(eomc.compiler.model.ceiling); the rhs alone is not bounded by it."""

import pytest

import eomc
from eomc.compiler.model.ceiling import MAX_DENSE_COORDINATES, check_ceiling
from eomc.compiler.model.spec import read_model
from eomc.runtime.errors import ModelError

LINK = ('<link name="l{i}"><inertial><origin xyz="0 0 0.2"/><mass value="1"/><inertia ixx="0.02" ixy="0" '
        'ixz="0" iyy="0.02" iyz="0" izz="0.001"/></inertial></link>\n')
JOINT = ('<joint name="j{i}" type="revolute"><parent link="l{p}"/><child link="l{i}"/><origin xyz="0 0 0.4"/>'
         '<axis xyz="{a}"/></joint>\n')


def chain(path, n):
    body = "".join(LINK.format(i=i) + JOINT.format(i=i, p=i - 1, a="1 0 0" if i % 2 else "0 1 0")
                   for i in range(1, n + 1))
    path.write_text(f'<?xml version="1.0"?>\n<robot name="chain">\n<link name="l0"/>\n{body}</robot>\n')
    return path


@pytest.fixture(scope="module")
def long_chain(tmp_path_factory):
    return chain(tmp_path_factory.mktemp("chain") / "chain.urdf", MAX_DENSE_COORDINATES + 1)


def test_a_default_build_past_the_ceiling_is_refused_before_deriving(long_chain, monkeypatch):
    import eomc.compiler.driver as driver

    def refuse(*args, **kwargs):
        raise AssertionError("the model was derived")
    monkeypatch.setattr(driver, "spec_of", refuse)
    monkeypatch.delenv("EOMC_BUILD_CEILING", raising=False)
    with pytest.raises(ModelError) as error:
        eomc.compile(str(long_chain), progress=False)  # refuse() above: reading the file, not deriving it
    text = str(error.value)
    assert f"{MAX_DENSE_COORDINATES + 1} coordinates" in text and "about 62 MB of C" in text, text
    assert "--outputs rhs,mass_matrix,forcing,inverse_dynamics,outputs,events,poses" in text, text
    assert "EOMC_BUILD_CEILING=off" in text and "\n" not in text
    with pytest.raises(ModelError, match=r"the dense Jacobians \(jac_x\) "):
        eomc.compile(str(long_chain), functions=["rhs", "jacobian"], progress=False)


def test_the_rhs_alone_and_the_override_pass(long_chain, monkeypatch):
    read = read_model(str(long_chain))
    monkeypatch.delenv("EOMC_BUILD_CEILING", raising=False)
    check_ceiling(read, ["rhs", "poses"])                # linear: no ceiling
    with pytest.raises(ModelError):
        check_ceiling(read, None)
    monkeypatch.setenv("EOMC_BUILD_CEILING", "off")
    check_ceiling(read, None)
    small = read_model(str(chain(long_chain.with_name("small.urdf"), MAX_DENSE_COORDINATES)))
    monkeypatch.delenv("EOMC_BUILD_CEILING")
    check_ceiling(small, None)


def test_a_large_build_without_dense_jacobians_states_its_cost(tmp_path, monkeypatch):
    from eomc.compiler.model.ceiling import LARGE_COORDINATES
    from eomc.runtime.errors import EomcWarning
    monkeypatch.delenv("EOMC_BUILD_CEILING", raising=False)
    read = read_model(str(chain(tmp_path / "big.urdf", LARGE_COORDINATES + 1)))
    with pytest.warns(EomcWarning, match=rf"big: {LARGE_COORDINATES + 1} coordinates: expect this build "
                                         r"to take about [\d.]+ min of CPU and [\d.]+ MB of memory"):
        check_ceiling(read, ["rhs"])
