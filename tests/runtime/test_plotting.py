"""Plots a person can read: no panel above its curve cap, no legend over the data, kinds apart."""
import numpy as np
import pytest

from eomc.runtime.plotting import MAX_CURVES, MAX_PANELS, panels, plot_result
from eomc.runtime.result import SimulationResult

matplotlib = pytest.importorskip("matplotlib")
matplotlib.use("Agg")


class _Model:
    nu = 18


def _go2_like(extra=0):
    """A Go2-sized run: 18 coordinates, 18 speeds, `extra` activations, 36 outputs (an energy,
    two frames' positions and velocities, one frame's rotation and Jacobian entries)."""
    t = np.linspace(0.0, 1.0, 101)
    names = [f"q{k}" for k in range(18)] + [f"u{k}" for k in range(18)] + [f"a{k}" for k in range(extra)]
    rng = np.random.default_rng(1)
    x = np.sin(np.outer(t, rng.uniform(1, 6, len(names))) + rng.uniform(0, 3, len(names)))
    outputs = {"energy": -19 + 0.01 * t, "tip_x": 2 * np.cos(t), "tip_y": 2 * np.sin(t)}
    for frame in ("FL_foot", "com"):
        for part in "pv":
            for a in "xyz":
                outputs[f"{frame}.{part}.{a}"] = rng.uniform(-1, 1) * t
    outputs.update({f"FL_foot.R[{i}][{j}]": t * 0 + (i == j) for i in range(3) for j in range(3)})
    outputs.update({f"FL_foot.J[{i}][{j}]": t * 0.1 for i in range(6) for j in range(18)})
    res = SimulationResult(t=t, x=x, state_names=tuple(names), stats={}, model_name="go2", method="radau",
                           outputs=outputs, nq=18)
    res.model = _Model()
    return res


def _overlaps(a, b):
    return a.x0 < b.x1 and b.x0 < a.x1 and a.y0 < b.y1 and b.y0 < a.y1


def test_many_states_make_capped_panels_with_legends_outside(tmp_path):
    res = _go2_like(extra=3)
    chosen = panels(res)
    labels = [label for label, _ in chosen]
    assert all(len(group) <= MAX_CURVES for _, group in chosen)
    drawn = {n for _, group in chosen for n in group}
    assert not any(".R[" in n or ".J[" in n for n in drawn), "rotations/Jacobians plotted"
    assert {f"q{k}" for k in range(18)} | {f"u{k}" for k in range(18)} <= drawn
    # activations are extra states, not speeds; the energy is not on the tips' axis
    assert any(label.startswith("extra states") and "a0" in group for label, group in chosen)
    assert not any("energy" in group and "tip_x" in group for _, group in chosen)
    assert "FL_foot position" in labels and "com velocity" in labels
    figures = plot_result(res)
    assert isinstance(figures, list) and len(figures) == -(-len(chosen) // MAX_PANELS)
    for fig in figures:
        fig.canvas.draw()
        renderer = fig.canvas.get_renderer()
        axes = fig.axes
        assert len(axes) <= MAX_PANELS
        for ax in axes:
            assert len(ax.lines) <= MAX_CURVES
            colors = [tuple(line.get_color()) if not isinstance(line.get_color(), str) else line.get_color()
                      for line in ax.lines]
            assert len(set(colors)) == len(colors), "a colour repeats within a panel"
            legend = ax.get_legend().get_window_extent(renderer)
            for other in axes:   # the legend covers no axes' data area, its own or another's
                assert not _overlaps(legend, other.get_window_extent(renderer)), (ax.get_ylabel(), other.get_ylabel())
    written = plot_result(res, tmp_path / "go2.png")
    assert [p.name for p in written][:2] == ["go2.png", "go2-2.png"] and all(p.is_file() for p in written)


def test_chosen_names_and_a_bad_name(tmp_path):
    res = _go2_like()
    assert panels(res, ["q0", "u3", "energy"]) == [("coordinates", ["q0"]), ("speeds", ["u3"]),
                                                   ("outputs", ["energy"])]
    out = res.plot(tmp_path / "one.png", names=["q0", "q1"])
    assert out.is_file()
    with pytest.raises(ValueError, match="cannot plot q99"):
        res.plot(tmp_path / "bad.png", names=["q99"])


def test_a_split_kind_shares_its_curves_evenly():
    """9 coordinates (gymnasium's walker2d) made panels of 8 and 1; now 5 and 4.  18 (Go2): 6, 6, 6."""
    from eomc.runtime.plotting import _chunks
    names = [f"q{k}" for k in range(9)]
    assert [(label, len(part)) for label, part in _chunks("coordinates", names)] == [
        ("coordinates (1/2)", 5), ("coordinates (2/2)", 4)]
    assert [len(part) for _, part in _chunks("speeds", [f"u{k}" for k in range(18)])] == [6, 6, 6]
    assert _chunks("speeds", names[:8]) == [("speeds", names[:8])]
    assert sum((part for _, part in _chunks("q", names)), []) == names


def test_a_conserved_energy_is_drawn_as_its_change_without_an_offset():
    """The quick start's energy panel (a double pendulum's energy, -19.20981617 drifting by 1e-5)
    read "1e-5-1.92098e1" over its axis: matplotlib's offset notation.  A panel whose curves move
    by less than 1e-4 of their size plots each curve's change from its start, the start in the
    legend, and no axis of any panel carries an offset."""
    t = np.linspace(0.0, 10.0, 201)
    energy = -19.20981617 + 1e-5 * np.sin(t)
    res = SimulationResult(t=t, x=np.column_stack([np.sin(t), np.cos(t)]), state_names=("q1", "u1"), stats={},
                           model_name="double_pendulum", method="dop853",
                           outputs={"energy": energy, "tip_x": 1000.0 + 0.5 * np.sin(t)}, nq=1)
    fig = plot_result(res)
    fig.canvas.draw()
    by_curve = {line.get_label(): (ax, line) for ax in fig.axes for line in ax.lines}
    ax_energy, line = by_curve["energy (start -19.20981617)"]
    assert ax_energy.get_ylabel() == "outputs (1/2): change from the start"     # tip_x: panel 2/2
    np.testing.assert_allclose(line.get_ydata(), energy - energy[0])
    ax_tip, tip = by_curve["tip_x"]        # moves by 1e-3 of its size: drawn as it is
    np.testing.assert_array_equal(tip.get_ydata(), res["tip_x"])
    for ax in fig.axes:
        offset = ax.yaxis.get_offset_text().get_text()
        assert "19" not in offset and "1000" not in offset and "+" not in offset, offset
    assert "times" in ax_energy.yaxis.get_offset_text().get_text() and "10^{-5}" in \
        ax_energy.yaxis.get_offset_text().get_text().replace("\u2212", "-")      # a factor, x10^-5
