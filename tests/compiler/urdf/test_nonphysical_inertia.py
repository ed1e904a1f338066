"""Romeo LAAS small (example-robot-data): moving links with principal moments of -0.0027 and
-0.021 kg m^2 -- not rounding.  Refused by default (file:line, naming the link, with the
opt-in in the message); with ``allow_nonphysical_inertia`` it builds with one warning per
such link and agrees with Pinocchio (which loads it as it is) in ABA, RNEA and CRBA to
1e-12 relative at random states where the articulated pivots of ABA stay away from zero.
One recursive build of 32 joints (floating base): a few seconds."""
import warnings

import numpy as np
import pinocchio as pin
import pytest

import eomc
from eomc.cli import main
from eomc.compiler.urdf import build_tree, read_urdf
from eomc.compiler.urdf.model import UrdfModel
from eomc.runtime.errors import EomcWarning, ModelFileError
from helpers.robots import PinRef, relative_error, robot_path

ROMEO_SMALL = "romeo_description/urdf/romeo_laas_small.urdf"
NEGATIVE = {"body": 327, "LHipPitch_link": 358, "RHipPitch_link": 430}   # link -> line in the file
FUNCTIONS = ["rhs", "inverse_dynamics", "mass_matrix"]


def test_refused_by_default_naming_the_link_and_the_opt_in():
    path = robot_path(ROMEO_SMALL)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", EomcWarning)     # its massless grippers are merged, said
        with pytest.raises(ModelFileError) as info:
            build_tree(read_urdf(path), floating_base=True)
    text = str(info.value)
    assert text.startswith(f"{path}:{NEGATIVE['body']}: link 'body'"), text
    assert "-0.0213468" in text and "allow_nonphysical_inertia=True" in text
    assert "--allow-nonphysical-inertia" in text


@pytest.fixture(scope="module")
def romeo(tmp_path_factory):
    path = robot_path(ROMEO_SMALL)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        tree = build_tree(read_urdf(path), floating_base=True, allow_nonphysical_inertia=True)
        model = eomc.compile(UrdfModel(path, floating_base=True, allow_nonphysical_inertia=True, limits=False),
                             "romeo_small", functions=FUNCTIONS, formulation="recursive",
                             cache_dir=tmp_path_factory.mktemp("cache"), progress=False)
    notes = [str(w.message) for w in caught if issubclass(w.category, EomcWarning)]
    ref = PinRef(path, [(j.name, j.type) for j in tree.joints], floating=True, locked=tree.locked)
    return model, ref, notes, path


def test_opt_in_warns_once_per_link_naming_it(romeo):
    _, _, notes, path = romeo
    kept = [n for n in notes if "allow_nonphysical_inertia" in n]
    for link, line in NEGATIVE.items():
        mine = [n for n in kept if f"{path}:{line}: link '{link}'" in n]
        assert len(mine) == 2, (link, kept)      # one from build_tree above, one from the compile
    assert len(kept) == 2 * len(NEGATIVE) and all("\n" not in n for n in kept)


def _pivots_positive(ref, q):
    """ABA's articulated-body pivots D_i = S_i^T I^A_i S_i at q are all positive: the joint
    space inertia (CRBA) is then positive definite too, and ABA's divisions are sound."""
    M = pin.crba(ref.model, ref.data, ref.q(q))
    M = np.triu(M) + np.triu(M, 1).T
    return bool(np.all(np.linalg.eigvalsh(M) > 1e-9 * np.max(np.abs(M))))


def test_agrees_with_pinocchio(romeo):
    model, ref, _, _ = romeo
    rng = np.random.default_rng(19)
    worst, used = 0.0, 0
    for _ in range(40):
        q = rng.uniform(-np.pi, np.pi, model.nq)
        q[:3], q[3:6] = rng.normal(size=3), rng.uniform(-1.2, 1.2, 3)
        if not _pivots_positive(ref, q):
            continue
        v, tau, a = rng.normal(size=model.nu), rng.normal(size=model.ninput), rng.normal(size=model.nu)
        x = np.concatenate([q, v])
        worst = max(worst,
                    relative_error(model.rhs(0.0, x, r=tau)[model.nq:], ref.aba(q, v, tau)),
                    relative_error(model.inverse_dynamics(0.0, x, a, r=np.zeros(model.ninput)),
                                   ref.rnea(q, v, a)),
                    relative_error(model.mass_matrix(0.0, x), ref.mass_matrix(q)))
        used += 1
        if used == 5:
            break
    assert used == 5, f"only {used} of 40 random states had a positive definite mass matrix"
    assert worst < 1e-12, f"{worst:.3g}"


def test_cli_flag_reaches_the_urdf_reader(tmp_path, monkeypatch, capsys):
    """`eomc build --allow-nonphysical-inertia` hands the driver a UrdfModel with the option
    (the build itself is the one above)."""
    import eomc.compiler.driver as driver
    seen = []

    def stand_in(source, *args, **kwargs):
        seen.append(source)
        raise ModelFileError("stop here", "x.urdf", 1)
    monkeypatch.setattr(driver, "compile", stand_in)
    urdf = tmp_path / "r.urdf"
    urdf.write_text("<robot name='r'><link name='a'/></robot>")
    main(["build", str(urdf), "-o", str(tmp_path / "out"), "--allow-nonphysical-inertia", "-q"])
    assert len(seen) == 1 and isinstance(seen[0], UrdfModel), seen
    assert seen[0].allow_nonphysical_inertia and not seen[0].floating_base
