#pragma once
// Prior mean functions of a GP: m(x) = h(x)^T beta with the basis
//   zero:     h(x) = []                 (the paper's GPs)
//   constant: h(x) = [1]
//   linear:   h(x) = [1, q, qd, qdd]    (the raw 3n inputs, not the kernel's features)
// beta maximises the marginal likelihood for the kernel's hyperparameters: it is
// profiled out by generalised least squares (evaluate_profiled_nll in
// exact_gp.hpp), so the optimiser never sees it. Unlike kernel parameters the
// coefficients are signed, so they are stored as they are, not in log space.
#include <Eigen/Dense>
#include <string>
#include <vector>

#include "gipdyn/eigen_abi.hpp"

namespace gipdyn {

enum class MeanKind { Zero, Constant, Linear };
MeanKind parse_mean_kind(const std::string& name);  // zero | constant | linear
std::string to_string(MeanKind kind);

class MeanFunction {
 public:
  MeanFunction() = default;  // zero mean
  MeanFunction(MeanKind kind, int input_dim);

  MeanKind kind() const { return kind_; }
  int input_dim() const { return input_dim_; }
  int num_params() const;
  const Eigen::VectorXd& params() const { return beta_; }
  void set_params(const Eigen::VectorXd& beta);  // throws gipdyn::Error on a wrong length
  // "mean.constant", then "mean.x1" .. "mean.x<3n>" for a linear mean.
  std::vector<std::string> param_names() const;

  // H: rows(X) x num_params() basis matrix.
  void basis(const Eigen::Ref<const Eigen::MatrixXd>& X, Eigen::MatrixXd& H) const;
  Eigen::VectorXd evaluate(const Eigen::Ref<const Eigen::MatrixXd>& X) const;
  double evaluate_one(const double* x) const;  // no allocation: the control-loop path

 private:
  MeanKind kind_ = MeanKind::Zero;
  int input_dim_ = 0;
  Eigen::VectorXd beta_;
};

}  // namespace gipdyn
