/*
 * fmi2_cosimulation.c - FMI 2.0 co-simulation layer of the shipid native FMU.
 *
 * Written once and shared by every generated FMU (after the pattern of the Modelica
 * Reference-FMUs: one reviewed FMI layer, a small generated model part). The model part
 * is included from model_config.h and model_equations.h; see ship_fmu.h for the contract.
 *
 * Behaviour (the documented contract; tests/test_fmu_native.py checks it):
 *
 * - All data live in the instance; any number of instances per process.
 * - Memory comes from the callbacks' allocateMemory/freeMemory (calloc/free when the
 *   environment passes NULL, which FMI 2.0 does not allow but some hosts do).
 * - The state (u, v, r, x, y, psi), i.e. the outputs, follows the parameters u0 ... psi0
 *   until fmi2ExitInitializationMode: it is reset from them at instantiation, at every
 *   fmi2SetReal before the end of initialisation and at fmi2ExitInitializationMode.
 *   From then on it only changes through fmi2DoStep, fmi2SetFMUstate and fmi2Reset.
 * - fmi2ExitInitializationMode refuses a start speed sqrt(u0^2 + v0^2) below
 *   MIN_START_SPEED (nonzero for a model whose equations divide by the speed) with
 *   fmi2Error; the instance stays in initialization mode, so u0 or v0 can be corrected.
 * - fmi2DoStep integrates with the classical RK4 in n equal internal steps,
 *   n = 1 if h <= max_step else ceil(h / max_step * (1 - 1e-12)), the rule of
 *   fmu_model.simulate.n_substeps; inputs are held constant over the step; the
 *   propeller speed enters the equations as rpm / 60 [rev/s].
 * - Errors (fmi2Error, message in category logStatusError) leave the instance unchanged,
 *   so a master may correct the call and continue:
 *     a non-finite value or a value outside a declared min/max passed to fmi2SetReal
 *     (the whole call is rejected, no value of it is applied), or found in an FMU state
 *     given to fmi2SetFMUstate or fmi2DeSerializeFMUstate (the state is not restored);
 *     setting an output, or a parameter after fmi2ExitInitializationMode;
 *     an unknown value reference; a call not allowed in the current state;
 *     a start below the least start speed (above);
 *     a non-positive or non-finite communication step, a currentCommunicationPoint
 *     that is not the FMU's time, a step too small to advance the time (t + h == t),
 *     or a step needing more than MAX_SUBSTEPS internal steps (about 1 s of CPU);
 *     every function this FMU does not implement.
 * - A status this FMU cannot give (fmi2GetStatus, fmi2GetIntegerStatus,
 *   fmi2GetStringStatus, and every kind of fmi2GetRealStatus and fmi2GetBooleanStatus
 *   but fmi2LastSuccessfulTime and fmi2Terminated) is fmi2Discard (category
 *   logStatusDiscard), as FMI 2.0 section 2.1.3 asks of a co-simulation slave.
 * - A diverging state (non-finite, |u| or |v| > DIVERGENCE_MAX_SPEED, |r| >
 *   DIVERGENCE_MAX_YAW_RATE, the rule of fmu_model.interface generated into model_config.h)
 *   ends fmi2DoStep with fmi2Discard (category logStatusDiscard): the state stays at the
 *   beginning of the step, fmi2LastSuccessfulTime is that time, fmi2Terminated is true,
 *   and only fmi2GetReal, the status functions, fmi2SetFMUstate, fmi2Reset, fmi2Terminate
 *   and fmi2FreeInstance are allowed. fmi2Fatal is never returned.
 * - Logging: the categories logStatusWarning, logStatusDiscard, logStatusError and
 *   logStatusFatal are on from instantiation (they report failures, not debug output);
 *   logAll (a trace of every call) follows the loggingOn argument. fmi2SetDebugLogging
 *   with nCategories = 0 switches all categories, otherwise the named ones.
 * - fmi2GetFMUstate copies everything that evolves (values, time, FMI state); the
 *   serialised form is that copy with a header (magic, format version, GUID, size) in
 *   the byte order of the machine; restoring it continues bit-identically.
 */
#include <math.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fmi2Functions.h"
#include "model_config.h"
#include "model_equations.h"

/* Relative tolerance on currentCommunicationPoint against the FMU's time. */
#define SHIP_TIME_TOLERANCE 1.0e-9

/* Compile-time checks of the generated layout (a negative array size fails the build). */
typedef char
    ship_check_coefficients[(VR_COEFFICIENTS + MODEL_N_COEFFICIENTS <= MODEL_N_VARIABLES) ? 1 : -1];
typedef char ship_check_states[(VR_STATE + SHIP_N_STATES <= MODEL_N_VARIABLES) ? 1 : -1];
typedef char ship_check_initial[(VR_INITIAL_STATE + SHIP_N_STATES <= MODEL_N_VARIABLES) ? 1 : -1];

#if defined(__GNUC__)
#define SHIP_PRINTF(fmt_index, first_arg) __attribute__((format(printf, fmt_index, first_arg)))
#else
#define SHIP_PRINTF(fmt_index, first_arg)
#endif

/* ---------------------------------------------------------------------------------- */
/* Instance                                                                            */
/* ---------------------------------------------------------------------------------- */

typedef enum {
    STATE_INSTANTIATED = 1 << 0,
    STATE_INITIALIZATION = 1 << 1,
    STATE_STEP_COMPLETE = 1 << 2,
    STATE_STEP_FAILED = 1 << 3,
    STATE_TERMINATED = 1 << 4
} ModelState;

/* Every state of this FMU. */
#define STATE_ANY                                                                       \
    (STATE_INSTANTIATED | STATE_INITIALIZATION | STATE_STEP_COMPLETE | STATE_STEP_FAILED | \
     STATE_TERMINATED)

/* Where FMI 2.0 (co-simulation state table) allows fmi2GetFMUstate, fmi2SetFMUstate,
   fmi2FreeFMUstate and the serialisation functions: instantiated, initialization mode,
   stepComplete, stepFailed, stepCanceled, terminated and error. This FMU has no
   stepCanceled (fmi2DoStep is synchronous) and no error state (fmi2Error leaves the
   instance in its state), so here that is every state: STATE_ANY. */
#define FMUSTATE_ALLOWED_IN                                                             \
    (STATE_INSTANTIATED | STATE_INITIALIZATION | STATE_STEP_COMPLETE | STATE_STEP_FAILED | \
     STATE_TERMINATED)

typedef enum {
    LOG_STATUS_WARNING = 0,
    LOG_STATUS_DISCARD,
    LOG_STATUS_ERROR,
    LOG_STATUS_FATAL,
    LOG_ALL,
    N_LOG_CATEGORIES
} LogCategory;

/* Must match fmu_model.model_description.LOG_CATEGORIES (checked by the tests). */
static const char *const LOG_CATEGORY_NAMES[N_LOG_CATEGORIES] = {
    "logStatusWarning", "logStatusDiscard", "logStatusError", "logStatusFatal", "logAll"};

/* Everything that evolves: what fmi2GetFMUstate saves and fmi2SetFMUstate restores. */
typedef struct {
    double values[MODEL_N_VARIABLES]; /* indexed by value reference */
    double time;                      /* current communication point [s] */
    double start_time;                /* from fmi2SetupExperiment [s] */
    double last_successful_time;      /* end of the last completed step [s] */
    int state;                        /* ModelState */
} Snapshot;

#define INSTANCE_MAGIC 0x53484950u /* "SHIP" */
#define FMUSTATE_MAGIC 0x53544154u /* "STAT" */

typedef struct {
    unsigned magic;
    Snapshot s;
    char *instance_name;
    fmi2CallbackLogger logger;
    fmi2CallbackAllocateMemory allocate_memory;
    fmi2CallbackFreeMemory free_memory;
    fmi2ComponentEnvironment environment;
    int log_enabled[N_LOG_CATEGORIES];
} Instance;

typedef struct {
    unsigned magic;
    Snapshot s;
} SavedState;

static void *default_allocate(size_t n, size_t size) { return calloc(n, size); }

static void default_free(void *pointer) { free(pointer); }

/* ---------------------------------------------------------------------------------- */
/* Logging                                                                             */
/* ---------------------------------------------------------------------------------- */

static void log_message(const Instance *inst, fmi2Status status, LogCategory category,
                        const char *format, ...) SHIP_PRINTF(4, 5);

static void log_message(const Instance *inst, fmi2Status status, LogCategory category,
                        const char *format, ...)
{
    char buffer[512];
    va_list args;
    if (inst->logger == NULL || !inst->log_enabled[category]) {
        return;
    }
    va_start(args, format);
    vsnprintf(buffer, sizeof buffer, format, args);
    va_end(args);
    /* The logger takes a printf format: pass the text as an argument, never as format. */
    inst->logger(inst->environment, inst->instance_name, status, LOG_CATEGORY_NAMES[category],
                 "%s", buffer);
}

#define LOG_ERROR(inst, ...) log_message((inst), fmi2Error, LOG_STATUS_ERROR, __VA_ARGS__)
#define LOG_TRACE(inst, ...) log_message((inst), fmi2OK, LOG_ALL, __VA_ARGS__)

static const char *state_name(int state)
{
    switch (state) {
    case STATE_INSTANTIATED:
        return "instantiated";
    case STATE_INITIALIZATION:
        return "initialization mode";
    case STATE_STEP_COMPLETE:
        return "step complete";
    case STATE_STEP_FAILED:
        return "step failed";
    case STATE_TERMINATED:
        return "terminated";
    default:
        return "unknown";
    }
}

/* Return nonzero when `function` may be called in the instance's current state. */
static int allowed(const Instance *inst, const char *function, int states)
{
    if (inst->s.state & states) {
        return 1;
    }
    LOG_ERROR(inst, "%s must not be called in state '%s'", function, state_name(inst->s.state));
    return 0;
}

/* Every function that starts from an fmi2Component does this first. */
#define BEGIN(function, states)                                                 \
    Instance *inst = (Instance *)c;                                             \
    if (inst == NULL || inst->magic != INSTANCE_MAGIC) {                        \
        return fmi2Error;                                                       \
    }                                                                           \
    if (!allowed(inst, function, states)) {                                     \
        return fmi2Error;                                                       \
    }

/* ---------------------------------------------------------------------------------- */
/* Model                                                                               */
/* ---------------------------------------------------------------------------------- */

/* The state follows u0 ... psi0 until the end of initialisation. */
static void reset_state_from_parameters(Instance *inst)
{
    int i;
    for (i = 0; i < SHIP_N_STATES; i++) {
        inst->s.values[VR_STATE + i] = inst->s.values[VR_INITIAL_STATE + i];
    }
}

static void set_start_values(Instance *inst)
{
    int i;
    for (i = 0; i < MODEL_N_VARIABLES; i++) {
        inst->s.values[i] = MODEL_VARIABLES[i].start;
    }
    reset_state_from_parameters(inst);
    inst->s.time = 0.0;
    inst->s.start_time = 0.0;
    inst->s.last_successful_time = 0.0;
    inst->s.state = STATE_INSTANTIATED;
}

/* One classical Runge-Kutta step with the inputs held; same operation order as
   fmu_model.simulate.rk4_step so that the results agree to rounding. */
static void rk4_step(const double *theta, double length, double *x, double rudder, double n_rps,
                     double h)
{
    double k1[SHIP_N_STATES], k2[SHIP_N_STATES], k3[SHIP_N_STATES], k4[SHIP_N_STATES];
    double tmp[SHIP_N_STATES];
    const double half = 0.5 * h;
    const double sixth = h / 6.0;
    int i;
    model_rhs(theta, length, x, rudder, n_rps, k1);
    for (i = 0; i < SHIP_N_STATES; i++) {
        tmp[i] = x[i] + half * k1[i];
    }
    model_rhs(theta, length, tmp, rudder, n_rps, k2);
    for (i = 0; i < SHIP_N_STATES; i++) {
        tmp[i] = x[i] + half * k2[i];
    }
    model_rhs(theta, length, tmp, rudder, n_rps, k3);
    for (i = 0; i < SHIP_N_STATES; i++) {
        tmp[i] = x[i] + h * k3[i];
    }
    model_rhs(theta, length, tmp, rudder, n_rps, k4);
    for (i = 0; i < SHIP_N_STATES; i++) {
        x[i] = x[i] + sixth * (((k1[i] + 2.0 * k2[i]) + 2.0 * k3[i]) + k4[i]);
    }
}

/* Number of equal internal steps (fmu_model.simulate.n_substeps); 0 when more than
   MAX_SUBSTEPS (about 1 s of CPU, see fmu_model.interface.MAX_SUBSTEPS). */
static double n_substeps(double step, double max_step)
{
    double n;
    if (step <= max_step) {
        return 1.0;
    }
    n = ceil(step / max_step * (1.0 - 1e-12));
    if (!(n <= MAX_SUBSTEPS)) {
        return 0.0;
    }
    return n < 1.0 ? 1.0 : n;
}

/* Return nonzero when the snapshot holds only values fmi2SetReal would accept (finite,
   within each variable's declared min/max) and finite times; else log why, naming
   `function`, and return 0. The check of every restored FMU state. */
static int snapshot_is_valid(const Instance *inst, const char *function, const Snapshot *s)
{
    int i;
    for (i = 0; i < MODEL_N_VARIABLES; i++) {
        const ShipVariable *var = &MODEL_VARIABLES[i];
        const double value = s->values[i];
        if (!isfinite(value)) {
            LOG_ERROR(inst, STATE_NONFINITE_FORMAT, function, var->name, value);
            return 0;
        }
        if ((var->has_min && value < var->min) || (var->has_max && value > var->max)) {
            LOG_ERROR(inst, STATE_RANGE_FORMAT, function, var->name, value,
                      var->has_min ? var->min : -HUGE_VAL, var->has_max ? var->max : HUGE_VAL);
            return 0;
        }
    }
    if (!isfinite(s->time) || !isfinite(s->start_time) || !isfinite(s->last_successful_time)) {
        LOG_ERROR(inst,
                  "%s: the FMU state is not restored: its times (%g, %g, %g s) must be finite",
                  function, s->time, s->start_time, s->last_successful_time);
        return 0;
    }
    return 1;
}

static int state_is_valid(const double *x)
{
    int i;
    for (i = 0; i < SHIP_N_STATES; i++) {
        if (!isfinite(x[i])) {
            return 0;
        }
    }
    return fabs(x[0]) <= DIVERGENCE_MAX_SPEED && fabs(x[1]) <= DIVERGENCE_MAX_SPEED &&
           fabs(x[2]) <= DIVERGENCE_MAX_YAW_RATE;
}

/* ---------------------------------------------------------------------------------- */
/* Common functions                                                                    */
/* ---------------------------------------------------------------------------------- */

const char *fmi2GetTypesPlatform(void) { return fmi2TypesPlatform; }

const char *fmi2GetVersion(void) { return fmi2Version; }

fmi2Status fmi2SetDebugLogging(fmi2Component c, fmi2Boolean loggingOn, size_t nCategories,
                               const fmi2String categories[])
{
    size_t i;
    int k;
    int chosen[N_LOG_CATEGORIES] = {0};
    BEGIN("fmi2SetDebugLogging", STATE_ANY)
    if (nCategories > 0 && categories == NULL) {
        LOG_ERROR(inst, "fmi2SetDebugLogging: categories is NULL");
        return fmi2Error;
    }
    for (i = 0; i < nCategories; i++) {
        int found = 0;
        for (k = 0; k < N_LOG_CATEGORIES; k++) {
            if (categories[i] != NULL && strcmp(categories[i], LOG_CATEGORY_NAMES[k]) == 0) {
                chosen[k] = 1;
                found = 1;
            }
        }
        if (!found) {
            LOG_ERROR(inst, "fmi2SetDebugLogging: unknown log category '%s'",
                      categories[i] == NULL ? "(null)" : categories[i]);
            return fmi2Error;
        }
    }
    for (k = 0; k < N_LOG_CATEGORIES; k++) {
        if (nCategories == 0 || chosen[k]) {
            inst->log_enabled[k] = loggingOn ? 1 : 0;
        }
    }
    return fmi2OK;
}

fmi2Component fmi2Instantiate(fmi2String instanceName, fmi2Type fmuType, fmi2String fmuGUID,
                              fmi2String fmuResourceLocation,
                              const fmi2CallbackFunctions *functions, fmi2Boolean visible,
                              fmi2Boolean loggingOn)
{
    Instance *inst;
    fmi2CallbackAllocateMemory allocate_memory = default_allocate;
    fmi2CallbackFreeMemory free_memory = default_free;
    fmi2CallbackLogger logger = NULL;
    fmi2ComponentEnvironment environment = NULL;
    const char *name = instanceName != NULL ? instanceName : "";
    size_t length;
    int k;
    (void)fmuResourceLocation;
    (void)visible;

    if (functions != NULL) {
        logger = functions->logger;
        environment = functions->componentEnvironment;
        if (functions->allocateMemory != NULL && functions->freeMemory != NULL) {
            allocate_memory = functions->allocateMemory;
            free_memory = functions->freeMemory;
        }
    }
    if (fmuType != fmi2CoSimulation) {
        if (logger != NULL) {
            logger(environment, name, fmi2Error, "logStatusError",
                   "%s supports only co-simulation (fmuType fmi2CoSimulation)",
                   MODEL_IDENTIFIER_NAME);
        }
        return NULL;
    }
    if (fmuGUID == NULL || strcmp(fmuGUID, MODEL_GUID) != 0) {
        if (logger != NULL) {
            logger(environment, name, fmi2Error, "logStatusError",
                   "GUID '%s' does not match this binary's GUID '%s'",
                   fmuGUID == NULL ? "(null)" : fmuGUID, MODEL_GUID);
        }
        return NULL;
    }
    inst = (Instance *)allocate_memory(1, sizeof(Instance));
    if (inst == NULL) {
        if (logger != NULL) {
            logger(environment, name, fmi2Error, "logStatusError", "out of memory");
        }
        return NULL;
    }
    length = strlen(name);
    inst->instance_name = (char *)allocate_memory(length + 1, 1);
    if (inst->instance_name == NULL) {
        free_memory(inst);
        if (logger != NULL) {
            logger(environment, name, fmi2Error, "logStatusError", "out of memory");
        }
        return NULL;
    }
    memcpy(inst->instance_name, name, length + 1);
    inst->magic = INSTANCE_MAGIC;
    inst->logger = logger;
    inst->allocate_memory = allocate_memory;
    inst->free_memory = free_memory;
    inst->environment = environment;
    for (k = 0; k < N_LOG_CATEGORIES; k++) {
        inst->log_enabled[k] = 1;
    }
    inst->log_enabled[LOG_ALL] = loggingOn ? 1 : 0;
    set_start_values(inst);
    LOG_TRACE(inst, "fmi2Instantiate: %s, GUID %s", MODEL_IDENTIFIER_NAME, MODEL_GUID);
    return inst;
}

void fmi2FreeInstance(fmi2Component c)
{
    Instance *inst = (Instance *)c;
    fmi2CallbackFreeMemory free_memory;
    if (inst == NULL || inst->magic != INSTANCE_MAGIC) {
        return;
    }
    LOG_TRACE(inst, "fmi2FreeInstance");
    free_memory = inst->free_memory;
    inst->magic = 0;
    free_memory(inst->instance_name);
    free_memory(inst);
}

fmi2Status fmi2SetupExperiment(fmi2Component c, fmi2Boolean toleranceDefined, fmi2Real tolerance,
                               fmi2Real startTime, fmi2Boolean stopTimeDefined, fmi2Real stopTime)
{
    BEGIN("fmi2SetupExperiment", STATE_INSTANTIATED)
    /* The integrator is a fixed-step RK4: the tolerance and the stop time are not used. */
    (void)toleranceDefined;
    (void)tolerance;
    (void)stopTimeDefined;
    (void)stopTime;
    if (!isfinite(startTime)) {
        LOG_ERROR(inst, "fmi2SetupExperiment: startTime must be finite, got %g", startTime);
        return fmi2Error;
    }
    LOG_TRACE(inst, "fmi2SetupExperiment: startTime %.17g", startTime);
    inst->s.start_time = startTime;
    inst->s.time = startTime;
    inst->s.last_successful_time = startTime;
    return fmi2OK;
}

fmi2Status fmi2EnterInitializationMode(fmi2Component c)
{
    BEGIN("fmi2EnterInitializationMode", STATE_INSTANTIATED)
    LOG_TRACE(inst, "fmi2EnterInitializationMode");
    reset_state_from_parameters(inst);
    inst->s.state = STATE_INITIALIZATION;
    return fmi2OK;
}

fmi2Status fmi2ExitInitializationMode(fmi2Component c)
{
    double u0;
    double v0;
    double speed;
    BEGIN("fmi2ExitInitializationMode", STATE_INITIALIZATION)
    LOG_TRACE(inst, "fmi2ExitInitializationMode");
    /* A model that divides by the speed is 0/0 at rest: refuse such a start (the state
       stays in initialization mode, so the master can set u0 or v0 and try again). */
    u0 = inst->s.values[VR_INITIAL_STATE];
    v0 = inst->s.values[VR_INITIAL_STATE + 1];
    speed = sqrt(u0 * u0 + v0 * v0);
    if (MIN_START_SPEED > 0.0 && !(speed >= MIN_START_SPEED)) {
        LOG_ERROR(inst, START_SPEED_FORMAT, speed, MIN_START_SPEED);
        return fmi2Error;
    }
    reset_state_from_parameters(inst);
    inst->s.last_successful_time = inst->s.time;
    inst->s.state = STATE_STEP_COMPLETE;
    return fmi2OK;
}

fmi2Status fmi2Terminate(fmi2Component c)
{
    BEGIN("fmi2Terminate", STATE_STEP_COMPLETE | STATE_STEP_FAILED)
    LOG_TRACE(inst, "fmi2Terminate");
    inst->s.state = STATE_TERMINATED;
    return fmi2OK;
}

fmi2Status fmi2Reset(fmi2Component c)
{
    BEGIN("fmi2Reset", STATE_ANY)
    LOG_TRACE(inst, "fmi2Reset");
    set_start_values(inst);
    return fmi2OK;
}

/* ---------------------------------------------------------------------------------- */
/* Getting and setting values                                                          */
/* ---------------------------------------------------------------------------------- */

fmi2Status fmi2GetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                       fmi2Real value[])
{
    size_t i;
    BEGIN("fmi2GetReal",
          STATE_INITIALIZATION | STATE_STEP_COMPLETE | STATE_STEP_FAILED | STATE_TERMINATED)
    if (nvr > 0 && (vr == NULL || value == NULL)) {
        LOG_ERROR(inst, "fmi2GetReal: vr or value is NULL");
        return fmi2Error;
    }
    for (i = 0; i < nvr; i++) {
        if (vr[i] >= MODEL_N_VARIABLES) {
            LOG_ERROR(inst, "fmi2GetReal: unknown value reference %u", vr[i]);
            return fmi2Error;
        }
        value[i] = inst->s.values[vr[i]];
    }
    return fmi2OK;
}

/* Check one value for fmi2SetReal; logs and returns 0 when it must be rejected. */
static int check_set_real(const Instance *inst, fmi2ValueReference vr, double value)
{
    const ShipVariable *var;
    if (vr >= MODEL_N_VARIABLES) {
        LOG_ERROR(inst, "fmi2SetReal: unknown value reference %u", vr);
        return 0;
    }
    var = &MODEL_VARIABLES[vr];
    if (var->causality == SHIP_OUTPUT) {
        LOG_ERROR(inst, "fmi2SetReal: '%s' (vr %u) is an output and cannot be set", var->name,
                  vr);
        return 0;
    }
    if (var->causality == SHIP_PARAMETER &&
        !(inst->s.state & (STATE_INSTANTIATED | STATE_INITIALIZATION))) {
        LOG_ERROR(inst,
                  "fmi2SetReal: '%s' (vr %u) is a fixed parameter; it can only be set before "
                  "fmi2ExitInitializationMode",
                  var->name, vr);
        return 0;
    }
    if (!isfinite(value)) {
        LOG_ERROR(inst, "fmi2SetReal: '%s' (vr %u) must be finite, got %g", var->name, vr, value);
        return 0;
    }
    if ((var->has_min && value < var->min) || (var->has_max && value > var->max)) {
        LOG_ERROR(inst, "fmi2SetReal: '%s' (vr %u) = %.17g is outside [%.17g, %.17g]", var->name,
                  vr, value, var->has_min ? var->min : -HUGE_VAL,
                  var->has_max ? var->max : HUGE_VAL);
        return 0;
    }
    return 1;
}

fmi2Status fmi2SetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                       const fmi2Real value[])
{
    size_t i;
    BEGIN("fmi2SetReal", STATE_INSTANTIATED | STATE_INITIALIZATION | STATE_STEP_COMPLETE)
    if (nvr > 0 && (vr == NULL || value == NULL)) {
        LOG_ERROR(inst, "fmi2SetReal: vr or value is NULL");
        return fmi2Error;
    }
    /* All or nothing: check every value before applying any. */
    for (i = 0; i < nvr; i++) {
        if (!check_set_real(inst, vr[i], value[i])) {
            return fmi2Error;
        }
    }
    for (i = 0; i < nvr; i++) {
        inst->s.values[vr[i]] = value[i];
    }
    if (inst->s.state & (STATE_INSTANTIATED | STATE_INITIALIZATION)) {
        reset_state_from_parameters(inst);
    }
    return fmi2OK;
}

/* This FMU has Real variables only. */
static fmi2Status no_variables_of_type(fmi2Component c, const char *function, size_t nvr)
{
    BEGIN(function, STATE_ANY)
    if (nvr == 0) {
        return fmi2OK;
    }
    LOG_ERROR(inst, "%s: this FMU has no variables of that type", function);
    return fmi2Error;
}

fmi2Status fmi2GetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                          fmi2Integer value[])
{
    (void)vr;
    (void)value;
    return no_variables_of_type(c, "fmi2GetInteger", nvr);
}

fmi2Status fmi2GetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                          fmi2Boolean value[])
{
    (void)vr;
    (void)value;
    return no_variables_of_type(c, "fmi2GetBoolean", nvr);
}

fmi2Status fmi2GetString(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                         fmi2String value[])
{
    (void)vr;
    (void)value;
    return no_variables_of_type(c, "fmi2GetString", nvr);
}

fmi2Status fmi2SetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                          const fmi2Integer value[])
{
    (void)vr;
    (void)value;
    return no_variables_of_type(c, "fmi2SetInteger", nvr);
}

fmi2Status fmi2SetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                          const fmi2Boolean value[])
{
    (void)vr;
    (void)value;
    return no_variables_of_type(c, "fmi2SetBoolean", nvr);
}

fmi2Status fmi2SetString(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                         const fmi2String value[])
{
    (void)vr;
    (void)value;
    return no_variables_of_type(c, "fmi2SetString", nvr);
}

/* ---------------------------------------------------------------------------------- */
/* FMU state                                                                           */
/* ---------------------------------------------------------------------------------- */

fmi2Status fmi2GetFMUstate(fmi2Component c, fmi2FMUstate *FMUstate)
{
    SavedState *saved;
    BEGIN("fmi2GetFMUstate", FMUSTATE_ALLOWED_IN)
    if (FMUstate == NULL) {
        LOG_ERROR(inst, "fmi2GetFMUstate: FMUstate is NULL");
        return fmi2Error;
    }
    saved = (SavedState *)*FMUstate;
    if (saved != NULL && saved->magic != FMUSTATE_MAGIC) {
        LOG_ERROR(inst, "fmi2GetFMUstate: *FMUstate is not an FMU state of this FMU");
        return fmi2Error;
    }
    if (saved == NULL) {
        saved = (SavedState *)inst->allocate_memory(1, sizeof(SavedState));
        if (saved == NULL) {
            LOG_ERROR(inst, "fmi2GetFMUstate: out of memory");
            return fmi2Error;
        }
        saved->magic = FMUSTATE_MAGIC;
    }
    saved->s = inst->s;
    *FMUstate = saved;
    return fmi2OK;
}

fmi2Status fmi2SetFMUstate(fmi2Component c, fmi2FMUstate FMUstate)
{
    const SavedState *saved = (const SavedState *)FMUstate;
    BEGIN("fmi2SetFMUstate", FMUSTATE_ALLOWED_IN)
    if (saved == NULL || saved->magic != FMUSTATE_MAGIC) {
        LOG_ERROR(inst, "fmi2SetFMUstate: not an FMU state of this FMU");
        return fmi2Error;
    }
    if (!snapshot_is_valid(inst, "fmi2SetFMUstate", &saved->s)) {
        return fmi2Error;
    }
    inst->s = saved->s;
    return fmi2OK;
}

fmi2Status fmi2FreeFMUstate(fmi2Component c, fmi2FMUstate *FMUstate)
{
    SavedState *saved;
    BEGIN("fmi2FreeFMUstate", FMUSTATE_ALLOWED_IN)
    if (FMUstate == NULL || *FMUstate == NULL) {
        return fmi2OK;
    }
    saved = (SavedState *)*FMUstate;
    if (saved->magic != FMUSTATE_MAGIC) {
        LOG_ERROR(inst, "fmi2FreeFMUstate: not an FMU state of this FMU");
        return fmi2Error;
    }
    saved->magic = 0;
    inst->free_memory(saved);
    *FMUstate = NULL;
    return fmi2OK;
}

/* Serialised layout: magic (8 bytes), format version (uint32), number of variables
   (uint32), GUID (64 bytes, NUL padded), FMI state (int32), padding (4 bytes), then the
   doubles time, start_time, last_successful_time and values[MODEL_N_VARIABLES]. */
static const char SERIAL_MAGIC[8] = {'S', 'H', 'I', 'P', 'F', 'M', 'U', '\0'};
#define SERIAL_VERSION 1u
#define SERIAL_GUID_SIZE 64
#define SERIAL_HEADER_SIZE (8 + 4 + 4 + SERIAL_GUID_SIZE + 4 + 4)
#define SERIAL_SIZE (SERIAL_HEADER_SIZE + (3 + MODEL_N_VARIABLES) * sizeof(double))

typedef char ship_check_guid[(sizeof(MODEL_GUID) <= SERIAL_GUID_SIZE) ? 1 : -1];

fmi2Status fmi2SerializedFMUstateSize(fmi2Component c, fmi2FMUstate FMUstate, size_t *size)
{
    BEGIN("fmi2SerializedFMUstateSize", FMUSTATE_ALLOWED_IN)
    (void)FMUstate;
    if (size == NULL) {
        LOG_ERROR(inst, "fmi2SerializedFMUstateSize: size is NULL");
        return fmi2Error;
    }
    *size = SERIAL_SIZE;
    return fmi2OK;
}

fmi2Status fmi2SerializeFMUstate(fmi2Component c, fmi2FMUstate FMUstate, fmi2Byte serializedState[],
                                 size_t size)
{
    const SavedState *saved = (const SavedState *)FMUstate;
    char guid[SERIAL_GUID_SIZE] = {0};
    unsigned int version = SERIAL_VERSION;
    unsigned int n_variables = MODEL_N_VARIABLES;
    int state;
    int padding = 0;
    char *p = serializedState;
    BEGIN("fmi2SerializeFMUstate", FMUSTATE_ALLOWED_IN)
    if (saved == NULL || saved->magic != FMUSTATE_MAGIC) {
        LOG_ERROR(inst, "fmi2SerializeFMUstate: not an FMU state of this FMU");
        return fmi2Error;
    }
    if (serializedState == NULL || size < SERIAL_SIZE) {
        LOG_ERROR(inst, "fmi2SerializeFMUstate: buffer of %lu bytes, need %lu",
                  (unsigned long)size, (unsigned long)SERIAL_SIZE);
        return fmi2Error;
    }
    memcpy(guid, MODEL_GUID, sizeof(MODEL_GUID));
    state = saved->s.state;
    memcpy(p, SERIAL_MAGIC, 8);
    p += 8;
    memcpy(p, &version, 4);
    p += 4;
    memcpy(p, &n_variables, 4);
    p += 4;
    memcpy(p, guid, SERIAL_GUID_SIZE);
    p += SERIAL_GUID_SIZE;
    memcpy(p, &state, 4);
    p += 4;
    memcpy(p, &padding, 4);
    p += 4;
    memcpy(p, &saved->s.time, sizeof(double));
    p += sizeof(double);
    memcpy(p, &saved->s.start_time, sizeof(double));
    p += sizeof(double);
    memcpy(p, &saved->s.last_successful_time, sizeof(double));
    p += sizeof(double);
    memcpy(p, saved->s.values, sizeof saved->s.values);
    return fmi2OK;
}

fmi2Status fmi2DeSerializeFMUstate(fmi2Component c, const fmi2Byte serializedState[], size_t size,
                                   fmi2FMUstate *FMUstate)
{
    const char *p = serializedState;
    char guid[SERIAL_GUID_SIZE] = {0};
    unsigned int version;
    unsigned int n_variables;
    int state;
    Snapshot s;
    SavedState *saved;
    BEGIN("fmi2DeSerializeFMUstate", FMUSTATE_ALLOWED_IN)
    if (FMUstate == NULL || serializedState == NULL || size != SERIAL_SIZE) {
        LOG_ERROR(inst, "fmi2DeSerializeFMUstate: expected %lu bytes, got %lu",
                  (unsigned long)SERIAL_SIZE, (unsigned long)size);
        return fmi2Error;
    }
    memcpy(guid, MODEL_GUID, sizeof(MODEL_GUID));
    if (memcmp(p, SERIAL_MAGIC, 8) != 0) {
        LOG_ERROR(inst, "fmi2DeSerializeFMUstate: not a serialised state of this FMU");
        return fmi2Error;
    }
    p += 8;
    memcpy(&version, p, 4);
    p += 4;
    memcpy(&n_variables, p, 4);
    p += 4;
    if (version != SERIAL_VERSION || n_variables != MODEL_N_VARIABLES ||
        memcmp(p, guid, SERIAL_GUID_SIZE) != 0) {
        LOG_ERROR(inst, "fmi2DeSerializeFMUstate: the state was serialised by another FMU or "
                        "format version");
        return fmi2Error;
    }
    p += SERIAL_GUID_SIZE;
    memcpy(&state, p, 4);
    p += 8; /* state and padding */
    if (!(state & STATE_ANY) || (state & (state - 1)) != 0) {
        LOG_ERROR(inst, "fmi2DeSerializeFMUstate: invalid FMI state %d", state);
        return fmi2Error;
    }
    memset(&s, 0, sizeof s);
    s.state = state;
    memcpy(&s.time, p, sizeof(double));
    p += sizeof(double);
    memcpy(&s.start_time, p, sizeof(double));
    p += sizeof(double);
    memcpy(&s.last_successful_time, p, sizeof(double));
    p += sizeof(double);
    memcpy(s.values, p, sizeof s.values);
    /* Restored as if every value were set again: the range checks of fmi2SetReal. */
    if (!snapshot_is_valid(inst, "fmi2DeSerializeFMUstate", &s)) {
        return fmi2Error;
    }
    saved = (SavedState *)*FMUstate;
    if (saved != NULL && saved->magic != FMUSTATE_MAGIC) {
        LOG_ERROR(inst, "fmi2DeSerializeFMUstate: *FMUstate is not an FMU state of this FMU");
        return fmi2Error;
    }
    if (saved == NULL) {
        saved = (SavedState *)inst->allocate_memory(1, sizeof(SavedState));
        if (saved == NULL) {
            LOG_ERROR(inst, "fmi2DeSerializeFMUstate: out of memory");
            return fmi2Error;
        }
        saved->magic = FMUSTATE_MAGIC;
    }
    saved->s = s;
    *FMUstate = saved;
    return fmi2OK;
}

/* ---------------------------------------------------------------------------------- */
/* Co-simulation                                                                       */
/* ---------------------------------------------------------------------------------- */

fmi2Status fmi2DoStep(fmi2Component c, fmi2Real currentCommunicationPoint,
                      fmi2Real communicationStepSize, fmi2Boolean noSetFMUStatePriorToCurrentPoint)
{
    const double t = currentCommunicationPoint;
    const double h = communicationStepSize;
    double end;
    double x[SHIP_N_STATES];
    double n;
    double hs;
    double rudder;
    double n_rps;
    long i;
    int k;
    BEGIN("fmi2DoStep", STATE_STEP_COMPLETE)
    (void)noSetFMUStatePriorToCurrentPoint;
    LOG_TRACE(inst, "fmi2DoStep: t = %.17g, h = %.17g", t, h);
    if (!(h > 0.0) || !isfinite(h)) {
        LOG_ERROR(inst, "fmi2DoStep: communicationStepSize must be positive and finite, got %g",
                  h);
        return fmi2Error;
    }
    if (!isfinite(t) ||
        fabs(t - inst->s.time) > SHIP_TIME_TOLERANCE * (1.0 + fabs(inst->s.time))) {
        LOG_ERROR(inst,
                  "fmi2DoStep: currentCommunicationPoint %.17g is not the FMU's time %.17g", t,
                  inst->s.time);
        return fmi2Error;
    }
    end = t + h; /* the assignment rounds to double, also with x87 excess precision */
    if (!(end > t)) {
        /* h is below half the spacing of doubles at t: the time would not advance. */
        LOG_ERROR(inst, TIME_STALL_FORMAT, h, t);
        return fmi2Error;
    }
    n = n_substeps(h, inst->s.values[VR_MAX_STEP]);
    if (n == 0.0) {
        LOG_ERROR(inst, SUBSTEP_LIMIT_FORMAT, h, h / inst->s.values[VR_MAX_STEP],
                  inst->s.values[VR_MAX_STEP], MAX_SUBSTEPS);
        return fmi2Error;
    }
    hs = h / n;
    rudder = inst->s.values[VR_RUDDER_ANGLE];
    n_rps = inst->s.values[VR_PROPELLER_RPM] / 60.0;
    for (k = 0; k < SHIP_N_STATES; k++) {
        x[k] = inst->s.values[VR_STATE + k];
    }
    for (i = 0; i < (long)n; i++) {
        rk4_step(&inst->s.values[VR_COEFFICIENTS], inst->s.values[VR_LENGTH], x, rudder, n_rps,
                 hs);
        if (!state_is_valid(x)) {
            inst->s.state = STATE_STEP_FAILED;
            inst->s.last_successful_time = inst->s.time;
            log_message(inst, fmi2Discard, LOG_STATUS_DISCARD, DIVERGENCE_FORMAT,
                        t + (double)(i + 1) * hs, x[0], x[1], x[2], DIVERGENCE_MAX_SPEED,
                        DIVERGENCE_MAX_YAW_RATE, inst->s.time);
            return fmi2Discard;
        }
    }
    for (k = 0; k < SHIP_N_STATES; k++) {
        inst->s.values[VR_STATE + k] = x[k];
    }
    inst->s.time = end;
    inst->s.last_successful_time = inst->s.time;
    return fmi2OK;
}

/* ---------------------------------------------------------------------------------- */
/* Status                                                                              */
/* ---------------------------------------------------------------------------------- */

/* Where FMI 2.0 allows the fmi2GetXXXStatus functions (stepCanceled does not occur). */
#define STATUS_ALLOWED_IN (STATE_STEP_COMPLETE | STATE_STEP_FAILED | STATE_TERMINATED)

/* A status this FMU cannot give: FMI 2.0 section 2.1.3 asks a co-simulation slave for
   fmi2Discard ("the slave is not able to return the required status information"). */
static fmi2Status status_not_available(const Instance *inst, const char *function,
                                       const char *why)
{
    log_message(inst, fmi2Discard, LOG_STATUS_DISCARD, "%s: %s", function, why);
    return fmi2Discard;
}

fmi2Status fmi2GetRealStatus(fmi2Component c, const fmi2StatusKind s, fmi2Real *value)
{
    BEGIN("fmi2GetRealStatus", STATUS_ALLOWED_IN)
    if (s != fmi2LastSuccessfulTime) {
        return status_not_available(inst, "fmi2GetRealStatus",
                                    "only fmi2LastSuccessfulTime is available");
    }
    if (value == NULL) {
        LOG_ERROR(inst, "fmi2GetRealStatus: value is NULL");
        return fmi2Error;
    }
    *value = inst->s.last_successful_time;
    return fmi2OK;
}

fmi2Status fmi2GetBooleanStatus(fmi2Component c, const fmi2StatusKind s, fmi2Boolean *value)
{
    BEGIN("fmi2GetBooleanStatus", STATUS_ALLOWED_IN)
    if (s != fmi2Terminated) {
        return status_not_available(inst, "fmi2GetBooleanStatus",
                                    "only fmi2Terminated is available");
    }
    if (value == NULL) {
        LOG_ERROR(inst, "fmi2GetBooleanStatus: value is NULL");
        return fmi2Error;
    }
    /* After a divergence the slave cannot continue from this state. */
    *value = inst->s.state == STATE_STEP_FAILED ? fmi2True : fmi2False;
    return fmi2OK;
}

fmi2Status fmi2GetStatus(fmi2Component c, const fmi2StatusKind s, fmi2Status *value)
{
    BEGIN("fmi2GetStatus", STATUS_ALLOWED_IN)
    (void)s;
    (void)value;
    return status_not_available(inst, "fmi2GetStatus",
                                "no status available: fmi2DoStep is synchronous, never pending");
}

fmi2Status fmi2GetIntegerStatus(fmi2Component c, const fmi2StatusKind s, fmi2Integer *value)
{
    BEGIN("fmi2GetIntegerStatus", STATUS_ALLOWED_IN)
    (void)s;
    (void)value;
    return status_not_available(inst, "fmi2GetIntegerStatus",
                                "no status available: FMI 2.0 defines no integer status");
}

fmi2Status fmi2GetStringStatus(fmi2Component c, const fmi2StatusKind s, fmi2String *value)
{
    BEGIN("fmi2GetStringStatus", STATUS_ALLOWED_IN)
    (void)s;
    (void)value;
    return status_not_available(inst, "fmi2GetStringStatus",
                                "no status available: fmi2DoStep is synchronous, never pending");
}

/* ---------------------------------------------------------------------------------- */
/* Not supported: each returns fmi2Error with a message                                */
/* ---------------------------------------------------------------------------------- */

/* The one body of every function below: check the instance, log "<function> is not
   supported: <why>" (category logStatusError) and return fmi2Error. */
static fmi2Status unsupported(fmi2Component c, const char *function, const char *why)
{
    BEGIN(function, STATE_ANY)
    LOG_ERROR(inst, "%s is not supported: %s", function, why);
    return fmi2Error;
}

#define NO_ME "this FMU implements co-simulation only"

fmi2Status fmi2SetRealInputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                                       const fmi2Integer order[], const fmi2Real value[])
{
    (void)vr;
    (void)nvr;
    (void)order;
    (void)value;
    return unsupported(c, "fmi2SetRealInputDerivatives", "inputs are held constant over a step");
}

fmi2Status fmi2GetRealOutputDerivatives(fmi2Component c, const fmi2ValueReference vr[],
                                        size_t nvr, const fmi2Integer order[], fmi2Real value[])
{
    (void)vr;
    (void)nvr;
    (void)order;
    (void)value;
    return unsupported(c, "fmi2GetRealOutputDerivatives", "maxOutputDerivativeOrder is 0");
}

fmi2Status fmi2CancelStep(fmi2Component c)
{
    return unsupported(c, "fmi2CancelStep", "fmi2DoStep is synchronous");
}

fmi2Status fmi2GetDirectionalDerivative(fmi2Component c, const fmi2ValueReference vUnknown_ref[],
                                        size_t nUnknown, const fmi2ValueReference vKnown_ref[],
                                        size_t nKnown, const fmi2Real dvKnown[],
                                        fmi2Real dvUnknown[])
{
    (void)vUnknown_ref;
    (void)nUnknown;
    (void)vKnown_ref;
    (void)nKnown;
    (void)dvKnown;
    (void)dvUnknown;
    return unsupported(c, "fmi2GetDirectionalDerivative", "providesDirectionalDerivative is false");
}

fmi2Status fmi2EnterEventMode(fmi2Component c)
{
    return unsupported(c, "fmi2EnterEventMode", NO_ME);
}

fmi2Status fmi2NewDiscreteStates(fmi2Component c, fmi2EventInfo *eventInfo)
{
    (void)eventInfo;
    return unsupported(c, "fmi2NewDiscreteStates", NO_ME);
}

fmi2Status fmi2EnterContinuousTimeMode(fmi2Component c)
{
    return unsupported(c, "fmi2EnterContinuousTimeMode", NO_ME);
}

fmi2Status fmi2CompletedIntegratorStep(fmi2Component c,
                                       fmi2Boolean noSetFMUStatePriorToCurrentPoint,
                                       fmi2Boolean *enterEventMode,
                                       fmi2Boolean *terminateSimulation)
{
    (void)noSetFMUStatePriorToCurrentPoint;
    (void)enterEventMode;
    (void)terminateSimulation;
    return unsupported(c, "fmi2CompletedIntegratorStep", NO_ME);
}

fmi2Status fmi2SetTime(fmi2Component c, fmi2Real time)
{
    (void)time;
    return unsupported(c, "fmi2SetTime", NO_ME);
}

fmi2Status fmi2SetContinuousStates(fmi2Component c, const fmi2Real x[], size_t nx)
{
    (void)x;
    (void)nx;
    return unsupported(c, "fmi2SetContinuousStates", NO_ME);
}

fmi2Status fmi2GetDerivatives(fmi2Component c, fmi2Real derivatives[], size_t nx)
{
    (void)derivatives;
    (void)nx;
    return unsupported(c, "fmi2GetDerivatives", NO_ME);
}

fmi2Status fmi2GetEventIndicators(fmi2Component c, fmi2Real eventIndicators[], size_t ni)
{
    (void)eventIndicators;
    (void)ni;
    return unsupported(c, "fmi2GetEventIndicators", NO_ME);
}

fmi2Status fmi2GetContinuousStates(fmi2Component c, fmi2Real x[], size_t nx)
{
    (void)x;
    (void)nx;
    return unsupported(c, "fmi2GetContinuousStates", NO_ME);
}

fmi2Status fmi2GetNominalsOfContinuousStates(fmi2Component c, fmi2Real x_nominal[], size_t nx)
{
    (void)x_nominal;
    (void)nx;
    return unsupported(c, "fmi2GetNominalsOfContinuousStates", NO_ME);
}
