// Cross-check with an independent implementation: an RBF GP with fixed
// hyperparameters against scikit-learn's GaussianProcessRegressor
// (tests/sklearn_reference.py writes its answers; CTest runs it first).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "gipdyn/gp/exact_gp.hpp"
#include "gipdyn/kernels/rbf_kernel.hpp"

namespace gipdyn {
namespace {

Eigen::MatrixXd read_plain_csv(const std::string& path) {
  std::ifstream in(path);
  EXPECT_TRUE(in.good()) << path;
  std::vector<std::vector<double>> rows;
  std::string line;
  while (std::getline(in, line)) {
    std::stringstream ss(line);
    std::string cell;
    rows.emplace_back();
    while (std::getline(ss, cell, ',')) rows.back().push_back(std::stod(cell));
  }
  Eigen::MatrixXd M(static_cast<Eigen::Index>(rows.size()), static_cast<Eigen::Index>(rows[0].size()));
  for (size_t r = 0; r < rows.size(); ++r)
    for (size_t c = 0; c < rows[r].size(); ++c) M(static_cast<Eigen::Index>(r), static_cast<Eigen::Index>(c)) = rows[r][c];
  return M;
}

TEST(SklearnCrossCheck, RbfPosteriorAndLikelihoodAgree) {
  const char* dir_env = std::getenv("GIPDYN_SKLEARN_DIR");
  ASSERT_NE(dir_env, nullptr) << "run through ctest (the fixture writes the reference data)";
  const std::string dir = dir_env;
  const Eigen::MatrixXd train = read_plain_csv(dir + "/train.csv");
  const Eigen::MatrixXd Xs = read_plain_csv(dir + "/test.csv");
  const Eigen::MatrixXd expected = read_plain_csv(dir + "/expected.csv");
  std::ifstream jf(dir + "/expected.json");
  const nlohmann::json ref = nlohmann::json::parse(jf);

  const Eigen::Index D = train.cols() - 1;
  const Eigen::MatrixXd X = train.leftCols(D);
  const Eigen::VectorXd y = train.col(D);
  std::vector<int> cols;
  std::vector<std::string> labels;
  for (int d = 0; d < D; ++d) {
    cols.push_back(d);
    labels.push_back("x" + std::to_string(d));
  }
  auto k = std::make_unique<RbfKernel>(cols, labels);
  Eigen::VectorXd p(D + 1);
  p(0) = std::log(ref["variance"].get<double>());
  const auto ell = ref["lengthscales"].get<std::vector<double>>();
  for (int d = 0; d < D; ++d) p(1 + d) = std::log(ell[static_cast<size_t>(d)]);
  k->set_log_params(p);
  const double log_noise = std::log(ref["noise"].get<double>());

  GpWorkspace ws;
  const NllEvaluation e = evaluate_nll(*k, log_noise, X, y, false, ws);
  ASSERT_TRUE(e.ok());
  const double lml = ref["log_marginal_likelihood"].get<double>();
  EXPECT_NEAR(-e.nll, lml, 1e-8 * std::abs(lml));

  GpRegressor gp(std::move(k), log_noise);
  ASSERT_TRUE(gp.fit(X, y, true, ws).ok());
  Eigen::VectorXd mean, var;
  gp.predict_mean(Xs, X, mean);
  gp.predict_variance(Xs, X, var);
  for (Eigen::Index i = 0; i < Xs.rows(); ++i) {
    EXPECT_NEAR(mean(i), expected(i, 0), 1e-8 * std::max(1.0, std::abs(expected(i, 0)))) << "mean " << i;
    EXPECT_NEAR(var(i), expected(i, 1), 1e-8 * std::max(1e-2, std::abs(expected(i, 1)))) << "variance " << i;
  }
}

}  // namespace
}  // namespace gipdyn
