/*
 * ship_common.c - the FMI-version-neutral part of the shipid native FMU layer.
 *
 * Written once and shared by every generated FMU and both FMI API versions (after the
 * pattern of the Modelica Reference-FMUs: one reviewed FMI layer, a small generated
 * model part). Not compiled on its own: fmi2_functions.c and fmi3_functions.c each
 * include it, so that one FMU binary is one translation unit, every helper here is
 * static and the FMU exports nothing but its FMI functions. Before the #include the
 * API file defines
 *
 *   ShipApi     a struct with what that FMI version's instantiation passed (logger,
 *               environment) and the fields allocate and free_memory;
 *   api_log     static void api_log(const Instance *, ShipStatus, const char *category,
 *               const char *message): pass one message to that version's logger.
 *
 * Behaviour (the documented contract; tests/test_fmu_native.py and tests/test_fmu_kinds.py
 * check it; FMI sections of FMI 2.0.4 and FMI 3.0.2):
 *
 * - All data live in the instance; any number of instances per process.
 * - The state (u, v, r, x, y, psi), i.e. the outputs, follows the parameters u0 ... psi0
 *   until ExitInitializationMode: it is reset from them at instantiation, at every
 *   SetReal/SetFloat64 before the end of initialisation and at ExitInitializationMode.
 *   From then on it only changes through DoStep (co-simulation), SetContinuousStates
 *   (model exchange), SetFMUState and Reset.
 * - ExitInitializationMode refuses a start speed sqrt(u0^2 + v0^2) below
 *   MIN_START_SPEED (nonzero for a model whose equations divide by the speed) with an
 *   error; the instance stays in initialization mode, so u0 or v0 can be corrected.
 * - DoStep integrates with the classical RK4 in n equal internal steps,
 *   n = 1 if h <= max_step else ceil(h / max_step * (1 - 1e-12)), the rule of
 *   fmu_model.integrate.n_substeps; inputs are held constant over the step; the
 *   propeller speed enters the equations as rpm / 60 [rev/s].
 * - The environment inputs (current, wind) add their terms to model_rhs through
 *   model_environment (the wind load with the windage parameters, the current to the
 *   kinematics); with zero current and zero windage areas they add nothing, so the
 *   state is bit for bit that of the model alone. The outputs sog and cog (speed and
 *   course over ground) are calculated from the state and the current when read
 *   (model_ground); they are not states.
 * - Model exchange is event-free: no event indicators, no time events, no discrete
 *   states; the derivatives der(u) ... der(psi) are model_rhs at the current state and
 *   inputs. max_step is not used.
 * - Directional derivatives (FMI 2.0 section 3.2.2, FMI 3.0 section 2.2.11) are exact,
 *   from model_jacobian and model_environment_jacobian: unknowns are state derivatives
 *   or outputs (states, sog, cog), knowns are states or inputs; d der(x_i) / d x_j =
 *   dfdx, d der(x_i) / d input = dfdu (by rpm: dfdu / 60) or dfde (environment),
 *   d x_i / d x_j = identity, d x_i / d input = 0 (no feed-through); d (sog, cog) by
 *   the states and the environment from model_ground_jacobian (0 at rest over
 *   ground), by rudder and rpm 0.
 * - Errors (status error, message in category logStatusError) leave the instance
 *   unchanged, so a master may correct the call and continue:
 *     a non-finite value or a value outside a declared min/max passed to SetReal (the
 *     whole call is rejected, no value of it is applied), or found in an FMU state given
 *     to SetFMUState or DeserializeFMUState (the state is not restored); an FMU state
 *     past initialization whose windage has a singular sway-yaw mass matrix (not
 *     restored either); setting an output, local or the time, or a parameter after
 *     ExitInitializationMode; an unknown value reference; a call not allowed in the
 *     current state; a start below the least start speed or a windage whose sway-yaw
 *     mass matrix is singular; a non-positive or non-finite communication step, a
 *     currentCommunicationPoint that is not the FMU's time, a step too small to advance
 *     the time (t + h == t), or a step needing more than MAX_SUBSTEPS internal steps
 *     (about 1 s of CPU); non-finite continuous states, time or seeds; every function
 *     this FMU does not implement (one helper, unsupported()).
 * - A diverging state (non-finite, |u| or |v| > DIVERGENCE_MAX_SPEED, |r| >
 *   DIVERGENCE_MAX_YAW_RATE, the rule of fmu_model.fmi_rules generated into
 *   model_config.h) is a discard (category logStatusDiscard), never fatal: it ends
 *   DoStep with the state at the beginning of the step, the last successful time that
 *   time, and only the getters, SetFMUState, Reset, Terminate and FreeInstance allowed
 *   ("step failed"); in model exchange the derivatives of a diverged state are a discard,
 *   so that the host's solver can retry with a smaller step.
 * - Beyond the logs (fmu_model.envelope.ExtrapolationWatch; MODEL_HAS_ENVELOPE and the
 *   ENVELOPE_* values of model_config.h, from params.json identification.envelope):
 *   after every completed DoStep, the step's rudder angle and propeller speed and the
 *   state at its end (r' = r L / U where U >= ENVELOPE_MIN_SPEED_RATIO_FOR_YAW_RATE U0,
 *   U / U0, U0 = sqrt(u0^2 + v0^2)) are judged against what the identification's logs
 *   reached; the first time since ExitInitializationMode that they go beyond it on an
 *   axis and side, by more than the margins, is one warning (status warning, category
 *   logStatusWarning, EXTRAPOLATION_FORMAT). The step itself is OK: the model
 *   extrapolates, it does not fail. Model exchange does not judge.
 * - Logging: the categories logStatusWarning, logStatusDiscard, logStatusError and
 *   logStatusFatal are on from instantiation (they report failures, not debug output);
 *   logAll (a trace of every call) follows the loggingOn argument. SetDebugLogging
 *   with nCategories = 0 switches all categories, otherwise the named ones.
 * - GetFMUState copies everything that evolves (values, time, FMI state); the
 *   serialised form is that copy with a header (magic, format version, GUID, size) in
 *   the byte order of the machine; restoring it continues bit-identically.
 */
#include <math.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "model_config.h"
#include "model_equations.h"

/* Compile-time checks of the generated layout (a negative array size fails the build). */
typedef char
    ship_check_coefficients[(VR_COEFFICIENTS + MODEL_N_COEFFICIENTS <= MODEL_N_VARIABLES) ? 1 : -1];
typedef char ship_check_states[(VR_STATE + SHIP_N_STATES <= MODEL_N_VARIABLES) ? 1 : -1];
typedef char ship_check_initial[(VR_INITIAL_STATE + SHIP_N_STATES <= MODEL_N_VARIABLES) ? 1 : -1];
typedef char ship_check_derivatives[(VR_DERIVATIVES + SHIP_N_STATES <= MODEL_N_VARIABLES) ? 1 : -1];
typedef char ship_check_time[(VR_TIME < MODEL_N_VARIABLES) ? 1 : -1];
typedef char
    ship_check_environment[(VR_ENVIRONMENT + SHIP_N_ENVIRONMENT <= MODEL_N_VARIABLES) ? 1 : -1];
typedef char ship_check_ground[(VR_GROUND + SHIP_N_GROUND <= MODEL_N_VARIABLES) ? 1 : -1];
typedef char ship_check_windage[(VR_WINDAGE + SHIP_N_WINDAGE <= MODEL_N_VARIABLES) ? 1 : -1];

#if defined(__GNUC__)
#define SHIP_PRINTF(fmt_index, first_arg) __attribute__((format(printf, fmt_index, first_arg)))
#else
#define SHIP_PRINTF(fmt_index, first_arg)
#endif

/* The statuses of this layer; equal to those of fmi2Status and fmi3Status (checked by the
   API files), so that they are returned as they are. No call of this FMU is fatal. */
typedef enum { SHIP_OK = 0, SHIP_WARNING = 1, SHIP_DISCARD = 2, SHIP_ERROR = 3 } ShipStatus;

/* What an instance was instantiated for. */
typedef enum { KIND_CO_SIMULATION = 1, KIND_MODEL_EXCHANGE = 2 } ShipKind;

/* ---------------------------------------------------------------------------------- */
/* Instance                                                                            */
/* ---------------------------------------------------------------------------------- */

/* The states of FMI 2.0 sections 3.2.3 (model exchange) and 4.2.4 (co-simulation) and
   FMI 3.0 section 3.2 / 4.2 this FMU uses. STATE_STEP_COMPLETE is co-simulation's
   stepComplete (FMI 2.0) or Step Mode (FMI 3.0); STATE_STEP_FAILED follows a diverged
   step. The FMU has no stepCanceled (DoStep is synchronous) and no error state (an error
   leaves the instance in its state). */
typedef enum {
    STATE_INSTANTIATED = 1 << 0,
    STATE_INITIALIZATION = 1 << 1,
    STATE_STEP_COMPLETE = 1 << 2,
    STATE_STEP_FAILED = 1 << 3,
    STATE_EVENT_MODE = 1 << 4,
    STATE_CONTINUOUS_TIME_MODE = 1 << 5,
    STATE_TERMINATED = 1 << 6
} ModelState;

/* The states of each kind of instance. */
#define STATES_CO_SIMULATION                                                            \
    (STATE_INSTANTIATED | STATE_INITIALIZATION | STATE_STEP_COMPLETE | STATE_STEP_FAILED | \
     STATE_TERMINATED)
#define STATES_MODEL_EXCHANGE                                                        \
    (STATE_INSTANTIATED | STATE_INITIALIZATION | STATE_EVENT_MODE |                   \
     STATE_CONTINUOUS_TIME_MODE | STATE_TERMINATED)
#define STATE_ANY (STATES_CO_SIMULATION | STATES_MODEL_EXCHANGE)

/* After initialisation, before termination: where inputs may be set and values read. */
#define STATES_RUNNING                                                               \
    (STATE_STEP_COMPLETE | STATE_STEP_FAILED | STATE_EVENT_MODE | STATE_CONTINUOUS_TIME_MODE)
/* Past ExitInitializationMode: the parameters are fixed and were accepted by it. */
#define STATES_INITIALIZED (STATES_RUNNING | STATE_TERMINATED)
/* Where values may be read: from initialization mode on (FMI 2.0 sections 3.2.3 and
   4.2.4, FMI 3.0 section 2.2.6.2). */
#define STATES_GET (STATE_INITIALIZATION | STATES_RUNNING | STATE_TERMINATED)
/* Where an input may be set. Outside "step failed": after a diverged step only the
   getters, SetFMUState, Reset, Terminate and FreeInstance are allowed. */
#define STATES_SET_INPUT                                                             \
    (STATE_INSTANTIATED | STATE_INITIALIZATION | STATE_STEP_COMPLETE | STATE_EVENT_MODE | \
     STATE_CONTINUOUS_TIME_MODE)
/* Where a fixed parameter may be set. */
#define STATES_SET_PARAMETER (STATE_INSTANTIATED | STATE_INITIALIZATION)

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

/* Everything that evolves: what GetFMUState saves and SetFMUState restores. */
typedef struct {
    double values[MODEL_N_VARIABLES]; /* indexed by value reference */
    double time;                      /* current time [s] */
    double start_time;                /* from SetupExperiment / EnterInitializationMode [s] */
    double last_successful_time;      /* end of the last completed step [s] */
    int state;                        /* ModelState */
} Snapshot;

#define INSTANCE_MAGIC 0x53484950u /* "SHIP" */
#define FMUSTATE_MAGIC 0x53544154u /* "STAT" */

typedef struct Instance {
    unsigned magic;
    Snapshot s;
    ShipKind kind;
    char *instance_name;
    ShipApi api;
    int log_enabled[N_LOG_CATEGORIES];
    unsigned warned_beyond; /* bit k: axis k of BeyondAxis warned about since the start */
} Instance;

typedef struct {
    unsigned magic;
    Snapshot s;
} SavedState;

static void api_log(const Instance *inst, ShipStatus status, const char *category,
                    const char *message);

/* ---------------------------------------------------------------------------------- */
/* Logging                                                                             */
/* ---------------------------------------------------------------------------------- */

static void log_message(const Instance *inst, ShipStatus status, LogCategory category,
                        const char *format, ...) SHIP_PRINTF(4, 5);

static void log_message(const Instance *inst, ShipStatus status, LogCategory category,
                        const char *format, ...)
{
    char buffer[512];
    va_list args;
    if (!inst->log_enabled[category]) {
        return;
    }
    va_start(args, format);
    vsnprintf(buffer, sizeof buffer, format, args);
    va_end(args);
    api_log(inst, status, LOG_CATEGORY_NAMES[category], buffer);
}

#define LOG_WARNING(inst, ...) log_message((inst), SHIP_WARNING, LOG_STATUS_WARNING, __VA_ARGS__)
#define LOG_ERROR(inst, ...) log_message((inst), SHIP_ERROR, LOG_STATUS_ERROR, __VA_ARGS__)
#define LOG_DISCARD(inst, ...) log_message((inst), SHIP_DISCARD, LOG_STATUS_DISCARD, __VA_ARGS__)
#define LOG_TRACE(inst, ...) log_message((inst), SHIP_OK, LOG_ALL, __VA_ARGS__)

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
    case STATE_EVENT_MODE:
        return "event mode";
    case STATE_CONTINUOUS_TIME_MODE:
        return "continuous-time mode";
    case STATE_TERMINATED:
        return "terminated";
    default:
        return "unknown";
    }
}

/* The instance behind a handle, when `function` may be called on it in its current
   state; else NULL (logged when the handle is an instance). Every function that starts
   from an instance does this first. */
static Instance *ship_begin(void *handle, const char *function, int states)
{
    Instance *inst = (Instance *)handle;
    if (inst == NULL || inst->magic != INSTANCE_MAGIC) {
        return NULL;
    }
    if (!(inst->s.state & states)) {
        LOG_ERROR(inst, "%s must not be called in state '%s'", function,
                  state_name(inst->s.state));
        return NULL;
    }
    return inst;
}

/* A function this FMU does not implement: log "<function> is not supported: <why>"
   (category logStatusError) and return an error; the one body of every such function. */
static ShipStatus unsupported(void *handle, const char *function, const char *why)
{
    Instance *inst = ship_begin(handle, function, STATE_ANY);
    if (inst != NULL) {
        LOG_ERROR(inst, "%s is not supported: %s", function, why);
    }
    return SHIP_ERROR;
}

/* A getter or setter of a type this FMU has no variables of (it has Float64 only). */
static ShipStatus no_variables_of_type(void *handle, const char *function, size_t nvr)
{
    Instance *inst = ship_begin(handle, function, STATE_ANY);
    if (inst == NULL) {
        return SHIP_ERROR;
    }
    if (nvr == 0) {
        return SHIP_OK;
    }
    LOG_ERROR(inst, "%s: this FMU has no variables of that type", function);
    return SHIP_ERROR;
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

static double rudder_of(const Instance *inst) { return inst->s.values[VR_RUDDER_ANGLE]; }

/* The propeller speed enters the equations in rev/s. */
static double n_rps_of(const Instance *inst) { return inst->s.values[VR_PROPELLER_RPM] / 60.0; }

/* The model's right-hand side, then what the environment adds to it. */
static void rhs(const Instance *inst, const double *x, double *dx)
{
    model_rhs(&inst->s.values[VR_COEFFICIENTS], inst->s.values[VR_LENGTH], x, rudder_of(inst),
              n_rps_of(inst), dx);
    model_environment(x, &inst->s.values[VR_ENVIRONMENT], &inst->s.values[VR_WINDAGE], dx);
}

/* One classical Runge-Kutta step with the inputs held; same operation order as
   fmu_model.integrate.rk4_into so that the results agree to rounding. */
static void rk4_step(const Instance *inst, double *x, double h)
{
    double k1[SHIP_N_STATES], k2[SHIP_N_STATES], k3[SHIP_N_STATES], k4[SHIP_N_STATES];
    double tmp[SHIP_N_STATES];
    const double half = 0.5 * h;
    const double sixth = h / 6.0;
    int i;
    rhs(inst, x, k1);
    for (i = 0; i < SHIP_N_STATES; i++) {
        tmp[i] = x[i] + half * k1[i];
    }
    rhs(inst, tmp, k2);
    for (i = 0; i < SHIP_N_STATES; i++) {
        tmp[i] = x[i] + half * k2[i];
    }
    rhs(inst, tmp, k3);
    for (i = 0; i < SHIP_N_STATES; i++) {
        tmp[i] = x[i] + h * k3[i];
    }
    rhs(inst, tmp, k4);
    for (i = 0; i < SHIP_N_STATES; i++) {
        x[i] = x[i] + sixth * (((k1[i] + 2.0 * k2[i]) + 2.0 * k3[i]) + k4[i]);
    }
}

/* Number of equal internal steps (fmu_model.integrate.n_substeps); 0 when more than
   MAX_SUBSTEPS (about 1 s of CPU, see fmu_model.fmi_rules.MAX_SUBSTEPS). */
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

/* The windage rule of fmu_model.fmi_rules.windage_problem: return nonzero when the
   sway-yaw mass matrix of `windage` (the values from VR_WINDAGE on) is regular,
   coupling^2 < sway_mass * yaw_inertia; else log WINDAGE_COUPLING_FORMAT after
   "`function`: `refusal`" and return 0. The check of ExitInitializationMode and of every
   restored FMU state past initialization. */
static int windage_is_valid(const Instance *inst, const char *function, const char *refusal,
                            const double *windage)
{
    const double mass_product = windage[WINDAGE_SWAY_MASS] * windage[WINDAGE_YAW_INERTIA];
    const double coupling = windage[WINDAGE_SWAY_YAW_COUPLING];
    if (coupling * coupling < mass_product) {
        return 1;
    }
    LOG_ERROR(inst, "%s: %s" WINDAGE_COUPLING_FORMAT, function, refusal, coupling,
              sqrt(mass_product));
    return 0;
}

/* Return nonzero when the snapshot holds only values SetReal would accept (finite,
   within each variable's declared min/max), finite times, an FMI state of the
   instance's kind and, in a state past initialization (STATES_INITIALIZED), a windage
   ExitInitializationMode would accept (else the wind's accelerations divide by zero);
   else log why, naming `function`, and return 0. The check of every restored FMU
   state. */
static int snapshot_is_valid(const Instance *inst, const char *function, const Snapshot *s)
{
    const int kind_states =
        inst->kind == KIND_CO_SIMULATION ? STATES_CO_SIMULATION : STATES_MODEL_EXCHANGE;
    int i;
    if (!(s->state & kind_states) || (s->state & (s->state - 1)) != 0) {
        LOG_ERROR(inst, "%s: the FMU state is not restored: invalid FMI state %d", function,
                  s->state);
        return 0;
    }
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
    if ((s->state & STATES_INITIALIZED) &&
        !windage_is_valid(inst, function, "the FMU state is not restored: ",
                          &s->values[VR_WINDAGE])) {
        return 0;
    }
    return 1;
}

/* The divergence rule of fmu_model.fmi_rules.state_diverged. */
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
/* Life cycle                                                                          */
/* ---------------------------------------------------------------------------------- */

/* A new instance in state "instantiated", or NULL (logged through `api`) for a wrong
   GUID / instantiation token or no memory. */
static Instance *ship_instantiate(const char *instance_name, ShipKind kind, const char *token,
                                  ShipApi api, int logging_on)
{
    Instance *inst;
    Instance message_only; /* logs before the instance exists */
    const char *name = instance_name != NULL ? instance_name : "";
    size_t length = strlen(name);
    int k;
    memset(&message_only, 0, sizeof message_only);
    message_only.instance_name = (char *)name;
    message_only.api = api;
    message_only.log_enabled[LOG_STATUS_ERROR] = 1;
    if (token == NULL || strcmp(token, MODEL_GUID) != 0) {
        LOG_ERROR(&message_only, "GUID '%s' does not match this binary's GUID '%s'",
                  token == NULL ? "(null)" : token, MODEL_GUID);
        return NULL;
    }
    inst = (Instance *)api.allocate(1, sizeof(Instance));
    if (inst == NULL) {
        LOG_ERROR(&message_only, "out of memory");
        return NULL;
    }
    inst->instance_name = (char *)api.allocate(length + 1, 1);
    if (inst->instance_name == NULL) {
        api.free_memory(inst);
        LOG_ERROR(&message_only, "out of memory");
        return NULL;
    }
    memcpy(inst->instance_name, name, length + 1);
    inst->magic = INSTANCE_MAGIC;
    inst->kind = kind;
    inst->api = api;
    for (k = 0; k < N_LOG_CATEGORIES; k++) {
        inst->log_enabled[k] = 1;
    }
    inst->log_enabled[LOG_ALL] = logging_on ? 1 : 0;
    inst->warned_beyond = 0u;
    set_start_values(inst);
    LOG_TRACE(inst, "Instantiate: %s (%s), GUID %s", MODEL_IDENTIFIER_NAME,
              kind == KIND_CO_SIMULATION ? "co-simulation" : "model exchange", MODEL_GUID);
    return inst;
}

static void ship_free_instance(void *handle)
{
    Instance *inst = (Instance *)handle;
    ShipApi api;
    if (inst == NULL || inst->magic != INSTANCE_MAGIC) {
        return;
    }
    LOG_TRACE(inst, "FreeInstance");
    api = inst->api;
    inst->magic = 0;
    api.free_memory(inst->instance_name);
    api.free_memory(inst);
}

static ShipStatus ship_set_debug_logging(Instance *inst, const char *function, int logging_on,
                                         size_t n_categories, const char *const categories[])
{
    size_t i;
    int k;
    int chosen[N_LOG_CATEGORIES] = {0};
    if (n_categories > 0 && categories == NULL) {
        LOG_ERROR(inst, "%s: categories is NULL", function);
        return SHIP_ERROR;
    }
    for (i = 0; i < n_categories; i++) {
        int found = 0;
        for (k = 0; k < N_LOG_CATEGORIES; k++) {
            if (categories[i] != NULL && strcmp(categories[i], LOG_CATEGORY_NAMES[k]) == 0) {
                chosen[k] = 1;
                found = 1;
            }
        }
        if (!found) {
            LOG_ERROR(inst, "%s: unknown log category '%s'", function,
                      categories[i] == NULL ? "(null)" : categories[i]);
            return SHIP_ERROR;
        }
    }
    for (k = 0; k < N_LOG_CATEGORIES; k++) {
        if (n_categories == 0 || chosen[k]) {
            inst->log_enabled[k] = logging_on ? 1 : 0;
        }
    }
    return SHIP_OK;
}

/* The start time (FMI 2.0 fmi2SetupExperiment, FMI 3.0 fmi3EnterInitializationMode). The
   integrator is a fixed-step RK4: the tolerance and the stop time are not used. */
static ShipStatus ship_set_start_time(Instance *inst, const char *function, double start_time)
{
    if (!isfinite(start_time)) {
        LOG_ERROR(inst, "%s: startTime must be finite, got %g", function, start_time);
        return SHIP_ERROR;
    }
    LOG_TRACE(inst, "%s: startTime %.17g", function, start_time);
    inst->s.start_time = start_time;
    inst->s.time = start_time;
    inst->s.last_successful_time = start_time;
    return SHIP_OK;
}

static void ship_enter_initialization_mode(Instance *inst)
{
    reset_state_from_parameters(inst);
    inst->s.state = STATE_INITIALIZATION;
}

/* Leave initialization mode for stepComplete / Step Mode (co-simulation) or Event Mode
   (model exchange). A model that divides by the speed is 0/0 at rest: such a start is
   refused, and so is a windage whose sway-yaw mass matrix is singular (its parameters are
   all set only now); the instance stays in initialization mode, so that the master can
   set u0 or v0, or the windage, and try again. */
static ShipStatus ship_exit_initialization_mode(Instance *inst, const char *function)
{
    const double u0 = inst->s.values[VR_INITIAL_STATE];
    const double v0 = inst->s.values[VR_INITIAL_STATE + 1];
    const double speed = sqrt(u0 * u0 + v0 * v0);
    if (MIN_START_SPEED > 0.0 && !(speed >= MIN_START_SPEED)) {
        LOG_ERROR(inst, "%s: " START_SPEED_FORMAT, function, speed, MIN_START_SPEED);
        return SHIP_ERROR;
    }
    if (!windage_is_valid(inst, function, "", &inst->s.values[VR_WINDAGE])) {
        return SHIP_ERROR;
    }
    reset_state_from_parameters(inst);
    inst->s.last_successful_time = inst->s.time;
    inst->s.state = inst->kind == KIND_CO_SIMULATION ? STATE_STEP_COMPLETE : STATE_EVENT_MODE;
    inst->warned_beyond = 0u;
    return SHIP_OK;
}

/* States where Terminate is allowed: after initialisation. */
#define STATES_TERMINATE STATES_RUNNING

static void ship_terminate(Instance *inst) { inst->s.state = STATE_TERMINATED; }

static void ship_reset(Instance *inst) { set_start_values(inst); }

/* ---------------------------------------------------------------------------------- */
/* Getting and setting values                                                          */
/* ---------------------------------------------------------------------------------- */

static int is_derivative(unsigned vr)
{
    return vr >= VR_DERIVATIVES && vr < VR_DERIVATIVES + SHIP_N_STATES;
}

static int is_state(unsigned vr) { return vr >= VR_STATE && vr < VR_STATE + SHIP_N_STATES; }

/* sog or cog: an output over ground, calculated when read. */
static int is_ground(unsigned vr) { return vr >= VR_GROUND && vr < VR_GROUND + SHIP_N_GROUND; }

static int is_environment(unsigned vr)
{
    return vr >= VR_ENVIRONMENT && vr < VR_ENVIRONMENT + SHIP_N_ENVIRONMENT;
}

static ShipStatus ship_get_real(Instance *inst, const char *function, const unsigned vr[],
                                size_t nvr, double value[])
{
    double dx[SHIP_N_STATES];
    double ground[SHIP_N_GROUND];
    int have_dx = 0;
    int have_ground = 0;
    size_t i;
    if (nvr > 0 && (vr == NULL || value == NULL)) {
        LOG_ERROR(inst, "%s: vr or value is NULL", function);
        return SHIP_ERROR;
    }
    for (i = 0; i < nvr; i++) {
        if (vr[i] >= MODEL_N_VARIABLES) {
            LOG_ERROR(inst, "%s: unknown value reference %u", function, vr[i]);
            return SHIP_ERROR;
        }
    }
    for (i = 0; i < nvr; i++) {
        if (vr[i] == VR_TIME) {
            value[i] = inst->s.time;
        } else if (is_derivative(vr[i])) {
            if (!have_dx) {
                rhs(inst, &inst->s.values[VR_STATE], dx);
                have_dx = 1;
            }
            value[i] = dx[vr[i] - VR_DERIVATIVES];
        } else if (is_ground(vr[i])) {
            if (!have_ground) {
                model_ground(&inst->s.values[VR_STATE], &inst->s.values[VR_ENVIRONMENT], ground);
                have_ground = 1;
            }
            value[i] = ground[vr[i] - VR_GROUND];
        } else {
            value[i] = inst->s.values[vr[i]];
        }
    }
    return SHIP_OK;
}

/* Check one value for SetReal; logs and returns 0 when it must be rejected. */
static int check_set_real(const Instance *inst, const char *function, unsigned vr, double value)
{
    const ShipVariable *var;
    if (vr >= MODEL_N_VARIABLES) {
        LOG_ERROR(inst, "%s: unknown value reference %u", function, vr);
        return 0;
    }
    var = &MODEL_VARIABLES[vr];
    if (var->causality == SHIP_OUTPUT || var->causality == SHIP_LOCAL ||
        var->causality == SHIP_INDEPENDENT) {
        LOG_ERROR(inst, "%s: '%s' (vr %u) is %s and cannot be set", function, var->name, vr,
                  var->causality == SHIP_OUTPUT  ? "an output"
                  : var->causality == SHIP_LOCAL ? "a calculated local"
                                                 : "the independent variable");
        return 0;
    }
    if (var->causality == SHIP_PARAMETER && !(inst->s.state & STATES_SET_PARAMETER)) {
        LOG_ERROR(inst,
                  "%s: '%s' (vr %u) is a fixed parameter; it can only be set before "
                  "ExitInitializationMode",
                  function, var->name, vr);
        return 0;
    }
    if (!isfinite(value)) {
        LOG_ERROR(inst, "%s: '%s' (vr %u) must be finite, got %g", function, var->name, vr,
                  value);
        return 0;
    }
    if ((var->has_min && value < var->min) || (var->has_max && value > var->max)) {
        LOG_ERROR(inst, "%s: '%s' (vr %u) = %.17g is outside [%.17g, %.17g]", function,
                  var->name, vr, value, var->has_min ? var->min : -HUGE_VAL,
                  var->has_max ? var->max : HUGE_VAL);
        return 0;
    }
    return 1;
}

static ShipStatus ship_set_real(Instance *inst, const char *function, const unsigned vr[],
                                size_t nvr, const double value[])
{
    size_t i;
    if (nvr > 0 && (vr == NULL || value == NULL)) {
        LOG_ERROR(inst, "%s: vr or value is NULL", function);
        return SHIP_ERROR;
    }
    /* All or nothing: check every value before applying any. */
    for (i = 0; i < nvr; i++) {
        if (!check_set_real(inst, function, vr[i], value[i])) {
            return SHIP_ERROR;
        }
    }
    for (i = 0; i < nvr; i++) {
        inst->s.values[vr[i]] = value[i];
    }
    if (inst->s.state & STATES_SET_PARAMETER) {
        reset_state_from_parameters(inst);
    }
    return SHIP_OK;
}

/* ---------------------------------------------------------------------------------- */
/* Beyond the identification's logs (fmu_model.envelope)                               */
/* ---------------------------------------------------------------------------------- */

/* The axes and sides, in the order of fmu_model.envelope.AXES. */
typedef enum {
    BEYOND_RUDDER_PORT = 0,
    BEYOND_RUDDER_STARBOARD,
    BEYOND_YAW_RATE_PORT,
    BEYOND_YAW_RATE_STARBOARD,
    BEYOND_SPEED,
    BEYOND_APPROACH_SPEED,
    BEYOND_PROPELLER
} BeyondAxis;

static const char *const SIDE_NAMES[2] = {"port", "starboard"};

/* Warn about `axis` with `phrase`, unless it was warned about since the start. */
static void warn_beyond(Instance *inst, const char *function, BeyondAxis axis, const char *phrase)
{
    if (inst->warned_beyond & (1u << axis)) {
        return;
    }
    inst->warned_beyond |= 1u << axis;
    LOG_WARNING(inst, EXTRAPOLATION_FORMAT, function, inst->s.time, phrase);
}

/* Envelope._past_sides: each side (port, starboard) on which `sailed` exceeds `logged`
   by more than the margin, said x`scale` with the printf format `format`. */
static void past_sides(Instance *inst, const char *function, BeyondAxis port_axis,
                       const char *format, double scale, const double logged[2],
                       const double sailed[2])
{
    char phrase[160];
    int side;
    for (side = 0; side < 2; side++) {
        if (sailed[side] > (1.0 + ENVELOPE_MARGIN) * logged[side]) {
            snprintf(phrase, sizeof phrase, format, scale * sailed[side], SIDE_NAMES[side],
                     scale * logged[side]);
            warn_beyond(inst, function, (BeyondAxis)(port_axis + side), phrase);
        }
    }
}

/* Span.said: "low-high unit", or "value unit" when both ends read the same. */
static void span_said(char *out, size_t size, double low, double high, double scale,
                      const char *unit)
{
    char a[32], b[32];
    snprintf(a, sizeof a, ENVELOPE_SPAN_VALUE_FORMAT, scale * low);
    snprintf(b, sizeof b, ENVELOPE_SPAN_VALUE_FORMAT, scale * high);
    if (strcmp(a, b) == 0) {
        snprintf(out, size, "%s %s", a, unit);
    } else {
        snprintf(out, size, "%s-%s %s", a, b, unit);
    }
}

/* Envelope._past_span of one value: outside [low, high] by more than the margin. */
static void past_span(Instance *inst, const char *function, BeyondAxis axis, const char *label,
                      double low, double high, double value, double scale, const char *unit)
{
    char sailed[48], logged[80], phrase[200];
    if ((1.0 - ENVELOPE_MARGIN) * low <= value && value <= (1.0 + ENVELOPE_MARGIN) * high) {
        return;
    }
    span_said(sailed, sizeof sailed, value, value, scale, unit);
    span_said(logged, sizeof logged, low, high, scale, unit);
    snprintf(phrase, sizeof phrase, ENVELOPE_SPAN_FORMAT, label, sailed, logged);
    warn_beyond(inst, function, axis, phrase);
}

/* ExtrapolationWatch.news of the instant after a step: its instant_envelope (the step's
   inputs, the state at its end, U0 from u0 and v0) against the logs' envelope. */
static void warn_beyond_logs(Instance *inst, const char *function)
{
    static const double logged_rudder[2] = {ENVELOPE_RUDDER_PORT, ENVELOPE_RUDDER_STARBOARD};
    static const double logged_yaw_rate[2] = {ENVELOPE_YAW_RATE_PORT, ENVELOPE_YAW_RATE_STARBOARD};
    const double *x = &inst->s.values[VR_STATE];
    const double u0 = inst->s.values[VR_INITIAL_STATE];
    const double v0 = inst->s.values[VR_INITIAL_STATE + 1];
    const double start_speed = sqrt(u0 * u0 + v0 * v0);
    const double speed = sqrt(x[0] * x[0] + x[1] * x[1]);
    const double rudder = rudder_of(inst);
    double ratio = 1.0, yaw_rate = 0.0;
    double sailed[2];
    char phrase[160];
    if (!MODEL_HAS_ENVELOPE) {
        return;
    }
    if (start_speed > 0.0) {
        ratio = speed / start_speed;
        if (ratio >= ENVELOPE_MIN_SPEED_RATIO_FOR_YAW_RATE) {
            yaw_rate = x[2] * inst->s.values[VR_LENGTH] / speed;
        }
    }
    sailed[0] = rudder < 0.0 ? -rudder : 0.0;
    sailed[1] = rudder > 0.0 ? rudder : 0.0;
    past_sides(inst, function, BEYOND_RUDDER_PORT, ENVELOPE_RUDDER_FORMAT, ENVELOPE_DEG_PER_RAD,
               logged_rudder, sailed);
    sailed[0] = yaw_rate < 0.0 ? -yaw_rate : 0.0;
    sailed[1] = yaw_rate > 0.0 ? yaw_rate : 0.0;
    past_sides(inst, function, BEYOND_YAW_RATE_PORT, ENVELOPE_YAW_RATE_FORMAT, 1.0,
               logged_yaw_rate, sailed);
    if (ratio < ENVELOPE_SPEED_RATIO_MIN - ENVELOPE_SPEED_RATIO_MARGIN) {
        snprintf(phrase, sizeof phrase, ENVELOPE_SPEED_RATIO_FORMAT, ratio,
                 ENVELOPE_SPEED_RATIO_MIN);
        warn_beyond(inst, function, BEYOND_SPEED, phrase);
    }
    past_span(inst, function, BEYOND_APPROACH_SPEED, "approach speed", ENVELOPE_APPROACH_LOW,
              ENVELOPE_APPROACH_HIGH, start_speed, 1.0, "m/s");
    past_span(inst, function, BEYOND_PROPELLER, "propeller", ENVELOPE_PROPELLER_LOW,
              ENVELOPE_PROPELLER_HIGH, n_rps_of(inst), ENVELOPE_RPM_PER_RPS, "rpm");
}

/* ---------------------------------------------------------------------------------- */
/* Co-simulation                                                                       */
/* ---------------------------------------------------------------------------------- */

/* One communication step from t over h (FMI 2.0 section 4.2.2, FMI 3.0 section 4.2.1).
   SHIP_OK: the state advanced to t + h; SHIP_ERROR: refused before any work, instance
   unchanged; SHIP_DISCARD: the state diverged, it stays at t and the instance is in
   "step failed". */
static ShipStatus ship_do_step(Instance *inst, const char *function, double t, double h)
{
    double end;
    double x[SHIP_N_STATES];
    double n;
    double hs;
    long i;
    int k;
    LOG_TRACE(inst, "%s: t = %.17g, h = %.17g", function, t, h);
    if (!(h > 0.0) || !isfinite(h)) {
        LOG_ERROR(inst, "%s: " STEP_SIZE_FORMAT, function, h);
        return SHIP_ERROR;
    }
    if (!isfinite(t) ||
        fabs(t - inst->s.time) > STEP_TIME_TOLERANCE * (1.0 + fabs(inst->s.time))) {
        LOG_ERROR(inst, "%s: " STEP_TIME_FORMAT, function, t, inst->s.time);
        return SHIP_ERROR;
    }
    end = t + h; /* the assignment rounds to double, also with x87 excess precision */
    if (!(end > t)) {
        /* h is below half the spacing of doubles at t: the time would not advance. */
        LOG_ERROR(inst, "%s: " TIME_STALL_FORMAT, function, h, t);
        return SHIP_ERROR;
    }
    n = n_substeps(h, inst->s.values[VR_MAX_STEP]);
    if (n == 0.0) {
        LOG_ERROR(inst, "%s: " SUBSTEP_LIMIT_FORMAT, function, h, h / inst->s.values[VR_MAX_STEP],
                  inst->s.values[VR_MAX_STEP], MAX_SUBSTEPS);
        return SHIP_ERROR;
    }
    hs = h / n;
    for (k = 0; k < SHIP_N_STATES; k++) {
        x[k] = inst->s.values[VR_STATE + k];
    }
    for (i = 0; i < (long)n; i++) {
        rk4_step(inst, x, hs);
        if (!state_is_valid(x)) {
            inst->s.state = STATE_STEP_FAILED;
            inst->s.last_successful_time = inst->s.time;
            LOG_DISCARD(inst, "%s: " DIVERGENCE_FORMAT, function, t + (double)(i + 1) * hs, x[0], x[1], x[2],
                        DIVERGENCE_MAX_SPEED, DIVERGENCE_MAX_YAW_RATE, inst->s.time);
            return SHIP_DISCARD;
        }
    }
    for (k = 0; k < SHIP_N_STATES; k++) {
        inst->s.values[VR_STATE + k] = x[k];
    }
    inst->s.time = end;
    inst->s.last_successful_time = inst->s.time;
    warn_beyond_logs(inst, function);
    return SHIP_OK;
}

/* ---------------------------------------------------------------------------------- */
/* Model exchange (FMI 2.0 section 3.2, FMI 3.0 section 3.2): event-free               */
/* ---------------------------------------------------------------------------------- */

/* States where the continuous states, their nominals and derivatives may be read. */
#define STATES_ME_GET                                                                 \
    (STATE_INITIALIZATION | STATE_EVENT_MODE | STATE_CONTINUOUS_TIME_MODE | STATE_TERMINATED)

static ShipStatus ship_set_time(Instance *inst, const char *function, double time)
{
    if (!isfinite(time)) {
        LOG_ERROR(inst, "%s: time must be finite, got %g", function, time);
        return SHIP_ERROR;
    }
    inst->s.time = time;
    return SHIP_OK;
}

/* nx must be the number of continuous states. */
static int check_nx(const Instance *inst, const char *function, const void *array, size_t nx)
{
    if (array == NULL || nx != SHIP_N_STATES) {
        LOG_ERROR(inst, "%s: expected an array of %d continuous states, got %lu%s", function,
                  SHIP_N_STATES, (unsigned long)nx, array == NULL ? " (NULL)" : "");
        return 0;
    }
    return 1;
}

static ShipStatus ship_set_continuous_states(Instance *inst, const char *function,
                                             const double x[], size_t nx)
{
    int i;
    if (!check_nx(inst, function, x, nx)) {
        return SHIP_ERROR;
    }
    for (i = 0; i < SHIP_N_STATES; i++) {
        if (!isfinite(x[i])) {
            LOG_ERROR(inst, "%s: '%s' must be finite, got %g", function,
                      MODEL_VARIABLES[VR_STATE + i].name, x[i]);
            return SHIP_ERROR;
        }
    }
    for (i = 0; i < SHIP_N_STATES; i++) {
        inst->s.values[VR_STATE + i] = x[i];
    }
    return SHIP_OK;
}

static ShipStatus ship_get_continuous_states(Instance *inst, const char *function, double x[],
                                             size_t nx)
{
    int i;
    if (!check_nx(inst, function, x, nx)) {
        return SHIP_ERROR;
    }
    for (i = 0; i < SHIP_N_STATES; i++) {
        x[i] = inst->s.values[VR_STATE + i];
    }
    return SHIP_OK;
}

/* The derivatives at the current state and inputs; a discard at a diverged state (the
   divergence rule), so that the host's solver may retry with a smaller step. */
static ShipStatus ship_get_derivatives(Instance *inst, const char *function, double dx[],
                                       size_t nx)
{
    const double *x = &inst->s.values[VR_STATE];
    if (!check_nx(inst, function, dx, nx)) {
        return SHIP_ERROR;
    }
    if (!state_is_valid(x)) {
        LOG_DISCARD(inst, "%s: " DIVERGED_STATE_FORMAT, function, inst->s.time, x[0], x[1], x[2],
                    DIVERGENCE_MAX_SPEED, DIVERGENCE_MAX_YAW_RATE);
        return SHIP_DISCARD;
    }
    rhs(inst, x, dx);
    return SHIP_OK;
}

/* Nominal magnitudes of the states, for the host's error control: the start speed
   (at least 1 m/s) for u and v, that speed over the length for r, the length for x and
   y, 1 rad for psi. */
static ShipStatus ship_get_nominals(Instance *inst, const char *function, double nominal[],
                                    size_t nx)
{
    const double u0 = inst->s.values[VR_INITIAL_STATE];
    const double v0 = inst->s.values[VR_INITIAL_STATE + 1];
    const double length = inst->s.values[VR_LENGTH];
    const double speed = fmax(sqrt(u0 * u0 + v0 * v0), 1.0);
    if (!check_nx(inst, function, nominal, nx)) {
        return SHIP_ERROR;
    }
    nominal[0] = speed;
    nominal[1] = speed;
    nominal[2] = speed / length;
    nominal[3] = length;
    nominal[4] = length;
    nominal[5] = 1.0;
    return SHIP_OK;
}

/* This FMU has no event indicators: only ni = 0 is right. */
static ShipStatus ship_get_event_indicators(Instance *inst, const char *function, size_t ni)
{
    if (ni != 0) {
        LOG_ERROR(inst, "%s: this FMU has no event indicators, asked for %lu", function,
                  (unsigned long)ni);
        return SHIP_ERROR;
    }
    return SHIP_OK;
}

/* ---------------------------------------------------------------------------------- */
/* Directional and adjoint derivatives                                                 */
/* ---------------------------------------------------------------------------------- */

/* States where directional derivatives may be asked for (FMI 2.0 sections 3.2.3 and
   4.2.4, FMI 3.0 section 2.2.11): from initialization mode on. */
#define STATES_DERIVATIVES STATES_GET

/* The Jacobians at the current point: of the derivatives by the state (dfdx), by rudder
   and propeller speed (dfdu) and by the environment (dfde), and of sog and cog by the
   state (dgdx) and the environment (dgde). */
typedef struct {
    double dfdx[SHIP_N_STATES * SHIP_N_STATES];
    double dfdu[SHIP_N_STATES * SHIP_N_INPUTS];
    double dfde[SHIP_N_STATES * SHIP_N_ENVIRONMENT];
    double dgdx[SHIP_N_GROUND * SHIP_N_STATES];
    double dgde[SHIP_N_GROUND * SHIP_N_ENVIRONMENT];
} Jacobians;

/* Partial derivative of the unknown `unknown` (a state derivative or an output: a state,
   sog or cog) by the known `known` (a state or an input). */
static double partial(const Jacobians *J, unsigned unknown, unsigned known)
{
    if (is_state(unknown)) {
        return known == unknown ? 1.0 : 0.0; /* outputs are states: no feed-through */
    }
    if (is_ground(unknown)) {
        if (is_state(known)) {
            return J->dgdx[SHIP_N_STATES * (unknown - VR_GROUND) + (known - VR_STATE)];
        }
        if (is_environment(known)) {
            return J->dgde[SHIP_N_ENVIRONMENT * (unknown - VR_GROUND) + (known - VR_ENVIRONMENT)];
        }
        return 0.0; /* rudder and propeller act on the accelerations only */
    }
    if (is_state(known)) {
        return J->dfdx[SHIP_N_STATES * (unknown - VR_DERIVATIVES) + (known - VR_STATE)];
    }
    if (is_environment(known)) {
        return J->dfde[SHIP_N_ENVIRONMENT * (unknown - VR_DERIVATIVES) + (known - VR_ENVIRONMENT)];
    }
    if (known == VR_RUDDER_ANGLE) {
        return J->dfdu[SHIP_N_INPUTS * (unknown - VR_DERIVATIVES)];
    }
    return J->dfdu[SHIP_N_INPUTS * (unknown - VR_DERIVATIVES) + 1] / 60.0; /* by rpm */
}

/* Check the value references and the seed of a directional or adjoint derivative. */
static int check_derivative_call(const Instance *inst, const char *function,
                                 const unsigned unknowns[], size_t n_unknowns,
                                 const unsigned knowns[], size_t n_knowns, const double seed[],
                                 size_t n_seed, const double sensitivity[])
{
    size_t i;
    if ((n_unknowns > 0 && unknowns == NULL) || (n_knowns > 0 && knowns == NULL) ||
        (n_seed > 0 && seed == NULL) || (n_unknowns > 0 && n_knowns > 0 && sensitivity == NULL)) {
        LOG_ERROR(inst, "%s: an array argument is NULL", function);
        return 0;
    }
    for (i = 0; i < n_unknowns; i++) {
        if (!is_state(unknowns[i]) && !is_derivative(unknowns[i]) && !is_ground(unknowns[i])) {
            LOG_ERROR(inst, "%s: unknown vr %u is not a state derivative or an output",
                      function, unknowns[i]);
            return 0;
        }
    }
    for (i = 0; i < n_knowns; i++) {
        if (!is_state(knowns[i]) && knowns[i] != VR_RUDDER_ANGLE &&
            knowns[i] != VR_PROPELLER_RPM && !is_environment(knowns[i])) {
            LOG_ERROR(inst, "%s: known vr %u is not a state or an input", function, knowns[i]);
            return 0;
        }
    }
    for (i = 0; i < n_seed; i++) {
        if (!isfinite(seed[i])) {
            LOG_ERROR(inst, "%s: seed %lu must be finite, got %g", function, (unsigned long)i,
                      seed[i]);
            return 0;
        }
    }
    return 1;
}

/* sensitivity = J seed (directional, FMI 2.0 section 3.2.2 and FMI 3.0 section 2.2.11.1)
   or sensitivity = J^T seed (adjoint, FMI 3.0 section 2.2.11.2), J the partial derivatives
   of the unknowns (rows) by the knowns (columns) at the current state and inputs. */
static ShipStatus ship_derivatives(Instance *inst, const char *function, int adjoint,
                                   const unsigned unknowns[], size_t n_unknowns,
                                   const unsigned knowns[], size_t n_knowns,
                                   const double seed[], double sensitivity[])
{
    Jacobians J;
    const double *x = &inst->s.values[VR_STATE];
    const double *env = &inst->s.values[VR_ENVIRONMENT];
    const size_t n_seed = adjoint ? n_unknowns : n_knowns;
    const size_t n_out = adjoint ? n_knowns : n_unknowns;
    size_t i;
    size_t j;
    if (!check_derivative_call(inst, function, unknowns, n_unknowns, knowns, n_knowns, seed,
                               n_seed, sensitivity)) {
        return SHIP_ERROR;
    }
    model_jacobian(&inst->s.values[VR_COEFFICIENTS], inst->s.values[VR_LENGTH], x,
                   rudder_of(inst), n_rps_of(inst), J.dfdx, J.dfdu);
    model_environment_jacobian(x, env, &inst->s.values[VR_WINDAGE], J.dfdx, J.dfde);
    model_ground_jacobian(x, env, J.dgdx, J.dgde);
    for (i = 0; i < n_out; i++) {
        sensitivity[i] = 0.0;
    }
    for (i = 0; i < n_unknowns; i++) {
        for (j = 0; j < n_knowns; j++) {
            const double d = partial(&J, unknowns[i], knowns[j]);
            if (adjoint) {
                sensitivity[j] += d * seed[i];
            } else {
                sensitivity[i] += d * seed[j];
            }
        }
    }
    return SHIP_OK;
}

/* ---------------------------------------------------------------------------------- */
/* FMU state                                                                           */
/* ---------------------------------------------------------------------------------- */

/* Where FMI 2.0 (sections 3.2.3 and 4.2.4) and FMI 3.0 (section 2.2.6.4) allow getting,
   setting, freeing and serialising FMU states: in every state of this FMU. */
#define FMUSTATE_ALLOWED_IN STATE_ANY

/* Store the snapshot s in *fmu_state: the state given there (checked to be one of this
 * FMU's) is overwritten, or a new one is allocated when *fmu_state is NULL. */
static ShipStatus store_fmu_state(Instance *inst, const char *function, void **fmu_state,
                                  const Snapshot *s)
{
    SavedState *saved;
    saved = (SavedState *)*fmu_state;
    if (saved != NULL && saved->magic != FMUSTATE_MAGIC) {
        LOG_ERROR(inst, "%s: *FMUstate is not an FMU state of this FMU", function);
        return SHIP_ERROR;
    }
    if (saved == NULL) {
        saved = (SavedState *)inst->api.allocate(1, sizeof(SavedState));
        if (saved == NULL) {
            LOG_ERROR(inst, "%s: out of memory", function);
            return SHIP_ERROR;
        }
        saved->magic = FMUSTATE_MAGIC;
    }
    saved->s = *s;
    *fmu_state = saved;
    return SHIP_OK;
}

static ShipStatus ship_get_fmu_state(Instance *inst, const char *function, void **fmu_state)
{
    if (fmu_state == NULL) {
        LOG_ERROR(inst, "%s: FMUstate is NULL", function);
        return SHIP_ERROR;
    }
    return store_fmu_state(inst, function, fmu_state, &inst->s);
}

static ShipStatus ship_set_fmu_state(Instance *inst, const char *function, const void *fmu_state)
{
    const SavedState *saved = (const SavedState *)fmu_state;
    if (saved == NULL || saved->magic != FMUSTATE_MAGIC) {
        LOG_ERROR(inst, "%s: not an FMU state of this FMU", function);
        return SHIP_ERROR;
    }
    if (!snapshot_is_valid(inst, function, &saved->s)) {
        return SHIP_ERROR;
    }
    inst->s = saved->s;
    return SHIP_OK;
}

static ShipStatus ship_free_fmu_state(Instance *inst, const char *function, void **fmu_state)
{
    SavedState *saved;
    if (fmu_state == NULL || *fmu_state == NULL) {
        return SHIP_OK;
    }
    saved = (SavedState *)*fmu_state;
    if (saved->magic != FMUSTATE_MAGIC) {
        LOG_ERROR(inst, "%s: not an FMU state of this FMU", function);
        return SHIP_ERROR;
    }
    saved->magic = 0;
    inst->api.free_memory(saved);
    *fmu_state = NULL;
    return SHIP_OK;
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

static ShipStatus ship_serialized_size(Instance *inst, const char *function, size_t *size)
{
    if (size == NULL) {
        LOG_ERROR(inst, "%s: size is NULL", function);
        return SHIP_ERROR;
    }
    *size = SERIAL_SIZE;
    return SHIP_OK;
}

static ShipStatus ship_serialize(Instance *inst, const char *function, const void *fmu_state,
                                 unsigned char *buffer, size_t size)
{
    const SavedState *saved = (const SavedState *)fmu_state;
    char guid[SERIAL_GUID_SIZE] = {0};
    unsigned int version = SERIAL_VERSION;
    unsigned int n_variables = MODEL_N_VARIABLES;
    int state;
    int padding = 0;
    unsigned char *p = buffer;
    if (saved == NULL || saved->magic != FMUSTATE_MAGIC) {
        LOG_ERROR(inst, "%s: not an FMU state of this FMU", function);
        return SHIP_ERROR;
    }
    if (buffer == NULL || size < SERIAL_SIZE) {
        LOG_ERROR(inst, "%s: buffer of %lu bytes, need %lu", function, (unsigned long)size,
                  (unsigned long)SERIAL_SIZE);
        return SHIP_ERROR;
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
    return SHIP_OK;
}

static ShipStatus ship_deserialize(Instance *inst, const char *function,
                                   const unsigned char *buffer, size_t size, void **fmu_state)
{
    const unsigned char *p = buffer;
    char guid[SERIAL_GUID_SIZE] = {0};
    unsigned int version;
    unsigned int n_variables;
    Snapshot s;
    if (fmu_state == NULL || buffer == NULL || size != SERIAL_SIZE) {
        LOG_ERROR(inst, "%s: expected %lu bytes, got %lu", function, (unsigned long)SERIAL_SIZE,
                  (unsigned long)size);
        return SHIP_ERROR;
    }
    memcpy(guid, MODEL_GUID, sizeof(MODEL_GUID));
    if (memcmp(p, SERIAL_MAGIC, 8) != 0) {
        LOG_ERROR(inst, "%s: not a serialised state of this FMU", function);
        return SHIP_ERROR;
    }
    p += 8;
    memcpy(&version, p, 4);
    p += 4;
    memcpy(&n_variables, p, 4);
    p += 4;
    if (version != SERIAL_VERSION || n_variables != MODEL_N_VARIABLES ||
        memcmp(p, guid, SERIAL_GUID_SIZE) != 0) {
        LOG_ERROR(inst, "%s: the state was serialised by another FMU or format version",
                  function);
        return SHIP_ERROR;
    }
    p += SERIAL_GUID_SIZE;
    memset(&s, 0, sizeof s);
    memcpy(&s.state, p, 4);
    p += 8; /* state and padding */
    memcpy(&s.time, p, sizeof(double));
    p += sizeof(double);
    memcpy(&s.start_time, p, sizeof(double));
    p += sizeof(double);
    memcpy(&s.last_successful_time, p, sizeof(double));
    p += sizeof(double);
    memcpy(s.values, p, sizeof s.values);
    /* Restored as if every value were set again: the range checks of SetReal. */
    if (!snapshot_is_valid(inst, function, &s)) {
        return SHIP_ERROR;
    }
    return store_fmu_state(inst, function, fmu_state, &s);
}
