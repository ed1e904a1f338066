"""A hand-written C model implementing eomc_model.h: a damped, driven oscillator.

Build, cache and loader tests run against this fixed C text, so they test the
build machinery and the runtime independently of the code generator.

    q' = u,   m u' = F - c u - k q        x = [q, u], p = [m, c, k], r = [F]

m = 0 makes the "mass matrix" singular: rhs reports EOMC_SINGULAR_MASS_MATRIX.
Outputs: energy = m u^2 / 2 + k q^2 / 2.  No constraints (pointer NULL).
"""
from dataclasses import dataclass, field

import numpy as np

__all__ = ["Generated", "oscillator", "oscillator_rhs", "HEADER", "SOURCE", "CDEF"]


@dataclass(frozen=True)
class Generated:
    """Stand-in with GeneratedModel's fields (eomc.compiler.emit.generated)."""
    name: str
    c_source: str
    header: str
    cdef: str
    metadata: dict = field(default_factory=dict)


SOURCE = """\
#include "{n}.h"

static const char *const {n}_state_names[] = {{"q", "u"}};
static const char *const {n}_param_names[] = {{"m", "c", "k"}};
static const double {n}_param_defaults[] = {{2.0, 0.5, 8.0}};
static const char *const {n}_input_names[] = {{"F"}};
static const char *const {n}_output_names[] = {{"energy"}};

int {n}_forcing(double t, const double *x, const double *p, const double *r, double *out, double *work)
{{
    (void)t; (void)work;
    out[0] = r[0] - p[1] * x[1] - p[2] * x[0];
    return EOMC_OK;
}}

int {n}_mass_matrix(double t, const double *x, const double *p, const double *r, double *out, double *work)
{{
    (void)t; (void)x; (void)r; (void)work;
    out[0] = p[0];
    return EOMC_OK;
}}

int {n}_rhs(double t, const double *x, const double *p, const double *r, double *xdot, double *work)
{{
    int s = {n}_forcing(t, x, p, r, work, work + 1);
    if (s != EOMC_OK) return s;
    if (p[0] == 0.0) return EOMC_SINGULAR_MASS_MATRIX;
    xdot[0] = x[1];
    xdot[1] = work[0] / p[0];
    return EOMC_OK;
}}

int {n}_jac_x(double t, const double *x, const double *p, const double *r, double *out, double *work)
{{
    (void)t; (void)x; (void)r; (void)work;
    if (p[0] == 0.0) return EOMC_SINGULAR_MASS_MATRIX;
    out[0] = 0.0; out[1] = 1.0;
    out[2] = -p[2] / p[0]; out[3] = -p[1] / p[0];
    return EOMC_OK;
}}

int {n}_jac_r(double t, const double *x, const double *p, const double *r, double *out, double *work)
{{
    (void)t; (void)x; (void)r; (void)work;
    if (p[0] == 0.0) return EOMC_SINGULAR_MASS_MATRIX;
    out[0] = 0.0; out[1] = 1.0 / p[0];
    return EOMC_OK;
}}

int {n}_outputs(double t, const double *x, const double *p, const double *r, double *out, double *work)
{{
    (void)t; (void)r; (void)work;
    out[0] = 0.5 * p[0] * x[1] * x[1] + 0.5 * p[2] * x[0] * x[0];
    return EOMC_OK;
}}

int {n}_inverse_dynamics(double t, const double *x, const double *udot, const double *p, const double *r, double *tau, double *work)
{{
    int s = {n}_forcing(t, x, p, r, work, work + 1);
    if (s != EOMC_OK) return s;
    tau[0] = p[0] * udot[0] - work[0];
    return EOMC_OK;
}}

int {n}_linearize(double t, const double *x, const double *p, const double *r, double *A, double *B, double *work)
{{
    int s = {n}_jac_x(t, x, p, r, A, work);
    if (s != EOMC_OK) return s;
    return {n}_jac_r(t, x, p, r, B, work);
}}

static const eomc_model {n}_model_struct = {{
    EOMC_ABI_VERSION, "{n}",
    1, 1, 2,
    3, 1,
    1,
    0, 0,
    2,
    {n}_state_names, {n}_param_names, {n}_param_defaults, {n}_input_names, {n}_output_names,
    {n}_rhs, {n}_jac_x, {n}_jac_r, {n}_mass_matrix, {n}_forcing, {n}_outputs, NULL, NULL
}};

const eomc_model *{n}_model(void) {{ return &{n}_model_struct; }}
"""

CDEF = """\
const eomc_model *{n}_model(void);
int {n}_rhs(double t, const double *x, const double *p, const double *r, double *xdot, double *work);
int {n}_jac_x(double t, const double *x, const double *p, const double *r, double *out, double *work);
int {n}_jac_r(double t, const double *x, const double *p, const double *r, double *out, double *work);
int {n}_mass_matrix(double t, const double *x, const double *p, const double *r, double *out, double *work);
int {n}_forcing(double t, const double *x, const double *p, const double *r, double *out, double *work);
int {n}_outputs(double t, const double *x, const double *p, const double *r, double *out, double *work);
int {n}_inverse_dynamics(double t, const double *x, const double *udot, const double *p, const double *r, double *tau, double *work);
int {n}_linearize(double t, const double *x, const double *p, const double *r, double *A, double *B, double *work);
"""

HEADER = "#ifndef {N}_H\n#define {N}_H\n#include \"eomc_model.h\"\n" + CDEF + "#endif\n"

FUNCTIONS = ["rhs", "jac_x", "jac_r", "mass_matrix", "forcing", "outputs", "inverse_dynamics", "linearize"]


def oscillator(name="osc", c_source=None):
    """The oscillator as a GeneratedModel-like object named ``name``."""
    fmt = dict(n=name, N=name.upper())
    metadata = {
        "name": name, "abi_version": 1, "eomc_version": "0.1.0",
        "nq": 1, "nu": 1, "nx": 2, "nparam": 3, "ninput": 1, "noutput": 1,
        "nhol": 0, "nvel": 0, "work_size": 2,
        "state_names": ["q", "u"], "param_names": ["m", "c", "k"],
        "param_defaults": [2.0, 0.5, 8.0], "input_names": ["F"], "output_names": ["energy"],
        "functions": list(FUNCTIONS),
        "op_counts": {f: {"adds": 1, "muls": 1, "divs": 0, "calls": 0} for f in FUNCTIONS},
        "mass_matrix_sparsity": ["x"],
    }
    return Generated(name, c_source if c_source is not None else SOURCE.format(**fmt),
                     HEADER.format(**fmt), CDEF.format(**fmt), metadata)


def oscillator_rhs(t, x, p=(2.0, 0.5, 8.0), r=(0.0,)):
    """The same right-hand side in numpy: the tests' independent oracle."""
    m, c, k = p
    return np.array([x[1], (r[0] - c * x[1] - k * x[0]) / m])
