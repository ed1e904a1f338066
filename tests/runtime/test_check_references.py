"""`eomc check`'s two references run at once and stop where they part (runtime/check_references.py).

A chaotic double pendulum (examples/double_pendulum.py from (2.5, 2.5) rad): its references, DOP853
at rtol 1e-10 and 1e-11, part after ~5 s.  Before s31 they ran to t_final whatever happened (G1:
110 s and 106 s of a 305 s check, parting at t = 1.15 of 10)."""
from pathlib import Path

import numpy as np
import pytest

from eomc.runtime import check_references, stability
from helpers.spoiled_method import spoil_dop853
from eomc.runtime.stability import check_model, outcome

CHAOTIC = np.array([2.5, 2.5, 0.0, 0.0])
TOLS = [(1e-10, 1e-10), (1e-11, 1e-11)]      # stability.REF_TOLS at rtol 1e-8, atol 1e-10


@pytest.fixture(scope="module")
def double_pendulum(tmp_path_factory):
    import eomc
    example = Path(__file__).resolve().parents[2] / "examples" / "double_pendulum.py"
    return eomc.compile(str(example), cache_dir=tmp_path_factory.mktemp("dp"), progress=False)


def _refs(model, t_final, on_parting=True):
    t_eval = np.linspace(0.0, t_final, 201)
    return check_references._both(model, CHAOTIC, model.param_defaults, t_final, t_eval, "dop853", TOLS,
                                  1e-8, 1e-10, 10 ** 7, stability.AGREE, on_parting)


def test_the_references_stop_where_they_part_with_the_rows_of_a_whole_run(double_pendulum, monkeypatch):
    """Over 6000 s the pair parts within the first seconds: both runs are stopped (status 9,
    ``stopped``) long before t_final, and the rows they wrote are the bits of the same pair run to
    t_final unstopped, the same first row parting: the verdict does not depend on when a poll looked."""
    monkeypatch.setattr(check_references, "POLL_S", 0.0005)
    cut, whole = _refs(double_pendulum, 6000.0), _refs(double_pendulum, 6000.0, on_parting=False)
    assert whole.loose.status == whole.tight.status == 0 and whole.rows == 201
    assert cut.parted == whole.parted is not None and cut.failed is None
    for run in (cut.loose, cut.tight):
        assert run.status == 9 and run.stopped and run.t[-1] < 3000.0, (run.status, run.t[-1])
    assert cut.parted < cut.rows
    np.testing.assert_array_equal(cut.loose.x[:cut.rows], whole.loose.x[:cut.rows])
    np.testing.assert_array_equal(cut.tight.x[:cut.rows], whole.tight.x[:cut.rows])


def test_a_check_whose_references_part_early_says_up_to_when_it_judged(double_pendulum, monkeypatch):
    """60 s: the references part at t = 4.8 (row 16 of 201).  The check judges DOP853 up to there
    and says so, and why; the references stopped (they ran 10x less than t_final would take)."""
    seen, real = [], stability.run_references
    monkeypatch.setattr(stability, "run_references", lambda *a, **k: seen.append(real(*a, **k)) or seen[-1])
    checks = {c.name: c for c in check_model(double_pendulum, CHAOTIC, 60.0, methods=("dop853",))}
    ref, acc = checks["reference"], checks["dop853 accuracy"]
    horizon = float(ref.measured.split("until t=")[1].split(",")[0])
    assert 3.0 < horizon < 8.0 and seen[0].parted is not None
    assert ref.passed and "so both stopped there and nothing after it is judged" in ref.measured
    assert acc.passed and f"judged up to t={horizon:.4g}, where the references part" in acc.measured
    assert f"on [0, {horizon:.4g}] where the references agree" in acc.expected
    assert outcome(list(checks.values())) == "passed"
    summary = stability.format_checks(list(checks.values())).splitlines()[-1]    # not only in the lines above
    assert summary.endswith(f"checks passed; accuracy judged on [0, {horizon:.4g}] only, where the references "
                            f"part (the reference line says why)"), summary


def test_a_method_that_stops_still_fails_where_the_references_part_early(double_pendulum):
    """Judged on [0, 4.8] only, a method must still reach t_final: DOPRI5 out of steps at t = 5.7
    (500 steps) fails the check, though it stopped after the references parted."""
    checks = check_model(double_pendulum, CHAOTIC, 60.0, methods=("dopri5",), max_steps=500)
    acc = {c.name: c for c in checks}["dopri5 accuracy"]
    assert not acc.passed and not acc.inconclusive and not acc.stiff
    assert "maximum number of steps" in acc.measured
    assert outcome(checks) == "failed"


def test_a_method_off_by_orders_of_magnitude_before_the_parting_fails(double_pendulum, monkeypatch):
    """A run 1e-2 off in q1 from t = 1 s (inside [0, 4.8]: ~4e5 x its tolerance) fails, as it did
    with references run to t_final."""
    spoil_dop853(monkeypatch, 1e-2)
    checks = check_model(double_pendulum, CHAOTIC, 60.0, methods=("dop853",))
    acc = {c.name: c for c in checks}["dop853 accuracy"]
    assert not acc.passed and "missed by orders of magnitude" in acc.measured
    assert outcome(checks) == "failed"


def test_a_reference_out_of_steps_before_the_parting_leaves_the_check_inconclusive(double_pendulum):
    """Too few steps for the references to reach the parting (10 x --max-steps 20): inconclusive,
    never passed, and the line says where the reference stopped."""
    checks = check_model(double_pendulum, CHAOTIC, 60.0, methods=("dop853",), max_steps=20)
    ref = {c.name: c for c in checks}["reference"]
    assert ref.inconclusive and "maximum number of steps" in ref.measured
    assert outcome(checks) == "inconclusive"
