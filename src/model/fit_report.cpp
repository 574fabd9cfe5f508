#include "gipdyn/model/fit_report.hpp"

#include <algorithm>
#include <cstdio>

#include "gipdyn/error.hpp"

namespace gipdyn {

std::string to_string(FitStatus status) {
  switch (status) {
    case FitStatus::Converged: return "converged";
    case FitStatus::NotConverged: return "not converged";
    case FitStatus::Completed: return "completed";
    case FitStatus::Failed: return "failed";
  }
  return "failed";
}

FitStatus combine_joint_statuses(const std::vector<JointReport>& joints) {
  FitStatus s = FitStatus::Converged;
  for (const auto& j : joints) {
    if (j.status == OptimizerResult::Status::Failed) return FitStatus::Failed;
    if (j.status != OptimizerResult::Status::Converged) s = FitStatus::NotConverged;
  }
  return s;
}

bool one_coupled_fit(const std::vector<JointReport>& joints) {
  return joints.size() > 1 &&  // one joint's report reads better as a joint's
         std::all_of(joints.begin(), joints.end(), [](const JointReport& j) { return j.coupled; });
}

namespace {

const char* const kOneCoupledFit = "the one fit of every joint";

// Reports that are told apart: a coupled fit's reports differ only in their
// noise, so its first stands for all of them.
size_t distinct_reports(const std::vector<JointReport>& joints) { return one_coupled_fit(joints) ? 1 : joints.size(); }

std::string starts_line(const JointReport& j) {
  std::string out = j.warm_start_evaluations > 0 ? " NLL over starts (warm-start subsample):"
                    : j.screening_evaluations > 0
                        ? " NLL over starts (those behind the leader stopped after " +
                              std::to_string(j.screening_evaluations) + " evaluations):"
                        : " NLL over starts:";
  char buf[32];
  for (double v : j.restart_nlls) {
    std::snprintf(buf, sizeof buf, " %.6g", v);
    out += buf;
  }
  return out + "\n";
}

}  // namespace

std::string FitReport::brief_report() const {
  char buf[200];
  std::snprintf(buf, sizeof buf, "fit %s in %.1f s", to_string(status).c_str(), seconds);
  std::string out = buf;
  if (!message.empty()) out += ": " + message;
  out += "\n";
  if (joints.empty()) return out;
  const bool coupled = one_coupled_fit(joints);
  out += " joint  status     NLL            evals  (warm)  |grad|     noise var  jitter   seconds\n";
  // A coupled fit gets one row and its noise per joint below it.
  const size_t rows = distinct_reports(joints);
  for (size_t k = 0; k < rows; ++k) {
    const JointReport& j = joints[k];
    std::string joint = "all", noise = "below";
    if (!coupled) {
      joint = std::to_string(j.joint + 1);
      std::snprintf(buf, sizeof buf, "%.2e", j.noise_variance);
      noise = buf;
    }
    std::snprintf(buf, sizeof buf, " %5s  %-9s  %-13.6g  %5d  %6d  %-9.2e  %-9s  %-7.1e  %7.1f\n", joint.c_str(),
                  to_string(j.status).c_str(), j.nll, j.evaluations, j.warm_start_evaluations, j.grad_norm,
                  noise.c_str(), j.jitter, j.seconds);
    out += buf;
  }
  if (coupled) {
    out += " one fit learned every joint together; noise var per joint:";
    for (const auto& j : joints) {
      std::snprintf(buf, sizeof buf, " %.2e", j.noise_variance);
      out += buf;
    }
    out += "\n";
  }
  if (joints.front().hyperparameter_rows > 0)
    out += " hyperparameters learned on " + std::to_string(joints.front().hyperparameter_rows) +
           " rows (a constant-step subsample), the model conditioned on every row\n";
  for (size_t k = 0; k < rows; ++k) {
    const JointReport& j = joints[k];
    if (j.restart_nlls.size() >= 2)
      out += (coupled ? std::string() : " joint " + std::to_string(j.joint + 1)) + starts_line(j);
  }
  return out;
}

std::vector<std::string> convergence_warnings(const std::vector<JointReport>& joints) {
  std::vector<std::string> out;
  std::vector<std::ptrdiff_t> capped_joints, stalled_joints;
  const bool coupled = one_coupled_fit(joints);
  for (const auto& j : joints) {
    if (j.status == OptimizerResult::Status::MaxIterations) capped_joints.push_back(j.joint);
    if (j.status == OptimizerResult::Status::Stalled) stalled_joints.push_back(j.joint);
  }
  const auto who = [&](const std::vector<std::ptrdiff_t>& numbers) {
    if (numbers.empty()) return std::string();
    return coupled ? std::string(kOneCoupledFit) : "joint(s) " + joint_numbers(numbers);
  };
  const std::string capped = who(capped_joints), stalled = who(stalled_joints);
  if (!capped.empty())
    out.push_back(capped + " stopped at the evaluation limit before converging; raise OptimizerOptions::max_iterations");
  if (!stalled.empty())
    out.push_back(stalled +
                  " stalled (the line search broke down with more decrease left along the gradient than the NLL's "
                  "rounding hides) before converging; more starts (SearchSettings::restarts) may find a lower NLL");
  return out;
}

namespace {

// Jitter acts as extra noise on the rows the model is conditioned on: beside
// the noise the fit learned it says whether the model still fits its data.
std::string jitter_warning(const JointReport& j, bool coupled) {
  char amount[96];
  std::snprintf(amount, sizeof amount, " needed a jitter of %.3g on the kernel diagonal", j.jitter);
  std::string out = (coupled ? std::string(kOneCoupledFit) : "joint " + std::to_string(j.joint + 1)) + amount;
  if (j.noise_variance > 0.0 && j.jitter > j.noise_variance) {
    char times[160];
    std::snprintf(times, sizeof times,
                  ", %.2g times the noise variance it learned, so the model is smoothed more than its data ask and "
                  "may predict badly (check it on held-out rows)",
                  j.jitter / j.noise_variance);
    out += times;
  }
  return out + "; raise SearchSettings::min_noise_fraction or remove duplicate rows";
}

}  // namespace

std::vector<std::string> FitReport::warnings() const {
  std::vector<std::string> out = convergence_warnings(joints);
  const bool coupled = one_coupled_fit(joints);
  for (size_t k = 0; k < distinct_reports(joints); ++k)
    if (joints[k].jitter > 0.0) out.push_back(jitter_warning(joints[k], coupled));
  if (std::string noisy = noise_share_warning(joints); !noisy.empty()) out.push_back(std::move(noisy));
  return out;
}

std::string noise_share_warning(const std::vector<JointReport>& joints) {
  std::string noisy;
  for (const auto& j : joints)
    if (j.noise_share >= kNoiseShareWarning) {  // false for NaN
      char share[32];
      std::snprintf(share, sizeof share, " (%.0f %%)", 100.0 * std::min(j.noise_share, 1.0));
      noisy += (noisy.empty() ? "" : ", ") + std::to_string(j.joint + 1) + share;
    }
  if (noisy.empty()) return noisy;
  return "joint(s) " + noisy +
         ": the fit calls most of the torque noise, so predictions there stay near the training mean; the torque may "
         "be below the sensor noise or not a function of q, qd, qdd (check the data, or learn from a motion that "
         "loads the joint more)";
}

}  // namespace gipdyn
