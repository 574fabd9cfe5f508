#pragma once
// Numbers that may not exist (a failed fit's NLL, the nMSE of a constant torque) are NaN in
// memory; JSON has no NaN, so model files and reports hold them as null.
#include <Eigen/Dense>
#include <nlohmann/json.hpp>

#include "gipdyn/eigen_abi.hpp"

namespace gipdyn {

nlohmann::json number_or_null(double v);
nlohmann::json numbers_or_null(const Eigen::VectorXd& v);  // a JSON array
double number_or_nan(const nlohmann::json& v);

}  // namespace gipdyn
