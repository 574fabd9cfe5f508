#include "gipdyn/estimators/estimator.hpp"

#include <algorithm>
#include <nlohmann/json.hpp>

namespace gipdyn {
namespace {

// Any estimator, one row at a time through its batch predict(): correct, but
// each query allocates the row and the result.
class BatchQueryWorkspace final : public QueryWorkspace {
 public:
  explicit BatchQueryWorkspace(const Estimator& estimator)
      : QueryWorkspace(estimator.joints().size()), estimator_(estimator) {}
  void predict(const double* x, double* tau) override {
    const int n = estimator_.joints().size();
    const Eigen::MatrixXd t = estimator_.predict(Eigen::Map<const Eigen::RowVectorXd>(x, 3 * n));
    Eigen::Map<Eigen::RowVectorXd>(tau, n) = t.row(0);
  }
  bool allocation_free() const override { return false; }

 private:
  const Estimator& estimator_;
};

}  // namespace

QueryWorkspace::QueryWorkspace(int num_joints)
    : x_(3 * static_cast<size_t>(num_joints)), tau_(static_cast<size_t>(num_joints)) {}

void QueryWorkspace::rigid_body_terms(const double* q, const double* qd, double* gravity, double* M, double* bias) {
  const size_t n = tau_.size();
  std::fill(x_.begin(), x_.end(), 0.0);
  std::copy(q, q + n, x_.begin());
  predict(x_.data(), gravity);
  // Torque is affine in qdd: one unit acceleration of joint j gives column j of M over gravity.
  for (size_t j = 0; j < n; ++j) {
    x_[2 * n + j] = 1.0;
    predict(x_.data(), tau_.data());
    x_[2 * n + j] = 0.0;
    for (size_t i = 0; i < n; ++i) M[i * n + j] = tau_[i] - gravity[i];
  }
  if (bias) {
    std::copy(qd, qd + n, x_.begin() + static_cast<std::ptrdiff_t>(n));
    predict(x_.data(), bias);
  }
}

std::unique_ptr<QueryWorkspace> Estimator::make_query_workspace() const {
  return std::make_unique<BatchQueryWorkspace>(*this);
}

void Estimator::set_teaching_record(const nlohmann::json& record) {
  teaching_record_ = record.is_null() ? nullptr : std::make_shared<const nlohmann::json>(record);
}

void Estimator::set_options_record(const nlohmann::json& record) {
  options_record_ = record.is_null() ? nullptr : std::make_shared<const nlohmann::json>(record);
}

void Estimator::set_selection_record(const nlohmann::json& record) {
  selection_record_ = record.is_null() ? nullptr : std::make_shared<const nlohmann::json>(record);
}

}  // namespace gipdyn
