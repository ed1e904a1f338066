"""A method made wrong on purpose, for the tests of `eomc check`'s verdicts: stability.simulate
patched so that DOP853 at rtol 1e-8 (the method under check) returns its result off by ``offset``
in q1 from ``t_from`` on, while every other run (the references) stays true."""
from eomc.runtime import stability


def spoil_dop853(monkeypatch, offset, t_from=1.0):
    real = stability.simulate

    def wrong(model, x0, t_span, **kw):
        res = real(model, x0, t_span, **kw)
        if kw.get("method") == "dop853" and kw.get("rtol") == 1e-8:
            res.x[res.t >= t_from, 0] += offset
        return res
    monkeypatch.setattr(stability, "simulate", wrong)
