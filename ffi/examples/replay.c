/*
 * A machine's control task in miniature: build a controller from a commissioned bundle and a program
 * file, then step it once per recorded sensor sample and print the commands it would have sent.
 *
 *   replay BUNDLE PROGRAM SENSOR_LOG
 *
 * SENSOR_LOG: the sensor-log contract (docs/replay.md) as CSV: a header line, then one line per
 * control period `t_s,x_mm,force_n,gauge_um` (NaN or an empty field: no reading). Output on stdout: `cycle,voltage_v,flags,iterations` (the voltage with 17
 * significant digits: it reads back to the same double). On stderr: the ABI version and the allocator
 * calls counted inside the step loop — malloc, calloc, realloc, free, posix_memalign and aligned_alloc
 * are wrapped at link time (`-Wl,--wrap=malloc,...`), so every call the library makes is counted.
 *
 * Built and run by ffi/tests/c_program.rs with -Wall -Wextra -Wpedantic -Werror (docs/runtime.md).
 */
#include <errno.h>
#include <math.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "millcomp.h"

/* ---- allocator calls, counted while `counting` is set ---- */
static volatile int counting = 0;
static volatile unsigned long alloc_calls = 0;

void *__real_malloc(size_t size);
void *__real_calloc(size_t n, size_t size);
void *__real_realloc(void *p, size_t size);
void __real_free(void *p);
int __real_posix_memalign(void **p, size_t align, size_t size);
void *__real_aligned_alloc(size_t align, size_t size);

void *__wrap_malloc(size_t size);
void *__wrap_calloc(size_t n, size_t size);
void *__wrap_realloc(void *p, size_t size);
void __wrap_free(void *p);
int __wrap_posix_memalign(void **p, size_t align, size_t size);
void *__wrap_aligned_alloc(size_t align, size_t size);

void *__wrap_malloc(size_t size) {
  if (counting) alloc_calls++;
  return __real_malloc(size);
}
void *__wrap_calloc(size_t n, size_t size) {
  if (counting) alloc_calls++;
  return __real_calloc(n, size);
}
void *__wrap_realloc(void *p, size_t size) {
  if (counting) alloc_calls++;
  return __real_realloc(p, size);
}
void __wrap_free(void *p) {
  if (counting && p != NULL) alloc_calls++;
  __real_free(p);
}
int __wrap_posix_memalign(void **p, size_t align, size_t size) {
  if (counting) alloc_calls++;
  return __real_posix_memalign(p, align, size);
}
void *__wrap_aligned_alloc(size_t align, size_t size) {
  if (counting) alloc_calls++;
  return __real_aligned_alloc(align, size);
}

/* one field of a log line: a number, NaN for an empty field; 0 on a malformed one */
static int field(char **s, double *out) {
  char *end;
  if (**s == ',' || **s == '\n' || **s == '\r' || **s == '\0') {
    *out = (double)NAN;
  } else {
    errno = 0;
    *out = strtod(*s, &end);
    if (end == *s) return 0;
    *s = end;
  }
  if (**s == ',') (*s)++;
  return 1;
}

int main(int argc, char **argv) {
  if (argc != 4) {
    fprintf(stderr, "usage: %s BUNDLE PROGRAM SENSOR_LOG\n", argv[0]);
    return 2;
  }
  if (millcomp_abi_version() != MILLCOMP_ABI_VERSION) {
    fprintf(stderr, "library ABI %u, header %u\n", millcomp_abi_version(), MILLCOMP_ABI_VERSION);
    return 1;
  }
  /* the log, read whole before the loop (the loop itself must not allocate) */
  FILE *f = fopen(argv[3], "r");
  if (f == NULL) {
    fprintf(stderr, "%s: cannot open: %s\n", argv[3], strerror(errno));
    return 1;
  }
  size_t cap = 1024, n = 0;
  MillcompMeasurement *log = malloc(cap * sizeof *log);
  char line[512];
  unsigned long row = 0;
  if (log == NULL || fgets(line, sizeof line, f) == NULL) {
    fprintf(stderr, "%s: empty log (a header line is expected)\n", argv[3]);
    return 1;
  }
  while (fgets(line, sizeof line, f) != NULL) {
    row++;
    if (n == cap) {
      cap *= 2;
      log = realloc(log, cap * sizeof *log);
      if (log == NULL) return 1;
    }
    char *s = line;
    MillcompMeasurement m;
    double t_s;
    if (!field(&s, &t_s) || !field(&s, &m.x_mm) || !field(&s, &m.force_n) ||
        !field(&s, &m.gauge_um)) {
      fprintf(stderr, "%s: row %lu: expected t_s,x_mm,force_n,gauge_um: %s", argv[3], row, line);
      return 1;
    }
    log[n++] = m;
  }
  fclose(f);

  char err[512];
  MillcompController *ctl = millcomp_controller_new(argv[1], argv[2], err, sizeof err);
  if (ctl == NULL) {
    fprintf(stderr, "error: %s\n", err);
    return 1;
  }
  MillcompCommand *out = malloc(n * sizeof *out);
  if (out == NULL) return 1;

  /* the control loop: nothing but steps */
  counting = 1;
  for (size_t k = 0; k < n; k++) {
    if (millcomp_controller_step(ctl, &log[k], &out[k]) != MILLCOMP_OK) {
      counting = 0;
      fprintf(stderr, "step %zu failed\n", k);
      return 1;
    }
  }
  counting = 0;

  printf("cycle,voltage_v,flags,iterations\n");
  for (size_t k = 0; k < n; k++) {
    printf("%zu,%.17g,%u,%u\n", k, out[k].voltage_v, out[k].flags, out[k].iterations);
  }
  fprintf(stderr, "abi %u: %zu steps, %lu allocator calls inside the step loop\n",
          millcomp_abi_version(), n, alloc_calls);
  millcomp_controller_free(ctl);
  millcomp_controller_free(NULL);
  free(out);
  free(log);
  return 0;
}
