/*
 * fmi2_functions.c - FMI 2.0 co-simulation and model exchange of the shipid native FMU.
 *
 * The FMI 2.0 API (FMI 2.0.4, chapters 2-4) over the version-neutral layer
 * ship_common.c; see there for the behaviour, and ship_fmu.h for the generated model
 * part. One binary serves both kinds: fmi2Instantiate with fmi2CoSimulation or
 * fmi2ModelExchange. What is specific to FMI 2.0:
 *
 * - Memory comes from the callbacks' allocateMemory/freeMemory (calloc/free when the
 *   environment passes NULL, which FMI 2.0 does not allow but some hosts do).
 * - The status queries of co-simulation (section 4.2.3): fmi2LastSuccessfulTime and
 *   fmi2Terminated (true after a diverged step) are given; a status this FMU cannot give
 *   (fmi2GetStatus, fmi2GetIntegerStatus, fmi2GetStringStatus, the other kinds of
 *   fmi2GetRealStatus and fmi2GetBooleanStatus) is fmi2Discard (category
 *   logStatusDiscard), as section 2.1.3 asks of a slave that "is not able to return the
 *   required status information"; fmi2Error would mean the instance is unusable.
 * - Model exchange has no events: fmi2NewDiscreteStates reports nothing new, and
 *   fmi2CompletedIntegratorStep neither asks for an event nor terminates.
 */
#include <stddef.h>
#include <stdlib.h>

#include "fmi2Functions.h"

/* What fmi2Instantiate passed: the logger and the memory functions. */
typedef struct {
    fmi2CallbackLogger logger;
    fmi2ComponentEnvironment environment;
    fmi2CallbackAllocateMemory allocate;
    fmi2CallbackFreeMemory free_memory;
} ShipApi;

#include "ship_common.c"

typedef char ship_check_status[(fmi2OK == (int)SHIP_OK && fmi2Warning == (int)SHIP_WARNING &&
                                fmi2Discard == (int)SHIP_DISCARD && fmi2Error == (int)SHIP_ERROR)
                                   ? 1
                                   : -1];

static void api_log(const Instance *inst, ShipStatus status, const char *category,
                    const char *message)
{
    if (inst->api.logger == NULL) {
        return;
    }
    /* The logger takes a printf format: pass the text as an argument, never as format. */
    inst->api.logger(inst->api.environment, inst->instance_name, (fmi2Status)status, category,
                     "%s", message);
}

static void *default_allocate(size_t n, size_t size) { return calloc(n, size); }

static void default_free(void *pointer) { free(pointer); }

/* Every function that starts from an fmi2Component does this first. */
#define BEGIN(function, states)                                 \
    Instance *inst = ship_begin(c, function, states);           \
    if (inst == NULL) {                                         \
        return fmi2Error;                                       \
    }

/* ---------------------------------------------------------------------------------- */
/* Common functions (section 2.1)                                                      */
/* ---------------------------------------------------------------------------------- */

const char *fmi2GetTypesPlatform(void) { return fmi2TypesPlatform; }

const char *fmi2GetVersion(void) { return fmi2Version; }

fmi2Status fmi2SetDebugLogging(fmi2Component c, fmi2Boolean loggingOn, size_t nCategories,
                               const fmi2String categories[])
{
    BEGIN("fmi2SetDebugLogging", STATE_ANY)
    return (fmi2Status)ship_set_debug_logging(inst, "fmi2SetDebugLogging", loggingOn,
                                              nCategories, categories);
}

fmi2Component fmi2Instantiate(fmi2String instanceName, fmi2Type fmuType, fmi2String fmuGUID,
                              fmi2String fmuResourceLocation,
                              const fmi2CallbackFunctions *functions, fmi2Boolean visible,
                              fmi2Boolean loggingOn)
{
    ShipApi api = {NULL, NULL, default_allocate, default_free};
    (void)fmuResourceLocation;
    (void)visible;
    if (functions != NULL) {
        api.logger = functions->logger;
        api.environment = functions->componentEnvironment;
        if (functions->allocateMemory != NULL && functions->freeMemory != NULL) {
            api.allocate = functions->allocateMemory;
            api.free_memory = functions->freeMemory;
        }
    }
    if (fmuType != fmi2CoSimulation && fmuType != fmi2ModelExchange) {
        if (api.logger != NULL) {
            api.logger(api.environment, instanceName != NULL ? instanceName : "", fmi2Error,
                       "logStatusError", "unknown fmuType %d", (int)fmuType);
        }
        return NULL;
    }
    return ship_instantiate(instanceName,
                            fmuType == fmi2CoSimulation ? KIND_CO_SIMULATION
                                                        : KIND_MODEL_EXCHANGE,
                            fmuGUID, api, loggingOn);
}

void fmi2FreeInstance(fmi2Component c) { ship_free_instance(c); }

fmi2Status fmi2SetupExperiment(fmi2Component c, fmi2Boolean toleranceDefined, fmi2Real tolerance,
                               fmi2Real startTime, fmi2Boolean stopTimeDefined, fmi2Real stopTime)
{
    BEGIN("fmi2SetupExperiment", STATE_INSTANTIATED)
    (void)toleranceDefined;
    (void)tolerance;
    (void)stopTimeDefined;
    (void)stopTime;
    return (fmi2Status)ship_set_start_time(inst, "fmi2SetupExperiment", startTime);
}

fmi2Status fmi2EnterInitializationMode(fmi2Component c)
{
    BEGIN("fmi2EnterInitializationMode", STATE_INSTANTIATED)
    LOG_TRACE(inst, "fmi2EnterInitializationMode");
    ship_enter_initialization_mode(inst);
    return fmi2OK;
}

fmi2Status fmi2ExitInitializationMode(fmi2Component c)
{
    BEGIN("fmi2ExitInitializationMode", STATE_INITIALIZATION)
    LOG_TRACE(inst, "fmi2ExitInitializationMode");
    return (fmi2Status)ship_exit_initialization_mode(inst, "fmi2ExitInitializationMode");
}

fmi2Status fmi2Terminate(fmi2Component c)
{
    BEGIN("fmi2Terminate", STATES_TERMINATE)
    LOG_TRACE(inst, "fmi2Terminate");
    ship_terminate(inst);
    return fmi2OK;
}

fmi2Status fmi2Reset(fmi2Component c)
{
    BEGIN("fmi2Reset", STATE_ANY)
    LOG_TRACE(inst, "fmi2Reset");
    ship_reset(inst);
    return fmi2OK;
}

/* ---------------------------------------------------------------------------------- */
/* Getting and setting values (section 2.1.7)                                          */
/* ---------------------------------------------------------------------------------- */

fmi2Status fmi2GetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                       fmi2Real value[])
{
    BEGIN("fmi2GetReal", STATES_GET)
    return (fmi2Status)ship_get_real(inst, "fmi2GetReal", vr, nvr, value);
}

fmi2Status fmi2SetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                       const fmi2Real value[])
{
    BEGIN("fmi2SetReal", STATES_SET_INPUT)
    return (fmi2Status)ship_set_real(inst, "fmi2SetReal", vr, nvr, value);
}

fmi2Status fmi2GetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                          fmi2Integer value[])
{
    (void)vr;
    (void)value;
    return (fmi2Status)no_variables_of_type(c, "fmi2GetInteger", nvr);
}

fmi2Status fmi2GetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                          fmi2Boolean value[])
{
    (void)vr;
    (void)value;
    return (fmi2Status)no_variables_of_type(c, "fmi2GetBoolean", nvr);
}

fmi2Status fmi2GetString(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                         fmi2String value[])
{
    (void)vr;
    (void)value;
    return (fmi2Status)no_variables_of_type(c, "fmi2GetString", nvr);
}

fmi2Status fmi2SetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                          const fmi2Integer value[])
{
    (void)vr;
    (void)value;
    return (fmi2Status)no_variables_of_type(c, "fmi2SetInteger", nvr);
}

fmi2Status fmi2SetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                          const fmi2Boolean value[])
{
    (void)vr;
    (void)value;
    return (fmi2Status)no_variables_of_type(c, "fmi2SetBoolean", nvr);
}

fmi2Status fmi2SetString(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                         const fmi2String value[])
{
    (void)vr;
    (void)value;
    return (fmi2Status)no_variables_of_type(c, "fmi2SetString", nvr);
}

/* ---------------------------------------------------------------------------------- */
/* FMU state (section 2.1.8)                                                           */
/* ---------------------------------------------------------------------------------- */

fmi2Status fmi2GetFMUstate(fmi2Component c, fmi2FMUstate *FMUstate)
{
    BEGIN("fmi2GetFMUstate", FMUSTATE_ALLOWED_IN)
    return (fmi2Status)ship_get_fmu_state(inst, "fmi2GetFMUstate", FMUstate);
}

fmi2Status fmi2SetFMUstate(fmi2Component c, fmi2FMUstate FMUstate)
{
    BEGIN("fmi2SetFMUstate", FMUSTATE_ALLOWED_IN)
    return (fmi2Status)ship_set_fmu_state(inst, "fmi2SetFMUstate", FMUstate);
}

fmi2Status fmi2FreeFMUstate(fmi2Component c, fmi2FMUstate *FMUstate)
{
    BEGIN("fmi2FreeFMUstate", FMUSTATE_ALLOWED_IN)
    return (fmi2Status)ship_free_fmu_state(inst, "fmi2FreeFMUstate", FMUstate);
}

fmi2Status fmi2SerializedFMUstateSize(fmi2Component c, fmi2FMUstate FMUstate, size_t *size)
{
    BEGIN("fmi2SerializedFMUstateSize", FMUSTATE_ALLOWED_IN)
    (void)FMUstate;
    return (fmi2Status)ship_serialized_size(inst, "fmi2SerializedFMUstateSize", size);
}

fmi2Status fmi2SerializeFMUstate(fmi2Component c, fmi2FMUstate FMUstate, fmi2Byte serializedState[],
                                 size_t size)
{
    BEGIN("fmi2SerializeFMUstate", FMUSTATE_ALLOWED_IN)
    return (fmi2Status)ship_serialize(inst, "fmi2SerializeFMUstate", FMUstate,
                                      (unsigned char *)serializedState, size);
}

fmi2Status fmi2DeSerializeFMUstate(fmi2Component c, const fmi2Byte serializedState[], size_t size,
                                   fmi2FMUstate *FMUstate)
{
    BEGIN("fmi2DeSerializeFMUstate", FMUSTATE_ALLOWED_IN)
    return (fmi2Status)ship_deserialize(inst, "fmi2DeSerializeFMUstate",
                                        (const unsigned char *)serializedState, size, FMUstate);
}

/* ---------------------------------------------------------------------------------- */
/* Partial derivatives (section 2.1.9)                                                 */
/* ---------------------------------------------------------------------------------- */

fmi2Status fmi2GetDirectionalDerivative(fmi2Component c, const fmi2ValueReference vUnknown_ref[],
                                        size_t nUnknown, const fmi2ValueReference vKnown_ref[],
                                        size_t nKnown, const fmi2Real dvKnown[],
                                        fmi2Real dvUnknown[])
{
    BEGIN("fmi2GetDirectionalDerivative", STATES_DERIVATIVES)
    return (fmi2Status)ship_derivatives(inst, "fmi2GetDirectionalDerivative", 0, vUnknown_ref,
                                        nUnknown, vKnown_ref, nKnown, dvKnown, dvUnknown);
}

/* ---------------------------------------------------------------------------------- */
/* Model exchange (section 3.2)                                                        */
/* ---------------------------------------------------------------------------------- */

fmi2Status fmi2EnterEventMode(fmi2Component c)
{
    BEGIN("fmi2EnterEventMode", STATE_EVENT_MODE | STATE_CONTINUOUS_TIME_MODE)
    inst->s.state = STATE_EVENT_MODE;
    return fmi2OK;
}

fmi2Status fmi2NewDiscreteStates(fmi2Component c, fmi2EventInfo *eventInfo)
{
    BEGIN("fmi2NewDiscreteStates", STATE_EVENT_MODE)
    if (eventInfo == NULL) {
        LOG_ERROR(inst, "fmi2NewDiscreteStates: eventInfo is NULL");
        return fmi2Error;
    }
    eventInfo->newDiscreteStatesNeeded = fmi2False;
    eventInfo->terminateSimulation = fmi2False;
    eventInfo->nominalsOfContinuousStatesChanged = fmi2False;
    eventInfo->valuesOfContinuousStatesChanged = fmi2False;
    eventInfo->nextEventTimeDefined = fmi2False;
    eventInfo->nextEventTime = 0.0;
    return fmi2OK;
}

fmi2Status fmi2EnterContinuousTimeMode(fmi2Component c)
{
    BEGIN("fmi2EnterContinuousTimeMode", STATE_EVENT_MODE)
    inst->s.state = STATE_CONTINUOUS_TIME_MODE;
    return fmi2OK;
}

fmi2Status fmi2CompletedIntegratorStep(fmi2Component c,
                                       fmi2Boolean noSetFMUStatePriorToCurrentPoint,
                                       fmi2Boolean *enterEventMode,
                                       fmi2Boolean *terminateSimulation)
{
    BEGIN("fmi2CompletedIntegratorStep", STATE_CONTINUOUS_TIME_MODE)
    (void)noSetFMUStatePriorToCurrentPoint;
    if (enterEventMode == NULL || terminateSimulation == NULL) {
        LOG_ERROR(inst, "fmi2CompletedIntegratorStep: an argument is NULL");
        return fmi2Error;
    }
    *enterEventMode = fmi2False;
    *terminateSimulation = fmi2False;
    return fmi2OK;
}

fmi2Status fmi2SetTime(fmi2Component c, fmi2Real time)
{
    BEGIN("fmi2SetTime", STATE_EVENT_MODE | STATE_CONTINUOUS_TIME_MODE)
    return (fmi2Status)ship_set_time(inst, "fmi2SetTime", time);
}

fmi2Status fmi2SetContinuousStates(fmi2Component c, const fmi2Real x[], size_t nx)
{
    BEGIN("fmi2SetContinuousStates", STATE_CONTINUOUS_TIME_MODE)
    return (fmi2Status)ship_set_continuous_states(inst, "fmi2SetContinuousStates", x, nx);
}

fmi2Status fmi2GetDerivatives(fmi2Component c, fmi2Real derivatives[], size_t nx)
{
    BEGIN("fmi2GetDerivatives", STATES_ME_GET)
    return (fmi2Status)ship_get_derivatives(inst, "fmi2GetDerivatives", derivatives, nx);
}

fmi2Status fmi2GetEventIndicators(fmi2Component c, fmi2Real eventIndicators[], size_t ni)
{
    BEGIN("fmi2GetEventIndicators", STATES_ME_GET)
    (void)eventIndicators;
    return (fmi2Status)ship_get_event_indicators(inst, "fmi2GetEventIndicators", ni);
}

fmi2Status fmi2GetContinuousStates(fmi2Component c, fmi2Real x[], size_t nx)
{
    BEGIN("fmi2GetContinuousStates", STATES_ME_GET)
    return (fmi2Status)ship_get_continuous_states(inst, "fmi2GetContinuousStates", x, nx);
}

fmi2Status fmi2GetNominalsOfContinuousStates(fmi2Component c, fmi2Real x_nominal[], size_t nx)
{
    BEGIN("fmi2GetNominalsOfContinuousStates", STATE_INSTANTIATED | STATES_ME_GET)
    return (fmi2Status)ship_get_nominals(inst, "fmi2GetNominalsOfContinuousStates", x_nominal,
                                         nx);
}

/* ---------------------------------------------------------------------------------- */
/* Co-simulation (section 4.2)                                                         */
/* ---------------------------------------------------------------------------------- */

fmi2Status fmi2DoStep(fmi2Component c, fmi2Real currentCommunicationPoint,
                      fmi2Real communicationStepSize, fmi2Boolean noSetFMUStatePriorToCurrentPoint)
{
    BEGIN("fmi2DoStep", STATE_STEP_COMPLETE)
    (void)noSetFMUStatePriorToCurrentPoint;
    return (fmi2Status)ship_do_step(inst, "fmi2DoStep", currentCommunicationPoint,
                                    communicationStepSize);
}

fmi2Status fmi2SetRealInputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                                       const fmi2Integer order[], const fmi2Real value[])
{
    (void)vr;
    (void)nvr;
    (void)order;
    (void)value;
    return (fmi2Status)unsupported(c, "fmi2SetRealInputDerivatives",
                                   "inputs are held constant over a step");
}

fmi2Status fmi2GetRealOutputDerivatives(fmi2Component c, const fmi2ValueReference vr[],
                                        size_t nvr, const fmi2Integer order[], fmi2Real value[])
{
    (void)vr;
    (void)nvr;
    (void)order;
    (void)value;
    return (fmi2Status)unsupported(c, "fmi2GetRealOutputDerivatives",
                                   "maxOutputDerivativeOrder is 0");
}

fmi2Status fmi2CancelStep(fmi2Component c)
{
    return (fmi2Status)unsupported(c, "fmi2CancelStep", "fmi2DoStep is synchronous");
}

/* Where FMI 2.0 allows the fmi2GetXXXStatus functions (stepCanceled does not occur). */
#define STATUS_ALLOWED_IN (STATE_STEP_COMPLETE | STATE_STEP_FAILED | STATE_TERMINATED)

/* A status this FMU cannot give: FMI 2.0 section 2.1.3 asks a co-simulation slave for
   fmi2Discard ("the slave is not able to return the required status information"). */
static fmi2Status status_not_available(const Instance *inst, const char *function,
                                       const char *why)
{
    LOG_DISCARD(inst, "%s: %s", function, why);
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
