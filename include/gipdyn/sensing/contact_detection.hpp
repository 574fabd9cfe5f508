#pragma once
// Contact detection from joint torques alone (proprioceptive sensing). A
// robot in contact obeys
//   M(q) qdd + C(q, qd) qd + g(q) = tau + tau_ext,
// tau the measured joint torque and tau_ext the torque the environment applies
// to each joint. A learned model f(q, qd, qdd) stands in for the left-hand
// side, and tau_ext is estimated in one of two ways:
//
//   Residual: r = f(q, qd, qdd) - tau. Needs the accelerations; any estimator.
//   Momentum: De Luca and Mattone's generalized-momentum observer. With
//     p = M(q) qd and n(q, qd) = f(q, qd, 0) (Coriolis, gravity, friction),
//     dp/dt = tau + tau_ext - n + (dM/dt) qd, and
//       r = K (p - p(0) - integral(tau - n + (dM/dt) qd + r) dt)
//     follows tau_ext through a first-order lag of time constant 1/K. No
//     acceleration enters, so it suits real logs whose qdd is noisy; it needs
//     M(q) from the model (estimators/physics.hpp). Integrated by the
//     trapezoidal rule between rows, dM/dt qd by M's change between them.
//
// A contact-free r has on joint j about the standard deviation
//   sigma_j(x) = sqrt(latent_j(x)^2 + s_j^2),
// latent the model's predictive standard deviation (zero for models without
// one) and s_j the joint's noise: the RMS of r over contact-free calibration
// rows where the detector was calibrated, else the model's learned noise
// (estimators/uncertainty.hpp). For the momentum observer sigma is a bound:
// its low-pass filter only lowers a stationary residual's variance. A joint is
// flagged in contact once |r_j| > k sigma_j on min_samples() consecutive rows,
// and stays flagged while |r_j| > k sigma_j; k is the two-sided Gaussian
// quantile of false_alarm_rate.
#include <Eigen/Dense>
#include <memory>
#include <string>

#include "gipdyn/eigen_abi.hpp"
#include "gipdyn/estimators/estimator.hpp"

namespace gipdyn {

class TorqueUncertainty;

enum class ContactMethod { Residual, Momentum };
// "residual" | "momentum"; throws gipdyn::Error naming both for another name.
ContactMethod parse_contact_method(const std::string& name);
std::string to_string(ContactMethod method);

struct ContactOptions {
  ContactMethod method = ContactMethod::Residual;
  // The probability that one joint's contact-free residual exceeds the
  // threshold on one row, were it Gaussian with standard deviation sigma.
  // Per row and joint: a 1 kHz log of a 6-joint arm has 21.6 million of them
  // an hour. The minimum duration lowers the rate of false contacts further.
  double false_alarm_rate = 1e-6;
  // Seconds |r| must stay above the threshold before a contact is flagged, at
  // least one row: isolated spikes of noise are not contacts.
  double min_duration = 0.005;
  // The rows' sampling period, s. Needed by both methods (min_duration) and
  // by the momentum observer's integral.
  double sample_time = 0.0;
  // The momentum observer's gain K, 1/s; its product with sample_time at most
  // 1. 0: automatic, a time constant of 10 ms or of two rows, whichever is
  // longer.
  double momentum_gain = 0.0;
  // Whether sigma holds the model's predictive standard deviation where it has
  // one. false: the noise alone (calibrated or learned), as in ContactStream;
  // it spares a loaded model's factorisation (O(N^3) per joint for a GP,
  // O((N n)^3) for lip) and O(N^2) a row.
  bool predictive_variance = true;

  // Throws gipdyn::Error naming the field.
  void validate() const;
  // k: the threshold in standard deviations.
  double threshold_factor() const;
  // The consecutive rows min_duration spans, at least 1.
  int min_samples() const;
  // K, the automatic one where momentum_gain is 0.
  double observer_gain() const;
};

// Per row (rows x n each): the estimated external torque, the threshold
// k sigma, the flag and |ext| / threshold (above 1 where |ext| exceeds it).
struct ContactDetection {
  ContactMethod method = ContactMethod::Residual;
  Eigen::MatrixXd external_torque;
  Eigen::MatrixXd threshold;
  Eigen::MatrixXi contact;  // 0 or 1
  Eigen::MatrixXd margin;
  double threshold_factor = 0.0;
  // Where sigma's noise part came from: "calibration" or "model".
  std::string noise_source;
  // Per joint: the noise s_j used, and the number of contacts (runs of flagged rows).
  Eigen::VectorXd noise_std;
  Eigen::VectorXi contact_count;
  // One line per joint: contacts, flagged share of rows, largest margin.
  std::string brief_report() const;
};

// A detection scored against the true external torque of a simulated log
// (SimulationResult::external): a true contact is a run of rows with a nonzero
// external torque on one joint.
struct ContactScore {
  int contacts = 0;
  int detected = 0;        // flagged on their joint at some row of the contact
  double mean_delay = 0.0;  // s from a detected contact's first row to its first flagged row
  double max_delay = 0.0;
  // Flagged runs that overlap no true contact of their joint, and the
  // contact-free time they were counted in (rows without external torque on any joint).
  int false_alarms = 0;
  double contact_free_seconds = 0.0;
  // Over the detected contacts: RMS(estimate - truth) over the contact's rows / |truth|, averaged.
  double torque_error = 0.0;
  double detection_rate() const { return contacts > 0 ? static_cast<double>(detected) / contacts : 0.0; }
  double false_alarms_per_minute() const {
    return contact_free_seconds > 0.0 ? 60.0 * false_alarms / contact_free_seconds : 0.0;
  }
};
// Throws gipdyn::Error where true_external is not rows x n like the detection.
ContactScore score_contacts(const ContactDetection& detection, const Eigen::Ref<const Eigen::MatrixXd>& true_external,
                            double sample_time);

// The flagging rule above, one row at a time: allocation-free, for a control
// loop. ext, sigma: n values; contact, margin: n outputs.
class ContactFlagger {
 public:
  ContactFlagger(int joints, double threshold_factor, int min_samples);
  void reset();
  void step(const double* ext, const double* sigma, int* contact, double* margin, double* threshold = nullptr);

 private:
  double k_;
  int min_samples_;
  Eigen::VectorXi run_;  // consecutive rows above the threshold, per joint
};

// The generalized-momentum observer, one row at a time: allocation-free once
// made. step() takes M(q) (n x n), qd and tau - n(q, qd) of a row and gives r.
class MomentumObserver {
 public:
  MomentumObserver(int joints, double gain, double sample_time);
  void reset();
  const Eigen::VectorXd& step(const Eigen::Ref<const Eigen::MatrixXd>& M, const Eigen::Ref<const Eigen::VectorXd>& qd,
                              const Eigen::Ref<const Eigen::VectorXd>& tau_minus_n);

 private:
  double gain_, dt_;
  bool started_ = false;
  Eigen::VectorXd p0_, integral_, r_, prev_qd_, prev_drive_, p_, mean_qd_;
  Eigen::MatrixXd prev_M_;
};

// The detection of one row at a time, for a control loop: allocation-free
// once made wherever the estimator's query workspace is
// (Estimator::make_query_workspace). Its threshold is k times a constant sigma
// per joint: the model's predictive variance, O(N^2) a query for an exact GP,
// does not fit a 1 kHz loop and is left out. Give it the sigma measured on
// contact-free rows (ContactDetector::noise_std() after calibrate()), which
// holds the model's error there as well as the noise. With a model without
// predictive variance and that sigma, it flags exactly the rows
// ContactDetector::detect flags. The estimator must outlive it.
class ContactStream {
 public:
  // Throws gipdyn::Error for invalid options, a sigma not of n positive
  // values, and the momentum method on a model without M(q).
  ContactStream(const Estimator& estimator, const ContactOptions& options, const Eigen::VectorXd& sigma);
  ~ContactStream();
  // Starts a new log: the observer's momentum and the minimum-duration counts.
  void reset();
  // One row: q, qd, tau (n values each) and qdd (n values; the momentum method
  // does not read it, and it may be null there). Outputs n values each: the
  // external torque estimate, the flag (0 or 1) and |ext| / threshold.
  void step(const double* q, const double* qd, const double* qdd, const double* tau, double* ext, int* contact,
            double* margin);
  int num_joints() const { return static_cast<int>(sigma_.size()); }
  ContactMethod method() const { return method_; }

 private:
  const Estimator* estimator_;
  ContactMethod method_;
  Eigen::VectorXd sigma_;
  std::unique_ptr<QueryWorkspace> query_;
  ContactFlagger flagger_;
  std::unique_ptr<MomentumObserver> observer_;  // the momentum method's
  Eigen::VectorXd x_, predicted_, gravity_, drive_, ext_;
  Eigen::MatrixXd M_;
};

// A detector over one estimator, which must outlive it. Read-only once
// calibrated.
class ContactDetector {
 public:
  // Throws gipdyn::Error for invalid options and, for the momentum method, a
  // model without M(q) (estimators/physics.hpp). A model with a predictive
  // standard deviation prepares it here (TorqueUncertainty: O(N^3) for a
  // loaded GP model).
  ContactDetector(const Estimator& estimator, ContactOptions options);
  ~ContactDetector();
  ContactDetector(ContactDetector&&) noexcept;
  ContactDetector& operator=(ContactDetector&&) noexcept;

  // Learns each joint's noise s_j as the RMS of the method's r over rows known
  // to be free of contact (the training log, say): X rows x 3n, tau rows x n.
  // Needed for models without a predictive standard deviation; for the others
  // it replaces the model's learned noise by the one measured on the robot.
  void calibrate(const Eigen::Ref<const Eigen::MatrixXd>& X, const Eigen::Ref<const Eigen::MatrixXd>& tau);
  bool calibrated() const { return calibrated_noise_.size() > 0; }
  // Per joint, the noise s_j: the calibrated one, else the model's learned
  // noise. Throws gipdyn::Error for a model without one that is not calibrated.
  Eigen::VectorXd noise_std() const;

  // Runs the method over consecutive rows of one log, from the first.
  ContactDetection detect(const Eigen::Ref<const Eigen::MatrixXd>& X, const Eigen::Ref<const Eigen::MatrixXd>& tau) const;

  // r for every row: the method's estimate of the external torque.
  Eigen::MatrixXd external_torque(const Eigen::Ref<const Eigen::MatrixXd>& X,
                                  const Eigen::Ref<const Eigen::MatrixXd>& tau) const;
  const ContactOptions& options() const { return options_; }

 private:
  void check_rows(const Eigen::Ref<const Eigen::MatrixXd>& X, const Eigen::Ref<const Eigen::MatrixXd>& tau) const;

  const Estimator* estimator_;
  ContactOptions options_;
  Eigen::VectorXd calibrated_noise_;
  std::unique_ptr<TorqueUncertainty> uncertainty_;  // null for models without one
};

}  // namespace gipdyn
