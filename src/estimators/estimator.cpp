#include "gipdyn/estimators/estimator.hpp"

#include <nlohmann/json.hpp>

#include "gipdyn/detail/rigid_body_queries.hpp"
#include "gipdyn/estimators/estimator_registry.hpp"

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
  detail::rigid_body_terms_by_queries(static_cast<int>(tau_.size()), q, qd, x_.data(), tau_.data(), gravity, M, bias,
                                      [this](const double* x, double* tau) { predict(x, tau); });
}

std::unique_ptr<QueryWorkspace> Estimator::make_query_workspace() const {
  return std::make_unique<BatchQueryWorkspace>(*this);
}

bool Estimator::gives_rigid_body_terms() const { return estimator_spec(name()).rigid_body_terms; }

std::string Estimator::why_no_rigid_body_terms() const {
  return "its torque is not affine in the accelerations";
}

bool Estimator::gives_uncertainty() const { return estimator_spec(name()).predictive_variance; }

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
