"""NAME_energy (compiler/emit/generate.energy_program): the output named "energy" alone, in the
default set of a model that has one (rollout's per-step energy watch reads it instead of the whole
outputs call: eomc_options.watch_fn).  Oracle: the same library's NAME_outputs -- the value must
be its energy bit for bit (the watch's verdict is simulate's, which reads the outputs).  A model
without an energy output gets no such function (its C stays as it was: benchmarks/c_identity.py).
The contact tree's energy (gymnasium-style MJCF, compiler/tree/contacts.py) is checked the same
way in tests/runtime/test_rollout.py::test_implicitfast_rows_get_simulates_energy_verdict."""
from pathlib import Path

import numpy as np
from eomc.compiler.driver import compile as compile_model, generate

EXAMPLES = Path(__file__).resolve().parents[3] / "examples"
PENDULUM, CART = EXAMPLES / "double_pendulum.py", EXAMPLES / "cart_pole_system.py"
STRICT = "-O2 -std=c99 -fPIC -Wall -Wextra -Werror"


def energy_of(model, t, x, p):
    """NAME_energy's out[0] at (t, x, p), through the model's own cffi library."""
    ffi = model.ffi
    out = ffi.new("double[1]")
    work = ffi.new("double[]", max(1, model.c_model.work_size))
    status = getattr(model.model_lib, f"{model.name}_energy")(
        t, ffi.new("double[]", list(x)), ffi.new("double[]", list(p)), ffi.NULL, out, work)
    assert status == 0
    return out[0]


def test_energy_function_equals_the_outputs_energy_bit_for_bit(tmp_path):
    model = compile_model(str(PENDULUM), "en_kane", cache_dir=tmp_path, cflags=STRICT, progress=False)
    assert "energy" in model.metadata["functions"] and model.noutput > 1
    rng = np.random.default_rng(5)
    P = np.asarray(model.param_defaults, dtype=float)
    for k in range(20):
        x = rng.uniform(-3.0, 3.0, model.nx)
        p = P * rng.uniform(0.5, 2.0, P.size)
        want = model.outputs(0.1 * k, x, p=p)["energy"]
        assert energy_of(model, 0.1 * k, x, p) == want


def test_only_models_with_an_energy_output_get_it():
    pendulum = generate(str(PENDULUM), "en_pend")[1]
    assert "int en_pend_energy(double t," in pendulum.header
    assert "en_pend_energy" in pendulum.cdef
    cart = generate(str(CART), "en_cart")[1]          # outputs, none named energy
    assert cart.metadata["noutput"] > 0 and "energy" not in cart.metadata["output_names"]
    assert "energy" not in cart.metadata["functions"] and "_energy(" not in cart.c_source
    # asked alone it brings the outputs it is one of; asked without, neither is there
    alone = generate(str(PENDULUM), "en_alone", functions=("rhs", "energy"))[1]
    assert alone.metadata["functions"] == ["rhs", "outputs", "energy"]
    assert "energy" not in generate(str(PENDULUM), "en_none", functions=("rhs", "outputs"))[1].metadata["functions"]
