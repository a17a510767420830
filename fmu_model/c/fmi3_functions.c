/*
 * fmi3_functions.c - FMI 3.0 co-simulation and model exchange of the shipid native FMU.
 *
 * The FMI 3.0 API (FMI 3.0.2, chapters 2-4) over the version-neutral layer
 * ship_common.c; see there for the behaviour, and ship_fmu.h for the generated model
 * part. One binary serves both kinds: fmi3InstantiateCoSimulation and
 * fmi3InstantiateModelExchange; fmi3InstantiateScheduledExecution is refused. Every
 * function of the API is exported (section 2.2.1); the ones this FMU has no use for
 * are errors with a message (unsupported()). What is specific to FMI 3.0:
 *
 * - Memory is the C library's (FMI 3.0 has no memory callbacks).
 * - Co-simulation has no event mode (hasEventMode = false: eventModeUsed is refused),
 *   never returns early and has no intermediate update. fmi3DoStep reports the end of
 *   a diverged step through *terminateSimulation = true and *lastSuccessfulTime (the
 *   start of the step) with fmi3Discard (section 4.2.1); FMI 3.0 has no status queries.
 * - Model exchange is event-free: fmi3UpdateDiscreteStates reports nothing new and
 *   fmi3CompletedIntegratorStep neither asks for an event nor terminates.
 * - The FMU has Float64 variables only; every other getter and setter accepts only an
 *   empty call.
 */
#include <stddef.h>
#include <stdlib.h>

#include "fmi3Functions.h"

/* What the fmi3Instantiate* function passed: the logger, and the C library's memory. */
typedef struct {
    fmi3LogMessageCallback logger;
    fmi3InstanceEnvironment environment;
    void *(*allocate)(size_t n, size_t size);
    void (*free_memory)(void *pointer);
} ShipApi;

#include "ship_common.c"

typedef char ship_check_status[(fmi3OK == (int)SHIP_OK && fmi3Warning == (int)SHIP_WARNING &&
                                fmi3Discard == (int)SHIP_DISCARD && fmi3Error == (int)SHIP_ERROR)
                                   ? 1
                                   : -1];

static void api_log(const Instance *inst, ShipStatus status, const char *category,
                    const char *message)
{
    if (inst->api.logger != NULL) {
        inst->api.logger(inst->api.environment, (fmi3Status)status, category, message);
    }
}

static ShipApi api_of(fmi3InstanceEnvironment environment, fmi3LogMessageCallback logger)
{
    ShipApi api;
    api.logger = logger;
    api.environment = environment;
    api.allocate = calloc;
    api.free_memory = free;
    return api;
}

/* Every function that starts from an fmi3Instance does this first. */
#define BEGIN(function, states)                                 \
    Instance *inst = ship_begin(instance, function, states);    \
    if (inst == NULL) {                                         \
        return fmi3Error;                                       \
    }

/* ---------------------------------------------------------------------------------- */
/* Common functions (section 2.2)                                                      */
/* ---------------------------------------------------------------------------------- */

const char *fmi3GetVersion(void) { return fmi3Version; }

fmi3Status fmi3SetDebugLogging(fmi3Instance instance, fmi3Boolean loggingOn, size_t nCategories,
                               const fmi3String categories[])
{
    BEGIN("fmi3SetDebugLogging", STATE_ANY)
    return (fmi3Status)ship_set_debug_logging(inst, "fmi3SetDebugLogging", loggingOn,
                                              nCategories, categories);
}

fmi3Instance fmi3InstantiateModelExchange(fmi3String instanceName, fmi3String instantiationToken,
                                          fmi3String resourcePath, fmi3Boolean visible,
                                          fmi3Boolean loggingOn,
                                          fmi3InstanceEnvironment instanceEnvironment,
                                          fmi3LogMessageCallback logMessage)
{
    (void)resourcePath;
    (void)visible;
    return ship_instantiate(instanceName, KIND_MODEL_EXCHANGE, instantiationToken,
                            api_of(instanceEnvironment, logMessage), loggingOn);
}

fmi3Instance fmi3InstantiateCoSimulation(
    fmi3String instanceName, fmi3String instantiationToken, fmi3String resourcePath,
    fmi3Boolean visible, fmi3Boolean loggingOn, fmi3Boolean eventModeUsed,
    fmi3Boolean earlyReturnAllowed, const fmi3ValueReference requiredIntermediateVariables[],
    size_t nRequiredIntermediateVariables, fmi3InstanceEnvironment instanceEnvironment,
    fmi3LogMessageCallback logMessage, fmi3IntermediateUpdateCallback intermediateUpdate)
{
    (void)resourcePath;
    (void)visible;
    (void)earlyReturnAllowed; /* never returns early */
    (void)requiredIntermediateVariables;
    (void)nRequiredIntermediateVariables;
    (void)intermediateUpdate; /* providesIntermediateUpdate = false */
    if (eventModeUsed) {
        if (logMessage != NULL) {
            logMessage(instanceEnvironment, fmi3Error, "logStatusError",
                       "fmi3InstantiateCoSimulation: this FMU has no event mode in "
                       "co-simulation (hasEventMode = false); eventModeUsed must be false");
        }
        return NULL;
    }
    return ship_instantiate(instanceName, KIND_CO_SIMULATION, instantiationToken,
                            api_of(instanceEnvironment, logMessage), loggingOn);
}

fmi3Instance fmi3InstantiateScheduledExecution(
    fmi3String instanceName, fmi3String instantiationToken, fmi3String resourcePath,
    fmi3Boolean visible, fmi3Boolean loggingOn, fmi3InstanceEnvironment instanceEnvironment,
    fmi3LogMessageCallback logMessage, fmi3ClockUpdateCallback clockUpdate,
    fmi3LockPreemptionCallback lockPreemption, fmi3UnlockPreemptionCallback unlockPreemption)
{
    (void)instanceName;
    (void)instantiationToken;
    (void)resourcePath;
    (void)visible;
    (void)loggingOn;
    (void)clockUpdate;
    (void)lockPreemption;
    (void)unlockPreemption;
    if (logMessage != NULL) {
        logMessage(instanceEnvironment, fmi3Error, "logStatusError",
                   "fmi3InstantiateScheduledExecution is not supported: this FMU implements "
                   "co-simulation and model exchange");
    }
    return NULL;
}

void fmi3FreeInstance(fmi3Instance instance) { ship_free_instance(instance); }

fmi3Status fmi3EnterInitializationMode(fmi3Instance instance, fmi3Boolean toleranceDefined,
                                       fmi3Float64 tolerance, fmi3Float64 startTime,
                                       fmi3Boolean stopTimeDefined, fmi3Float64 stopTime)
{
    BEGIN("fmi3EnterInitializationMode", STATE_INSTANTIATED)
    (void)toleranceDefined;
    (void)tolerance;
    (void)stopTimeDefined;
    (void)stopTime;
    if (ship_set_start_time(inst, "fmi3EnterInitializationMode", startTime) != SHIP_OK) {
        return fmi3Error;
    }
    ship_enter_initialization_mode(inst);
    return fmi3OK;
}

fmi3Status fmi3ExitInitializationMode(fmi3Instance instance)
{
    BEGIN("fmi3ExitInitializationMode", STATE_INITIALIZATION)
    LOG_TRACE(inst, "fmi3ExitInitializationMode");
    return (fmi3Status)ship_exit_initialization_mode(inst, "fmi3ExitInitializationMode");
}

fmi3Status fmi3EnterEventMode(fmi3Instance instance)
{
    BEGIN("fmi3EnterEventMode", STATE_EVENT_MODE | STATE_CONTINUOUS_TIME_MODE)
    inst->s.state = STATE_EVENT_MODE;
    return fmi3OK;
}

fmi3Status fmi3Terminate(fmi3Instance instance)
{
    BEGIN("fmi3Terminate", STATES_TERMINATE)
    LOG_TRACE(inst, "fmi3Terminate");
    ship_terminate(inst);
    return fmi3OK;
}

fmi3Status fmi3Reset(fmi3Instance instance)
{
    BEGIN("fmi3Reset", STATE_ANY)
    LOG_TRACE(inst, "fmi3Reset");
    ship_reset(inst);
    return fmi3OK;
}

/* ---------------------------------------------------------------------------------- */
/* Getting and setting values (section 2.2.6.2)                                        */
/* ---------------------------------------------------------------------------------- */

/* Every variable is a scalar: nValues must equal nValueReferences. */
static int scalars_only(const Instance *inst, const char *function, size_t nvr, size_t n_values)
{
    if (n_values != nvr) {
        LOG_ERROR(inst, "%s: %lu values for %lu scalar variables", function,
                  (unsigned long)n_values, (unsigned long)nvr);
        return 0;
    }
    return 1;
}

fmi3Status fmi3GetFloat64(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                          size_t nValueReferences, fmi3Float64 values[], size_t nValues)
{
    BEGIN("fmi3GetFloat64", STATES_GET)
    if (!scalars_only(inst, "fmi3GetFloat64", nValueReferences, nValues)) {
        return fmi3Error;
    }
    return (fmi3Status)ship_get_real(inst, "fmi3GetFloat64", valueReferences, nValueReferences,
                                     values);
}

fmi3Status fmi3SetFloat64(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                          size_t nValueReferences, const fmi3Float64 values[], size_t nValues)
{
    BEGIN("fmi3SetFloat64", STATES_SET_INPUT)
    if (!scalars_only(inst, "fmi3SetFloat64", nValueReferences, nValues)) {
        return fmi3Error;
    }
    return (fmi3Status)ship_set_real(inst, "fmi3SetFloat64", valueReferences, nValueReferences,
                                     values);
}

/* The getters and setters of the types this FMU has no variables of. */
#define NO_VARIABLES_GET(function, type)                                                  \
    fmi3Status function(fmi3Instance instance, const fmi3ValueReference valueReferences[], \
                        size_t nValueReferences, type values[], size_t nValues)           \
    {                                                                                     \
        (void)valueReferences;                                                            \
        (void)values;                                                                     \
        (void)nValues;                                                                    \
        return (fmi3Status)no_variables_of_type(instance, #function, nValueReferences);   \
    }
#define NO_VARIABLES_SET(function, type)                                                  \
    fmi3Status function(fmi3Instance instance, const fmi3ValueReference valueReferences[], \
                        size_t nValueReferences, const type values[], size_t nValues)     \
    {                                                                                     \
        (void)valueReferences;                                                            \
        (void)values;                                                                     \
        (void)nValues;                                                                    \
        return (fmi3Status)no_variables_of_type(instance, #function, nValueReferences);   \
    }

NO_VARIABLES_GET(fmi3GetFloat32, fmi3Float32)
NO_VARIABLES_GET(fmi3GetInt8, fmi3Int8)
NO_VARIABLES_GET(fmi3GetUInt8, fmi3UInt8)
NO_VARIABLES_GET(fmi3GetInt16, fmi3Int16)
NO_VARIABLES_GET(fmi3GetUInt16, fmi3UInt16)
NO_VARIABLES_GET(fmi3GetInt32, fmi3Int32)
NO_VARIABLES_GET(fmi3GetUInt32, fmi3UInt32)
NO_VARIABLES_GET(fmi3GetInt64, fmi3Int64)
NO_VARIABLES_GET(fmi3GetUInt64, fmi3UInt64)
NO_VARIABLES_GET(fmi3GetBoolean, fmi3Boolean)
NO_VARIABLES_GET(fmi3GetString, fmi3String)
NO_VARIABLES_SET(fmi3SetFloat32, fmi3Float32)
NO_VARIABLES_SET(fmi3SetInt8, fmi3Int8)
NO_VARIABLES_SET(fmi3SetUInt8, fmi3UInt8)
NO_VARIABLES_SET(fmi3SetInt16, fmi3Int16)
NO_VARIABLES_SET(fmi3SetUInt16, fmi3UInt16)
NO_VARIABLES_SET(fmi3SetInt32, fmi3Int32)
NO_VARIABLES_SET(fmi3SetUInt32, fmi3UInt32)
NO_VARIABLES_SET(fmi3SetInt64, fmi3Int64)
NO_VARIABLES_SET(fmi3SetUInt64, fmi3UInt64)
NO_VARIABLES_SET(fmi3SetBoolean, fmi3Boolean)
NO_VARIABLES_SET(fmi3SetString, fmi3String)

fmi3Status fmi3GetBinary(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                         size_t nValueReferences, size_t valueSizes[], fmi3Binary values[],
                         size_t nValues)
{
    (void)valueReferences;
    (void)valueSizes;
    (void)values;
    (void)nValues;
    return (fmi3Status)no_variables_of_type(instance, "fmi3GetBinary", nValueReferences);
}

fmi3Status fmi3SetBinary(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                         size_t nValueReferences, const size_t valueSizes[],
                         const fmi3Binary values[], size_t nValues)
{
    (void)valueReferences;
    (void)valueSizes;
    (void)values;
    (void)nValues;
    return (fmi3Status)no_variables_of_type(instance, "fmi3SetBinary", nValueReferences);
}

fmi3Status fmi3GetClock(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                        size_t nValueReferences, fmi3Clock values[])
{
    (void)valueReferences;
    (void)values;
    return (fmi3Status)no_variables_of_type(instance, "fmi3GetClock", nValueReferences);
}

fmi3Status fmi3SetClock(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                        size_t nValueReferences, const fmi3Clock values[])
{
    (void)valueReferences;
    (void)values;
    return (fmi3Status)no_variables_of_type(instance, "fmi3SetClock", nValueReferences);
}

/* ---------------------------------------------------------------------------------- */
/* Variable dependencies, configuration mode, clocks: not supported                    */
/* ---------------------------------------------------------------------------------- */

#define NO_PER_ELEMENT "providesPerElementDependencies is false (see ModelStructure)"
#define NO_CLOCKS "this FMU has no clocks"

fmi3Status fmi3GetNumberOfVariableDependencies(fmi3Instance instance,
                                               fmi3ValueReference valueReference,
                                               size_t *nDependencies)
{
    (void)valueReference;
    (void)nDependencies;
    return (fmi3Status)unsupported(instance, "fmi3GetNumberOfVariableDependencies",
                                   NO_PER_ELEMENT);
}

fmi3Status fmi3GetVariableDependencies(fmi3Instance instance, fmi3ValueReference dependent,
                                       size_t elementIndicesOfDependent[],
                                       fmi3ValueReference independents[],
                                       size_t elementIndicesOfIndependents[],
                                       fmi3DependencyKind dependencyKinds[], size_t nDependencies)
{
    (void)dependent;
    (void)elementIndicesOfDependent;
    (void)independents;
    (void)elementIndicesOfIndependents;
    (void)dependencyKinds;
    (void)nDependencies;
    return (fmi3Status)unsupported(instance, "fmi3GetVariableDependencies", NO_PER_ELEMENT);
}

fmi3Status fmi3EnterConfigurationMode(fmi3Instance instance)
{
    return (fmi3Status)unsupported(instance, "fmi3EnterConfigurationMode",
                                   "this FMU has no structural parameters");
}

fmi3Status fmi3ExitConfigurationMode(fmi3Instance instance)
{
    return (fmi3Status)unsupported(instance, "fmi3ExitConfigurationMode",
                                   "this FMU has no structural parameters");
}

fmi3Status fmi3GetIntervalDecimal(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                                  size_t nValueReferences, fmi3Float64 intervals[],
                                  fmi3IntervalQualifier qualifiers[])
{
    (void)valueReferences;
    (void)nValueReferences;
    (void)intervals;
    (void)qualifiers;
    return (fmi3Status)unsupported(instance, "fmi3GetIntervalDecimal", NO_CLOCKS);
}

fmi3Status fmi3GetIntervalFraction(fmi3Instance instance,
                                   const fmi3ValueReference valueReferences[],
                                   size_t nValueReferences, fmi3UInt64 counters[],
                                   fmi3UInt64 resolutions[], fmi3IntervalQualifier qualifiers[])
{
    (void)valueReferences;
    (void)nValueReferences;
    (void)counters;
    (void)resolutions;
    (void)qualifiers;
    return (fmi3Status)unsupported(instance, "fmi3GetIntervalFraction", NO_CLOCKS);
}

fmi3Status fmi3GetShiftDecimal(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                               size_t nValueReferences, fmi3Float64 shifts[])
{
    (void)valueReferences;
    (void)nValueReferences;
    (void)shifts;
    return (fmi3Status)unsupported(instance, "fmi3GetShiftDecimal", NO_CLOCKS);
}

fmi3Status fmi3GetShiftFraction(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                                size_t nValueReferences, fmi3UInt64 counters[],
                                fmi3UInt64 resolutions[])
{
    (void)valueReferences;
    (void)nValueReferences;
    (void)counters;
    (void)resolutions;
    return (fmi3Status)unsupported(instance, "fmi3GetShiftFraction", NO_CLOCKS);
}

fmi3Status fmi3SetIntervalDecimal(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                                  size_t nValueReferences, const fmi3Float64 intervals[])
{
    (void)valueReferences;
    (void)nValueReferences;
    (void)intervals;
    return (fmi3Status)unsupported(instance, "fmi3SetIntervalDecimal", NO_CLOCKS);
}

fmi3Status fmi3SetIntervalFraction(fmi3Instance instance,
                                   const fmi3ValueReference valueReferences[],
                                   size_t nValueReferences, const fmi3UInt64 counters[],
                                   const fmi3UInt64 resolutions[])
{
    (void)valueReferences;
    (void)nValueReferences;
    (void)counters;
    (void)resolutions;
    return (fmi3Status)unsupported(instance, "fmi3SetIntervalFraction", NO_CLOCKS);
}

fmi3Status fmi3SetShiftDecimal(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                               size_t nValueReferences, const fmi3Float64 shifts[])
{
    (void)valueReferences;
    (void)nValueReferences;
    (void)shifts;
    return (fmi3Status)unsupported(instance, "fmi3SetShiftDecimal", NO_CLOCKS);
}

fmi3Status fmi3SetShiftFraction(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                                size_t nValueReferences, const fmi3UInt64 counters[],
                                const fmi3UInt64 resolutions[])
{
    (void)valueReferences;
    (void)nValueReferences;
    (void)counters;
    (void)resolutions;
    return (fmi3Status)unsupported(instance, "fmi3SetShiftFraction", NO_CLOCKS);
}

fmi3Status fmi3ActivateModelPartition(fmi3Instance instance, fmi3ValueReference clockReference,
                                      fmi3Float64 activationTime)
{
    (void)clockReference;
    (void)activationTime;
    return (fmi3Status)unsupported(instance, "fmi3ActivateModelPartition",
                                   "this FMU does not implement scheduled execution");
}

fmi3Status fmi3EvaluateDiscreteStates(fmi3Instance instance)
{
    return (fmi3Status)unsupported(instance, "fmi3EvaluateDiscreteStates",
                                   "this FMU has no discrete states "
                                   "(providesEvaluateDiscreteStates is false)");
}

/* ---------------------------------------------------------------------------------- */
/* FMU state (section 2.2.6.4)                                                         */
/* ---------------------------------------------------------------------------------- */

fmi3Status fmi3GetFMUState(fmi3Instance instance, fmi3FMUState *FMUState)
{
    BEGIN("fmi3GetFMUState", FMUSTATE_ALLOWED_IN)
    return (fmi3Status)ship_get_fmu_state(inst, "fmi3GetFMUState", FMUState);
}

fmi3Status fmi3SetFMUState(fmi3Instance instance, fmi3FMUState FMUState)
{
    BEGIN("fmi3SetFMUState", FMUSTATE_ALLOWED_IN)
    return (fmi3Status)ship_set_fmu_state(inst, "fmi3SetFMUState", FMUState);
}

fmi3Status fmi3FreeFMUState(fmi3Instance instance, fmi3FMUState *FMUState)
{
    BEGIN("fmi3FreeFMUState", FMUSTATE_ALLOWED_IN)
    return (fmi3Status)ship_free_fmu_state(inst, "fmi3FreeFMUState", FMUState);
}

fmi3Status fmi3SerializedFMUStateSize(fmi3Instance instance, fmi3FMUState FMUState, size_t *size)
{
    BEGIN("fmi3SerializedFMUStateSize", FMUSTATE_ALLOWED_IN)
    (void)FMUState;
    return (fmi3Status)ship_serialized_size(inst, "fmi3SerializedFMUStateSize", size);
}

fmi3Status fmi3SerializeFMUState(fmi3Instance instance, fmi3FMUState FMUState,
                                 fmi3Byte serializedState[], size_t size)
{
    BEGIN("fmi3SerializeFMUState", FMUSTATE_ALLOWED_IN)
    return (fmi3Status)ship_serialize(inst, "fmi3SerializeFMUState", FMUState, serializedState,
                                      size);
}

fmi3Status fmi3DeserializeFMUState(fmi3Instance instance, const fmi3Byte serializedState[],
                                   size_t size, fmi3FMUState *FMUState)
{
    BEGIN("fmi3DeserializeFMUState", FMUSTATE_ALLOWED_IN)
    return (fmi3Status)ship_deserialize(inst, "fmi3DeserializeFMUState", serializedState, size,
                                        FMUState);
}

/* ---------------------------------------------------------------------------------- */
/* Partial derivatives (section 2.2.11)                                                */
/* ---------------------------------------------------------------------------------- */

/* nSeed and nSensitivity must be those of scalar knowns and unknowns. */
static int derivative_sizes(const Instance *inst, const char *function, size_t n_seed,
                            size_t expected_seed, size_t n_sensitivity,
                            size_t expected_sensitivity)
{
    if (n_seed != expected_seed || n_sensitivity != expected_sensitivity) {
        LOG_ERROR(inst, "%s: nSeed = %lu and nSensitivity = %lu, expected %lu and %lu",
                  function, (unsigned long)n_seed, (unsigned long)n_sensitivity,
                  (unsigned long)expected_seed, (unsigned long)expected_sensitivity);
        return 0;
    }
    return 1;
}

fmi3Status fmi3GetDirectionalDerivative(fmi3Instance instance, const fmi3ValueReference unknowns[],
                                        size_t nUnknowns, const fmi3ValueReference knowns[],
                                        size_t nKnowns, const fmi3Float64 seed[], size_t nSeed,
                                        fmi3Float64 sensitivity[], size_t nSensitivity)
{
    BEGIN("fmi3GetDirectionalDerivative", STATES_DERIVATIVES)
    if (!derivative_sizes(inst, "fmi3GetDirectionalDerivative", nSeed, nKnowns, nSensitivity,
                          nUnknowns)) {
        return fmi3Error;
    }
    return (fmi3Status)ship_derivatives(inst, "fmi3GetDirectionalDerivative", 0, unknowns,
                                        nUnknowns, knowns, nKnowns, seed, sensitivity);
}

fmi3Status fmi3GetAdjointDerivative(fmi3Instance instance, const fmi3ValueReference unknowns[],
                                    size_t nUnknowns, const fmi3ValueReference knowns[],
                                    size_t nKnowns, const fmi3Float64 seed[], size_t nSeed,
                                    fmi3Float64 sensitivity[], size_t nSensitivity)
{
    BEGIN("fmi3GetAdjointDerivative", STATES_DERIVATIVES)
    if (!derivative_sizes(inst, "fmi3GetAdjointDerivative", nSeed, nUnknowns, nSensitivity,
                          nKnowns)) {
        return fmi3Error;
    }
    return (fmi3Status)ship_derivatives(inst, "fmi3GetAdjointDerivative", 1, unknowns, nUnknowns,
                                        knowns, nKnowns, seed, sensitivity);
}

/* ---------------------------------------------------------------------------------- */
/* Model exchange (chapter 3)                                                          */
/* ---------------------------------------------------------------------------------- */

fmi3Status fmi3UpdateDiscreteStates(fmi3Instance instance, fmi3Boolean *discreteStatesNeedUpdate,
                                    fmi3Boolean *terminateSimulation,
                                    fmi3Boolean *nominalsOfContinuousStatesChanged,
                                    fmi3Boolean *valuesOfContinuousStatesChanged,
                                    fmi3Boolean *nextEventTimeDefined, fmi3Float64 *nextEventTime)
{
    BEGIN("fmi3UpdateDiscreteStates", STATE_EVENT_MODE)
    /* The arguments are optional outputs (section 3.2.2): NULL means not wanted. */
    if (discreteStatesNeedUpdate != NULL) {
        *discreteStatesNeedUpdate = fmi3False;
    }
    if (terminateSimulation != NULL) {
        *terminateSimulation = fmi3False;
    }
    if (nominalsOfContinuousStatesChanged != NULL) {
        *nominalsOfContinuousStatesChanged = fmi3False;
    }
    if (valuesOfContinuousStatesChanged != NULL) {
        *valuesOfContinuousStatesChanged = fmi3False;
    }
    if (nextEventTimeDefined != NULL) {
        *nextEventTimeDefined = fmi3False;
    }
    if (nextEventTime != NULL) {
        *nextEventTime = 0.0;
    }
    return fmi3OK;
}

fmi3Status fmi3EnterContinuousTimeMode(fmi3Instance instance)
{
    BEGIN("fmi3EnterContinuousTimeMode", STATE_EVENT_MODE)
    inst->s.state = STATE_CONTINUOUS_TIME_MODE;
    return fmi3OK;
}

fmi3Status fmi3CompletedIntegratorStep(fmi3Instance instance,
                                       fmi3Boolean noSetFMUStatePriorToCurrentPoint,
                                       fmi3Boolean *enterEventMode,
                                       fmi3Boolean *terminateSimulation)
{
    BEGIN("fmi3CompletedIntegratorStep", STATE_CONTINUOUS_TIME_MODE)
    (void)noSetFMUStatePriorToCurrentPoint;
    if (enterEventMode == NULL || terminateSimulation == NULL) {
        LOG_ERROR(inst, "fmi3CompletedIntegratorStep: an argument is NULL");
        return fmi3Error;
    }
    *enterEventMode = fmi3False;
    *terminateSimulation = fmi3False;
    return fmi3OK;
}

fmi3Status fmi3SetTime(fmi3Instance instance, fmi3Float64 time)
{
    BEGIN("fmi3SetTime", STATE_EVENT_MODE | STATE_CONTINUOUS_TIME_MODE)
    return (fmi3Status)ship_set_time(inst, "fmi3SetTime", time);
}

fmi3Status fmi3SetContinuousStates(fmi3Instance instance, const fmi3Float64 continuousStates[],
                                   size_t nContinuousStates)
{
    BEGIN("fmi3SetContinuousStates", STATE_CONTINUOUS_TIME_MODE)
    return (fmi3Status)ship_set_continuous_states(inst, "fmi3SetContinuousStates",
                                                  continuousStates, nContinuousStates);
}

fmi3Status fmi3GetContinuousStateDerivatives(fmi3Instance instance, fmi3Float64 derivatives[],
                                             size_t nContinuousStates)
{
    BEGIN("fmi3GetContinuousStateDerivatives", STATES_ME_GET)
    return (fmi3Status)ship_get_derivatives(inst, "fmi3GetContinuousStateDerivatives",
                                            derivatives, nContinuousStates);
}

fmi3Status fmi3GetEventIndicators(fmi3Instance instance, fmi3Float64 eventIndicators[],
                                  size_t nEventIndicators)
{
    BEGIN("fmi3GetEventIndicators", STATES_ME_GET)
    (void)eventIndicators;
    return (fmi3Status)ship_get_event_indicators(inst, "fmi3GetEventIndicators",
                                                 nEventIndicators);
}

fmi3Status fmi3GetContinuousStates(fmi3Instance instance, fmi3Float64 continuousStates[],
                                   size_t nContinuousStates)
{
    BEGIN("fmi3GetContinuousStates", STATES_ME_GET)
    return (fmi3Status)ship_get_continuous_states(inst, "fmi3GetContinuousStates",
                                                  continuousStates, nContinuousStates);
}

fmi3Status fmi3GetNominalsOfContinuousStates(fmi3Instance instance, fmi3Float64 nominals[],
                                             size_t nContinuousStates)
{
    BEGIN("fmi3GetNominalsOfContinuousStates", STATE_INSTANTIATED | STATES_ME_GET)
    return (fmi3Status)ship_get_nominals(inst, "fmi3GetNominalsOfContinuousStates", nominals,
                                         nContinuousStates);
}

fmi3Status fmi3GetNumberOfEventIndicators(fmi3Instance instance, size_t *nEventIndicators)
{
    BEGIN("fmi3GetNumberOfEventIndicators", STATE_ANY)
    if (nEventIndicators == NULL) {
        LOG_ERROR(inst, "fmi3GetNumberOfEventIndicators: nEventIndicators is NULL");
        return fmi3Error;
    }
    *nEventIndicators = 0;
    return fmi3OK;
}

fmi3Status fmi3GetNumberOfContinuousStates(fmi3Instance instance, size_t *nContinuousStates)
{
    BEGIN("fmi3GetNumberOfContinuousStates", STATE_ANY)
    if (nContinuousStates == NULL) {
        LOG_ERROR(inst, "fmi3GetNumberOfContinuousStates: nContinuousStates is NULL");
        return fmi3Error;
    }
    *nContinuousStates = SHIP_N_STATES;
    return fmi3OK;
}

/* ---------------------------------------------------------------------------------- */
/* Co-simulation (chapter 4)                                                           */
/* ---------------------------------------------------------------------------------- */

fmi3Status fmi3EnterStepMode(fmi3Instance instance)
{
    return (fmi3Status)unsupported(instance, "fmi3EnterStepMode",
                                   "this FMU has no event mode in co-simulation "
                                   "(hasEventMode is false): it enters Step Mode from "
                                   "fmi3ExitInitializationMode");
}

fmi3Status fmi3GetOutputDerivatives(fmi3Instance instance,
                                    const fmi3ValueReference valueReferences[],
                                    size_t nValueReferences, const fmi3Int32 orders[],
                                    fmi3Float64 values[], size_t nValues)
{
    (void)valueReferences;
    (void)nValueReferences;
    (void)orders;
    (void)values;
    (void)nValues;
    return (fmi3Status)unsupported(instance, "fmi3GetOutputDerivatives",
                                   "maxOutputDerivativeOrder is 0");
}

fmi3Status fmi3DoStep(fmi3Instance instance, fmi3Float64 currentCommunicationPoint,
                      fmi3Float64 communicationStepSize,
                      fmi3Boolean noSetFMUStatePriorToCurrentPoint,
                      fmi3Boolean *eventHandlingNeeded, fmi3Boolean *terminateSimulation,
                      fmi3Boolean *earlyReturn, fmi3Float64 *lastSuccessfulTime)
{
    ShipStatus status;
    BEGIN("fmi3DoStep", STATE_STEP_COMPLETE)
    (void)noSetFMUStatePriorToCurrentPoint;
    if (eventHandlingNeeded == NULL || terminateSimulation == NULL || earlyReturn == NULL ||
        lastSuccessfulTime == NULL) {
        LOG_ERROR(inst, "fmi3DoStep: an output argument is NULL");
        return fmi3Error;
    }
    status = ship_do_step(inst, "fmi3DoStep", currentCommunicationPoint, communicationStepSize);
    *eventHandlingNeeded = fmi3False;
    *earlyReturn = fmi3False;
    /* After a diverged step the FMU cannot continue from this state. */
    *terminateSimulation = inst->s.state == STATE_STEP_FAILED ? fmi3True : fmi3False;
    *lastSuccessfulTime = inst->s.last_successful_time;
    return (fmi3Status)status;
}
