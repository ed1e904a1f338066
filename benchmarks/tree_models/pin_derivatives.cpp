// Pinocchio's analytic derivatives (Carpentier & Mansard 2018; second order: Singh, Russell &
// Wensing 2022) of any model written as text by benchmarks/bench_derivatives.py's pin_text
// (pinocchio.Model -> one line per joint: name, parent, type, axis, placement, inertia; first
// line: gravity), assembled at start-up with addJoint/appendBodyToJoint, header-only from the
// pin / cmeel wheels (whose Python bindings do not export the second-order RNEA derivatives).
// Called from the C harnesses of bench_derivatives.py and bench_second_order.py: the calls compute
// into Pinocchio's Data (the harness times them), pin_copy_* lay the results out for the agreement
// checks.
#include <pinocchio/multibody.hpp>
#include <pinocchio/algorithm/aba-derivatives.hpp>
#include <pinocchio/algorithm/rnea-derivatives.hpp>
#include <pinocchio/algorithm/rnea-second-order-derivatives.hpp>
#include <Eigen/Core>
#include <cstdio>
#include <cstdlib>
#include <string>

static pinocchio::Model *model;
static pinocchio::Data *data;

extern "C" int pin_setup(const char *path) {
  using namespace pinocchio;
  FILE *f = fopen(path, "r");
  if (!f) { fprintf(stderr, "no %s\n", path); exit(1); }
  model = new Model();
  double g[3];
  if (fscanf(f, "gravity %lf %lf %lf", &g[0], &g[1], &g[2]) != 3) exit(4);
  model->gravity = Motion(Eigen::Vector3d(g[0], g[1], g[2]), Eigen::Vector3d::Zero());
  int parent; char type[64], name[256];
  double ax[3], R[9], t[3], mass, lever[3], I[9];
  while (fscanf(f, "%255s %d %63s", name, &parent, type) == 3) {
    for (double &v : ax) if (fscanf(f, "%lf", &v) != 1) exit(3);
    for (double &v : R) if (fscanf(f, "%lf", &v) != 1) exit(3);
    for (double &v : t) if (fscanf(f, "%lf", &v) != 1) exit(3);
    if (fscanf(f, "%lf", &mass) != 1) exit(3);
    for (double &v : lever) if (fscanf(f, "%lf", &v) != 1) exit(3);
    for (double &v : I) if (fscanf(f, "%lf", &v) != 1) exit(3);
    Eigen::Matrix3d Rm; Rm << R[0], R[1], R[2], R[3], R[4], R[5], R[6], R[7], R[8];
    SE3 P(Rm, Eigen::Vector3d(t[0], t[1], t[2]));
    Eigen::Vector3d axis(ax[0], ax[1], ax[2]);
    std::string ty(type);
    JointModel jm;
    if (ty == "JointModelRX") jm = JointModelRX();
    else if (ty == "JointModelRY") jm = JointModelRY();
    else if (ty == "JointModelRZ") jm = JointModelRZ();
    else if (ty == "JointModelPX") jm = JointModelPX();
    else if (ty == "JointModelPY") jm = JointModelPY();
    else if (ty == "JointModelPZ") jm = JointModelPZ();
    else if (ty == "JointModelRUBX") jm = JointModelRUBX();
    else if (ty == "JointModelRUBY") jm = JointModelRUBY();
    else if (ty == "JointModelRUBZ") jm = JointModelRUBZ();
    else if (ty == "JointModelRevoluteUnaligned") jm = JointModelRevoluteUnaligned(axis);
    else if (ty == "JointModelPrismaticUnaligned") jm = JointModelPrismaticUnaligned(axis);
    else if (ty == "JointModelFreeFlyer") jm = JointModelFreeFlyer();
    else { fprintf(stderr, "joint type %s\n", type); exit(2); }
    JointIndex id = model->addJoint((JointIndex)parent, jm, P, name);
    Eigen::Matrix3d Im; Im << I[0], I[1], I[2], I[3], I[4], I[5], I[6], I[7], I[8];
    model->appendBodyToJoint(id, Inertia(mass, Eigen::Vector3d(lever[0], lever[1], lever[2]), Im), SE3::Identity());
  }
  fclose(f);
  data = new Data(*model);
  return model->nq * 1000 + model->nv;
}

extern "C" void pin_aba_derivatives(const double *q, const double *v, const double *tau) {
  Eigen::Map<const Eigen::VectorXd> Q(q, model->nq), V(v, model->nv), T(tau, model->nv);
  pinocchio::computeABADerivatives(*model, *data, Q, V, T);
}

extern "C" void pin_rnea_derivatives(const double *q, const double *v, const double *a) {
  Eigen::Map<const Eigen::VectorXd> Q(q, model->nq), V(v, model->nv), A(a, model->nv);
  pinocchio::computeRNEADerivatives(*model, *data, Q, V, A);
}

// nv x nv blocks, row-major: d/dq (Lie tangent), d/dv.  ABA: Pinocchio fills only the upper
// triangle of Minv, but ddq_dq and ddq_dv are whole.
extern "C" void pin_copy_aba(double *dq, double *dv) {
  const int nv = model->nv;
  for (int i = 0; i < nv; i++) for (int j = 0; j < nv; j++) {
    dq[i * nv + j] = data->ddq_dq(i, j);
    dv[i * nv + j] = data->ddq_dv(i, j);
  }
}

extern "C" void pin_copy_rnea(double *dq, double *dv) {
  const int nv = model->nv;
  for (int i = 0; i < nv; i++) for (int j = 0; j < nv; j++) {
    dq[i * nv + j] = data->dtau_dq(i, j);
    dv[i * nv + j] = data->dtau_dv(i, j);
  }
}

extern "C" void pin_rnea_second_order(const double *q, const double *v, const double *a) {
  Eigen::Map<const Eigen::VectorXd> Q(q, model->nq), V(v, model->nv), A(a, model->nv);
  pinocchio::ComputeRNEASecondOrderDerivatives(*model, *data, Q, V, A);
}

// nv x nv x nv tensors, [i][j][k] = entry (i, j, k) at i * nv * nv + j * nv + k: d2 tau_i / dq_j dq_k,
// d2 tau_i / dv_j dv_k, d2 tau_i / dq_j dv_k (Pinocchio's d2tau_dqdv: q along the columns, v along
// the pages, as measured against eomc's hess_id; its header's comment says the reverse) and
// dM_ij / dq_k (d2tau_dadq), all along Pinocchio's Lie tangent for q.
extern "C" void pin_copy_rnea_second_order(double *qq, double *vv, double *qv, double *aq) {
  const int nv = model->nv;
  for (int i = 0; i < nv; i++) for (int j = 0; j < nv; j++) for (int k = 0; k < nv; k++) {
    const int at = (i * nv + j) * nv + k;
    qq[at] = data->d2tau_dqdq(i, j, k);
    vv[at] = data->d2tau_dvdv(i, j, k);
    qv[at] = data->d2tau_dqdv(i, j, k);
    aq[at] = data->d2tau_dadq(i, j, k);
  }
}
