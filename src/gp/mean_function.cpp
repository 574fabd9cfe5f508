#include "gipdyn/gp/mean_function.hpp"

#include "gipdyn/error.hpp"

namespace gipdyn {

MeanKind parse_mean_kind(const std::string& name) {
  if (name == "zero") return MeanKind::Zero;
  if (name == "constant") return MeanKind::Constant;
  if (name == "linear") return MeanKind::Linear;
  throw Error("GpOptions::mean '" + name + "' is unknown; choose zero, constant or linear");
}

std::string to_string(MeanKind kind) {
  switch (kind) {
    case MeanKind::Zero: return "zero";
    case MeanKind::Constant: return "constant";
    case MeanKind::Linear: return "linear";
  }
  return "zero";
}

MeanFunction::MeanFunction(MeanKind kind, int input_dim) : kind_(kind), input_dim_(input_dim) {
  if (input_dim < 0) throw Error("mean function: input dimension must be >= 0");
  beta_ = Eigen::VectorXd::Zero(num_params());
}

int MeanFunction::num_params() const {
  switch (kind_) {
    case MeanKind::Zero: return 0;
    case MeanKind::Constant: return 1;
    case MeanKind::Linear: return 1 + input_dim_;
  }
  return 0;
}

void MeanFunction::set_params(const Eigen::VectorXd& beta) {
  if (beta.size() != num_params())
    throw Error("a " + to_string(kind_) + " mean has " + std::to_string(num_params()) + " coefficients, not " +
                std::to_string(beta.size()));
  beta_ = beta;
}

std::vector<std::string> MeanFunction::param_names() const {
  std::vector<std::string> names;
  if (kind_ == MeanKind::Zero) return names;
  names.push_back("mean.constant");
  if (kind_ == MeanKind::Linear)
    for (int k = 1; k <= input_dim_; ++k) names.push_back("mean.x" + std::to_string(k));
  return names;
}

void MeanFunction::basis(const Eigen::Ref<const Eigen::MatrixXd>& X, Eigen::MatrixXd& H) const {
  if (kind_ == MeanKind::Linear && X.cols() != input_dim_)
    throw Error("linear mean: inputs have " + std::to_string(X.cols()) + " columns, expected " +
                std::to_string(input_dim_));
  H.resize(X.rows(), num_params());
  if (kind_ == MeanKind::Zero) return;
  H.col(0).setOnes();
  if (kind_ == MeanKind::Linear) H.rightCols(input_dim_) = X;
}

Eigen::VectorXd MeanFunction::evaluate(const Eigen::Ref<const Eigen::MatrixXd>& X) const {
  if (kind_ == MeanKind::Zero) return Eigen::VectorXd::Zero(X.rows());
  Eigen::MatrixXd H;
  basis(X, H);
  return H * beta_;
}

double MeanFunction::evaluate_one(const double* x) const {
  if (kind_ == MeanKind::Zero) return 0.0;
  double m = beta_(0);
  if (kind_ == MeanKind::Linear)
    for (int k = 0; k < input_dim_; ++k) m += beta_(k + 1) * x[k];
  return m;
}

}  // namespace gipdyn
