/*
 * host3.c - a small FMI 3.0 co-simulation master for the native ship FMU.
 *
 * Usage:
 *   host3 LIBRARY [STEPS]         self-test, exit status 0 when every check passes
 *   host3 LIBRARY --run NAME      sail manoeuvre NAME (manoeuvre.h: turn-35, zigzag-10,
 *                                 zigzag-10-current) and print it as CSV on stdout
 *
 * LIBRARY is the shared library of an unpacked FMI 3.0 FMU
 * (<dir>/binaries/x86_64-linux/<id>.so); the instantiationToken and the value references
 * are read from <dir>/modelDescription.xml by name. Written against the FMI 3.0 headers
 * the native FMU is compiled with (fmu_model.export_native.fmi_headers_dir(): fmpy's).
 *
 * The self-test sails a zig-zag (STEPS steps, default 3000) in two instances side by
 * side and checks: that fmi3GetFMUState/fmi3SetFMUState and
 * fmi3SerializeFMUState/fmi3DeserializeFMUState continue bit-identically, also in the
 * other instance; that bad calls (non-finite or out-of-range input, a fixed parameter
 * after initialisation, a step that is not positive or not at the FMU's time, a corrupt
 * serialised state) give fmi3Error with a logged message and change nothing; that a
 * diverging step gives fmi3Discard with terminateSimulation and the lastSuccessfulTime
 * of its start, and the next step fmi3Error; that fmi3Reset returns to the start; and
 * that a wrong instantiationToken or eventModeUsed is refused. FMI 3.0 has no memory
 * callbacks: leaks are valgrind's to find (tests/test_fmu_c_hosts.py).
 */
#define _XOPEN_SOURCE 700 /* POSIX 2008 with XSI: dlopen, realpath */

#include <dlfcn.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fmi3FunctionTypes.h"
#include "manoeuvre.h"

typedef struct {
    fmi3InstantiateCoSimulationTYPE *instantiate;
    fmi3FreeInstanceTYPE *free_instance;
    fmi3EnterInitializationModeTYPE *enter_initialization_mode;
    fmi3ExitInitializationModeTYPE *exit_initialization_mode;
    fmi3TerminateTYPE *terminate;
    fmi3ResetTYPE *reset;
    fmi3GetFloat64TYPE *get_float64;
    fmi3SetFloat64TYPE *set_float64;
    fmi3DoStepTYPE *do_step;
    fmi3GetFMUStateTYPE *get_fmu_state;
    fmi3SetFMUStateTYPE *set_fmu_state;
    fmi3FreeFMUStateTYPE *free_fmu_state;
    fmi3SerializedFMUStateSizeTYPE *serialized_size;
    fmi3SerializeFMUStateTYPE *serialize;
    fmi3DeserializeFMUStateTYPE *deserialize;
} Api;

/* What the logger saw, reached through instanceEnvironment. */
typedef struct {
    long errors_logged;
    long discards_logged;
    int quiet;
} Environment;

static Environment environment = {0, 0, 0};
static int failures = 0;

/* Read from modelDescription.xml. */
static char token[256] = "";
static char resource_path[4200] = "";
static unsigned int vr_inputs[N_RUN_INPUTS];
static unsigned int vr_outputs[N_RUN_OUTPUTS];
static unsigned int vr_max_step;
static unsigned int vr_a1;

#define CHECK(condition, ...)                                        \
    do {                                                             \
        if (!(condition)) {                                          \
            fprintf(stderr, "FAIL %s:%d: ", __FILE__, __LINE__);     \
            fprintf(stderr, __VA_ARGS__);                            \
            fputc('\n', stderr);                                     \
            failures++;                                              \
        }                                                            \
    } while (0)

static void logger(fmi3InstanceEnvironment env, fmi3Status status, fmi3String category,
                   fmi3String message)
{
    Environment *e = (Environment *)env;
    if (status == fmi3Discard) {
        e->discards_logged++;
    } else if (status >= fmi3Error) {
        e->errors_logged++;
    }
    if (!e->quiet) {
        fprintf(stderr, "%s (%d): %s\n", category, (int)status, message);
    }
}

static int load_api(void *library, Api *api)
{
    int ok = 1;
    LOAD(instantiate, "fmi3InstantiateCoSimulation");
    LOAD(free_instance, "fmi3FreeInstance");
    LOAD(enter_initialization_mode, "fmi3EnterInitializationMode");
    LOAD(exit_initialization_mode, "fmi3ExitInitializationMode");
    LOAD(terminate, "fmi3Terminate");
    LOAD(reset, "fmi3Reset");
    LOAD(get_float64, "fmi3GetFloat64");
    LOAD(set_float64, "fmi3SetFloat64");
    LOAD(do_step, "fmi3DoStep");
    LOAD(get_fmu_state, "fmi3GetFMUState");
    LOAD(set_fmu_state, "fmi3SetFMUState");
    LOAD(free_fmu_state, "fmi3FreeFMUState");
    LOAD(serialized_size, "fmi3SerializedFMUStateSize");
    LOAD(serialize, "fmi3SerializeFMUState");
    LOAD(deserialize, "fmi3DeserializeFMUState");
    return ok;
}

/* Token, resource path and value references from the FMU's modelDescription.xml. */
static int read_description(const char *library_path)
{
    char root[4096];
    char *text = read_model_description(library_path, root, sizeof root);
    int ok;
    if (text == NULL) {
        return 0;
    }
    snprintf(resource_path, sizeof resource_path, "%s/resources/", root);
    ok = root_attribute(text, "instantiationToken", token, sizeof token) &&
         run_value_references(text, vr_inputs, vr_outputs) &&
         value_reference(text, "max_step", &vr_max_step) && value_reference(text, "a1", &vr_a1);
    free(text);
    return ok;
}

static fmi3Instance instantiate(const Api *api, const char *name, const char *instantiation_token,
                                fmi3Boolean event_mode_used)
{
    return api->instantiate(name, instantiation_token, resource_path, fmi3False, fmi3False,
                            event_mode_used, fmi3False, NULL, 0, &environment, logger, NULL);
}

/* An instance in step mode at t = 0; parameter vr set to value first unless value is NaN. */
static fmi3Instance start(const Api *api, const char *name, unsigned int vr, double value)
{
    fmi3Instance c = instantiate(api, name, token, fmi3False);
    if (c == NULL) {
        return NULL;
    }
    if ((!isnan(value) && api->set_float64(c, &vr, 1, &value, 1) != fmi3OK) ||
        api->enter_initialization_mode(c, fmi3False, 0.0, 0.0, fmi3False, 0.0) != fmi3OK ||
        api->exit_initialization_mode(c) != fmi3OK) {
        api->free_instance(c);
        return NULL;
    }
    return c;
}

static void outputs(const Api *api, fmi3Instance c, double *y)
{
    if (api->get_float64(c, vr_outputs, N_RUN_OUTPUTS, y, N_RUN_OUTPUTS) != fmi3OK) {
        memset(y, 0, N_RUN_OUTPUTS * sizeof *y);
        failures++;
    }
}

/* One step of the helm's manoeuvre from step k; the status of fmi3DoStep (or of the
   fmi3SetFloat64 that failed). */
static fmi3Status step(const Api *api, fmi3Instance c, Helm *helm, int k)
{
    double y[N_RUN_OUTPUTS];
    double u[N_RUN_INPUTS];
    fmi3Boolean event_handling_needed, terminate, early_return;
    fmi3Float64 last_successful_time;
    fmi3Status status;
    outputs(api, c, y);
    helm_next(helm, y[RUN_PSI], u);
    status = api->set_float64(c, vr_inputs, N_RUN_INPUTS, u, N_RUN_INPUTS);
    if (status != fmi3OK) {
        return status;
    }
    return api->do_step(c, k * RUN_STEP_S, RUN_STEP_S, fmi3True, &event_handling_needed,
                        &terminate, &early_return, &last_successful_time);
}

/* Steps from .. to of the helm's manoeuvre; 0 when one failed. */
static int run(const Api *api, fmi3Instance c, Helm *helm, int from, int to)
{
    int k;
    for (k = from; k < to; k++) {
        if (step(api, c, helm, k) != fmi3OK) {
            return 0;
        }
    }
    return 1;
}

/* A bad call: fmi3Error, one logged error, the outputs unchanged. */
#define CHECK_REFUSED(call, what)                                                   \
    do {                                                                           \
        double before_[N_RUN_OUTPUTS], after_[N_RUN_OUTPUTS];                      \
        long errors_ = environment.errors_logged;                                  \
        outputs(api, c, before_);                                                  \
        environment.quiet = 1;                                                     \
        CHECK((call) == fmi3Error, "%s: not fmi3Error", what);                     \
        environment.quiet = 0;                                                     \
        CHECK(environment.errors_logged == errors_ + 1, "%s: no error logged", what); \
        outputs(api, c, after_);                                                   \
        CHECK(memcmp(before_, after_, sizeof before_) == 0, "%s: changed the state", what); \
    } while (0)

static void bad_calls(const Api *api, fmi3Instance c, int k)
{
    const double nan_value = nan("");
    const double too_much = 50.0 * PI / 180.0;
    const double small = 0.01;
    const double t = k * RUN_STEP_S;
    fmi3Boolean event_handling_needed, terminate, early_return;
    fmi3Float64 last;
    CHECK_REFUSED(api->set_float64(c, &vr_inputs[0], 1, &nan_value, 1), "NaN rudder");
    CHECK_REFUSED(api->set_float64(c, &vr_inputs[0], 1, &too_much, 1), "rudder 50 deg");
    CHECK_REFUSED(api->set_float64(c, &vr_inputs[2], 1, &nan_value, 1), "NaN current");
    CHECK_REFUSED(api->set_float64(c, &vr_max_step, 1, &small, 1), "parameter after init");
    CHECK_REFUSED(api->do_step(c, t, 0.0, fmi3True, &event_handling_needed, &terminate,
                               &early_return, &last),
                  "h = 0");
    CHECK_REFUSED(api->do_step(c, t, -0.1, fmi3True, &event_handling_needed, &terminate,
                               &early_return, &last),
                  "h < 0");
    CHECK_REFUSED(api->do_step(c, t + 5.0, 0.1, fmi3True, &event_handling_needed, &terminate,
                               &early_return, &last),
                  "a step at the wrong time");
}

/* a1 = 0.5 makes the surge unstable: u' = a1 u^2 + ... blows up within 0.4 s. */
static void divergence(const Api *api)
{
    double before[N_RUN_OUTPUTS], after[N_RUN_OUTPUTS];
    fmi3Boolean event_handling_needed = fmi3True, terminate = fmi3False, early_return = fmi3True;
    fmi3Float64 last = -1.0;
    long discards = environment.discards_logged;
    fmi3Instance c = start(api, "unstable", vr_a1, 0.5);
    CHECK(c != NULL, "instantiation with a1 = 0.5 failed");
    if (c == NULL) {
        return;
    }
    CHECK(api->do_step(c, 0.0, 0.1, fmi3True, &event_handling_needed, &terminate, &early_return,
                       &last) == fmi3OK,
          "first step of the unstable ship failed");
    CHECK(!terminate && last == 0.1, "first step: terminate %d, last %g", (int)terminate, last);
    outputs(api, c, before);
    environment.quiet = 1;
    CHECK(api->do_step(c, 0.1, 2.0, fmi3True, &event_handling_needed, &terminate, &early_return,
                       &last) == fmi3Discard,
          "a diverging step is not fmi3Discard");
    CHECK(terminate && last == 0.1 && !event_handling_needed && !early_return,
          "diverged: terminate %d, lastSuccessfulTime %g", (int)terminate, last);
    CHECK(environment.discards_logged == discards + 1, "no discard logged");
    outputs(api, c, after);
    CHECK(memcmp(before, after, sizeof before) == 0, "the diverged step changed the state");
    CHECK(api->do_step(c, 0.1, 0.1, fmi3True, &event_handling_needed, &terminate, &early_return,
                       &last) == fmi3Error,
          "a step after the diverged one is not fmi3Error");
    environment.quiet = 0;
    CHECK(api->terminate(c) == fmi3OK, "fmi3Terminate after divergence failed");
    api->free_instance(c);
}

static int self_test(const Api *api, int steps)
{
    double ya[N_RUN_OUTPUTS], yb[N_RUN_OUTPUTS], y1[N_RUN_OUTPUTS], y0[N_RUN_OUTPUTS];
    const Manoeuvre *zigzag = find_manoeuvre("zigzag-10");
    const Manoeuvre *turn = find_manoeuvre("turn-35");
    Helm helm_a = {NULL, 0.0, 0.0, 0.0, 0};
    Helm helm_b = {NULL, 0.0, 0.0, 0.0, 0};
    Helm helm_half = {NULL, 0.0, 0.0, 0.0, 0};
    fmi3FMUState saved = NULL;
    fmi3FMUState restored = NULL;
    fmi3Instance a, b;
    size_t size = 0;
    fmi3Byte *bytes;
    int k;
    const int half = steps / 2;
    helm_a.m = zigzag;
    helm_b.m = turn;

    /* Two instances side by side: a zig-zag and a turn. */
    a = start(api, "ship A", 0, nan(""));
    b = start(api, "ship B", 0, nan(""));
    CHECK(a != NULL && b != NULL, "instantiation failed");
    if (a == NULL || b == NULL) {
        return 1;
    }
    outputs(api, a, y0);
    for (k = 0; k < steps; k++) {
        if (k == half) {
            CHECK(api->get_fmu_state(a, &saved) == fmi3OK, "fmi3GetFMUState failed");
            helm_half = helm_a;
        }
        CHECK(step(api, a, &helm_a, k) == fmi3OK, "A: step %d failed", k);
        CHECK(step(api, b, &helm_b, k) == fmi3OK, "B: step %d failed", k);
    }
    outputs(api, a, ya);
    outputs(api, b, yb);
    for (k = 0; k < N_RUN_OUTPUTS; k++) {
        CHECK(isfinite(ya[k]) && isfinite(yb[k]), "non-finite output %d", k);
    }
    CHECK(ya[RUN_PSI] != 0.0 && yb[RUN_PSI] > 1.0, "the ships did not turn (%g, %g)",
          ya[RUN_PSI], yb[RUN_PSI]);

    /* Restore the state saved half-way and redo the second half: bit-identical. */
    CHECK(api->set_fmu_state(a, saved) == fmi3OK, "fmi3SetFMUState failed");
    helm_a = helm_half;
    CHECK(run(api, a, &helm_a, half, steps), "rerun after fmi3SetFMUState failed");
    outputs(api, a, y1);
    CHECK(memcmp(ya, y1, sizeof ya) == 0, "continuation after fmi3SetFMUState differs");

    /* The same through the serialised form, restored into B (the same FMU). */
    CHECK(api->serialized_size(a, saved, &size) == fmi3OK && size > 0, "size failed");
    bytes = (fmi3Byte *)malloc(size);
    CHECK(bytes != NULL, "out of memory");
    if (bytes != NULL) {
        fmi3Instance c = b;
        CHECK(api->serialize(a, saved, bytes, size) == fmi3OK, "serialize failed");
        CHECK(api->deserialize(b, bytes, size, &restored) == fmi3OK, "deserialize failed");
        CHECK(api->set_fmu_state(b, restored) == fmi3OK, "fmi3SetFMUState(B) failed");
        helm_b = helm_half;
        CHECK(run(api, b, &helm_b, half, steps), "rerun after deserialize failed");
        outputs(api, b, y1);
        CHECK(memcmp(ya, y1, sizeof ya) == 0, "continuation after deserialisation differs");
        bytes[0] ^= 0x55; /* corrupt the magic: refused, not a crash */
        CHECK_REFUSED(api->deserialize(b, bytes, size, &restored), "a corrupt state");
        free(bytes);
    }
    CHECK(api->free_fmu_state(a, &saved) == fmi3OK && saved == NULL, "free state failed");
    CHECK(api->free_fmu_state(b, &restored) == fmi3OK && restored == NULL, "free state failed");

    /* Bad calls: fmi3Error, nothing changed, and the instance goes on. */
    {
        fmi3Instance c = a;
        bad_calls(api, c, steps);
        CHECK(step(api, a, &helm_a, steps) == fmi3OK, "a step after the refused calls failed");
    }
    divergence(api);

    /* Reset: back to the start values, ready for a new run. */
    CHECK(api->reset(a) == fmi3OK, "fmi3Reset failed");
    CHECK(api->enter_initialization_mode(a, fmi3False, 0.0, 0.0, fmi3False, 0.0) == fmi3OK &&
              api->exit_initialization_mode(a) == fmi3OK,
          "re-initialisation after reset failed");
    outputs(api, a, y1);
    CHECK(memcmp(y0, y1, sizeof y0) == 0, "state after fmi3Reset differs from the start");
    CHECK(api->terminate(a) == fmi3OK && api->terminate(b) == fmi3OK, "fmi3Terminate failed");
    api->free_instance(a);
    api->free_instance(b);

    /* Refused instantiations: NULL, with a message. */
    environment.quiet = 1;
    CHECK(instantiate(api, "wrong token", "{00000000-0000-0000-0000-000000000000}",
                      fmi3False) == NULL,
          "a wrong instantiationToken was accepted");
    CHECK(instantiate(api, "event mode", token, fmi3True) == NULL, "eventModeUsed was accepted");
    environment.quiet = 0;

    if (failures == 0) {
        printf("ok: FMI 3.0, 2 instances x %d steps, state round trips, bad calls, "
               "divergence, reset\n",
               steps);
    }
    return failures == 0 ? 0 : 1;
}

/* Sail the manoeuvre and print it (manoeuvre.h); 0 when every call succeeded. */
static int sail(const Api *api, const Manoeuvre *m)
{
    double y[N_RUN_OUTPUTS];
    double u[N_RUN_INPUTS];
    Helm helm = {NULL, 0.0, 0.0, 0.0, 0};
    fmi3Boolean event_handling_needed, terminate, early_return;
    fmi3Float64 last;
    const int n = (int)(m->duration_s / RUN_STEP_S + 0.5);
    int k;
    fmi3Instance c = start(api, m->name, 0, nan(""));
    if (c == NULL) {
        fprintf(stderr, "instantiation failed\n");
        return 1;
    }
    helm.m = m;
    print_header();
    for (k = 0;; k++) {
        outputs(api, c, y);
        helm_next(&helm, y[RUN_PSI], u);
        print_row(k * RUN_STEP_S, u, y);
        if (k == n) {
            break;
        }
        if (api->set_float64(c, vr_inputs, N_RUN_INPUTS, u, N_RUN_INPUTS) != fmi3OK ||
            api->do_step(c, k * RUN_STEP_S, RUN_STEP_S, fmi3True, &event_handling_needed,
                         &terminate, &early_return, &last) != fmi3OK) {
            fprintf(stderr, "step %d failed\n", k);
            failures++;
            break;
        }
    }
    CHECK(api->terminate(c) == fmi3OK, "fmi3Terminate failed");
    api->free_instance(c);
    return failures == 0 ? 0 : 1;
}

int main(int argc, char **argv)
{
    Api api;
    void *library;
    char *path;
    const Manoeuvre *manoeuvre = NULL;
    int steps = 3000;
    int status;
    if (argc < 2 || argc > 4 || (argc == 4 && strcmp(argv[2], "--run") != 0)) {
        fprintf(stderr, "usage: %s LIBRARY [STEPS] | LIBRARY --run NAME\n", argv[0]);
        return 2;
    }
    if (argc == 4) {
        manoeuvre = find_manoeuvre(argv[3]);
        if (manoeuvre == NULL) {
            fprintf(stderr, "unknown manoeuvre %s\n", argv[3]);
            return 2;
        }
    } else if (argc == 3) {
        steps = atoi(argv[2]);
        if (steps < 2) {
            fprintf(stderr, "STEPS must be at least 2\n");
            return 2;
        }
    }
    path = realpath(argv[1], NULL);
    if (path == NULL || !read_description(path)) {
        fprintf(stderr, "cannot read the modelDescription.xml of %s\n", argv[1]);
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
    status = manoeuvre != NULL ? sail(&api, manoeuvre) : self_test(&api, steps);
    dlclose(library);
    return status;
}
