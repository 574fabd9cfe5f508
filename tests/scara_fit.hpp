#pragma once
// Fitting an estimator on simulated SCARA data, shared by the tests that use
// learned models (physics, closed loop).
#include <gtest/gtest.h>

#include <memory>
#include <string>

#include "gipdyn/estimators/fit_estimator.hpp"
#include "gipdyn/robot/robot_loader.hpp"
#include "gipdyn/sim/simulate.hpp"

namespace gipdyn::test {

// At most 100 NLL evaluations per start; the model-based estimators get the
// true SCARA as their nominal robot (with friction columns if asked).
inline std::unique_ptr<Estimator> fit_on_scara(const std::string& name, const SimulationResult& d,
                                               bool robot_friction = false) {
  EstimatorOptions o;
  o.name = name;
  o.search.optimizer.max_iterations = 100;
  if (estimator_needs_robot(name)) o.robot_prior = {std::make_shared<const RobotModel>(scara_robot()), robot_friction};
  FitResult r = fit_estimator(o, d.X, d.tau, scara_robot().joint_types());
  EXPECT_TRUE(r.report.ok()) << r.report.message;
  return std::move(r.estimator);
}

}  // namespace gipdyn::test
