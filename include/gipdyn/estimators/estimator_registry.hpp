#pragma once
// The estimators by name:
//   GP kernels  gip, gip-friction, rbf, gip+rbf, gip-friction+rbf, gip+friction, gip+friction+rbf, gip-envelope, gip-envelope+friction, pp, sp
//   lip         one GP over all joints with the Lagrangian kernel (energies)
//   fe          least squares on the rigid-body regressor (base parameters)
//   chain       fe on a serial chain whose geometry is identified from the log (robot/chain_identification.hpp)
//   nn          fully connected network (docs/method.md)
// fe, pp and sp are model-based: they need the nominal robot.
#include <string>
#include <vector>

namespace gipdyn {

// How an estimator is fitted and stored: its model file's "estimator" entry.
enum class EstimatorFamily { Gp, Lagrangian, Fisherian, NeuralNetwork };

// Names accepted by fit_estimator: the GP kernels, then lip, fe and nn.
const std::vector<std::string>& estimator_names();
// Throws gipdyn::Error listing the valid names unless `name` is one of them.
EstimatorFamily estimator_family(const std::string& name);
// The per-joint GP kernels (not lip).
bool is_gp_estimator(const std::string& name);
// GP kernels and lip: hyperparameters by marginal likelihood, cost cubic in the rows.
bool is_kernel_estimator(const std::string& name);
bool estimator_needs_robot(const std::string& name);
void require_known_estimator(const std::string& name);

}  // namespace gipdyn
