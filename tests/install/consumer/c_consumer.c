/* The installed C API from a C project: a missing model file must give a status and a message. */
#include <gipdyn/gipdyn.h>
#include <stdio.h>

int main(void) {
  gipdyn_model* model = NULL;
  const gipdyn_status s = gipdyn_model_load("/nonexistent.gipdyn", &model);
  if (s != GIPDYN_ERROR_FILE || model != NULL || gipdyn_last_error()[0] == '\0') {
    fprintf(stderr, "c_consumer: unexpected status %s\n", gipdyn_status_string(s));
    return 1;
  }
  printf("C API found: %s (%s)\n", gipdyn_status_string(s), gipdyn_last_error());
  return 0;
}
