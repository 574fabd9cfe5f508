#include "gipdyn/estimators/model_selection.hpp"

#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>
#include <optional>
#include <algorithm>

#include <nlohmann/json.hpp>

#include "gipdyn/error.hpp"
#include "gipdyn/io/detail/json_numbers.hpp"
#include "gipdyn/estimators/per_joint_estimator.hpp"
#include "gipdyn/metrics.hpp"
#include "gipdyn/training_data.hpp"

namespace gipdyn {
namespace {

// Fewer rows than these leave no block of time worth scoring on, or nothing to fit.
constexpr Eigen::Index kMinHeldOutRows = 10;
constexpr Eigen::Index kMinFitRows = 20;

double seconds_since(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

// The mean of the per-joint nMSE over the joints whose held-out torque varies (a constant one has none).
double mean_over_varying(const Eigen::VectorXd& nmse, const Eigen::VectorXd& variance) {
  double sum = 0.0;
  int count = 0;
  for (Eigen::Index j = 0; j < nmse.size(); ++j)
    if (variance(j) > 0.0) {
      sum += nmse(j);
      ++count;
    }
  return count > 0 ? sum / count : 0.0;
}

// Per joint: `overall` (the choice by mean nMSE), unless the joint's lowest nMSE is below overall's on it divided
// by `factor` (never where the joint's held-out torque is constant: no candidate can be told from another there);
// then the first scored candidate, in the order of preference, within `tolerance` of that lowest nMSE. So a joint
// leaves the overall choice only for a candidate that predicted it far better, and most models stay one estimator.
std::vector<std::string> choose_per_joint(const std::vector<CandidateScore>& candidates,
                                          const Eigen::VectorXd& held_variance, double factor, double tolerance,
                                          const std::string& overall) {
  std::vector<std::string> chosen(static_cast<size_t>(held_variance.size()), overall);
  for (Eigen::Index j = 0; j < held_variance.size(); ++j) {
    if (!(held_variance(j) > 0.0)) continue;
    double best = std::numeric_limits<double>::infinity(), overall_nmse = best;
    for (const CandidateScore& c : candidates)
      if (c.ok && std::isfinite(c.nmse(j))) {
        best = std::min(best, c.nmse(j));
        if (c.name == overall) overall_nmse = c.nmse(j);
      }
    if (!(best * factor < overall_nmse)) continue;
    for (const CandidateScore& c : candidates)
      if (c.ok && c.nmse(j) <= best * (1.0 + tolerance)) {
        chosen[static_cast<size_t>(j)] = c.name;
        break;
      }
  }
  return chosen;
}

// One report for a PerJointEstimator: each joint's from its model's fit, the time of all of them.
FitReport per_joint_report(const std::vector<FitResult>& fits, const std::vector<int>& joint_model) {
  FitReport report;
  bool capped = false, all_completed = true;
  for (const FitResult& f : fits) {
    report.seconds += f.report.seconds;
    capped = capped || f.report.status == FitStatus::NotConverged;
    all_completed = all_completed && f.report.status == FitStatus::Completed;
  }
  for (size_t i = 0; i < joint_model.size(); ++i)
    for (const JointReport& r : fits[static_cast<size_t>(joint_model[i])].report.joints)
      if (r.joint == static_cast<int>(i)) report.joints.push_back(r);
  report.status = capped ? FitStatus::NotConverged : all_completed ? FitStatus::Completed : FitStatus::Converged;
  return report;
}

}  // namespace

bool Selection::per_joint() const {
  for (const std::string& name : chosen_per_joint)
    if (name != chosen_per_joint.front()) return true;
  return false;
}

void SelectionOptions::validate() const {
  if (!(held_out_fraction > 0.0 && held_out_fraction < 1.0))
    throw Error("SelectionOptions::held_out_fraction must be in (0, 1), got " + std::to_string(held_out_fraction));
  if (!(tie_tolerance >= 0.0 && std::isfinite(tie_tolerance)))
    throw Error("SelectionOptions::tie_tolerance must be >= 0, got " + std::to_string(tie_tolerance));
  if (!(per_joint_factor >= 1.0 && std::isfinite(per_joint_factor)))
    throw Error("SelectionOptions::per_joint_factor must be >= 1, got " + std::to_string(per_joint_factor));
  for (const std::string& name : candidates) require_known_estimator(name);
}

EstimatorOptions candidate_options(const std::string& name, const EstimatorOptions& base,
                                   const TeacherOptions& teacher_settings) {
  const EstimatorSpec& spec = estimator_spec(name);
  EstimatorOptions o = base;
  o.name = name;
  o.teacher.reset();
  if (!o.search.restarts) o.search.restarts = 0;
  if (spec.default_estimator) o.teacher = choose_teacher(kAutomaticTeacher, o, teacher_settings);
  if (spec.family == EstimatorFamily::Lagrangian) o.search = teacher_settings.teacher_search(base.search);
  return o;
}

std::vector<Eigen::Index> candidate_rows(const std::string& name, Eigen::Index rows) {
  return constant_step_indices(rows, estimator_spec(name).selection_max_rows);
}

std::string Selection::brief_report() const {
  std::string out;
  char buf[256];
  std::snprintf(buf, sizeof buf,
                "choice by evidence: each candidate fitted on the log's first %ld rows, scored on its last %ld "
                "(held-out nMSE)\n",
                static_cast<long>(fit_rows), static_cast<long>(held_out_rows));
  out += buf;
  std::snprintf(buf, sizeof buf, " %-24s %6s %9s %10s   per joint\n", "candidate", "rows", "seconds", "mean");
  out += buf;
  for (const CandidateScore& c : candidates) {
    std::snprintf(buf, sizeof buf, " %-24s %6ld %9.1f ", c.name.c_str(), static_cast<long>(c.fit_rows), c.seconds);
    out += buf;
    if (!c.ok) {
      out += "    failed   " + c.failure + "\n";
      continue;
    }
    std::snprintf(buf, sizeof buf, "%10.3g  ", c.mean_nmse);
    out += buf;
    for (Eigen::Index j = 0; j < c.nmse.size(); ++j) {
      std::snprintf(buf, sizeof buf, " %.3g", c.nmse(j));
      out += buf;
    }
    out += "\n";
  }
  if (chosen.empty()) {
    out += "no candidate could be fitted\n";
  } else if (per_joint()) {
    char factor[32];
    std::snprintf(factor, sizeof factor, "%g", per_joint_factor);
    out += "chose per joint: " + chosen + " (the lowest mean nMSE, or within " +
           std::to_string(static_cast<int>(std::lround(100.0 * tie_tolerance))) +
           " % of it) except where another candidate's held-out nMSE on a joint was below its by a factor of " +
           factor + ":";
    for (size_t j = 0; j < chosen_per_joint.size(); ++j)
      out += (j == 0 ? " " : ", ") + std::to_string(j + 1) + " " + chosen_per_joint[j];
    out += "\n";
  } else if (chosen == best)
    out += "chose " + chosen + ": the lowest mean nMSE on the held-out rows\n";
  else
    out += "chose " + chosen + ": within " + std::to_string(static_cast<int>(std::lround(100.0 * tie_tolerance))) +
           " % of the lowest mean nMSE (" + best + "'s), and first in the order of preference\n";
  return out;
}

nlohmann::json Selection::record() const {
  nlohmann::json j;
  j["method"] = "held-out block";
  j["fit_rows"] = fit_rows;
  j["held_out_rows"] = held_out_rows;
  j["chosen"] = chosen;
  j["best"] = best;
  j["chosen_per_joint"] = chosen_per_joint;
  j["tie_tolerance"] = tie_tolerance;
  j["per_joint_factor"] = per_joint_factor;
  j["candidates"] = nlohmann::json::array();
  for (const CandidateScore& c : candidates) {
    nlohmann::json row{{"name", c.name}, {"status", c.ok ? "scored" : "failed"}, {"fit_rows", c.fit_rows},
                       {"seconds", c.seconds}};
    if (c.ok) {
      row["mean_nmse"] = number_or_null(c.mean_nmse);
      row["nmse"] = numbers_or_null(c.nmse);
    } else {
      row["failure"] = c.failure;
    }
    j["candidates"].push_back(row);
  }
  return j;
}

SelectionResult fit_selected_estimator(const EstimatorOptions& base, const SelectionOptions& options,
                                       const Eigen::MatrixXd& X, const Eigen::MatrixXd& Y, const JointTypes& joints,
                                       const TeacherOptions& teacher_settings, const ProgressCallback& progress) {
  options.validate();
  validate_training_data(X, Y, joints);
  const Eigen::Index rows = X.rows();
  const auto held_out = static_cast<Eigen::Index>(std::floor(options.held_out_fraction * static_cast<double>(rows)));
  if (held_out < kMinHeldOutRows || rows - held_out < kMinFitRows)
    throw Error("a log of " + std::to_string(rows) + " rows is too short to choose an estimator by evidence (it "
                "holds out its last " + std::to_string(held_out) + "; at least " + std::to_string(kMinHeldOutRows) +
                " held out and " + std::to_string(kMinFitRows) + " fitted are needed): name the estimator "
                "(EstimatorOptions::name)");
  const std::vector<std::string> names = options.candidates.empty() ? selection_candidates() : options.candidates;

  SelectionResult result;
  Selection& s = result.selection;
  s.fit_rows = rows - held_out;
  s.held_out_rows = held_out;
  const Eigen::MatrixXd X_fit = X.topRows(s.fit_rows), Y_fit = Y.topRows(s.fit_rows);
  const Eigen::MatrixXd X_held = X.bottomRows(held_out), Y_held = Y.bottomRows(held_out);
  const Eigen::VectorXd held_variance = column_variance(Y_held);
  s.tie_tolerance = options.tie_tolerance;
  s.per_joint_factor = options.per_joint_factor;
  // Scores a fitted candidate on the held-out rows.
  const auto score = [&](CandidateScore& c, const Estimator& fitted) {
    c.nmse = compute_accuracy(Y_held, fitted.predict(X_held)).nmse;
    c.mean_nmse = mean_over_varying(c.nmse, held_variance);
    c.ok = std::isfinite(c.mean_nmse);
    if (!c.ok) c.failure = "its held-out predictions are not finite";
  };
  // gip's teacher, where it taught: the lip candidate, fitted with the same options on the same rows.
  std::optional<CandidateScore> scored_teacher;
  for (size_t k = 0; k < names.size(); ++k) {
    CandidateScore c;
    c.name = names[k];
    if (scored_teacher && scored_teacher->name == c.name) {
      c = *scored_teacher;
      send_note(progress, c.name, "scored as " + estimator_name(EstimatorFamily::Gp) + "'s teacher, fitted on the same rows");
    } else {
      const auto start = std::chrono::steady_clock::now();
      try {
        const EstimatorOptions o = candidate_options(c.name, base, teacher_settings);
        check_estimator_options(o);
        const std::vector<Eigen::Index> fit = candidate_rows(c.name, s.fit_rows);
        c.fit_rows = static_cast<Eigen::Index>(fit.size());
        send_note(progress, c.name,
             "candidate " + std::to_string(k + 1) + " of " + std::to_string(names.size()) + ": fitting on " +
                 std::to_string(c.fit_rows) + " of the first " + std::to_string(s.fit_rows) + " rows");
        const FitResult r = fit_estimator(o, X_fit(fit, Eigen::all), Y_fit(fit, Eigen::all), joints, progress);
        if (!r.report.ok()) {
          c.failure = r.report.message;
        } else {
          score(c, *r.estimator);
        }
        // candidate_options gives lip its teacher's search; the rows must be the same too.
        const bool later = r.teacher && std::find(names.begin() + static_cast<long>(k) + 1, names.end(),
                                                  r.teacher->name()) != names.end();
        if (later && r.teacher_report && candidate_rows(r.teacher->name(), s.fit_rows).size() == fit.size()) {
          scored_teacher.emplace();
          scored_teacher->name = r.teacher->name();
          scored_teacher->fit_rows = c.fit_rows;
          scored_teacher->seconds = r.teacher_report->seconds;
          score(*scored_teacher, *r.teacher);
        }
      } catch (const Error& e) {  // options this candidate cannot honour, or memory it cannot have
        c.failure = e.what();
      }
      c.seconds = seconds_since(start);  // a taught candidate's includes its teacher's
    }
    if (c.ok) {
      char buf[96];
      std::snprintf(buf, sizeof buf, "held-out mean nMSE %.3g (%.1f s)", c.mean_nmse, c.seconds);
      send_note(progress, c.name, buf);
    } else {
      send_note(progress, c.name, "no score: " + c.failure);
    }
    s.candidates.push_back(std::move(c));
  }
  double best = std::numeric_limits<double>::infinity();
  for (const CandidateScore& c : s.candidates)
    if (c.ok && c.mean_nmse < best) {
      best = c.mean_nmse;
      s.best = c.name;
    }
  for (const CandidateScore& c : s.candidates)  // in the order of preference
    if (c.ok && c.mean_nmse <= best * (1.0 + options.tie_tolerance)) {
      s.chosen = c.name;
      break;
    }
  if (s.chosen.empty()) {
    result.fit.report.status = FitStatus::Failed;
    result.fit.report.message = "no candidate could be fitted on the log's first " + std::to_string(s.fit_rows) +
                                " rows (" + (s.candidates.empty() ? "none given" : s.candidates.front().failure) + ")";
    return result;
  }
  s.chosen_per_joint =
      choose_per_joint(s.candidates, held_variance, options.per_joint_factor, options.tie_tolerance, s.chosen);
  result.options = candidate_options(s.chosen, base, teacher_settings);
  // Every chosen candidate on the whole log, in the order of preference: one model, or, where joints chose
  // differently, each joint answered by its own.
  std::vector<std::string> distinct;
  for (const CandidateScore& c : s.candidates)
    if (std::find(s.chosen_per_joint.begin(), s.chosen_per_joint.end(), c.name) != s.chosen_per_joint.end())
      distinct.push_back(c.name);
  std::vector<FitResult> fits;
  for (const std::string& name : distinct) {
    const std::vector<Eigen::Index> refit = candidate_rows(name, rows);
    result.refit_rows = std::max(result.refit_rows, static_cast<Eigen::Index>(refit.size()));
    send_note(progress, name,
         std::string(s.per_joint() ? "chosen for some joints" : "chosen") + "; fitting on " +
             std::to_string(refit.size()) + " of the log's " + std::to_string(rows) + " rows");
    fits.push_back(fit_estimator(candidate_options(name, base, teacher_settings), X(refit, Eigen::all),
                                 Y(refit, Eigen::all), joints, progress));
    if (!fits.back().report.ok()) {
      result.fit = std::move(fits.back());
      if (s.per_joint())
        result.fit.report.message = name + ", chosen for some joints, failed on the whole log: " +
                                    result.fit.report.message;
      return result;
    }
  }
  if (fits.size() == 1) {
    result.fit = std::move(fits.front());
  } else {
    std::vector<int> joint_model;
    for (const std::string& name : s.chosen_per_joint)
      joint_model.push_back(static_cast<int>(std::find(distinct.begin(), distinct.end(), name) - distinct.begin()));
    std::vector<std::shared_ptr<const Estimator>> models;
    for (FitResult& f : fits) models.push_back(std::move(f.estimator));
    result.fit.report = per_joint_report(fits, joint_model);
    result.fit.estimator = std::make_unique<PerJointEstimator>(std::move(models), std::move(joint_model));
  }
  result.fit.estimator->set_selection_record(s.record());
  return result;
}

}  // namespace gipdyn
