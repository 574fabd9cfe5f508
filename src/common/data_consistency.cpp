#include "gipdyn/data_consistency.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include "gipdyn/error.hpp"
#include "gipdyn/joint_types.hpp"
#include "gipdyn/training_data.hpp"

namespace gipdyn {

void NeighbourConsistencyOptions::validate() const {
  if (!(radius > 0.0) || !std::isfinite(radius))
    throw Error("NeighbourConsistencyOptions::radius must be a finite number > 0, e.g. 0.1");
  if (min_separation_rows < 0) throw Error("NeighbourConsistencyOptions::min_separation_rows must be >= 0");
  if (max_queries < 1) throw Error("NeighbourConsistencyOptions::max_queries must be >= 1");
  if (min_pairs < 1) throw Error("NeighbourConsistencyOptions::min_pairs must be >= 1");
  if (!joints.empty()) {
    try {
      JointTypes::parse(joints);
    } catch (const Error& e) {
      throw Error(std::string("NeighbourConsistencyOptions::joints: ") + e.what());
    }
  }
}

std::string to_string(NeighbourConsistency::Status status) {
  return status == NeighbourConsistency::Status::Ok ? "ok" : "too-few-pairs";
}

namespace {

void require_log(const Eigen::MatrixXd& X, const Eigen::MatrixXd& tau, const char* what) {
  const std::string name(what);
  if (tau.cols() < 1) throw Error(name + ": no torque columns");
  if (X.cols() != 3 * tau.cols())
    throw Error(name + ": " + std::to_string(X.cols()) + " input columns for " + std::to_string(tau.cols()) +
                " joints; give q, qd and qdd of every joint (3 x joints columns)");
  if (X.rows() != tau.rows())
    throw Error(name + ": " + std::to_string(X.rows()) + " input rows but " + std::to_string(tau.rows()) +
                " torque rows");
  if (X.rows() < 2) throw Error(name + ": at least 2 rows are needed");
  if (!X.allFinite() || !tau.allFinite())
    throw Error(name + ": a value is NaN or infinite; remove or repair those rows first");
}

// The compared inputs (q, qd and optionally qdd), each divided by its standard
// deviation over the reference rows; columns that do not vary there are left
// out. A revolute position on the circle becomes two coordinates, cos q / sd
// and sin q / sd: their distance, 2 sin(dq / 2) / sd, is dq / sd for the small
// dq of a neighbour, and zero for dq = 2 pi. Its sd is that of q wrapped around
// its circular mean, so that turns do not count as spread.
struct Standardiser {
  std::vector<Eigen::Index> columns;
  std::vector<bool> on_circle;
  Eigen::RowVectorXd mean, scale;

  Standardiser(const Eigen::MatrixXd& reference, int joints, bool accelerations, const std::string& joint_types) {
    const Eigen::Index used = (accelerations ? 3 : 2) * joints;
    const std::vector<bool> revolute = revolute_positions(joint_types, joints);
    std::vector<double> m, s;
    for (Eigen::Index c = 0; c < used; ++c) {
      const bool circle = c < joints && revolute[static_cast<size_t>(c)];
      double mu = reference.col(c).mean(), sd = 0.0;
      if (circle) {
        const double centre = std::atan2(reference.col(c).array().sin().mean(), reference.col(c).array().cos().mean());
        const Eigen::ArrayXd d = (reference.col(c).array() - centre).unaryExpr(
            [](double x) { return std::remainder(x, 2.0 * M_PI); });
        sd = std::sqrt(std::max(0.0, d.square().mean() - d.mean() * d.mean()));
        mu = 0.0;
      } else {
        sd = std::sqrt((reference.col(c).array() - mu).square().mean());
      }
      if (!(sd > 1e-12 * (1.0 + std::abs(mu)))) continue;
      columns.push_back(c);
      on_circle.push_back(circle);
      m.push_back(mu);
      s.push_back(sd);
    }
    mean = Eigen::Map<Eigen::RowVectorXd>(m.data(), static_cast<Eigen::Index>(m.size()));
    scale = Eigen::Map<Eigen::RowVectorXd>(s.data(), static_cast<Eigen::Index>(s.size()));
  }

  static std::vector<bool> revolute_positions(const std::string& joint_types, int joints) {
    std::vector<bool> revolute(static_cast<size_t>(joints), false);
    if (joint_types.empty()) return revolute;
    const JointTypes types = JointTypes::parse(joint_types);
    if (types.size() != joints)
      throw Error("NeighbourConsistencyOptions::joints names " + std::to_string(types.size()) +
                  " joints but the log has " + std::to_string(joints) + "; give one R or P per joint");
    for (int j = 0; j < joints; ++j) revolute[static_cast<size_t>(j)] = types.is_revolute(j);
    return revolute;
  }

  Eigen::Index width() const {
    return static_cast<Eigen::Index>(columns.size()) +
           static_cast<Eigen::Index>(std::count(on_circle.begin(), on_circle.end(), true));
  }

  Eigen::MatrixXd apply(const Eigen::MatrixXd& X, const std::vector<Eigen::Index>& rows) const {
    Eigen::MatrixXd Z(static_cast<Eigen::Index>(rows.size()), width());
    for (Eigen::Index r = 0; r < Z.rows(); ++r) {
      Eigen::Index z = 0;
      for (size_t c = 0; c < columns.size(); ++c) {
        const double x = X(rows[static_cast<size_t>(r)], columns[c]);
        const Eigen::Index k = static_cast<Eigen::Index>(c);
        if (on_circle[c]) {
          Z(r, z++) = std::cos(x) / scale(k);
          Z(r, z++) = std::sin(x) / scale(k);
        } else {
          Z(r, z++) = (x - mean(k)) / scale(k);
        }
      }
    }
    return Z;
  }
};

std::vector<Eigen::Index> all_rows(Eigen::Index n) {
  std::vector<Eigen::Index> rows(static_cast<size_t>(n));
  for (Eigen::Index i = 0; i < n; ++i) rows[static_cast<size_t>(i)] = i;
  return rows;
}

// For every query, the nearest reference row (by squared distance) that is at
// least `separation` rows away when both come from one log (separation < 0:
// different logs). Blocks of GEMM keep memory small for long logs.
void nearest(const Eigen::MatrixXd& Q, const std::vector<Eigen::Index>& query_rows, const Eigen::MatrixXd& R,
             long separation, Eigen::VectorXd& best_d2, std::vector<Eigen::Index>& best_index) {
  constexpr Eigen::Index kQueryBlock = 256, kReferenceBlock = 4096;
  best_d2.setConstant(Q.rows(), std::numeric_limits<double>::infinity());
  best_index.assign(static_cast<size_t>(Q.rows()), -1);
  const Eigen::VectorXd qn = Q.rowwise().squaredNorm(), rn = R.rowwise().squaredNorm();
  Eigen::MatrixXd D;
  for (Eigen::Index q0 = 0; q0 < Q.rows(); q0 += kQueryBlock) {
    const Eigen::Index qb = std::min(kQueryBlock, Q.rows() - q0);
    for (Eigen::Index r0 = 0; r0 < R.rows(); r0 += kReferenceBlock) {
      const Eigen::Index rb = std::min(kReferenceBlock, R.rows() - r0);
      D.noalias() = -2.0 * Q.middleRows(q0, qb) * R.middleRows(r0, rb).transpose();
      for (Eigen::Index j = 0; j < rb; ++j)
        for (Eigen::Index i = 0; i < qb; ++i) {
          const Eigen::Index row = query_rows[static_cast<size_t>(q0 + i)];
          if (separation >= 0 && std::abs(row - (r0 + j)) < separation) continue;
          const double d2 = std::max(0.0, D(i, j) + qn(q0 + i) + rn(r0 + j));
          if (d2 < best_d2(q0 + i)) {
            best_d2(q0 + i) = d2;
            best_index[static_cast<size_t>(q0 + i)] = r0 + j;
          }
        }
    }
  }
}

NeighbourConsistency compare(const Eigen::MatrixXd& reference_X, const Eigen::MatrixXd& reference_tau,
                             const Eigen::MatrixXd& query_X, const Eigen::MatrixXd& query_tau, bool same_log,
                             const NeighbourConsistencyOptions& o) {
  o.validate();
  const int joints = static_cast<int>(reference_tau.cols());
  const Standardiser standardise(reference_X, joints, o.use_accelerations, o.joints);
  if (standardise.columns.empty())
    throw Error("neighbour_consistency: no input column varies over the reference rows; the robot never moved");
  const std::vector<Eigen::Index> queries = constant_step_indices(query_X.rows(), o.max_queries);
  const Eigen::MatrixXd Q = standardise.apply(query_X, queries);
  const Eigen::MatrixXd R = standardise.apply(reference_X, all_rows(reference_X.rows()));
  Eigen::VectorXd best_d2;
  std::vector<Eigen::Index> best;
  nearest(Q, queries, R, same_log ? o.min_separation_rows : -1, best_d2, best);

  NeighbourConsistency out;
  out.queries = static_cast<long>(queries.size());
  std::vector<std::pair<Eigen::Index, Eigen::Index>> pairs;
  for (size_t k = 0; k < queries.size(); ++k)
    if (best[k] >= 0 && best_d2(static_cast<Eigen::Index>(k)) <= o.radius * o.radius) pairs.emplace_back(queries[k], best[k]);
  out.pairs = static_cast<long>(pairs.size());
  out.neighbour_nmse = Eigen::VectorXd::Constant(joints, std::numeric_limits<double>::quiet_NaN());
  out.correlation = out.neighbour_nmse;
  if (out.pairs < o.min_pairs) {
    out.status = NeighbourConsistency::Status::TooFewPairs;
    out.message = "only " + std::to_string(out.pairs) + " of " + std::to_string(out.queries) +
                  " query rows have a neighbour within NeighbourConsistencyOptions::radius (" +
                  std::to_string(o.radius) + " standard deviations" +
                  (same_log ? ", at least " + std::to_string(o.min_separation_rows) + " rows apart" : std::string()) +
                  "), fewer than min_pairs (" + std::to_string(o.min_pairs) +
                  "); raise the radius, or the rows do not visit the same states twice";
    return out;
  }
  for (int j = 0; j < joints; ++j) {
    Eigen::VectorXd a(out.pairs), b(out.pairs), all(out.queries);
    for (long k = 0; k < out.pairs; ++k) {
      a(k) = query_tau(pairs[static_cast<size_t>(k)].first, j);
      b(k) = reference_tau(pairs[static_cast<size_t>(k)].second, j);
    }
    for (long k = 0; k < out.queries; ++k) all(k) = query_tau(queries[static_cast<size_t>(k)], j);
    const double variance = (all.array() - all.mean()).square().mean();
    out.neighbour_nmse(j) = variance > 0.0 ? (a - b).squaredNorm() / static_cast<double>(out.pairs) / variance
                                           : std::numeric_limits<double>::quiet_NaN();
    const Eigen::ArrayXd da = a.array() - a.mean(), db = b.array() - b.mean();
    const double denominator = std::sqrt(da.square().sum() * db.square().sum());
    out.correlation(j) = denominator > 0.0 ? (da * db).sum() / denominator : std::numeric_limits<double>::quiet_NaN();
  }
  out.status = NeighbourConsistency::Status::Ok;
  return out;
}

}  // namespace

NeighbourConsistency neighbour_consistency(const Eigen::MatrixXd& X, const Eigen::MatrixXd& tau,
                                           const NeighbourConsistencyOptions& options) {
  require_log(X, tau, "neighbour_consistency");
  return compare(X, tau, X, tau, true, options);
}

NeighbourConsistency neighbour_consistency(const Eigen::MatrixXd& reference_X, const Eigen::MatrixXd& reference_tau,
                                           const Eigen::MatrixXd& query_X, const Eigen::MatrixXd& query_tau,
                                           const NeighbourConsistencyOptions& options) {
  require_log(reference_X, reference_tau, "neighbour_consistency (reference)");
  require_log(query_X, query_tau, "neighbour_consistency (query)");
  if (query_tau.cols() != reference_tau.cols())
    throw Error("neighbour_consistency: the query log has " + std::to_string(query_tau.cols()) +
                " joints but the reference log " + std::to_string(reference_tau.cols()));
  return compare(reference_X, reference_tau, query_X, query_tau, false, options);
}

}  // namespace gipdyn
