// The C API over the C++ library: exceptions stop here and become status codes
// with a thread-local message; the query paths reuse the workspace's buffers.
#include "gipdyn/gipdyn.h"

#include <algorithm>
#include <cmath>
#include <memory>
#include <new>
#include <string>
#include <vector>

#include "gipdyn/error.hpp"
#include "gipdyn/estimators/estimator_file.hpp"
#include "gipdyn/estimators/physics.hpp"
#include "gipdyn/estimators/uncertainty.hpp"
#include "gipdyn/model/inverse_dynamics_model.hpp"
#include "gipdyn/sensing/contact_detection.hpp"
#include "gipdyn/version.hpp"

struct gipdyn_model {
  std::unique_ptr<gipdyn::Estimator> estimator;
  int joints = 0;
  bool physics = false, allocation_free = false;
};

struct gipdyn_workspace {
  const gipdyn_model* model = nullptr;
  std::unique_ptr<gipdyn::QueryWorkspace> prediction;
  // Sized once, reused by every query: x 3n, tau, gravity and rhs n, inertia n x n.
  std::vector<double> x, tau, gravity, rhs, inertia;
  explicit gipdyn_workspace(const gipdyn_model* m)
      : model(m), prediction(m->estimator->make_query_workspace()), x(3 * static_cast<size_t>(m->joints)),
        tau(static_cast<size_t>(m->joints)), gravity(tau.size()), rhs(tau.size()), inertia(tau.size() * tau.size()) {}
};

struct gipdyn_contact_detector {
  const gipdyn_model* model = nullptr;
  gipdyn::ContactStream stream;
  gipdyn_contact_detector(const gipdyn_model* m, const gipdyn::ContactOptions& o, const Eigen::VectorXd& sigma)
      : model(m), stream(*m->estimator, o, sigma) {}
};

namespace {

// The message buffer is reserved once per thread so that failures in the
// control loop do not allocate either (messages longer than this are cut).
constexpr size_t kMessageCapacity = 512;
thread_local std::string t_last_error = [] {
  std::string s;
  s.reserve(kMessageCapacity);
  return s;
}();

gipdyn_status fail(gipdyn_status status, const char* message) {
  t_last_error.assign(message, std::min(std::char_traits<char>::length(message), kMessageCapacity - 1));
  return status;
}

gipdyn_status ok() {
  t_last_error.clear();
  return GIPDYN_OK;
}

bool all_finite(const double* v, int n) {
  for (int i = 0; i < n; ++i)
    if (!std::isfinite(v[i])) return false;
  return true;
}

gipdyn_status check_query(const gipdyn_workspace* ws, int n, const void* out) {
  if (!ws || !out) return fail(GIPDYN_ERROR_NULL_ARGUMENT, "a workspace or output pointer is NULL");
  if (n != ws->model->joints)
    return fail(GIPDYN_ERROR_SIZE, "n does not match the model's joint count (gipdyn_model_num_joints)");
  return GIPDYN_OK;
}

gipdyn_status check_physics(const gipdyn_workspace* ws) {
  if (!ws->model->physics)
    return fail(GIPDYN_ERROR_UNSUPPORTED,
                ("this model's torque is not affine in the accelerations: gravity and inertia need a model of one "
                 "of " + gipdyn::joined(gipdyn::physics_estimator_names())).c_str());
  return GIPDYN_OK;
}

// tau = f(x) from the workspace's x; checks that the result is finite.
gipdyn_status predict_into(gipdyn_workspace* ws, double* tau) {
  ws->prediction->predict(ws->x.data(), tau);
  if (!all_finite(tau, ws->model->joints))
    return fail(GIPDYN_ERROR_NOT_FINITE, "the prediction is not finite: the state is far outside the training data");
  return GIPDYN_OK;
}

// Fills the workspace's x with (q, 0, 0) and its gravity buffer with f(q, 0, 0).
gipdyn_status gravity_into_workspace(gipdyn_workspace* ws, const double* q) {
  const int n = ws->model->joints;
  if (!all_finite(q, n)) return fail(GIPDYN_ERROR_NOT_FINITE, "q holds NaN or Inf");
  for (int i = 0; i < n; ++i) {
    ws->x[static_cast<size_t>(i)] = q[i];
    ws->x[static_cast<size_t>(n + i)] = 0.0;
    ws->x[static_cast<size_t>(2 * n + i)] = 0.0;
  }
  return predict_into(ws, ws->gravity.data());
}

}  // namespace

extern "C" {

const char* gipdyn_last_error(void) { return t_last_error.c_str(); }

const char* gipdyn_version(void) { return gipdyn::version(); }

const char* gipdyn_build_info(void) {
  static const std::string summary = gipdyn::build_summary();  // thread-safe initialisation
  return summary.c_str();
}

const char* gipdyn_status_string(gipdyn_status status) {
  switch (status) {
    case GIPDYN_OK: return "ok";
    case GIPDYN_ERROR_NULL_ARGUMENT: return "null argument";
    case GIPDYN_ERROR_FILE: return "model file error";
    case GIPDYN_ERROR_SIZE: return "wrong size";
    case GIPDYN_ERROR_UNSUPPORTED: return "not supported by this model";
    case GIPDYN_ERROR_NOT_FINITE: return "not finite";
    case GIPDYN_ERROR_OUT_OF_MEMORY: return "out of memory";
    case GIPDYN_ERROR_INTERNAL: return "internal error";
    case GIPDYN_ERROR_SINGULAR: return "singular inertia matrix";
    case GIPDYN_ERROR_INVALID_OPTION: return "invalid option";
  }
  return "unknown status";
}

gipdyn_status gipdyn_model_load(const char* path, gipdyn_model** model) {
  if (!model) return fail(GIPDYN_ERROR_NULL_ARGUMENT, "model (the output pointer) is NULL");
  *model = nullptr;
  if (!path) return fail(GIPDYN_ERROR_NULL_ARGUMENT, "path is NULL");
  try {
    auto m = std::make_unique<gipdyn_model>();
    m->estimator = gipdyn::load_estimator(path);
    m->joints = m->estimator->joints().size();
    m->physics = m->estimator->gives_rigid_body_terms();
    m->allocation_free = m->estimator->make_query_workspace()->allocation_free();
    *model = m.release();
    return ok();
  } catch (const gipdyn::Error& e) {
    return fail(GIPDYN_ERROR_FILE, e.what());
  } catch (const std::bad_alloc&) {
    return fail(GIPDYN_ERROR_OUT_OF_MEMORY, "out of memory while loading the model");
  } catch (const std::exception& e) {
    return fail(GIPDYN_ERROR_INTERNAL, e.what());
  }
}

void gipdyn_model_free(gipdyn_model* model) { delete model; }

int gipdyn_model_num_joints(const gipdyn_model* model) { return model ? model->joints : -1; }

int gipdyn_model_has_physics(const gipdyn_model* model) { return model && model->physics ? 1 : 0; }

int gipdyn_model_allocation_free(const gipdyn_model* model) { return model && model->allocation_free ? 1 : 0; }

gipdyn_status gipdyn_workspace_create(const gipdyn_model* model, gipdyn_workspace** workspace) {
  if (!workspace) return fail(GIPDYN_ERROR_NULL_ARGUMENT, "workspace (the output pointer) is NULL");
  *workspace = nullptr;
  if (!model) return fail(GIPDYN_ERROR_NULL_ARGUMENT, "model is NULL");
  try {
    *workspace = new gipdyn_workspace(model);
    return ok();
  } catch (const std::bad_alloc&) {
    return fail(GIPDYN_ERROR_OUT_OF_MEMORY, "out of memory while creating the workspace");
  } catch (const std::exception& e) {
    return fail(GIPDYN_ERROR_INTERNAL, e.what());
  }
}

void gipdyn_workspace_free(gipdyn_workspace* workspace) { delete workspace; }

gipdyn_status gipdyn_predict(gipdyn_workspace* ws, const double* q, const double* qd, const double* qdd, int n,
                             double* tau) {
  if (const gipdyn_status s = check_query(ws, n, tau); s != GIPDYN_OK) return s;
  if (!q || !qd || !qdd) return fail(GIPDYN_ERROR_NULL_ARGUMENT, "q, qd or qdd is NULL");
  if (!all_finite(q, n) || !all_finite(qd, n) || !all_finite(qdd, n))
    return fail(GIPDYN_ERROR_NOT_FINITE, "q, qd or qdd holds NaN or Inf");
  for (int i = 0; i < n; ++i) {
    ws->x[static_cast<size_t>(i)] = q[i];
    ws->x[static_cast<size_t>(n + i)] = qd[i];
    ws->x[static_cast<size_t>(2 * n + i)] = qdd[i];
  }
  if (const gipdyn_status s = predict_into(ws, tau); s != GIPDYN_OK) return s;
  return ok();
}

gipdyn_status gipdyn_gravity(gipdyn_workspace* ws, const double* q, int n, double* g) {
  if (const gipdyn_status s = check_query(ws, n, g); s != GIPDYN_OK) return s;
  if (!q) return fail(GIPDYN_ERROR_NULL_ARGUMENT, "q is NULL");
  if (const gipdyn_status s = check_physics(ws); s != GIPDYN_OK) return s;
  if (const gipdyn_status s = gravity_into_workspace(ws, q); s != GIPDYN_OK) return s;
  for (int i = 0; i < n; ++i) g[i] = ws->gravity[static_cast<size_t>(i)];
  return ok();
}

namespace {

// The rows as the joints' models learn them (what forward dynamics inverts), or their symmetric part; with qd,
// also the bias f(q, qd, 0) into the workspace's tau.
gipdyn_status inertia_into(gipdyn_workspace* ws, const double* q, const double* qd, int n, double* M,
                           bool symmetric) {
  if (const gipdyn_status s = check_query(ws, n, M); s != GIPDYN_OK) return s;
  if (!q) return fail(GIPDYN_ERROR_NULL_ARGUMENT, "q is NULL");
  if (const gipdyn_status s = check_physics(ws); s != GIPDYN_OK) return s;
  if (!all_finite(q, n)) return fail(GIPDYN_ERROR_NOT_FINITE, "q holds NaN or Inf");
  ws->prediction->rigid_body_terms(q, qd, ws->gravity.data(), M, qd ? ws->tau.data() : nullptr);
  if (!all_finite(ws->gravity.data(), n) || !all_finite(M, n * n) || (qd && !all_finite(ws->tau.data(), n)))
    return fail(GIPDYN_ERROR_NOT_FINITE, "the prediction is not finite: the state is far outside the training data");
  if (symmetric)
    for (int i = 0; i < n; ++i)
      for (int j = i + 1; j < n; ++j) M[i * n + j] = M[j * n + i] = 0.5 * (M[i * n + j] + M[j * n + i]);
  return ok();
}

}  // namespace

gipdyn_status gipdyn_inertia(gipdyn_workspace* ws, const double* q, int n, double* M) {
  return inertia_into(ws, q, nullptr, n, M, true);
}

gipdyn_status gipdyn_forward_dynamics(gipdyn_workspace* ws, const double* q, const double* qd, const double* tau,
                                      int n, double* qdd) {
  if (const gipdyn_status s = check_query(ws, n, qdd); s != GIPDYN_OK) return s;
  if (!q || !qd || !tau) return fail(GIPDYN_ERROR_NULL_ARGUMENT, "q, qd or tau is NULL");
  if (!all_finite(qd, n) || !all_finite(tau, n)) return fail(GIPDYN_ERROR_NOT_FINITE, "qd or tau holds NaN or Inf");
  double* M = ws->inertia.data();
  // With the bias f(q, qd, 0) (Coriolis, gravity and friction) in ws->tau.
  if (const gipdyn_status s = inertia_into(ws, q, qd, n, M, false); s != GIPDYN_OK) return s;
  double* b = ws->rhs.data();
  for (int i = 0; i < n; ++i) b[i] = tau[i] - ws->tau[static_cast<size_t>(i)];
  // Gaussian elimination with partial pivoting, in place (n is a handful of joints).
  double scale = 0.0;
  for (int k = 0; k < n * n; ++k) scale = std::max(scale, std::abs(M[k]));
  for (int c = 0; c < n; ++c) {
    int pivot = c;
    for (int r = c + 1; r < n; ++r)
      if (std::abs(M[r * n + c]) > std::abs(M[pivot * n + c])) pivot = r;
    if (!(std::abs(M[pivot * n + c]) > 1e-12 * scale))
      return fail(GIPDYN_ERROR_SINGULAR, "the learned inertia matrix is singular at this q: no accelerations");
    if (pivot != c) {
      for (int k = 0; k < n; ++k) std::swap(M[c * n + k], M[pivot * n + k]);
      std::swap(b[c], b[pivot]);
    }
    for (int r = c + 1; r < n; ++r) {
      const double factor = M[r * n + c] / M[c * n + c];
      for (int k = c; k < n; ++k) M[r * n + k] -= factor * M[c * n + k];
      b[r] -= factor * b[c];
    }
  }
  for (int r = n - 1; r >= 0; --r) {
    double sum = b[r];
    for (int k = r + 1; k < n; ++k) sum -= M[r * n + k] * qdd[k];
    qdd[r] = sum / M[r * n + r];
  }
  if (!all_finite(qdd, n)) return fail(GIPDYN_ERROR_NOT_FINITE, "the accelerations are not finite at this state");
  return ok();
}

gipdyn_contact_options gipdyn_contact_options_default(void) {
  const gipdyn::ContactOptions d;
  gipdyn_contact_options o;
  o.method = GIPDYN_CONTACT_RESIDUAL;
  o.false_alarm_rate = d.false_alarm_rate;
  o.min_duration = d.min_duration;
  o.sample_time = d.sample_time;
  o.momentum_gain = d.momentum_gain;
  return o;
}

gipdyn_status gipdyn_contact_detector_create(const gipdyn_model* model, const gipdyn_contact_options* options,
                                             const double* noise_std, int n, gipdyn_contact_detector** detector) {
  if (!detector) return fail(GIPDYN_ERROR_NULL_ARGUMENT, "detector (the output pointer) is NULL");
  *detector = nullptr;
  if (!model || !options) return fail(GIPDYN_ERROR_NULL_ARGUMENT, "model or options is NULL");
  if (n != model->joints)
    return fail(GIPDYN_ERROR_SIZE, "n does not match the model's joint count (gipdyn_model_num_joints)");
  if (options->method != GIPDYN_CONTACT_RESIDUAL && options->method != GIPDYN_CONTACT_MOMENTUM)
    return fail(GIPDYN_ERROR_INVALID_OPTION, "method must be GIPDYN_CONTACT_RESIDUAL or GIPDYN_CONTACT_MOMENTUM");
  gipdyn::ContactOptions o;
  o.method = options->method == GIPDYN_CONTACT_MOMENTUM ? gipdyn::ContactMethod::Momentum
                                                         : gipdyn::ContactMethod::Residual;
  o.false_alarm_rate = options->false_alarm_rate;
  o.min_duration = options->min_duration;
  o.sample_time = options->sample_time;
  o.momentum_gain = options->momentum_gain;
  try {
    o.validate();
  } catch (const gipdyn::Error& e) {
    return fail(GIPDYN_ERROR_INVALID_OPTION, e.what());
  }
  if (o.method == gipdyn::ContactMethod::Momentum && !model->physics)
    return fail(GIPDYN_ERROR_UNSUPPORTED,
                ("the momentum method needs the inertia matrix of a model of one of " +
                 gipdyn::joined(gipdyn::physics_estimator_names()) + "; use GIPDYN_CONTACT_RESIDUAL")
                    .c_str());
  try {
    Eigen::VectorXd sigma;
    if (noise_std) {
      if (!all_finite(noise_std, n)) return fail(GIPDYN_ERROR_NOT_FINITE, "noise_std holds NaN or Inf");
      sigma = Eigen::Map<const Eigen::VectorXd>(noise_std, n);
      if (!(sigma.array() > 0.0).all()) return fail(GIPDYN_ERROR_INVALID_OPTION, "noise_std must be positive");
    } else {
      if (!model->estimator->gives_uncertainty())
        return fail(GIPDYN_ERROR_UNSUPPORTED,
                    "this model learned no noise level: pass noise_std, measured on contact-free rows");
      sigma = gipdyn::learned_noise_std(*model->estimator);
    }
    *detector = new gipdyn_contact_detector(model, o, sigma);
    return ok();
  } catch (const std::bad_alloc&) {
    return fail(GIPDYN_ERROR_OUT_OF_MEMORY, "out of memory while creating the contact detector");
  } catch (const std::exception& e) {
    return fail(GIPDYN_ERROR_INTERNAL, e.what());
  }
}

void gipdyn_contact_detector_free(gipdyn_contact_detector* detector) { delete detector; }

gipdyn_status gipdyn_contact_detector_reset(gipdyn_contact_detector* detector) {
  if (!detector) return fail(GIPDYN_ERROR_NULL_ARGUMENT, "detector is NULL");
  detector->stream.reset();
  return ok();
}

gipdyn_status gipdyn_contact_detector_step(gipdyn_contact_detector* detector, const double* q, const double* qd,
                                           const double* qdd, const double* tau, int n, double* ext, int* contact,
                                           double* margin) {
  if (!detector || !q || !qd || !tau || !ext || !contact || !margin)
    return fail(GIPDYN_ERROR_NULL_ARGUMENT, "detector, q, qd, tau or an output pointer is NULL");
  if (n != detector->model->joints)
    return fail(GIPDYN_ERROR_SIZE, "n does not match the model's joint count (gipdyn_model_num_joints)");
  const bool needs_qdd = gipdyn::ContactMethod::Residual == detector->stream.method();
  if (needs_qdd && !qdd) return fail(GIPDYN_ERROR_NULL_ARGUMENT, "qdd is NULL: the residual method needs it");
  if (!all_finite(q, n) || !all_finite(qd, n) || !all_finite(tau, n) || (needs_qdd && !all_finite(qdd, n)))
    return fail(GIPDYN_ERROR_NOT_FINITE, "q, qd, qdd or tau holds NaN or Inf");
  detector->stream.step(q, qd, qdd, tau, ext, contact, margin);
  if (!all_finite(ext, n))
    return fail(GIPDYN_ERROR_NOT_FINITE, "the external torque is not finite: the state is far outside the training data");
  return ok();
}

}  // extern "C"
