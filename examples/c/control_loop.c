/*
 * A learned model in a control loop, through gipdyn's C API: load a model,
 * make a workspace, then query the feed-forward torque once per control tick
 * and report the latency distribution of those queries.
 *
 *   control_loop MODEL [CALLS]        (CALLS: default 100000)
 *
 * The states follow a smooth motion; for models with the rigid-body structure
 * (gip, gip-friction, pp) the gravity torque and inertia matrix at the first
 * state are printed too. For models that learned their noise (GP and lip),
 * a contact detector then runs on the same motion, both methods, with the
 * model's own torque as the measurement and a constant external torque on the
 * first joint from the middle of the motion on: its latency, and the tick at
 * which the contact is flagged.
 */
#include <gipdyn/gipdyn.h>

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <time.h>

#define MAX_JOINTS 32

static double now_ns(void) {
  struct timespec t;
  clock_gettime(CLOCK_MONOTONIC, &t);
  return (double)t.tv_sec * 1e9 + (double)t.tv_nsec;
}

static int compare_doubles(const void* a, const void* b) {
  const double x = *(const double*)a, y = *(const double*)b;
  return (x > y) - (x < y);
}

int main(int argc, char** argv) {
  if (argc < 2) {
    fprintf(stderr, "usage: %s MODEL [CALLS]\n", argv[0]);
    return 2;
  }
  const long calls = argc > 2 ? atol(argv[2]) : 100000;
  if (calls < 1) {
    fprintf(stderr, "control_loop: CALLS must be at least 1\n");
    return 2;
  }
  gipdyn_model* model = NULL;
  if (gipdyn_model_load(argv[1], &model) != GIPDYN_OK) {
    fprintf(stderr, "control_loop: %s\n", gipdyn_last_error());
    return 1;
  }
  const int n = gipdyn_model_num_joints(model);
  if (n > MAX_JOINTS) {
    fprintf(stderr, "control_loop: the model has %d joints, this example handles %d\n", n, MAX_JOINTS);
    gipdyn_model_free(model);
    return 1;
  }
  gipdyn_workspace* ws = NULL;
  if (gipdyn_workspace_create(model, &ws) != GIPDYN_OK) {
    fprintf(stderr, "control_loop: %s\n", gipdyn_last_error());
    gipdyn_model_free(model);
    return 1;
  }

  double q[MAX_JOINTS], qd[MAX_JOINTS], qdd[MAX_JOINTS], tau[MAX_JOINTS];
  double* latency = malloc((size_t)calls * sizeof(double));
  if (!latency) {
    fprintf(stderr, "control_loop: out of memory for %ld latencies\n", calls);
    return 1;
  }
  double checksum = 0.0;
  int status = 0;
  for (long k = 0; k < calls; ++k) {
    const double t = 0.001 * (double)k; /* 1 kHz ticks */
    for (int i = 0; i < n; ++i) {
      const double w = 0.5 + 0.1 * i;
      q[i] = 0.5 * sin(w * t + i);
      qd[i] = 0.5 * w * cos(w * t + i);
      qdd[i] = -0.5 * w * w * sin(w * t + i);
    }
    const double start = now_ns();
    const gipdyn_status s = gipdyn_predict(ws, q, qd, qdd, n, tau);
    latency[k] = now_ns() - start;
    if (s != GIPDYN_OK) {
      fprintf(stderr, "control_loop: tick %ld: %s\n", k, gipdyn_last_error());
      status = 1;
      break;
    }
    checksum += tau[0];
  }
  if (status == 0) {
    qsort(latency, (size_t)calls, sizeof(double), compare_doubles);
    printf("%ld torque queries, %d joints: p50 %.1f us, p99 %.1f us, max %.1f us (checksum %.6g)\n", calls, n,
           latency[calls / 2] / 1e3, latency[(long)(0.99 * (double)(calls - 1))] / 1e3, latency[calls - 1] / 1e3,
           checksum);
  }

  if (status == 0 && gipdyn_model_has_physics(model)) {
    double g[MAX_JOINTS], M[MAX_JOINTS * MAX_JOINTS];
    for (int i = 0; i < n; ++i) q[i] = 0.3;
    if (gipdyn_gravity(ws, q, n, g) != GIPDYN_OK || gipdyn_inertia(ws, q, n, M) != GIPDYN_OK) {
      fprintf(stderr, "control_loop: %s\n", gipdyn_last_error());
      status = 1;
    } else {
      printf("gravity at q = 0.3:");
      for (int i = 0; i < n; ++i) printf(" %.4g", g[i]);
      printf("\ninertia diagonal at q = 0.3:");
      for (int i = 0; i < n; ++i) printf(" %.4g", M[i * n + i]);
      printf("\n");
    }
  }
  const char* methods[2] = {"residual", "momentum"};
  for (int m = 0; m < 2 && status == 0; ++m) {
    gipdyn_contact_options options = gipdyn_contact_options_default();
    options.method = m == 0 ? GIPDYN_CONTACT_RESIDUAL : GIPDYN_CONTACT_MOMENTUM;
    options.sample_time = 0.001;
    gipdyn_contact_detector* detector = NULL;
    const gipdyn_status created = gipdyn_contact_detector_create(model, &options, NULL, n, &detector);
    if (created == GIPDYN_ERROR_UNSUPPORTED) {
      printf("contact detection (%s): %s\n", methods[m], gipdyn_last_error());
      continue;
    }
    if (created != GIPDYN_OK) {
      fprintf(stderr, "control_loop: %s\n", gipdyn_last_error());
      status = 1;
      break;
    }
    double ext[MAX_JOINTS], margin[MAX_JOINTS];
    int contact[MAX_JOINTS];
    long flagged_at = -1;
    for (long k = 0; k < calls && status == 0; ++k) {
      const double t = 0.001 * (double)k;
      for (int i = 0; i < n; ++i) {
        const double w = 0.5 + 0.1 * i;
        q[i] = 0.5 * sin(w * t + i);
        qd[i] = 0.5 * w * cos(w * t + i);
        qdd[i] = -0.5 * w * w * sin(w * t + i);
      }
      /* The robot's measured torque: what the model predicts, less a push of 1 N m on joint 1 from mid-run on. */
      if (gipdyn_predict(ws, q, qd, qdd, n, tau) != GIPDYN_OK) {
        fprintf(stderr, "control_loop: tick %ld: %s\n", k, gipdyn_last_error());
        status = 1;
        break;
      }
      if (k >= calls / 2) tau[0] -= 1.0;
      const double start = now_ns();
      const gipdyn_status s = gipdyn_contact_detector_step(detector, q, qd, qdd, tau, n, ext, contact, margin);
      latency[k] = now_ns() - start;
      if (s != GIPDYN_OK) {
        fprintf(stderr, "control_loop: tick %ld: %s\n", k, gipdyn_last_error());
        status = 1;
      } else if (contact[0] && flagged_at < 0) {
        flagged_at = k;
      }
    }
    if (status == 0) {
      qsort(latency, (size_t)calls, sizeof(double), compare_doubles);
      printf("%ld contact detector steps (%s): p50 %.1f us, p99 %.1f us, max %.1f us; push at tick %ld flagged at "
             "tick %ld\n",
             calls, methods[m], latency[calls / 2] / 1e3, latency[(long)(0.99 * (double)(calls - 1))] / 1e3,
             latency[calls - 1] / 1e3, calls / 2, flagged_at);
    }
    gipdyn_contact_detector_free(detector);
  }
  free(latency);
  gipdyn_workspace_free(ws);
  gipdyn_model_free(model);
  return status;
}
