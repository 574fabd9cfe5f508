#pragma once
// Helpers shared by the C++ tests.
#include <Eigen/Dense>
#include <cmath>
#include <functional>
#include <random>
#include <string>

#include "gipdyn/error.hpp"
#include "gipdyn/joint_types.hpp"
#include "gipdyn/model/inverse_dynamics_model.hpp"

namespace gipdyn::test {

// An estimator or kernel name as a GoogleTest parameter name ("gip-friction+rbf" -> "gip_friction_plus_rbf").
inline std::string test_name(const std::string& name) {
  std::string clean;
  for (char c : name) clean += c == '-' ? std::string("_") : c == '+' ? std::string("_plus_") : std::string(1, c);
  return clean;
}

// Rounding to allow between two paths that predict joint j at the raw state x
// and sum k(x, x_i) alpha_i in different orders: it grows with
// sum_i |alpha_i k(x, x_i)|, which cancels to the prediction (by 1e9 for some
// gip-envelope+friction fits), in the units of the torque.
inline double prediction_rounding(const InverseDynamicsModel& model, int j, const Eigen::VectorXd& x) {
  Eigen::MatrixXd Kq;
  model.joint_gp(j).kernel().cross(model.features().compute(x.transpose()), model.training_features(), Kq);
  return 1e-14 * model.output_scale()(j) * Kq.row(0).transpose().cwiseProduct(model.joint_gp(j).alpha()).cwiseAbs().sum();
}

// Random raw inputs (q, qd, qdd) for a joint string: revolute q in [-pi, pi],
// prismatic q in [0, 0.3] m, qd in [-2, 2], qdd in [-3, 3].
inline Eigen::MatrixXd random_inputs(const JointTypes& joints, int rows, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  const int n = joints.size();
  Eigen::MatrixXd X(rows, 3 * n);
  for (int r = 0; r < rows; ++r)
    for (int i = 0; i < n; ++i) {
      X(r, i) = joints.is_revolute(i) ? M_PI * u(rng) : 0.15 + 0.15 * u(rng);
      X(r, n + i) = 2.0 * u(rng);
      X(r, 2 * n + i) = 3.0 * u(rng);
    }
  return X;
}

inline Eigen::VectorXd random_vector(int size, double lo, double hi, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(lo, hi);
  Eigen::VectorXd v(size);
  for (int k = 0; k < size; ++k) v(k) = u(rng);
  return v;
}

// A rows x cols matrix of uniform values in [lo, hi] from its own seed: unlike
// Eigen's Random(), which draws from the process-wide std::rand(), the values do
// not depend on which tests ran before in the same process.
inline Eigen::MatrixXd random_matrix(int rows, int cols, double lo, double hi, unsigned seed) {
  return Eigen::Map<const Eigen::MatrixXd>(random_vector(rows * cols, lo, hi, seed).data(), rows, cols);
}

// M plus Gaussian noise of standard deviation sd from its own seed.
inline Eigen::MatrixXd with_noise(const Eigen::MatrixXd& M, double sd, unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> n(0.0, sd);
  Eigen::MatrixXd out = M;
  for (Eigen::Index k = 0; k < out.size(); ++k) out.data()[k] += n(rng);
  return out;
}

// The message of the gipdyn::Error that f throws, or "" if it throws none.
inline std::string error_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

// Fourth-order central difference of a scalar function of a vector.
inline Eigen::VectorXd finite_difference(const std::function<double(const Eigen::VectorXd&)>& f,
                                         const Eigen::VectorXd& x, double h) {
  Eigen::VectorXd g(x.size());
  for (Eigen::Index k = 0; k < x.size(); ++k) {
    auto at = [&](double d) {
      Eigen::VectorXd y = x;
      y(k) += d;
      return f(y);
    };
    g(k) = (-at(2 * h) + 8 * at(h) - 8 * at(-h) + at(-2 * h)) / (12 * h);
  }
  return g;
}

// Planar 2R arm in a vertical plane (gravity along -y), written out by hand:
// tau = M(q) qdd + C(q, qd) qd + g(q). Rows of X: q1 q2 qd1 qd2 qdd1 qdd2.
inline Eigen::MatrixXd two_link_torques(const Eigen::MatrixXd& X) {
  const double m1 = 1.0, m2 = 0.8, l1 = 0.5, lc1 = 0.25, lc2 = 0.2, I1 = 0.02, I2 = 0.015, g = 9.81;
  Eigen::MatrixXd tau(X.rows(), 2);
  for (Eigen::Index r = 0; r < X.rows(); ++r) {
    const double q1 = X(r, 0), q2 = X(r, 1), qd1 = X(r, 2), qd2 = X(r, 3), qdd1 = X(r, 4), qdd2 = X(r, 5);
    const double c2 = std::cos(q2), s2 = std::sin(q2);
    const double M11 = m1 * lc1 * lc1 + m2 * (l1 * l1 + lc2 * lc2 + 2 * l1 * lc2 * c2) + I1 + I2;
    const double M12 = m2 * (lc2 * lc2 + l1 * lc2 * c2) + I2, M22 = m2 * lc2 * lc2 + I2;
    const double h = -m2 * l1 * lc2 * s2;
    const double g1 = (m1 * lc1 + m2 * l1) * g * std::cos(q1) + m2 * lc2 * g * std::cos(q1 + q2);
    const double g2 = m2 * lc2 * g * std::cos(q1 + q2);
    tau(r, 0) = M11 * qdd1 + M12 * qdd2 + h * qd2 * qd2 + 2 * h * qd1 * qd2 + g1;
    tau(r, 1) = M12 * qdd1 + M22 * qdd2 - h * qd1 * qd1 + g2;
  }
  return tau;
}

// A smooth exciting trajectory of the 2R arm: each joint a sum of three
// sinusoids, sampled every dt; phases from the seed. Rows: q, qd, qdd.
inline Eigen::MatrixXd two_link_trajectory(int rows, double dt, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> phase(0.0, 2.0 * M_PI);
  const double w[3] = {0.31, 0.73, 1.37}, a[3] = {1.2, 0.5, 0.25};
  double p[2][3];
  for (auto& joint : p)
    for (double& v : joint) v = phase(rng);
  Eigen::MatrixXd X(rows, 6);
  for (int r = 0; r < rows; ++r) {
    const double t = r * dt;
    for (int i = 0; i < 2; ++i) {
      double q = 0, qd = 0, qdd = 0;
      for (int k = 0; k < 3; ++k) {
        const double s = std::sin(w[k] * t + p[i][k]), c = std::cos(w[k] * t + p[i][k]);
        q += a[k] * s;
        qd += a[k] * w[k] * c;
        qdd -= a[k] * w[k] * w[k] * s;
      }
      X(r, i) = q;
      X(r, 2 + i) = qd;
      X(r, 4 + i) = qdd;
    }
  }
  return X;
}

}  // namespace gipdyn::test
