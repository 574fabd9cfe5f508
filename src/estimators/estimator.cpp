#include "gipdyn/estimators/estimator.hpp"

#include <nlohmann/json.hpp>

namespace gipdyn {
namespace {

// Any estimator, one row at a time through its batch predict(): correct, but
// each query allocates the row and the result.
class BatchQueryWorkspace final : public QueryWorkspace {
 public:
  explicit BatchQueryWorkspace(const Estimator& estimator) : estimator_(estimator) {}
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

std::unique_ptr<QueryWorkspace> Estimator::make_query_workspace() const {
  return std::make_unique<BatchQueryWorkspace>(*this);
}

void Estimator::set_teaching_record(const nlohmann::json& record) {
  teaching_record_ = record.is_null() ? nullptr : std::make_shared<const nlohmann::json>(record);
}

void Estimator::set_selection_record(const nlohmann::json& record) {
  selection_record_ = record.is_null() ? nullptr : std::make_shared<const nlohmann::json>(record);
}

}  // namespace gipdyn
