// Pinocchio's analytic ABA derivatives (computeABADerivatives: Carpentier & Mansard 2018) for the
// n-link pendulum on a cart (relative angles), called from the C harness of bench_tree_jacobian.py.
// The model is pin_aba.cpp's (included, so both benchmarks build the same system).
#include "pin_aba.cpp"

#include <pinocchio/algorithm/aba-derivatives.hpp>

// d xdot / dx in eomc's layout (row-major nx x nx, x = [q; v]): the kinematic rows
// [0 I] and the acceleration rows [ddq_dq ddq_dv].
extern "C" void pin_jac(const double *q, const double *v, const double *tau, double *out) {
  Eigen::Map<const Eigen::VectorXd> Q(q, g_nv), V(v, g_nv), T(tau, g_nv);
  pinocchio::computeABADerivatives(*model, *data, Q, V, T);
  const int nx = 2 * g_nv;
  for (int i = 0; i < g_nv; i++) {
    for (int j = 0; j < nx; j++) out[i * nx + j] = (j == g_nv + i) ? 1.0 : 0.0;
    for (int j = 0; j < g_nv; j++) {
      out[(g_nv + i) * nx + j] = data->ddq_dq(i, j);
      out[(g_nv + i) * nx + g_nv + j] = data->ddq_dv(i, j);
    }
  }
}
