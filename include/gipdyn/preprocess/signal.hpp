#pragma once
// Signal processing for robot logs: a zero-phase Butterworth low-pass filter,
// numerical derivatives and resampling onto a uniform time grid. Column-wise:
// every routine treats each column of a matrix as one signal.
#include <Eigen/Dense>
#include <vector>

#include "gipdyn/eigen_abi.hpp"

namespace gipdyn {

// One second-order section: y = (b0 + b1 z^-1 + b2 z^-2) / (1 + a1 z^-1 + a2 z^-2) x.
struct Biquad {
  double b0 = 1, b1 = 0, b2 = 0, a1 = 0, a2 = 0;
  double dc_gain() const { return (b0 + b1 + b2) / (1.0 + a1 + a2); }
};

// Digital Butterworth low-pass of the given order (1..10) and cutoff (Hz, the
// -3 dB point of one pass) at sampling rate fs (Hz), by the bilinear transform
// with prewarping, as second-order sections with unit DC gain each. Throws
// gipdyn::Error unless 0 < cutoff < fs / 2.
std::vector<Biquad> butterworth_lowpass(int order, double cutoff_hz, double sample_rate_hz);

// Zero-phase filtering (forward, then backward): the gain is |H(f)|^2 and the
// phase is zero at every frequency. Edges as SciPy's sosfiltfilt: odd
// extension by 3 (2 sections + 1) samples and steady-state initial conditions.
// Throws gipdyn::Error when a column is not longer than the extension.
Eigen::MatrixXd filtfilt(const std::vector<Biquad>& sections, const Eigen::MatrixXd& x);
int filtfilt_padding(const std::vector<Biquad>& sections);

// Causal filtering (forward only, what a controller can run online): each
// section starts in the steady state of the first sample. Delays the signal.
Eigen::MatrixXd causal_filter(const std::vector<Biquad>& sections, const Eigen::MatrixXd& x);
// The cascade's group delay at zero frequency, in samples: how far a slow
// signal lags after causal_filter.
double dc_group_delay_samples(const std::vector<Biquad>& sections);

// Causal d/dt: (x_i - x_{i-1}) / dt, a lag of half a sample; the first row,
// with no past, is 0.
Eigen::MatrixXd backward_derivative(const Eigen::MatrixXd& x, double dt);

// d/dt of each column sampled every dt: second-order central differences
// inside, second-order one-sided differences at the two ends (numpy.gradient
// with edge_order=2). Needs at least 3 rows.
Eigen::MatrixXd time_derivative(const Eigen::MatrixXd& x, double dt);

// Linear interpolation of the rows of x, sampled at the strictly increasing
// times t, onto t_new (which must lie within [t.front(), t.back()]).
Eigen::MatrixXd resample_linear(const Eigen::VectorXd& t, const Eigen::MatrixXd& x, const Eigen::VectorXd& t_new);

}  // namespace gipdyn
