// Contact detection (sensing/contact_detection.hpp) against simulated contacts
// whose true external torque is known, and the simulator's contacts against
// KDL's inverse dynamics.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <nlohmann/json.hpp>

#include <unistd.h>

#include <filesystem>

#include "gipdyn/error.hpp"
#include "gipdyn/estimators/estimator_file.hpp"
#include "gipdyn/gipdyn.h"
#include "gipdyn/estimators/uncertainty.hpp"
#include "gipdyn/robot/dynamics.hpp"
#include "gipdyn/robot/robot_loader.hpp"
#include "gipdyn/sensing/contact_detection.hpp"
#include "gipdyn/sim/simulate.hpp"
#include "scara_fit.hpp"
#include "test_util.hpp"

using namespace gipdyn;
using test::error_of;

namespace {

SimulationResult scara_log(unsigned seed, int samples, double dt, double noise, int contacts) {
  SimulationOptions o;
  o.samples = samples;
  o.dt = dt;
  o.noise_std = noise;
  o.seed = seed;
  o.contacts.count = contacts;
  return simulate(scara_robot(), o);
}

// Rows where any joint has a true external torque.
struct TrueContact {
  Eigen::Index first = 0, last = 0;  // rows, inclusive
  int joint = 0;
};
std::vector<TrueContact> true_contacts(const Eigen::MatrixXd& external) {
  std::vector<TrueContact> out;
  for (Eigen::Index j = 0; j < external.cols(); ++j)
    for (Eigen::Index k = 0; k < external.rows(); ++k)
      if (external(k, j) != 0.0 && (k == 0 || external(k - 1, j) == 0.0)) {
        TrueContact c{k, k, static_cast<int>(j)};
        while (c.last + 1 < external.rows() && external(c.last + 1, j) != 0.0) ++c.last;
        out.push_back(c);
      }
  return out;
}

// The fe estimator on the true SCARA, fitted on a contact-free noisy log: the
// rigid-body model itself, to the noise's precision.
std::unique_ptr<Estimator> true_model() {
  return test::fit_on_scara("fe", scara_log(11, 400, 0.05, 0.01, 0));
}

}  // namespace

TEST(SimulatedContacts, ActThroughTheDynamicsAndAreWrittenBesideTheLog) {
  const SimulationResult d = scara_log(3, 1500, 0.01, 0.0, 4);
  ASSERT_EQ(d.external.rows(), 1500);
  // M qdd + C qd + g = tau + tau_ext on every row.
  const Eigen::MatrixXd rigid = inverse_dynamics(scara_robot(), d.X);
  EXPECT_LT((rigid - d.tau_true - d.external).cwiseAbs().maxCoeff(), 1e-8);
  const auto contacts = true_contacts(d.external);
  EXPECT_EQ(contacts.size(), 4u);
  for (const TrueContact& c : contacts) EXPECT_EQ(c.last - c.first + 1, 5);  // 50 ms at 100 Hz
  ASSERT_TRUE(d.metadata.contains("contacts"));
  EXPECT_EQ(d.metadata["contacts"]["drawn"].size(), 4u);
  // The controller keeps the robot near its reference: within 0.05 rad or m.
  SimulationOptions free;
  free.samples = 1500;
  free.dt = 0.01;
  free.noise_std = 0.0;
  free.seed = 3;
  const SimulationResult reference = simulate(scara_robot(), free);
  EXPECT_TRUE(reference.external.size() == 0);
  EXPECT_LT((reference.X.leftCols(4) - d.X.leftCols(4)).cwiseAbs().maxCoeff(), 0.05);
  // Seeded: the same seed gives the same contacts.
  EXPECT_EQ(scara_log(3, 1500, 0.01, 0.0, 4).external, d.external);
}

TEST(SimulatedContacts, BadOptionsNameTheField) {
  SimulationOptions o;
  o.samples = 100;
  o.contacts.count = 10;  // 10 x 3 x 0.05 s > 1 s
  EXPECT_NE(error_of([&] { simulate(scara_robot(), o); }).find("SimulatedContacts"), std::string::npos);
  o.contacts.count = 1;
  o.contacts.joint = 5;
  EXPECT_NE(error_of([&] { simulate(scara_robot(), o); }).find("SimulatedContacts::joint"), std::string::npos);
}

TEST(ContactOptions, ThresholdIsTheGaussianQuantileOfTheRate) {
  ContactOptions o;
  o.sample_time = 0.001;
  o.false_alarm_rate = 0.05;
  EXPECT_NEAR(o.threshold_factor(), 1.959963984540054, 1e-10);
  o.false_alarm_rate = 1e-6;
  EXPECT_NEAR(o.threshold_factor(), 4.891638475698358, 1e-9);
  // Two-sided: P(|z| > k) = rate.
  for (double rate : {0.3, 1e-3, 1e-9}) {
    o.false_alarm_rate = rate;
    EXPECT_NEAR(std::erfc(o.threshold_factor() / std::sqrt(2.0)) / rate, 1.0, 1e-9);
  }
  o.min_duration = 0.0045;
  EXPECT_EQ(o.min_samples(), 5);
  o.min_duration = 0.0;
  EXPECT_EQ(o.min_samples(), 1);
  EXPECT_NEAR(o.observer_gain(), 100.0, 1e-12);  // 10 ms at 1 kHz
  o.sample_time = 0.01;
  EXPECT_NEAR(o.observer_gain(), 50.0, 1e-12);  // two rows at 100 Hz
  for (double bad : {0.0, 1.0, -0.1}) {
    o.false_alarm_rate = bad;
    EXPECT_NE(error_of([&] { o.validate(); }).find("false_alarm_rate"), std::string::npos);
  }
  o.false_alarm_rate = 1e-6;
  o.momentum_gain = 200.0;  // x 0.01 s = 2
  EXPECT_NE(error_of([&] { o.validate(); }).find("momentum_gain"), std::string::npos);
  o.momentum_gain = 0.0;
  o.sample_time = 0.0;
  EXPECT_NE(error_of([&] { o.validate(); }).find("sample_time"), std::string::npos);
}

TEST(ContactFlagger, FlagsAfterTheMinimumRunAndClearsBelowTheThreshold) {
  ContactFlagger flagger(1, 2.0, 3);
  const double sigma = 1.0;
  const double ext[] = {0.5, 2.5, 2.5, 3.0, 2.1, 1.9, 2.5, -4.0, -4.0, -4.0};
  const int expected[] = {0, 0, 0, 1, 1, 0, 0, 0, 1, 0};
  for (int k = 0; k < 10; ++k) {
    int contact = -1;
    double margin = 0.0, threshold = 0.0;
    const double e = k == 9 ? 0.0 : ext[k];
    flagger.step(&e, &sigma, &contact, &margin, &threshold);
    EXPECT_EQ(contact, expected[k]) << "row " << k;
    EXPECT_DOUBLE_EQ(margin, std::abs(e) / 2.0);
    EXPECT_DOUBLE_EQ(threshold, 2.0);
  }
}

TEST(ContactDetector, ResidualIsTheExternalTorqueAndTheObserverItsFirstOrderLag) {
  const auto model = true_model();
  // 1 kHz: contacts switch between rows at 100 Hz (the controller runs ten times a row).
  const SimulationResult d = scara_log(5, 1500, 0.001, 0.0, 5);
  ContactOptions o;
  o.sample_time = 0.001;
  const Eigen::MatrixXd residual = ContactDetector(*model, o).external_torque(d.X, d.tau);
  const double size = d.external.cwiseAbs().maxCoeff();
  ASSERT_GT(size, 0.0);
  EXPECT_LT((residual - d.external).cwiseAbs().maxCoeff(), 0.02 * size);

  // The observer's discrete lag, r_k = (1 - K dt) r_{k-1} + K (integral of tau_ext from row k-1 to
  // row k), computed here apart from the contacts the simulator drew.
  o.method = ContactMethod::Momentum;
  const Eigen::MatrixXd observed = ContactDetector(*model, o).external_torque(d.X, d.tau);
  const double gain = o.observer_gain(), dt = o.sample_time, duration = d.metadata["contacts"]["duration_s"];
  Eigen::MatrixXd lag = Eigen::MatrixXd::Zero(d.external.rows(), d.external.cols());
  for (Eigen::Index k = 1; k < lag.rows(); ++k) {
    lag.row(k) = (1.0 - gain * dt) * lag.row(k - 1);
    for (const auto& c : d.metadata["contacts"]["drawn"]) {
      const double start = c["start_s"];
      const double overlap = std::max(0.0, std::min(k * dt, start + duration) - std::max((k - 1) * dt, start));
      lag(k, c["joint"].get<int>() - 1) += gain * overlap * c["torque"].get<double>();
    }
  }
  // Within one row of it: the trapezoidal integral runs up to half a row ahead of this lag.
  for (Eigen::Index k = 0; k + 1 < lag.rows(); ++k)
    for (Eigen::Index j = 0; j < lag.cols(); ++j)
      ASSERT_LE(std::abs(observed(k, j) - lag(k, j)), std::abs(lag(k + 1, j) - lag(k, j)) + 0.01 * size)
          << "row " << k << " joint " << j + 1;
}

TEST(ContactDetector, BothMethodsFindEveryContactOfACalibratedTrueModelAndNothingElse) {
  const auto model = true_model();
  // At 1 kHz: 20 ms are 20 rows, enough for the observer's lag.
  const SimulationResult calibration = scara_log(21, 1500, 0.001, 0.01, 0);
  const SimulationResult d = scara_log(22, 3000, 0.001, 0.01, 6);
  const auto contacts = true_contacts(d.external);
  ASSERT_EQ(contacts.size(), 6u);
  for (ContactMethod method : {ContactMethod::Residual, ContactMethod::Momentum}) {
    SCOPED_TRACE(to_string(method));
    ContactOptions o;
    o.method = method;
    o.sample_time = 0.001;
    ContactDetector detector(*model, o);
    EXPECT_NE(error_of([&] { detector.detect(d.X, d.tau); }).find("calibrate"), std::string::npos);
    detector.calibrate(calibration.X, calibration.tau);
    const ContactDetection r = detector.detect(d.X, d.tau);
    EXPECT_EQ(r.noise_source, "calibration");
    // Every contact flagged on its joint within 20 ms of its start.
    for (const TrueContact& c : contacts) {
      bool found = false;
      for (Eigen::Index k = c.first; k <= std::min(c.first + 20, c.last); ++k) found = found || r.contact(k, c.joint);
      EXPECT_TRUE(found) << "contact on joint " << c.joint + 1 << " at row " << c.first;
      // The estimate within 20 % of the contact's size, RMS over the contact (the observer's after its lag).
      const Eigen::Index from = method == ContactMethod::Residual ? c.first : c.first + 20;
      const double truth = d.external(c.first, c.joint);
      const auto error = r.external_torque.col(c.joint).segment(from, c.last + 1 - from).array() - truth;
      EXPECT_LT(std::sqrt(error.square().mean()), 0.2 * std::abs(truth)) << "contact at row " << c.first;
    }
    // No flag before a contact or after its end, but for the observer's settling (its r decays by
    // 1 - K dt = 0.9 a row: 100 rows take a contact 30000 times its threshold below it).
    const Eigen::Index settling = method == ContactMethod::Residual ? 1 : 100;
    Eigen::MatrixXi allowed = Eigen::MatrixXi::Zero(r.contact.rows(), r.contact.cols());
    for (const TrueContact& c : contacts)
      allowed.col(c.joint).segment(c.first, std::min<Eigen::Index>(c.last + 1 + settling, allowed.rows()) - c.first).setOnes();
    EXPECT_EQ((r.contact.array() > allowed.array()).count(), 0) << r.brief_report();
    EXPECT_EQ(r.contact_count.sum(), 6);
    const ContactScore score = score_contacts(r, d.external, o.sample_time);
    EXPECT_EQ(score.detected, 6);
    EXPECT_EQ(score.false_alarms, 0);
    EXPECT_LE(score.max_delay, 0.02);
  }
}

TEST(ContactDetector, AGpModelsOwnUncertaintySetsTheThreshold) {
  // 800 rows: with fewer the GIP's latent variance underestimates its error off the training motion.
  const SimulationResult train = scara_log(31, 800, 0.1, 0.01, 0);
  const auto model = test::fit_on_scara("gip", train);
  const TorqueUncertainty uncertainty(*model);
  // The learned noise is the simulated one's order of magnitude.
  for (int j = 0; j < 4; ++j) {
    EXPECT_GT(uncertainty.noise_std()(j), 0.003);
    EXPECT_LT(uncertainty.noise_std()(j), 0.03);
  }
  const SimulationResult d = scara_log(32, 2000, 0.01, 0.01, 5);
  ContactOptions o;
  o.sample_time = 0.01;
  const ContactDetection r = ContactDetector(*model, o).detect(d.X, d.tau);
  EXPECT_EQ(r.noise_source, "model");
  // The threshold holds the latent part: never below k times the noise.
  for (int j = 0; j < 4; ++j)
    EXPECT_GE(r.threshold.col(j).minCoeff(), r.threshold_factor * uncertainty.noise_std()(j) * (1 - 1e-12));
  // Every contact of at least ten times the noise is found (a wrist's 10 % of its
  // torque range can be below the noise), and no contact-free joint is flagged.
  int large = 0, found = 0;
  for (const TrueContact& c : true_contacts(d.external)) {
    if (std::abs(d.external(c.first, c.joint)) < 10 * 0.01) continue;
    ++large;
    found += r.contact.col(c.joint).segment(c.first, c.last - c.first + 1).any();
  }
  EXPECT_GE(large, 2);
  EXPECT_EQ(found, large) << r.brief_report();
  EXPECT_LE(r.contact_count.sum(), 5) << r.brief_report();
}

TEST(ContactDetector, RefusesWhatItCannotDo) {
  const SimulationResult train = scara_log(41, 200, 0.1, 0.01, 0);
  const auto rbf = test::fit_on_scara("rbf", train);
  ContactOptions o;
  o.sample_time = 0.01;
  o.method = ContactMethod::Momentum;
  EXPECT_NE(error_of([&] { ContactDetector(*rbf, o); }).find("cannot give gravity, inertia"), std::string::npos);
  o.method = ContactMethod::Residual;
  ContactDetector detector(*rbf, o);
  EXPECT_NE(error_of([&] { detector.detect(train.X.leftCols(8), train.tau); }).find("needs 12"), std::string::npos);
  EXPECT_NE(error_of([&] { detector.detect(train.X, train.tau.topRows(5)); }).find("one row of 4"), std::string::npos);
  EXPECT_EQ(error_of([&] { parse_contact_method("kalman"); }),
            "unknown contact detection method 'kalman'; choose residual or momentum");
}

TEST(ContactScore, CountsDetectionsDelaysAndFalseAlarmsAgainstTheTruth) {
  // One joint, 20 rows of 0.01 s: true contacts at rows 2-5 (found at row 4) and
  // 12-13 (missed); a flagged run at rows 16-17 overlaps none.
  ContactDetection d;
  d.contact = Eigen::MatrixXi::Zero(20, 1);
  d.external_torque = Eigen::MatrixXd::Zero(20, 1);
  Eigen::MatrixXd truth = Eigen::MatrixXd::Zero(20, 1);
  truth.block(2, 0, 4, 1).setConstant(2.0);
  truth.block(12, 0, 2, 1).setConstant(-1.0);
  d.contact.block(4, 0, 3, 1).setOnes();
  d.contact.block(16, 0, 2, 1).setOnes();
  d.external_torque.block(2, 0, 4, 1).setConstant(1.5);  // RMS error 0.5 on a contact of 2
  const ContactScore s = score_contacts(d, truth, 0.01);
  EXPECT_EQ(s.contacts, 2);
  EXPECT_EQ(s.detected, 1);
  EXPECT_DOUBLE_EQ(s.detection_rate(), 0.5);
  EXPECT_NEAR(s.mean_delay, 0.02, 1e-12);
  EXPECT_NEAR(s.max_delay, 0.02, 1e-12);
  EXPECT_EQ(s.false_alarms, 1);
  EXPECT_NEAR(s.contact_free_seconds, 0.14, 1e-12);
  EXPECT_NEAR(s.false_alarms_per_minute(), 60.0 / 0.14, 1e-9);
  EXPECT_NEAR(s.torque_error, 0.25, 1e-12);
  EXPECT_NE(error_of([&] { score_contacts(d, truth.topRows(5), 0.01); }).find("shape"), std::string::npos);
}

// The one-row path (ContactStream, and the C API over it) flags the rows the
// batch detector flags, for a model without predictive variance and the
// detector's calibrated noise.
TEST(ContactStream, FlagsWhatTheBatchDetectorFlags) {
  const auto model = true_model();
  const SimulationResult calibration = scara_log(21, 1000, 0.001, 0.01, 0);
  const SimulationResult d = scara_log(23, 2000, 0.001, 0.01, 4);
  const std::string path =
      (std::filesystem::temp_directory_path() / ("gipdyn_contacts_" + std::to_string(::getpid()) + ".gipdyn")).string();
  save_estimator(*model, path);
  gipdyn_model* c_model = nullptr;
  ASSERT_EQ(gipdyn_model_load(path.c_str(), &c_model), GIPDYN_OK) << gipdyn_last_error();
  for (ContactMethod method : {ContactMethod::Residual, ContactMethod::Momentum}) {
    SCOPED_TRACE(to_string(method));
    ContactOptions o;
    o.method = method;
    o.sample_time = 0.001;
    ContactDetector detector(*model, o);
    detector.calibrate(calibration.X, calibration.tau);
    const ContactDetection batch = detector.detect(d.X, d.tau);
    ContactStream stream(*model, o, detector.noise_std());

    gipdyn_contact_options c_options = gipdyn_contact_options_default();
    EXPECT_EQ(c_options.false_alarm_rate, ContactOptions{}.false_alarm_rate);
    c_options.method = method == ContactMethod::Momentum ? GIPDYN_CONTACT_MOMENTUM : GIPDYN_CONTACT_RESIDUAL;
    c_options.sample_time = 0.001;
    const Eigen::VectorXd noise = detector.noise_std();
    gipdyn_contact_detector* c_detector = nullptr;
    ASSERT_EQ(gipdyn_contact_detector_create(c_model, &c_options, noise.data(), 4, &c_detector), GIPDYN_OK)
        << gipdyn_last_error();

    const double size = d.external.cwiseAbs().maxCoeff();
    double ext[4], c_ext[4], margin[4], c_margin[4];
    int contact[4], c_contact[4];
    for (Eigen::Index k = 0; k < d.X.rows(); ++k) {
      const Eigen::RowVectorXd x = d.X.row(k), tau = d.tau.row(k);
      stream.step(x.data(), x.data() + 4, x.data() + 8, tau.data(), ext, contact, margin);
      const double* qdd = method == ContactMethod::Momentum ? nullptr : x.data() + 8;
      ASSERT_EQ(gipdyn_contact_detector_step(c_detector, x.data(), x.data() + 4, qdd, tau.data(), 4, c_ext, c_contact,
                                             c_margin),
                GIPDYN_OK)
          << gipdyn_last_error();
      for (int j = 0; j < 4; ++j) {
        ASSERT_NEAR(ext[j], batch.external_torque(k, j), 1e-9 * size) << "row " << k;
        ASSERT_EQ(contact[j], batch.contact(k, j)) << "row " << k << " joint " << j + 1;
        ASSERT_EQ(c_ext[j], ext[j]);
        ASSERT_EQ(c_contact[j], contact[j]);
      }
    }
    // reset() starts over: the first rows again give the first results.
    ASSERT_EQ(gipdyn_contact_detector_reset(c_detector), GIPDYN_OK);
    const Eigen::RowVectorXd x0 = d.X.row(0), tau0 = d.tau.row(0);
    ASSERT_EQ(gipdyn_contact_detector_step(c_detector, x0.data(), x0.data() + 4, x0.data() + 8, tau0.data(), 4, c_ext,
                                           c_contact, c_margin),
              GIPDYN_OK);
    for (int j = 0; j < 4; ++j) EXPECT_NEAR(c_ext[j], batch.external_torque(0, j), 1e-9 * size);
    gipdyn_contact_detector_free(c_detector);
  }

  // Misuse: a status and a message.
  gipdyn_contact_detector* c_detector = nullptr;
  gipdyn_contact_options bad = gipdyn_contact_options_default();
  EXPECT_EQ(gipdyn_contact_detector_create(c_model, &bad, nullptr, 4, &c_detector), GIPDYN_ERROR_INVALID_OPTION);
  EXPECT_NE(std::string(gipdyn_last_error()).find("sample_time"), std::string::npos);
  bad.sample_time = 0.001;
  EXPECT_EQ(gipdyn_contact_detector_create(c_model, &bad, nullptr, 4, &c_detector), GIPDYN_ERROR_UNSUPPORTED);
  EXPECT_NE(std::string(gipdyn_last_error()).find("pass noise_std"), std::string::npos);
  const double noise[4] = {0.01, 0.01, 0.01, 0.01};
  EXPECT_EQ(gipdyn_contact_detector_create(c_model, &bad, noise, 3, &c_detector), GIPDYN_ERROR_SIZE);
  bad.false_alarm_rate = 1.0;
  EXPECT_EQ(gipdyn_contact_detector_create(c_model, &bad, noise, 4, &c_detector), GIPDYN_ERROR_INVALID_OPTION);
  EXPECT_EQ(c_detector, nullptr);
  gipdyn_model_free(c_model);
  std::filesystem::remove(path);
}
