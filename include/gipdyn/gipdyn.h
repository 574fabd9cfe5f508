/*
 * gipdyn's C API (C99): a learned inverse dynamics model inside a control loop.
 *
 * Load a model file written by `gipdyn train` or the C++/Python APIs, make
 * one workspace per thread, then query torques (and, for models with the
 * rigid-body structure, gravity and inertia) for one state at a time. After
 * gipdyn_workspace_create, the query functions allocate no memory, whatever
 * the estimator (gipdyn_model_allocation_free says so per model), none takes
 * a lock or throws: every function returns a gipdyn_status, and
 * gipdyn_last_error() gives a one-line message for the last failure of the
 * calling thread.
 *
 *   gipdyn_model* model;
 *   if (gipdyn_model_load("arm.gipdyn", &model) != GIPDYN_OK) puts(gipdyn_last_error());
 *   gipdyn_workspace* ws;
 *   gipdyn_workspace_create(model, &ws);
 *   gipdyn_predict(ws, q, qd, qdd, n, tau);        // in the 1 kHz loop
 *   gipdyn_workspace_free(ws);
 *   gipdyn_model_free(model);
 *
 * A model is read-only and may be shared by threads; a workspace may not.
 * Free every workspace of a model before the model.
 */
#ifndef GIPDYN_C_API_H
#define GIPDYN_C_API_H

#ifdef __cplusplus
extern "C" {
#endif

typedef enum gipdyn_status {
  GIPDYN_OK = 0,
  GIPDYN_ERROR_NULL_ARGUMENT = 1, /* a required pointer was NULL */
  GIPDYN_ERROR_FILE = 2,          /* the model file is missing, unreadable, corrupt or of another format */
  GIPDYN_ERROR_SIZE = 3,          /* the joint count passed does not match the model's */
  GIPDYN_ERROR_UNSUPPORTED = 4,   /* the model cannot do this (e.g. inertia from an RBF model) */
  GIPDYN_ERROR_NOT_FINITE = 5,    /* an input is NaN or infinite, or the result would be */
  GIPDYN_ERROR_OUT_OF_MEMORY = 6,
  GIPDYN_ERROR_INTERNAL = 7,
  GIPDYN_ERROR_SINGULAR = 8,      /* the learned inertia matrix cannot be inverted at this state */
  GIPDYN_ERROR_INVALID_OPTION = 9 /* an option is out of its range (the message names it) */
} gipdyn_status;

typedef struct gipdyn_model gipdyn_model;
typedef struct gipdyn_workspace gipdyn_workspace;

/* The message of the calling thread's last failure ("" if none). Valid until
 * that thread's next gipdyn call. */
const char* gipdyn_last_error(void);
/* "ok", "null argument", ... */
const char* gipdyn_status_string(gipdyn_status status);

/* The library's version, e.g. "0.1.0". */
const char* gipdyn_version(void);
/* How the library was compiled and where it runs, one line for bug reports:
 * "built for x86-64 (SSE2); Eigen 3.4.0 (SSE, SSE2), 16-byte alignment;
 * running on a CPU with AVX2, FMA, AVX, SSE4.2; GIP kernel loops in AVX2".
 * Valid for the process's life. */
const char* gipdyn_build_info(void);

/* Loads any model file gipdyn writes: the GP estimators (gip, gip-friction,
 * rbf, the hybrids, pp, sp), lip, fe and nn. */
gipdyn_status gipdyn_model_load(const char* path, gipdyn_model** model);
void gipdyn_model_free(gipdyn_model* model); /* NULL is allowed */
/* Joint count, or -1 for a NULL model. */
int gipdyn_model_num_joints(const gipdyn_model* model);
/* 1 if gravity and inertia are defined (gip, gip-friction, gip+friction, pp,
 * fe, lip), else 0. */
int gipdyn_model_has_physics(const gipdyn_model* model);
/* 1 if this model's queries never allocate once the workspace exists (every
 * estimator gipdyn writes today: the GP kernels, lip, fe and nn); 0 for NULL. */
int gipdyn_model_allocation_free(const gipdyn_model* model);

gipdyn_status gipdyn_workspace_create(const gipdyn_model* model, gipdyn_workspace** workspace);
void gipdyn_workspace_free(gipdyn_workspace* workspace); /* NULL is allowed */

/* tau[n] = f(q[n], qd[n], qdd[n]); n must equal the model's joint count. */
gipdyn_status gipdyn_predict(gipdyn_workspace* workspace, const double* q, const double* qd, const double* qdd,
                             int n, double* tau);
/* g[n] = f(q, 0, 0). */
gipdyn_status gipdyn_gravity(gipdyn_workspace* workspace, const double* q, int n, double* g);
/* M[n * n], row-major: the symmetric part of the matrix whose column j is
 * f(q, 0, e_j) - g(q) (the C++ inertia()'s default form). */
gipdyn_status gipdyn_inertia(gipdyn_workspace* workspace, const double* q, int n, double* M);
/* Forward dynamics of the learned robot: qdd[n] = M(q)^-1 (tau - f(q, qd, 0)),
 * with M as learned (not symmetrised), so that gipdyn_predict at (q, qd, qdd)
 * gives back tau. */
gipdyn_status gipdyn_forward_dynamics(gipdyn_workspace* workspace, const double* q, const double* qd,
                                      const double* tau, int n, double* qdd);

/* Contact detection, one control tick at a time: from the measured joint
 * torques and the model, the external torque the environment applies to each
 * joint and a contact flag. Two methods: the torque residual
 * f(q, qd, qdd) - tau (any model), and the generalized-momentum observer,
 * which needs no acceleration but a model with physics
 * (gipdyn_model_has_physics). A joint is flagged once |ext| exceeds
 * k noise_std for min_duration seconds; k is the two-sided Gaussian quantile
 * of false_alarm_rate. After create, a step allocates no memory where the
 * model's queries do not (gipdyn_model_allocation_free). A detector is used
 * by one thread; free it before its model. */
typedef struct gipdyn_contact_detector gipdyn_contact_detector;

typedef enum gipdyn_contact_method { GIPDYN_CONTACT_RESIDUAL = 0, GIPDYN_CONTACT_MOMENTUM = 1 } gipdyn_contact_method;

typedef struct gipdyn_contact_options {
  gipdyn_contact_method method;
  double false_alarm_rate; /* per row and joint, in (0, 1) */
  double min_duration;     /* seconds above the threshold before a contact is flagged */
  double sample_time;      /* the control period in seconds: required */
  double momentum_gain;    /* the observer's gain in 1/s, at most 1 / sample_time; 0: automatic */
} gipdyn_contact_options;

/* The library's defaults (residual method), with sample_time 0: set it. */
gipdyn_contact_options gipdyn_contact_options_default(void);

/* noise_std[n]: each joint's standard deviation of the contact-free residual,
 * as measured on contact-free rows of the robot (`gipdyn detect --calibration`
 * prints it, "noise"); NULL: the noise the model learned (GP and lip models).
 * The model's predictive variance is left out: it costs O(N^2) a query. */
gipdyn_status gipdyn_contact_detector_create(const gipdyn_model* model, const gipdyn_contact_options* options,
                                             const double* noise_std, int n, gipdyn_contact_detector** detector);
void gipdyn_contact_detector_free(gipdyn_contact_detector* detector); /* NULL is allowed */
/* Starts a new motion: the observer's momentum and the duration counts. */
gipdyn_status gipdyn_contact_detector_reset(gipdyn_contact_detector* detector);
/* One tick: q, qd, tau[n] and qdd[n] (NULL allowed for the momentum method).
 * Writes ext[n] (N m or N), contact[n] (0 or 1) and margin[n] (|ext| over the
 * threshold; above 1 where it exceeds it). */
gipdyn_status gipdyn_contact_detector_step(gipdyn_contact_detector* detector, const double* q, const double* qd,
                                           const double* qdd, const double* tau, int n, double* ext, int* contact,
                                           double* margin);

#ifdef __cplusplus
}
#endif

#endif /* GIPDYN_C_API_H */
