// `gipdyn physics`: gravity, inertia, Coriolis and friction torques of a learned model.
#include <cstdio>
#include <limits>
#include <memory>

#include "commands.hpp"
#include "data_option.hpp"
#include "output_guard.hpp"
#include "gipdyn/error.hpp"
#include "gipdyn/estimators/estimator_file.hpp"
#include "gipdyn/estimators/lagrangian_estimator.hpp"
#include "gipdyn/estimators/physics.hpp"
#include "gipdyn/io/csv.hpp"
#include "gipdyn/io/dataset.hpp"

namespace gipdyn::cli {

Command add_physics(CLI::App& app) {
  struct Args {
    std::string model, data, columns, out;
  };
  auto a = std::make_shared<Args>();
  app.description(
      "Rigid-body terms of a learned model (" + joined(physics_estimator_names()) + "): gravity g(q), the inertia matrix M(q)\n"
      "and, when the states have velocities, the Coriolis/centrifugal torque C(q, qd) qd and the friction\n"
      "torque, all from the model's torque predictions. M is the symmetric part of the rows the joints'\n"
      "models learn; per row, how physical they are: their asymmetry and the smallest eigenvalue of M.\n"
      "A lip model also gives its potential energy (up to a constant) and, with velocities, its kinetic energy.");
  app.add_option("--model", a->model, "Model file from `gipdyn train`")->required()->check(CLI::ExistingFile);
  app.add_option("--data", a->data, "CSV of states: q1..qn, and qd1..qdn for the velocity terms (others ignored)")
      ->required()->check(CLI::ExistingFile);
  add_columns_option(app, a->columns);
  app.add_option("--out", a->out,
                 "Output CSV: g1..gn, M1_1..Mn_n (row i, column j), [coriolis1..n, friction1..n], "
                 "M_asymmetry, M_min_eigenvalue; lip: potential_energy [, kinetic_energy]")
      ->required();
  return [a]() -> int {
    refuse_overwrites({{"--model", a->model}, {"--data", a->data}}, {{"--out", a->out}});
    const std::unique_ptr<Estimator> model = load_estimator(a->model);
    require_physics(*model);
    const int n = model->joints().size();
    const LogColumns log_columns = parse_log_columns(a->columns);
    const CsvHeader columns = read_csv_header(a->data, log_columns);
    require_joint_columns(columns, a->data, model->joints(), "the model '" + a->model + "'");
    const Eigen::MatrixXd Q = read_csv_columns(a->data, joint_column_names("q", n), log_columns);
    const bool with_velocity = columns.has("qd1");
    const Eigen::MatrixXd g = gravity(*model, Q);
    const std::vector<Eigen::MatrixXd> M = inertia(*model, Q);
    const std::vector<Eigen::MatrixXd> M_learned = inertia(*model, Q, InertiaForm::AsLearned);
    const Eigen::MatrixXd QD = with_velocity ? read_csv_columns(a->data, joint_column_names("qd", n), log_columns) : Eigen::MatrixXd();
    VelocityTerms v;
    if (with_velocity) v = velocity_terms(*model, Q, QD);

    std::vector<std::string> header = joint_column_names("g", n);
    for (int i = 1; i <= n; ++i)
      for (const auto& c : joint_column_names("M" + std::to_string(i) + "_", n)) header.push_back(c);
    if (with_velocity) {
      for (const auto& c : joint_column_names("coriolis", n)) header.push_back(c);
      for (const auto& c : joint_column_names("friction", n)) header.push_back(c);
    }
    header.push_back("M_asymmetry");
    header.push_back("M_min_eigenvalue");
    const auto* lip = dynamic_cast<const LagrangianEstimator*>(model.get());
    Eigen::VectorXd potential, kinetic;
    if (lip) {
      potential = lip->potential_energy(Q);
      header.push_back("potential_energy");
      if (with_velocity) {
        Eigen::MatrixXd states(Q.rows(), 2 * n);
        states << Q, QD;
        kinetic = lip->kinetic_energy(states);
        header.push_back("kinetic_energy");
      }
    }
    Eigen::MatrixXd table(Q.rows(), static_cast<Eigen::Index>(header.size()));
    double worst_asymmetry = 0.0, smallest_eigenvalue = std::numeric_limits<double>::infinity();
    int not_positive = 0;
    for (Eigen::Index r = 0; r < Q.rows(); ++r) {
      Eigen::Index c = 0;
      table.row(r).segment(c, n) = g.row(r);
      c += n;
      for (int i = 0; i < n; ++i, c += n) table.row(r).segment(c, n) = M[static_cast<size_t>(r)].row(i);
      if (with_velocity) {
        table.row(r).segment(c, n) = v.coriolis.row(r);
        table.row(r).segment(c + n, n) = v.friction.row(r);
        c += 2 * n;
      }
      const InertiaDiagnostics d = diagnose_inertia(M_learned[static_cast<size_t>(r)]);
      table(r, c) = d.asymmetry;
      table(r, c + 1) = d.min_eigenvalue;
      if (potential.size() > 0) table(r, c + 2) = potential(r);
      if (kinetic.size() > 0) table(r, c + 3) = kinetic(r);
      worst_asymmetry = std::max(worst_asymmetry, d.asymmetry);
      smallest_eigenvalue = std::min(smallest_eigenvalue, d.min_eigenvalue);
      not_positive += d.min_eigenvalue <= 0.0;
    }
    write_csv(a->out, header, table);
    std::printf("%ld states -> %s: gravity, inertia%s%s\n", static_cast<long>(Q.rows()), a->out.c_str(),
                with_velocity ? ", Coriolis and friction" : " (no qd columns: no velocity terms)",
                lip ? (with_velocity ? ", potential and kinetic energy" : ", potential energy") : "");
    std::printf(" inertia: largest relative asymmetry %.3g, smallest eigenvalue %.3g, %d of %ld not positive definite\n",
                worst_asymmetry, smallest_eigenvalue, not_positive, static_cast<long>(Q.rows()));
    return 0;
  };
}

}  // namespace gipdyn::cli
