#include "gipdyn/robot/dynamics.hpp"

#include <kdl/chainidsolver_recursive_newton_euler.hpp>
#include <random>

#include "gipdyn/error.hpp"

namespace gipdyn {
namespace {

using Matrix6x10 = Eigen::Matrix<double, 6, 10>;

KDL::JntArray to_jnt(const Eigen::VectorXd& v) {
  KDL::JntArray a(static_cast<unsigned>(v.size()));
  a.data = v;
  return a;
}

void check_sizes(const RobotModel& robot, const Eigen::VectorXd& q, const Eigen::VectorXd& qd,
                 const Eigen::VectorXd& qdd) {
  const int n = robot.num_joints();
  if (q.size() != n || qd.size() != n || qdd.size() != n)
    throw Error("robot '" + robot.name() + "' has " + std::to_string(n) + " joints; q, qd, qdd must have that many entries");
}

Eigen::Vector3d vec(const KDL::Vector& v) { return {v.x(), v.y(), v.z()}; }

Eigen::Matrix3d cross_matrix(const Eigen::Vector3d& v) {
  Eigen::Matrix3d m;
  m << 0.0, -v.z(), v.y(), v.z(), 0.0, -v.x(), -v.y(), v.x(), 0.0;
  return m;
}

// L(v) with Io v = L(v) (Ixx, Ixy, Ixz, Iyy, Iyz, Izz) for a symmetric Io.
Eigen::Matrix<double, 3, 6> inertia_product(const Eigen::Vector3d& v) {
  Eigen::Matrix<double, 3, 6> L;
  L << v.x(), v.y(), v.z(), 0.0, 0.0, 0.0,
       0.0, v.x(), 0.0, v.y(), v.z(), 0.0,
       0.0, 0.0, v.x(), 0.0, v.y(), v.z();
  return L;
}

// The spatial force f = I a + v x* (I v) at the frame origin, as (force,
// torque), is linear in the body's standard parameters (m, h = m c, and the
// inertia Io about the origin: Ixx Ixy Ixz Iyy Iyz Izz); the columns of its
// matrix, for v = (vl, w) and a = (al, wd) as KDL twists:
//   force  = m (al + w x vl) + ([wd x] + [w x][w x]) h
//   torque = [(vl x w - al) x] h + (L(wd) + [w x] L(w)) Io
// (from force = m al - h x wd + w x (m vl - h x w) and torque = Io wd + h x al
// + w x (Io w + h x vl) + vl x (m vl - h x w); vl x vl vanishes and
// w x (h x vl) - vl x (h x w) = (vl x w) x h).
Matrix6x10 body_wrench_regressor(const Eigen::Vector3d& vl, const Eigen::Vector3d& w, const Eigen::Vector3d& al,
                                 const Eigen::Vector3d& wd) {
  const Eigen::Matrix3d W = cross_matrix(w);
  Matrix6x10 A = Matrix6x10::Zero();
  A.block<3, 1>(0, 0) = al + w.cross(vl);
  A.block<3, 3>(0, 1) = cross_matrix(wd) + W * W;
  A.block<3, 3>(3, 1) = cross_matrix(vl.cross(w) - al);
  A.block<3, 6>(3, 4) = inertia_product(wd) + W * inertia_product(w);
  return A;
}

// KDL::Frame * Wrench on the columns of a 6 x k matrix: moves wrenches from the
// tip frame of a segment to its base frame.
template <class M>
void transform_wrenches(const KDL::Frame& F, M& W) {
  const Eigen::Matrix3d R = Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>>(F.M.data);
  const Eigen::Vector3d p = vec(F.p);
  for (Eigen::Index c = 0; c < W.cols(); ++c) {
    const Eigen::Vector3d f = R * W.col(c).template head<3>();
    const Eigen::Vector3d t = R * W.col(c).template tail<3>() + p.cross(f);
    W.col(c) << f, t;
  }
}

}  // namespace

Eigen::VectorXd inverse_dynamics(const RobotModel& robot, const Eigen::VectorXd& q, const Eigen::VectorXd& qd,
                                 const Eigen::VectorXd& qdd, bool with_friction) {
  check_sizes(robot, q, qd, qdd);
  const Eigen::Vector3d& g = robot.gravity();
  KDL::ChainIdSolver_RNE solver(robot.chain(), KDL::Vector(g.x(), g.y(), g.z()));
  KDL::JntArray tau(static_cast<unsigned>(q.size()));
  KDL::Wrenches fext(robot.chain().getNrOfSegments(), KDL::Wrench::Zero());
  if (solver.CartToJnt(to_jnt(q), to_jnt(qd), to_jnt(qdd), fext, tau) < 0)
    throw Error("KDL inverse dynamics failed for robot '" + robot.name() + "'");
  Eigen::VectorXd out = tau.data;
  if (with_friction) {
    for (int i = 0; i < robot.num_joints(); ++i) {
      const JointFriction& f = robot.joint(i).friction;
      out(i) += f.viscous * qd(i) + f.coulomb * static_cast<double>((qd(i) > 0) - (qd(i) < 0));
    }
  }
  return out;
}

Eigen::MatrixXd inverse_dynamics(const RobotModel& robot, const Eigen::MatrixXd& X, bool with_friction) {
  const int n = robot.num_joints();
  if (X.cols() != 3 * n) throw Error("inputs must have 3n = " + std::to_string(3 * n) + " columns (q, qd, qdd)");
  Eigen::MatrixXd tau(X.rows(), n);
  for (Eigen::Index r = 0; r < X.rows(); ++r)
    tau.row(r) = inverse_dynamics(robot, X.row(r).segment(0, n).transpose(), X.row(r).segment(n, n).transpose(),
                                  X.row(r).segment(2 * n, n).transpose(), with_friction)
                     .transpose();
  return tau;
}

void mass_matrix_and_bias(const RobotModel& robot, const Eigen::VectorXd& q, const Eigen::VectorXd& qd,
                          bool with_friction, Eigen::MatrixXd& M, Eigen::VectorXd& h) {
  const int n = robot.num_joints();
  const Eigen::VectorXd zero = Eigen::VectorXd::Zero(n);
  h = inverse_dynamics(robot, q, qd, zero, with_friction);
  const Eigen::VectorXd g = inverse_dynamics(robot, q, zero, zero, false);
  M.resize(n, n);
  Eigen::VectorXd e = zero;
  for (int j = 0; j < n; ++j) {
    e(j) = 1.0;
    M.col(j) = inverse_dynamics(robot, q, zero, e, false) - g;
    e(j) = 0.0;
  }
}

Eigen::VectorXd forward_dynamics(const RobotModel& robot, const Eigen::VectorXd& q, const Eigen::VectorXd& qd,
                                 const Eigen::VectorXd& tau, bool with_friction) {
  if (tau.size() != robot.num_joints())
    throw Error("forward_dynamics needs one torque per joint (" + std::to_string(robot.num_joints()) + ")");
  Eigen::MatrixXd M;
  Eigen::VectorXd h;
  mass_matrix_and_bias(robot, q, qd, with_friction, M, h);
  return M.ldlt().solve(tau - h);
}

struct RegressorWorkspace::Frames {
  std::vector<KDL::Frame> X;
  std::vector<KDL::Twist> S;
  std::vector<Matrix6x10, Eigen::aligned_allocator<Matrix6x10>> A;
  explicit Frames(int n) : X(static_cast<size_t>(n)), S(static_cast<size_t>(n)), A(static_cast<size_t>(n)) {}
};

RegressorWorkspace::RegressorWorkspace(const RobotModel& robot)
    : frames_(std::make_unique<Frames>(robot.num_joints())) {}
RegressorWorkspace::~RegressorWorkspace() = default;
RegressorWorkspace::RegressorWorkspace(RegressorWorkspace&&) noexcept = default;
RegressorWorkspace& RegressorWorkspace::operator=(RegressorWorkspace&&) noexcept = default;

Eigen::MatrixXd regressor(const RobotModel& robot, const Eigen::VectorXd& q, const Eigen::VectorXd& qd,
                          const Eigen::VectorXd& qdd, bool with_friction) {
  check_sizes(robot, q, qd, qdd);
  const int n = robot.num_joints();
  RegressorWorkspace workspace(robot);
  Eigen::MatrixXd Phi(n, with_friction ? 12 * n : 10 * n);
  regressor_into(robot, q.data(), qd.data(), qdd.data(), with_friction, workspace, Phi);
  return Phi;
}

// The same recursion as KDL::ChainIdSolver_RNE (segment poses and unit twists
// from KDL), with the body wrench replaced by its regressor in the standard
// parameters, propagated link by link towards the base.
void regressor_into(const RobotModel& robot, const double* q_data, const double* qd_data, const double* qdd_data,
                    bool with_friction, RegressorWorkspace& workspace, Eigen::Ref<Eigen::MatrixXd> Phi) {
  const int n = robot.num_joints();
  const Eigen::Map<const Eigen::VectorXd> q(q_data, n), qd(qd_data, n), qdd(qdd_data, n);
  const KDL::Chain& chain = robot.chain();
  auto& X = workspace.frames_->X;
  auto& S = workspace.frames_->S;
  auto& A = workspace.frames_->A;
  const Eigen::Vector3d& g = robot.gravity();
  KDL::Twist v = KDL::Twist::Zero(), a = -KDL::Twist(KDL::Vector(g.x(), g.y(), g.z()), KDL::Vector::Zero());
  for (int i = 0; i < n; ++i) {
    const KDL::Segment& seg = chain.getSegment(static_cast<unsigned>(i));
    X[static_cast<size_t>(i)] = seg.pose(q(i));
    S[static_cast<size_t>(i)] = X[static_cast<size_t>(i)].M.Inverse(seg.twist(q(i), 1.0));
    const KDL::Twist vj = S[static_cast<size_t>(i)] * qd(i);
    v = X[static_cast<size_t>(i)].Inverse(v) + vj;
    a = X[static_cast<size_t>(i)].Inverse(a) + S[static_cast<size_t>(i)] * qdd(i) + v * vj;
    A[static_cast<size_t>(i)] = body_wrench_regressor(vec(v.vel), vec(v.rot), vec(a.vel), vec(a.rot));
  }
  Phi.setZero();
  for (int j = 0; j < n; ++j) {
    Matrix6x10 W = A[static_cast<size_t>(j)];
    for (int i = j; i >= 0; --i) {
      const KDL::Twist& s = S[static_cast<size_t>(i)];
      Eigen::Matrix<double, 1, 6> st;
      st << s.vel.x(), s.vel.y(), s.vel.z(), s.rot.x(), s.rot.y(), s.rot.z();
      Phi.block<1, 10>(i, 10 * j) = st * W;
      transform_wrenches(X[static_cast<size_t>(i)], W);
    }
  }
  if (with_friction) {
    for (int i = 0; i < n; ++i) {
      Phi(i, 10 * n + i) = qd(i);
      Phi(i, 11 * n + i) = static_cast<double>((qd(i) > 0) - (qd(i) < 0));
    }
  }
}

Eigen::MatrixXd stacked_regressor(const RobotModel& robot, const Eigen::MatrixXd& X, bool with_friction) {
  const int n = robot.num_joints();
  if (X.cols() != 3 * n) throw Error("inputs must have 3n = " + std::to_string(3 * n) + " columns (q, qd, qdd)");
  Eigen::MatrixXd Y(X.rows() * n, with_friction ? 12 * n : 10 * n);
  RegressorWorkspace workspace(robot);
  Eigen::VectorXd x(3 * n);
  for (Eigen::Index r = 0; r < X.rows(); ++r) {
    x = X.row(r).transpose();
    regressor_into(robot, x.data(), x.data() + n, x.data() + 2 * n, with_friction, workspace, Y.middleRows(r * n, n));
  }
  return Y;
}

Eigen::VectorXd BaseParameters::from_full(const Eigen::VectorXd& w) const {
  return w(independent) + K * w(dependent);
}

Eigen::MatrixXd BaseParameters::select(const Eigen::MatrixXd& Phi) const { return Phi(Eigen::all, independent); }

BaseParameters compute_base_parameters(const RobotModel& robot, bool with_friction, int samples, std::uint64_t seed) {
  const int n = robot.num_joints();
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  Eigen::MatrixXd X(samples, 3 * n);
  for (int r = 0; r < samples; ++r)
    for (int i = 0; i < n; ++i) {
      const JointLimits& l = robot.joint(i).limits;
      X(r, i) = 0.5 * (l.lower + l.upper) + 0.5 * (l.upper - l.lower) * u(rng);
      X(r, n + i) = 2.0 * u(rng);
      X(r, 2 * n + i) = 5.0 * u(rng);
    }
  const Eigen::MatrixXd Y = stacked_regressor(robot, X, with_friction);
  // Scale columns so the rank decision does not depend on units. Columns that
  // are zero up to rounding (parameters that never act on any joint) are zeroed,
  // not scaled: scaling would blow their rounding noise up to unit norm.
  Eigen::VectorXd scale = Y.colwise().norm().transpose();
  const double largest = scale.maxCoeff();
  Eigen::MatrixXd Ys = Y;
  for (Eigen::Index c = 0; c < scale.size(); ++c) {
    if (scale(c) <= 1e-10 * largest) {
      scale(c) = 1.0;
      Ys.col(c).setZero();
    } else {
      Ys.col(c) /= scale(c);
    }
  }
  Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr(Ys);
  qr.setThreshold(1e-10);
  BaseParameters b;
  b.rank = static_cast<int>(qr.rank());
  const auto& perm = qr.colsPermutation().indices();
  for (Eigen::Index k = 0; k < perm.size(); ++k) (k < b.rank ? b.independent : b.dependent).push_back(perm(k));
  const Eigen::MatrixXd R = qr.matrixR().topRows(b.rank);
  const Eigen::MatrixXd Ks = R.leftCols(b.rank).triangularView<Eigen::Upper>().solve(R.rightCols(Ys.cols() - b.rank));
  b.K = scale(b.independent).cwiseInverse().asDiagonal() * Ks * scale(b.dependent).asDiagonal();
  return b;
}

}  // namespace gipdyn
