#include "gipdyn/sensing/contact_detection.hpp"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <utility>
#include <vector>

#include "gipdyn/error.hpp"
#include "gipdyn/estimators/physics.hpp"
#include "gipdyn/estimators/uncertainty.hpp"

namespace gipdyn {

namespace {

// x with erfc(x) = y, for y in (0, 1). Newton's method from sqrt(-log y), where
// erfc(x) <= exp(-x^2) puts the start right of the root; erfc is convex there,
// so the first step lands left of the root and the rest climb to it.
double inverse_erfc(double y) {
  double x = std::sqrt(-std::log(y));
  for (int i = 0; i < 100; ++i) {
    const double step = (std::erfc(x) - y) / (-2.0 / std::sqrt(M_PI) * std::exp(-x * x));
    x -= step;
    if (std::abs(step) <= 1e-14 * std::max(1.0, std::abs(x))) break;
  }
  return x;
}

// Runs of rows where `on(k)` holds, as [first, last] pairs.
template <class On>
std::vector<std::pair<Eigen::Index, Eigen::Index>> runs(Eigen::Index rows, On&& on) {
  std::vector<std::pair<Eigen::Index, Eigen::Index>> out;
  for (Eigen::Index k = 0; k < rows; ++k)
    if (on(k) && (k == 0 || !on(k - 1))) {
      Eigen::Index last = k;
      while (last + 1 < rows && on(last + 1)) ++last;
      out.emplace_back(k, last);
    }
  return out;
}

const ContactOptions& validated(const ContactOptions& options) {
  options.validate();
  return options;
}

}  // namespace

ContactMethod parse_contact_method(const std::string& name) {
  if (name == "residual") return ContactMethod::Residual;
  if (name == "momentum") return ContactMethod::Momentum;
  throw Error("unknown contact detection method '" + name + "'; choose residual or momentum");
}

std::string to_string(ContactMethod method) { return method == ContactMethod::Residual ? "residual" : "momentum"; }

void ContactOptions::validate() const {
  if (!(false_alarm_rate > 0.0 && false_alarm_rate < 1.0))
    throw Error("ContactOptions::false_alarm_rate must lie in (0, 1): it is a probability per row and joint");
  if (false_alarm_rate < 1e-15)
    throw Error("ContactOptions::false_alarm_rate must be at least 1e-15: a smaller one asks for a threshold "
                "beyond what a Gaussian model of the residual can say");
  if (!(sample_time > 0.0) || !std::isfinite(sample_time))
    throw Error("ContactOptions::sample_time must be the rows' sampling period, a positive number of seconds");
  if (!(min_duration >= 0.0) || !std::isfinite(min_duration))
    throw Error("ContactOptions::min_duration must be a number of seconds >= 0");
  if (!(momentum_gain >= 0.0) || !std::isfinite(momentum_gain))
    throw Error("ContactOptions::momentum_gain must be >= 0 (0: automatic)");
  if (momentum_gain * sample_time > 1.0) {
    std::ostringstream message;
    message << "ContactOptions::momentum_gain times ContactOptions::sample_time is " << momentum_gain * sample_time
            << ": the observer needs at most 1; lower the gain to at most " << 1.0 / sample_time << " per second";
    throw Error(message.str());
  }
}

double ContactOptions::threshold_factor() const { return std::sqrt(2.0) * inverse_erfc(false_alarm_rate); }

int ContactOptions::min_samples() const {
  return std::max(1, static_cast<int>(std::ceil(min_duration / sample_time - 1e-9)));
}

double ContactOptions::observer_gain() const {
  if (momentum_gain > 0.0) return momentum_gain;
  const double time_constant = std::max(0.01, 2.0 * sample_time);
  return 1.0 / time_constant;
}

std::string ContactDetection::brief_report() const {
  std::ostringstream out;
  out << to_string(method) << " method, threshold " << threshold_factor << " sigma, noise from " << noise_source
      << "\n";
  const Eigen::Index rows = contact.rows();
  for (Eigen::Index j = 0; j < contact.cols(); ++j) {
    const double flagged = rows > 0 ? contact.col(j).cast<double>().mean() : 0.0;
    out << "  joint " << j + 1 << ": " << contact_count(j) << " contact" << (contact_count(j) == 1 ? "" : "s") << ", "
        << 100.0 * flagged << " % of rows flagged, noise " << noise_std(j) << ", largest margin "
        << (rows > 0 ? margin.col(j).maxCoeff() : 0.0) << "\n";
  }
  return out.str();
}

ContactFlagger::ContactFlagger(int joints, double threshold_factor, int min_samples)
    : k_(threshold_factor), min_samples_(min_samples), run_(Eigen::VectorXi::Zero(joints)) {
  if (joints < 1 || !(threshold_factor > 0.0) || min_samples < 1)
    throw Error("ContactFlagger needs joints >= 1, a positive threshold factor and min_samples >= 1");
}

void ContactFlagger::reset() { run_.setZero(); }

void ContactFlagger::step(const double* ext, const double* sigma, int* contact, double* margin, double* threshold) {
  for (Eigen::Index j = 0; j < run_.size(); ++j) {
    const double limit = k_ * sigma[j];
    const double ratio = limit > 0.0 ? std::abs(ext[j]) / limit : (ext[j] != 0.0 ? HUGE_VAL : 0.0);
    run_(j) = ratio > 1.0 ? run_(j) + 1 : 0;
    contact[j] = run_(j) >= min_samples_ ? 1 : 0;
    margin[j] = ratio;
    if (threshold) threshold[j] = limit;
  }
}

MomentumObserver::MomentumObserver(int joints, double gain, double sample_time)
    : gain_(gain), dt_(sample_time) {
  if (joints < 1 || !(gain > 0.0) || !(sample_time > 0.0) || gain * sample_time > 1.0)
    throw Error("MomentumObserver needs joints >= 1, gain > 0, sample_time > 0 and gain x sample_time <= 1");
  for (Eigen::VectorXd* v : {&p0_, &integral_, &r_, &prev_qd_, &prev_drive_, &p_, &mean_qd_}) v->setZero(joints);
  prev_M_.setZero(joints, joints);
}

void MomentumObserver::reset() {
  started_ = false;
  r_.setZero();
  integral_.setZero();
}

const Eigen::VectorXd& MomentumObserver::step(const Eigen::Ref<const Eigen::MatrixXd>& M,
                                              const Eigen::Ref<const Eigen::VectorXd>& qd,
                                              const Eigen::Ref<const Eigen::VectorXd>& tau_minus_n) {
  p_.noalias() = M * qd;
  if (!started_) {
    started_ = true;
    p0_ = p_;
    integral_.setZero();
    r_.setZero();
  } else {
    // p_k - p_{k-1} = (M_k - M_{k-1}) (qd_k + qd_{k-1}) / 2 + (M_k + M_{k-1}) / 2 (qd_k - qd_{k-1}),
    // the first term dM/dt qd's integral, the second M qdd's = tau + tau_ext - n's.
    mean_qd_ = 0.5 * (qd + prev_qd_);
    integral_.noalias() += M * mean_qd_;
    integral_.noalias() -= prev_M_ * mean_qd_;
    integral_ += 0.5 * dt_ * (tau_minus_n + prev_drive_) + dt_ * r_;
    r_ = gain_ * (p_ - p0_ - integral_);
  }
  prev_M_ = M;
  prev_qd_ = qd;
  prev_drive_ = tau_minus_n;
  return r_;
}

ContactStream::ContactStream(const Estimator& estimator, const ContactOptions& options, const Eigen::VectorXd& sigma)
    : estimator_(&estimator),
      method_(options.method),
      sigma_(sigma),
      query_(estimator.make_query_workspace()),
      flagger_(estimator.joints().size(), validated(options).threshold_factor(), options.min_samples()) {
  const int n = estimator.joints().size();
  if (sigma_.size() != n || !(sigma_.array() > 0.0).all() || !sigma_.allFinite())
    throw Error("ContactStream needs one positive, finite sigma per joint (" + std::to_string(n) + ")");
  if (method_ == ContactMethod::Momentum) {
    require_physics(estimator);
    observer_ = std::make_unique<MomentumObserver>(n, options.observer_gain(), options.sample_time);
  }
  x_.setZero(3 * n);
  for (Eigen::VectorXd* v : {&predicted_, &gravity_, &drive_, &ext_}) v->setZero(n);
  M_.setZero(n, n);
}

ContactStream::~ContactStream() = default;

void ContactStream::reset() {
  flagger_.reset();
  if (observer_) observer_->reset();
}

void ContactStream::step(const double* q, const double* qd, const double* qdd, const double* tau, double* ext,
                         int* contact, double* margin) {
  const Eigen::Index n = sigma_.size();
  const Eigen::Map<const Eigen::VectorXd> q_(q, n), qd_(qd, n), tau_(tau, n);
  if (method_ == ContactMethod::Residual) {
    x_ << q_, qd_, Eigen::Map<const Eigen::VectorXd>(qdd, n);
    query_->predict(x_.data(), ext_.data());
    ext_ -= tau_;
  } else {
    // M(q) as inertia() gives it (the symmetric part of the learned rows), and n(q, qd) = f(q, qd, 0). M_ is
    // column-major and rigid_body_terms writes rows: it holds M's transpose, which symmetrising makes M.
    query_->rigid_body_terms(q, qd, gravity_.data(), M_.data(), predicted_.data());
    for (Eigen::Index i = 0; i < n; ++i)
      for (Eigen::Index j = 0; j < i; ++j) M_(i, j) = M_(j, i) = 0.5 * (M_(i, j) + M_(j, i));
    drive_ = tau_ - predicted_;
    ext_ = observer_->step(M_, qd_, drive_);
  }
  Eigen::Map<Eigen::VectorXd>(ext, n) = ext_;
  flagger_.step(ext, sigma_.data(), contact, margin);
}

ContactDetector::ContactDetector(const Estimator& estimator, ContactOptions options)
    : estimator_(&estimator), options_(options) {
  options_.validate();
  if (options_.method == ContactMethod::Momentum) require_physics(estimator);
  if (options_.predictive_variance && estimator.gives_uncertainty())
    uncertainty_ = std::make_unique<TorqueUncertainty>(estimator);
}

ContactDetector::~ContactDetector() = default;
ContactDetector::ContactDetector(ContactDetector&&) noexcept = default;
ContactDetector& ContactDetector::operator=(ContactDetector&&) noexcept = default;

void ContactDetector::check_rows(const Eigen::Ref<const Eigen::MatrixXd>& X,
                                 const Eigen::Ref<const Eigen::MatrixXd>& tau) const {
  const int n = estimator_->joints().size();
  if (X.cols() != 3 * n)
    throw Error("contact detection: the states have " + std::to_string(X.cols()) + " columns; this " +
                estimator_->joints().str() + " model needs " + std::to_string(3 * n) + " (q, qd, qdd)");
  if (tau.cols() != n || tau.rows() != X.rows())
    throw Error("contact detection: the torques must be one row of " + std::to_string(n) + " per state row (got " +
                std::to_string(tau.rows()) + " x " + std::to_string(tau.cols()) + " for " + std::to_string(X.rows()) +
                " rows)");
  if (X.rows() < 1) throw Error("contact detection: the log has no rows");
  if (!X.allFinite() || !tau.allFinite()) throw Error("contact detection: the log contains NaN or Inf");
}

Eigen::MatrixXd ContactDetector::external_torque(const Eigen::Ref<const Eigen::MatrixXd>& X,
                                                 const Eigen::Ref<const Eigen::MatrixXd>& tau) const {
  check_rows(X, tau);
  const int n = estimator_->joints().size();
  if (options_.method == ContactMethod::Residual) return estimator_->predict(X) - tau;
  // n(q, qd) = f(q, qd, 0) and M(q) in two batches, then the observer row by row.
  Eigen::MatrixXd still = X;
  still.rightCols(n).setZero();
  const Eigen::MatrixXd bias = estimator_->predict(still);
  const std::vector<Eigen::MatrixXd> M = inertia(*estimator_, X.leftCols(n));
  MomentumObserver observer(n, options_.observer_gain(), options_.sample_time);
  Eigen::MatrixXd r(X.rows(), n);
  Eigen::VectorXd qd(n), drive(n);
  for (Eigen::Index k = 0; k < X.rows(); ++k) {
    qd = X.row(k).segment(n, n).transpose();
    drive = (tau.row(k) - bias.row(k)).transpose();
    r.row(k) = observer.step(M[static_cast<size_t>(k)], qd, drive).transpose();
  }
  return r;
}

void ContactDetector::calibrate(const Eigen::Ref<const Eigen::MatrixXd>& X, const Eigen::Ref<const Eigen::MatrixXd>& tau) {
  const Eigen::MatrixXd r = external_torque(X, tau);
  calibrated_noise_ = (r.colwise().squaredNorm() / static_cast<double>(r.rows())).cwiseSqrt().transpose();
}

Eigen::VectorXd ContactDetector::noise_std() const {
  if (calibrated()) return calibrated_noise_;
  if (uncertainty_) return uncertainty_->noise_std();
  if (estimator_->gives_uncertainty()) return learned_noise_std(*estimator_);
  throw Error("a '" + estimator_->name() +
              "' model gives no predictive standard deviation: calibrate the detector on contact-free rows "
              "(ContactDetector::calibrate), or use one of: " + joined(uncertainty_estimator_names()));
}

ContactDetection ContactDetector::detect(const Eigen::Ref<const Eigen::MatrixXd>& X,
                                         const Eigen::Ref<const Eigen::MatrixXd>& tau) const {
  const int n = estimator_->joints().size();
  ContactDetection d;
  d.method = options_.method;
  d.threshold_factor = options_.threshold_factor();
  d.noise_source = calibrated() ? "calibration" : "model";
  d.noise_std = noise_std();
  d.external_torque = external_torque(X, tau);
  const Eigen::Index rows = X.rows();
  Eigen::MatrixXd sigma(rows, n);
  if (uncertainty_) {
    sigma = uncertainty_->latent_std(X);
    sigma = (sigma.array().square().rowwise() + d.noise_std.array().square().transpose()).sqrt().matrix();
  } else {
    sigma.rowwise() = d.noise_std.transpose();
  }
  // Row-major rows for the flagger's per-row pointers.
  using RowMajor = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
  using RowMajorInt = Eigen::Matrix<int, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
  const RowMajor ext = d.external_torque, sig = sigma;
  RowMajor margin(rows, n), threshold(rows, n);
  RowMajorInt contact(rows, n);
  ContactFlagger flagger(n, d.threshold_factor, options_.min_samples());
  for (Eigen::Index k = 0; k < rows; ++k)
    flagger.step(ext.row(k).data(), sig.row(k).data(), contact.row(k).data(), margin.row(k).data(),
                 threshold.row(k).data());
  d.margin = margin;
  d.threshold = threshold;
  d.contact = contact;
  d.contact_count.resize(n);
  for (int j = 0; j < n; ++j)
    d.contact_count(j) = static_cast<int>(runs(rows, [&](Eigen::Index k) { return d.contact(k, j) != 0; }).size());
  return d;
}

ContactScore score_contacts(const ContactDetection& detection, const Eigen::Ref<const Eigen::MatrixXd>& true_external,
                            double sample_time) {
  const Eigen::Index rows = detection.contact.rows();
  if (true_external.rows() != rows || true_external.cols() != detection.contact.cols())
    throw Error("score_contacts: the true external torque must have the detection's " + std::to_string(rows) + " x " +
                std::to_string(detection.contact.cols()) + " shape");
  ContactScore s;
  double delay_sum = 0.0, error_sum = 0.0;
  for (Eigen::Index j = 0; j < true_external.cols(); ++j) {
    const auto truth = runs(rows, [&](Eigen::Index k) { return true_external(k, j) != 0.0; });
    for (const auto& [first, last] : truth) {
      ++s.contacts;
      Eigen::Index flagged = first;
      while (flagged <= last && !detection.contact(flagged, j)) ++flagged;
      if (flagged > last) continue;
      ++s.detected;
      const double delay = static_cast<double>(flagged - first) * sample_time;
      delay_sum += delay;
      s.max_delay = std::max(s.max_delay, delay);
      const auto error = detection.external_torque.col(j).segment(first, last - first + 1) -
                         true_external.col(j).segment(first, last - first + 1);
      error_sum += std::sqrt(error.squaredNorm() / static_cast<double>(last - first + 1)) /
                   true_external.col(j).segment(first, last - first + 1).cwiseAbs().mean();
    }
    for (const auto& [first, last] : runs(rows, [&](Eigen::Index k) { return detection.contact(k, j) != 0; })) {
      bool overlaps = false;
      for (const auto& [tf, tl] : truth) overlaps = overlaps || (first <= tl && tf <= last);
      s.false_alarms += overlaps ? 0 : 1;
    }
  }
  for (Eigen::Index k = 0; k < rows; ++k)
    if ((true_external.row(k).array() == 0.0).all()) s.contact_free_seconds += sample_time;
  if (s.detected > 0) {
    s.mean_delay = delay_sum / s.detected;
    s.torque_error = error_sum / s.detected;
  }
  return s;
}

}  // namespace gipdyn
