/*
 * host.c - a minimal FMI 2.0 co-simulation master for the native ship FMU.
 *
 * Usage:
 *   host LIBRARY [STEPS]            self-test, exit status 0 when every check passes
 *   host LIBRARY STEPS --bench      time STEPS calls of fmi2DoStep (h = 0.1 s) and print
 *                                   "us_per_step <microseconds>"
 *   host LIBRARY --run NAME         sail manoeuvre NAME (manoeuvre.h: turn-35, zigzag-10,
 *                                   zigzag-10-current) and print it as CSV on stdout, as
 *                                   the FMI 3.0 host host3.c does
 *
 * LIBRARY is the shared library of an unpacked FMU (<dir>/binaries/<platform>/<id>.so);
 * the GUID is read from <dir>/modelDescription.xml. The value references are those of
 * fmu_model.interface.fmu_variables: inputs rudder_angle 0, propeller_rpm 1; outputs
 * u, v, r, x, y, psi 2..7; parameters length 8, max_step 9, u0 ... psi0 10..15.
 *
 * The self-test runs two instances side by side (STEPS steps each, default 10000) and
 * checks that each equals a run of a fresh instance alone (no shared state), that
 * fmi2GetFMUstate/fmi2SetFMUstate and fmi2SerializeFMUstate/fmi2DeSerializeFMUstate
 * continue bit-identically, that fmi2Reset returns to the initial state, that bad
 * input gives fmi2Error, and that every allocation is freed. A run (--run) reads the
 * value references of its variables from modelDescription.xml by name.
 */
#define _XOPEN_SOURCE 700 /* POSIX 2008 with XSI: dlopen, clock_gettime, realpath */

#include <dlfcn.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "fmi2FunctionTypes.h"
#include "manoeuvre.h"

#define VR_RUDDER 0u
#define VR_RPM 1u
#define VR_STATE 2u
#define VR_MAX_STEP 9u
#define VR_U0 10u
#define N_STATES 6
#define STEP_SIZE 0.1

typedef struct {
    fmi2InstantiateTYPE *instantiate;
    fmi2FreeInstanceTYPE *free_instance;
    fmi2SetupExperimentTYPE *setup_experiment;
    fmi2EnterInitializationModeTYPE *enter_initialization_mode;
    fmi2ExitInitializationModeTYPE *exit_initialization_mode;
    fmi2TerminateTYPE *terminate;
    fmi2ResetTYPE *reset;
    fmi2GetRealTYPE *get_real;
    fmi2SetRealTYPE *set_real;
    fmi2DoStepTYPE *do_step;
    fmi2GetFMUstateTYPE *get_fmu_state;
    fmi2SetFMUstateTYPE *set_fmu_state;
    fmi2FreeFMUstateTYPE *free_fmu_state;
    fmi2SerializedFMUstateSizeTYPE *serialized_size;
    fmi2SerializeFMUstateTYPE *serialize;
    fmi2DeSerializeFMUstateTYPE *deserialize;
} Api;

/* Allocation and logging bookkeeping, reached through componentEnvironment. */
typedef struct {
    long live_allocations;
    long errors_logged;
    int quiet;
} Environment;

static Environment environment = {0, 0, 0};
static int failures = 0;

#define CHECK(condition, ...)                                        \
    do {                                                             \
        if (!(condition)) {                                          \
            fprintf(stderr, "FAIL %s:%d: ", __FILE__, __LINE__);     \
            fprintf(stderr, __VA_ARGS__);                            \
            fputc('\n', stderr);                                     \
            failures++;                                              \
        }                                                            \
    } while (0)

static void logger(fmi2ComponentEnvironment env, fmi2String instance, fmi2Status status,
                   fmi2String category, fmi2String message, ...)
{
    Environment *e = (Environment *)env;
    va_list args;
    if (status >= fmi2Error) {
        e->errors_logged++;
    }
    if (e->quiet) {
        return;
    }
    fprintf(stderr, "[%s] %s (%d): ", instance, category, (int)status);
    va_start(args, message);
    vfprintf(stderr, message, args);
    va_end(args);
    fputc('\n', stderr);
}

static void *allocate(size_t n, size_t size)
{
    void *p = calloc(n, size);
    if (p != NULL) {
        environment.live_allocations++;
    }
    return p;
}

static void release(void *p)
{
    if (p != NULL) {
        environment.live_allocations--;
    }
    free(p);
}

static const fmi2CallbackFunctions callbacks = {logger, allocate, release, NULL, &environment};

static int load_api(void *library, Api *api)
{
    int ok = 1;
    LOAD(instantiate, "fmi2Instantiate");
    LOAD(free_instance, "fmi2FreeInstance");
    LOAD(setup_experiment, "fmi2SetupExperiment");
    LOAD(enter_initialization_mode, "fmi2EnterInitializationMode");
    LOAD(exit_initialization_mode, "fmi2ExitInitializationMode");
    LOAD(terminate, "fmi2Terminate");
    LOAD(reset, "fmi2Reset");
    LOAD(get_real, "fmi2GetReal");
    LOAD(set_real, "fmi2SetReal");
    LOAD(do_step, "fmi2DoStep");
    LOAD(get_fmu_state, "fmi2GetFMUstate");
    LOAD(set_fmu_state, "fmi2SetFMUstate");
    LOAD(free_fmu_state, "fmi2FreeFMUstate");
    LOAD(serialized_size, "fmi2SerializedFMUstateSize");
    LOAD(serialize, "fmi2SerializeFMUstate");
    LOAD(deserialize, "fmi2DeSerializeFMUstate");
    return ok;
}

/* URI of the FMU's resources folder, passed to fmi2Instantiate. */
static char resource_location[4200] = "";
/* The value references of a run (--run), by name. */
static unsigned int vr_run_inputs[N_RUN_INPUTS];
static unsigned int vr_run_outputs[N_RUN_OUTPUTS];

/* Read guid="..." from <library>/../../modelDescription.xml into guid, set
   resource_location to file://<library>/../../resources and, for a run, its value
   references. */
static int read_guid(const char *library_path, char *guid, size_t size, int run)
{
    char root[4096];
    char *text = read_model_description(library_path, root, sizeof root);
    int ok;
    if (text == NULL) {
        return 0;
    }
    snprintf(resource_location, sizeof resource_location, "file://%s/resources", root);
    ok = root_attribute(text, "guid", guid, size) &&
         (!run || run_value_references(text, vr_run_inputs, vr_run_outputs));
    free(text);
    return ok;
}

/* Inputs of a run at step k: a rudder sine of amplitude `rudder_deg`, rpm near 120. */
static void inputs(int k, double rudder_deg, double *values)
{
    const double t = k * STEP_SIZE;
    values[0] = rudder_deg * PI / 180.0 * sin(2.0 * PI * t / 200.0);
    values[1] = 120.0 + 5.0 * sin(2.0 * PI * t / 300.0);
}

static fmi2Component start(const Api *api, const char *guid, const char *name, double u0)
{
    const fmi2ValueReference vr = VR_U0;
    fmi2Component c = api->instantiate(name, fmi2CoSimulation, guid, resource_location,
                                       &callbacks, fmi2False, fmi2False);
    if (c == NULL) {
        return NULL;
    }
    if (api->set_real(c, &vr, 1, &u0) != fmi2OK ||
        api->setup_experiment(c, fmi2False, 0.0, 0.0, fmi2False, 0.0) != fmi2OK ||
        api->enter_initialization_mode(c) != fmi2OK ||
        api->exit_initialization_mode(c) != fmi2OK) {
        api->free_instance(c);
        return NULL;
    }
    return c;
}

static int step(const Api *api, fmi2Component c, int k, double rudder_deg)
{
    const fmi2ValueReference vr[2] = {VR_RUDDER, VR_RPM};
    double u[2];
    inputs(k, rudder_deg, u);
    if (api->set_real(c, vr, 2, u) != fmi2OK) {
        return 0;
    }
    return api->do_step(c, k * STEP_SIZE, STEP_SIZE, fmi2True) == fmi2OK;
}

static void outputs(const Api *api, fmi2Component c, double *x)
{
    const fmi2ValueReference vr[N_STATES] = {2, 3, 4, 5, 6, 7};
    if (api->get_real(c, vr, N_STATES, x) != fmi2OK) {
        memset(x, 0, N_STATES * sizeof *x);
        failures++;
    }
}

/* Run `from` .. `to` steps; returns 0 on a failed step. */
static int run(const Api *api, fmi2Component c, int from, int to, double rudder_deg)
{
    int k;
    for (k = from; k < to; k++) {
        if (!step(api, c, k, rudder_deg)) {
            return 0;
        }
    }
    return 1;
}

static int self_test(const Api *api, const char *guid, int steps)
{
    double xa[N_STATES], xb[N_STATES], xa_alone[N_STATES], xb_alone[N_STATES];
    double x1[N_STATES], x2[N_STATES], x3[N_STATES], x0[N_STATES];
    fmi2Component a, b, alone;
    fmi2FMUstate saved = NULL;
    fmi2FMUstate restored = NULL;
    size_t size = 0;
    char *bytes;
    int k;
    const int half = steps / 2;

    /* Two instances side by side, different initial speed and rudder. */
    a = start(api, guid, "ship A", 5.0);
    b = start(api, guid, "ship B", 3.0);
    CHECK(a != NULL && b != NULL, "instantiation failed");
    if (a == NULL || b == NULL) {
        return 1;
    }
    outputs(api, a, x0);
    for (k = 0; k < steps; k++) {
        CHECK(step(api, a, k, 20.0), "A: step %d failed", k);
        CHECK(step(api, b, k, -10.0), "B: step %d failed", k);
        if (k == half - 1) {
            CHECK(api->get_fmu_state(a, &saved) == fmi2OK, "fmi2GetFMUstate failed");
        }
    }
    outputs(api, a, xa);
    outputs(api, b, xb);
    for (k = 0; k < N_STATES; k++) {
        CHECK(isfinite(xa[k]) && isfinite(xb[k]), "non-finite output %d", k);
    }
    CHECK(xa[0] > 0.0 && xb[0] > 0.0, "ships must still go ahead (u = %g, %g)", xa[0], xb[0]);

    /* Each instance alone gives bit-identical results: no state is shared. */
    alone = start(api, guid, "A alone", 5.0);
    CHECK(alone != NULL && run(api, alone, 0, steps, 20.0), "run of A alone failed");
    outputs(api, alone, xa_alone);
    api->free_instance(alone);
    alone = start(api, guid, "B alone", 3.0);
    CHECK(alone != NULL && run(api, alone, 0, steps, -10.0), "run of B alone failed");
    outputs(api, alone, xb_alone);
    api->free_instance(alone);
    CHECK(memcmp(xa, xa_alone, sizeof xa) == 0, "A differs from A run alone");
    CHECK(memcmp(xb, xb_alone, sizeof xb) == 0, "B differs from B run alone");

    /* Restore the state saved half-way and redo the second half: bit-identical. */
    memcpy(x1, xa, sizeof x1);
    CHECK(api->set_fmu_state(a, saved) == fmi2OK, "fmi2SetFMUstate failed");
    CHECK(run(api, a, half, steps, 20.0), "rerun after fmi2SetFMUstate failed");
    outputs(api, a, x2);
    CHECK(memcmp(x1, x2, sizeof x1) == 0, "continuation after fmi2SetFMUstate differs");

    /* Same through the serialised form. */
    CHECK(api->serialized_size(a, saved, &size) == fmi2OK && size > 0, "size failed");
    bytes = (char *)malloc(size);
    CHECK(bytes != NULL, "out of memory");
    if (bytes != NULL) {
        CHECK(api->serialize(a, saved, bytes, size) == fmi2OK, "serialize failed");
        CHECK(api->deserialize(b, bytes, size, &restored) == fmi2OK, "deserialize failed");
        /* A state saved in A restores into B (same FMU): B continues as A would. */
        CHECK(api->set_fmu_state(b, restored) == fmi2OK, "fmi2SetFMUstate(B) failed");
        CHECK(run(api, b, half, steps, 20.0), "rerun after deserialize failed");
        outputs(api, b, x3);
        CHECK(memcmp(x1, x3, sizeof x1) == 0, "continuation after deserialisation differs");
        bytes[0] ^= 0x55; /* corrupt the magic: must be rejected, not crash */
        environment.quiet = 1;
        CHECK(api->deserialize(b, bytes, size, &restored) == fmi2Error, "corrupt state accepted");
        environment.quiet = 0;
        free(bytes);
    }
    CHECK(api->free_fmu_state(a, &saved) == fmi2OK && saved == NULL, "free state failed");
    CHECK(api->free_fmu_state(b, &restored) == fmi2OK && restored == NULL, "free state failed");

    /* Bad input: fmi2Error with a logged message, never a crash; the instance goes on. */
    {
        const fmi2ValueReference vr = VR_RUDDER;
        const fmi2ValueReference vr_max_step = VR_MAX_STEP;
        const double nan_value = nan("");
        const double too_much = 50.0 * PI / 180.0;
        const double small = 0.01;
        long errors = environment.errors_logged;
        environment.quiet = 1;
        CHECK(api->set_real(a, &vr, 1, &nan_value) == fmi2Error, "NaN rudder accepted");
        CHECK(api->set_real(a, &vr, 1, &too_much) == fmi2Error, "rudder 50 deg accepted");
        CHECK(api->set_real(a, &vr_max_step, 1, &small) == fmi2Error, "parameter set after init");
        CHECK(api->do_step(a, steps * STEP_SIZE, -0.1, fmi2True) == fmi2Error, "h < 0 accepted");
        environment.quiet = 0;
        CHECK(environment.errors_logged == errors + 4, "expected 4 logged errors, got %ld",
              environment.errors_logged - errors);
        CHECK(step(api, a, steps, 20.0), "step after rejected calls failed");
    }

    /* Reset: back to the start values, ready for a new run. */
    CHECK(api->reset(a) == fmi2OK, "fmi2Reset failed");
    CHECK(api->setup_experiment(a, fmi2False, 0.0, 0.0, fmi2False, 0.0) == fmi2OK &&
              api->enter_initialization_mode(a) == fmi2OK &&
              api->exit_initialization_mode(a) == fmi2OK,
          "re-initialisation after reset failed");
    outputs(api, a, x1);
    CHECK(memcmp(x0, x1, sizeof x0) == 0, "state after fmi2Reset differs from the start");

    CHECK(api->terminate(a) == fmi2OK && api->terminate(b) == fmi2OK, "fmi2Terminate failed");
    api->free_instance(a);
    api->free_instance(b);
    CHECK(environment.live_allocations == 0, "%ld allocations not freed",
          environment.live_allocations);
    if (failures == 0) {
        printf("ok: 2 instances x %d steps, state round trips, reset, bad input\n", steps);
    }
    return failures == 0 ? 0 : 1;
}

static int bench(const Api *api, const char *guid, int steps)
{
    struct timespec t0, t1;
    double seconds;
    double x[N_STATES];
    fmi2Component c = start(api, guid, "bench", 5.0);
    if (c == NULL) {
        fprintf(stderr, "instantiation failed\n");
        return 1;
    }
    clock_gettime(CLOCK_MONOTONIC, &t0);
    if (!run(api, c, 0, steps, 20.0)) {
        fprintf(stderr, "a step failed\n");
        api->free_instance(c);
        return 1;
    }
    clock_gettime(CLOCK_MONOTONIC, &t1);
    outputs(api, c, x);
    api->free_instance(c);
    seconds = (double)(t1.tv_sec - t0.tv_sec) + 1e-9 * (double)(t1.tv_nsec - t0.tv_nsec);
    printf("steps %d\nus_per_step %.4f\nfinal_u %.17g\n", steps, 1e6 * seconds / steps, x[0]);
    return 0;
}

/* Sail the manoeuvre from the FMU's start values and print it (manoeuvre.h); 0 when every
   call succeeded. */
static int sail(const Api *api, const char *guid, const Manoeuvre *m)
{
    double y[N_RUN_OUTPUTS];
    double u[N_RUN_INPUTS];
    Helm helm = {NULL, 0.0, 0.0, 0.0, 0};
    const int n = (int)(m->duration_s / RUN_STEP_S + 0.5);
    int k;
    fmi2Component c = api->instantiate(m->name, fmi2CoSimulation, guid, resource_location,
                                       &callbacks, fmi2False, fmi2False);
    if (c == NULL || api->setup_experiment(c, fmi2False, 0.0, 0.0, fmi2False, 0.0) != fmi2OK ||
        api->enter_initialization_mode(c) != fmi2OK ||
        api->exit_initialization_mode(c) != fmi2OK) {
        fprintf(stderr, "instantiation failed\n");
        if (c != NULL) {
            api->free_instance(c);
        }
        return 1;
    }
    helm.m = m;
    print_header();
    for (k = 0;; k++) {
        if (api->get_real(c, vr_run_outputs, N_RUN_OUTPUTS, y) != fmi2OK) {
            failures++;
            break;
        }
        helm_next(&helm, y[RUN_PSI], u);
        print_row(k * RUN_STEP_S, u, y);
        if (k == n) {
            break;
        }
        if (api->set_real(c, vr_run_inputs, N_RUN_INPUTS, u) != fmi2OK ||
            api->do_step(c, k * RUN_STEP_S, RUN_STEP_S, fmi2True) != fmi2OK) {
            fprintf(stderr, "step %d failed\n", k);
            failures++;
            break;
        }
    }
    CHECK(api->terminate(c) == fmi2OK, "fmi2Terminate failed");
    api->free_instance(c);
    CHECK(environment.live_allocations == 0, "%ld allocations not freed",
          environment.live_allocations);
    return failures == 0 ? 0 : 1;
}

int main(int argc, char **argv)
{
    Api api;
    void *library;
    char *path;
    char guid[128];
    const Manoeuvre *manoeuvre = NULL;
    int steps = 10000;
    int status;
    if (argc < 2 || argc > 4) {
        fprintf(stderr, "usage: %s LIBRARY [STEPS] [--bench] | LIBRARY --run NAME\n", argv[0]);
        return 2;
    }
    if (argc == 4 && strcmp(argv[2], "--run") == 0) {
        manoeuvre = find_manoeuvre(argv[3]);
        if (manoeuvre == NULL) {
            fprintf(stderr, "unknown manoeuvre %s\n", argv[3]);
            return 2;
        }
    } else if (argc >= 3) {
        steps = atoi(argv[2]);
        if (steps < 2) {
            fprintf(stderr, "STEPS must be at least 2\n");
            return 2;
        }
    }
    path = realpath(argv[1], NULL);
    if (path == NULL || !read_guid(path, guid, sizeof guid, manoeuvre != NULL)) {
        fprintf(stderr, "cannot read the GUID from the modelDescription.xml of %s\n", argv[1]);
        free(path);
        return 2;
    }
    library = dlopen(path, RTLD_NOW | RTLD_LOCAL);
    free(path);
    if (library == NULL) {
        fprintf(stderr, "dlopen failed: %s\n", dlerror());
        return 2;
    }
    if (!load_api(library, &api)) {
        dlclose(library);
        return 2;
    }
    if (manoeuvre != NULL) {
        status = sail(&api, guid, manoeuvre);
    } else if (argc == 4 && strcmp(argv[3], "--bench") == 0) {
        status = bench(&api, guid, steps);
    } else {
        status = self_test(&api, guid, steps);
    }
    dlclose(library);
    return status;
}
