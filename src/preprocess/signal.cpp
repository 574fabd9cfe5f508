#include "gipdyn/preprocess/signal.hpp"

#include <cmath>
#include <complex>
#include <string>

#include "gipdyn/error.hpp"

namespace gipdyn {

std::vector<Biquad> butterworth_lowpass(int order, double cutoff_hz, double fs) {
  if (order < 1 || order > 10) throw Error("filter order must be 1..10, not " + std::to_string(order));
  if (!(fs > 0.0)) throw Error("sampling rate must be > 0");
  if (!(cutoff_hz > 0.0) || !(cutoff_hz < 0.5 * fs))
    throw Error("cutoff " + std::to_string(cutoff_hz) + " Hz must be above 0 and below the Nyquist frequency " +
                std::to_string(0.5 * fs) + " Hz of the sampling period; lower PreprocessOptions::cutoff_hz or shorten PreprocessOptions::dt");
  const double pi = std::acos(-1.0);
  // Prewarped analog cutoff: the digital filter's -3 dB point lands exactly on cutoff_hz.
  const double wc = 2.0 * fs * std::tan(pi * cutoff_hz / fs);
  std::vector<Biquad> sections;
  // Analog poles wc exp(i pi (2k + N + 1) / (2N)); one of each conjugate pair, then the real one.
  for (int k = 0; k < order / 2; ++k) {
    const std::complex<double> s = wc * std::polar(1.0, pi * (2.0 * k + order + 1.0) / (2.0 * order));
    const std::complex<double> z = (2.0 * fs + s) / (2.0 * fs - s);
    Biquad q;
    q.a1 = -2.0 * z.real();
    q.a2 = std::norm(z);
    // Both zeros at z = -1: numerator (1 + z^-1)^2, scaled to unit DC gain.
    const double g = (1.0 + q.a1 + q.a2) / 4.0;
    q.b0 = g;
    q.b1 = 2.0 * g;
    q.b2 = g;
    sections.push_back(q);
  }
  if (order % 2 == 1) {
    const double z = (2.0 * fs - wc) / (2.0 * fs + wc);  // the real pole s = -wc
    Biquad q;
    q.a1 = -z;
    const double g = (1.0 - z) / 2.0;
    q.b0 = g;
    q.b1 = g;
    sections.push_back(q);
  }
  return sections;
}

int filtfilt_padding(const std::vector<Biquad>& sections) {
  int zero_b2 = 0, zero_a2 = 0;
  for (const auto& s : sections) {
    zero_b2 += s.b2 == 0.0;
    zero_a2 += s.a2 == 0.0;
  }
  return 3 * (2 * static_cast<int>(sections.size()) + 1 - std::min(zero_b2, zero_a2));
}

namespace {

// Runs the cascade over x in place (transposed direct form II), each section
// starting in the steady state of a constant input equal to x's first sample.
void cascade_in_place(const std::vector<Biquad>& sections, Eigen::Ref<Eigen::VectorXd> x) {
  double u = x(0);
  for (const auto& s : sections) {
    const double g = s.dc_gain();
    // Steady state for constant input u: output g u.
    double z1 = (g - s.b0) * u, z2 = (s.b2 - s.a2 * g) * u;
    for (Eigen::Index i = 0; i < x.size(); ++i) {
      const double in = x(i), out = s.b0 * in + z1;
      z1 = s.b1 * in - s.a1 * out + z2;
      z2 = s.b2 * in - s.a2 * out;
      x(i) = out;
    }
    u *= g;
  }
}

}  // namespace

Eigen::MatrixXd filtfilt(const std::vector<Biquad>& sections, const Eigen::MatrixXd& x) {
  const Eigen::Index n = x.rows(), pad = filtfilt_padding(sections);
  if (n <= pad)
    throw Error("zero-phase filtering needs more than " + std::to_string(pad) + " samples, the log (or segment) has " +
                std::to_string(n) + "; filter a longer stretch, or leave this one unfiltered");
  Eigen::MatrixXd y(n, x.cols());
  Eigen::VectorXd e(n + 2 * pad);
  for (Eigen::Index c = 0; c < x.cols(); ++c) {
    // Odd extension: the signal continued by its point reflection about each end.
    for (Eigen::Index i = 0; i < pad; ++i) {
      e(i) = 2.0 * x(0, c) - x(pad - i, c);
      e(n + pad + i) = 2.0 * x(n - 1, c) - x(n - 2 - i, c);
    }
    e.segment(pad, n) = x.col(c);
    cascade_in_place(sections, e);
    e.reverseInPlace();
    cascade_in_place(sections, e);
    e.reverseInPlace();
    y.col(c) = e.segment(pad, n);
  }
  return y;
}

Eigen::MatrixXd causal_filter(const std::vector<Biquad>& sections, const Eigen::MatrixXd& x) {
  if (x.rows() == 0) throw Error("causal filtering needs at least 1 sample");
  Eigen::MatrixXd y = x;
  for (Eigen::Index c = 0; c < y.cols(); ++c) {
    Eigen::VectorXd col = y.col(c);
    cascade_in_place(sections, col);
    y.col(c) = col;
  }
  return y;
}

double dc_group_delay_samples(const std::vector<Biquad>& sections) {
  // For H = B / A at z = 1: delay = sum k b_k / sum b_k - sum k a_k / sum a_k.
  double delay = 0.0;
  for (const auto& s : sections)
    delay += (s.b1 + 2.0 * s.b2) / (s.b0 + s.b1 + s.b2) - (s.a1 + 2.0 * s.a2) / (1.0 + s.a1 + s.a2);
  return delay;
}

Eigen::MatrixXd backward_derivative(const Eigen::MatrixXd& x, double dt) {
  if (!(dt > 0.0)) throw Error("the sampling period must be > 0");
  Eigen::MatrixXd d = Eigen::MatrixXd::Zero(x.rows(), x.cols());
  if (x.rows() > 1) d.bottomRows(x.rows() - 1) = (x.bottomRows(x.rows() - 1) - x.topRows(x.rows() - 1)) / dt;
  return d;
}

Eigen::MatrixXd time_derivative(const Eigen::MatrixXd& x, double dt) {
  const Eigen::Index n = x.rows();
  if (n < 3) throw Error("numerical derivatives need at least 3 samples, the log has " + std::to_string(n));
  if (!(dt > 0.0)) throw Error("the sampling period must be > 0");
  Eigen::MatrixXd d(n, x.cols());
  d.middleRows(1, n - 2) = (x.bottomRows(n - 2) - x.topRows(n - 2)) / (2.0 * dt);
  d.row(0) = (-3.0 * x.row(0) + 4.0 * x.row(1) - x.row(2)) / (2.0 * dt);
  d.row(n - 1) = (3.0 * x.row(n - 1) - 4.0 * x.row(n - 2) + x.row(n - 3)) / (2.0 * dt);
  return d;
}

Eigen::MatrixXd resample_linear(const Eigen::VectorXd& t, const Eigen::MatrixXd& x, const Eigen::VectorXd& t_new) {
  if (t.size() != x.rows() || t.size() < 2) throw Error("resampling needs at least 2 samples with one time each");
  Eigen::MatrixXd y(t_new.size(), x.cols());
  Eigen::Index k = 0;
  for (Eigen::Index i = 0; i < t_new.size(); ++i) {
    const double ti = t_new(i);
    if (ti < t(0) || ti > t(t.size() - 1)) throw Error("resampling time outside the log's time span");
    while (k + 2 < t.size() && t(k + 1) < ti) ++k;  // t(k) <= ti <= t(k+1)
    const double w = (ti - t(k)) / (t(k + 1) - t(k));
    y.row(i) = (1.0 - w) * x.row(k) + w * x.row(k + 1);
  }
  return y;
}

}  // namespace gipdyn
