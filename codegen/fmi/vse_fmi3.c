/*
 * vse_fmi3.c: the FMI 3.0 co-simulation interface of a vsegen FMU, over vse_fmu_instance.
 *
 * Part of vsegen's FMU wrapper (not generated; the same for every estimator). The FMU offers
 * co-simulation without event mode, clocks, FMU state or derivatives; every other function of
 * fmi3Functions.h is exported and answers fmi3Error with a logged reason. Memory is allocated
 * only in fmi3InstantiateCoSimulation and freed in fmi3FreeInstance.
 */
#include <stdlib.h>
#include <string.h>

#include "fmi3Functions.h"
#include "vse_fmu_instance.h"

typedef struct {
    vse_fmu_instance shared;
    fmi3InstanceEnvironment environment;
    fmi3LogMessageCallback log_message;
} instance3;

/* The importer's logger, category logStatusError (declared in modelDescription.xml). */
static void log_error(void *adapter, const char *message)
{
    const instance3 *self = (const instance3 *)adapter;
    if (self->log_message != NULL) {
        self->log_message(self->environment, fmi3Error, "logStatusError", message);
    }
}

static vse_fmu_instance *shared(fmi3Instance instance)
{
    return &((instance3 *)instance)->shared;
}

static fmi3Status status(int result)
{
    return result == 0 ? fmi3OK : fmi3Error;
}

/* nValues must equal nValueReferences: every variable of the FMU is a scalar. */
static int scalars(fmi3Instance instance, size_t n_references, size_t n_values, const char *caller)
{
    if (n_references != n_values) {
        return vse_fmu_unsupported(shared(instance), caller, "nValues must equal nValueReferences: every variable is a scalar");
    }
    return 0;
}

/* Getters and setters of a type the FMU has no variable of: a call naming no variable succeeds. */
#define NO_VARIABLE_OF_TYPE(caller) \
    (void)valueReferences; (void)values; (void)nValues; \
    return nValueReferences == 0 ? fmi3OK \
        : status(vse_fmu_unsupported(shared(instance), caller, "the FMU has no variable of this type"))

#define NOT_OFFERED(caller, what) return status(vse_fmu_unsupported(shared(instance), caller, what))

const char *fmi3GetVersion(void)
{
    return fmi3Version;
}

fmi3Status fmi3SetDebugLogging(fmi3Instance instance, fmi3Boolean loggingOn, size_t nCategories,
                               const fmi3String categories[])
{
    (void)instance; (void)loggingOn; (void)nCategories; (void)categories;
    return fmi3OK;      /* errors are always logged; there is nothing else to log */
}

fmi3Instance fmi3InstantiateModelExchange(fmi3String instanceName, fmi3String instantiationToken,
                                          fmi3String resourcePath, fmi3Boolean visible, fmi3Boolean loggingOn,
                                          fmi3InstanceEnvironment instanceEnvironment,
                                          fmi3LogMessageCallback logMessage)
{
    (void)instanceName; (void)instantiationToken; (void)resourcePath; (void)visible; (void)loggingOn;
    if (logMessage != NULL) {
        logMessage(instanceEnvironment, fmi3Error, "logStatusError",
                   "fmi3InstantiateModelExchange: not supported (a co-simulation FMU only)");
    }
    return NULL;
}

fmi3Instance fmi3InstantiateCoSimulation(fmi3String instanceName, fmi3String instantiationToken,
                                         fmi3String resourcePath, fmi3Boolean visible, fmi3Boolean loggingOn,
                                         fmi3Boolean eventModeUsed, fmi3Boolean earlyReturnAllowed,
                                         const fmi3ValueReference requiredIntermediateVariables[],
                                         size_t nRequiredIntermediateVariables,
                                         fmi3InstanceEnvironment instanceEnvironment,
                                         fmi3LogMessageCallback logMessage,
                                         fmi3IntermediateUpdateCallback intermediateUpdate)
{
    instance3 *self;
    const char *refusal = NULL;
    (void)instanceName; (void)resourcePath; (void)visible; (void)loggingOn; (void)earlyReturnAllowed;
    (void)requiredIntermediateVariables; (void)nRequiredIntermediateVariables; (void)intermediateUpdate;
    if (instantiationToken == NULL || strcmp(instantiationToken, vse_fmu_model_token()) != 0) {
        refusal = "fmi3InstantiateCoSimulation: the instantiation token is not this FMU's (another modelDescription.xml?)";
    } else if (eventModeUsed) {
        refusal = "fmi3InstantiateCoSimulation: event mode is not supported (hasEventMode is false)";
    }
    if (refusal != NULL) {
        if (logMessage != NULL) {
            logMessage(instanceEnvironment, fmi3Error, "logStatusError", refusal);
        }
        return NULL;
    }
    self = (instance3 *)calloc(1, sizeof *self);
    if (self != NULL) {
        self->environment = instanceEnvironment;
        self->log_message = logMessage;
        self->shared.model = (vse_fmu_model *)calloc(2, vse_fmu_model_size());
    }
    if (self == NULL || self->shared.model == NULL) {
        free(self);
        if (logMessage != NULL) {
            logMessage(instanceEnvironment, fmi3Error, "logStatusError", "fmi3InstantiateCoSimulation: out of memory");
        }
        return NULL;
    }
    vse_fmu_instance_init(&self->shared, self->shared.model,
                          (vse_fmu_model *)((char *)self->shared.model + vse_fmu_model_size()), log_error, self);
    return self;
}

fmi3Instance fmi3InstantiateScheduledExecution(fmi3String instanceName, fmi3String instantiationToken,
                                               fmi3String resourcePath, fmi3Boolean visible,
                                               fmi3Boolean loggingOn, fmi3InstanceEnvironment instanceEnvironment,
                                               fmi3LogMessageCallback logMessage, fmi3ClockUpdateCallback clockUpdate,
                                               fmi3LockPreemptionCallback lockPreemption,
                                               fmi3UnlockPreemptionCallback unlockPreemption)
{
    (void)instanceName; (void)instantiationToken; (void)resourcePath; (void)visible; (void)loggingOn;
    (void)clockUpdate; (void)lockPreemption; (void)unlockPreemption;
    if (logMessage != NULL) {
        logMessage(instanceEnvironment, fmi3Error, "logStatusError",
                   "fmi3InstantiateScheduledExecution: not supported (a co-simulation FMU only)");
    }
    return NULL;
}

void fmi3FreeInstance(fmi3Instance instance)
{
    if (instance != NULL) {
        free(shared(instance)->model);
        free(instance);
    }
}

fmi3Status fmi3EnterInitializationMode(fmi3Instance instance, fmi3Boolean toleranceDefined, fmi3Float64 tolerance,
                                       fmi3Float64 startTime, fmi3Boolean stopTimeDefined, fmi3Float64 stopTime)
{
    (void)toleranceDefined; (void)tolerance; (void)stopTimeDefined; (void)stopTime;
    return status(vse_fmu_enter_initialization(shared(instance), startTime, "fmi3EnterInitializationMode"));
}

fmi3Status fmi3ExitInitializationMode(fmi3Instance instance)
{
    return status(vse_fmu_exit_initialization(shared(instance), "fmi3ExitInitializationMode"));
}

fmi3Status fmi3EnterEventMode(fmi3Instance instance)
{
    NOT_OFFERED("fmi3EnterEventMode", "no event mode");
}

fmi3Status fmi3Terminate(fmi3Instance instance)
{
    return status(vse_fmu_terminate(shared(instance), "fmi3Terminate"));
}

fmi3Status fmi3Reset(fmi3Instance instance)
{
    vse_fmu_instance_reset(shared(instance));
    return fmi3OK;
}

fmi3Status fmi3GetFloat64(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                          size_t nValueReferences, fmi3Float64 values[], size_t nValues)
{
    if (scalars(instance, nValueReferences, nValues, "fmi3GetFloat64") != 0) {
        return fmi3Error;
    }
    return status(vse_fmu_get_float64(shared(instance), valueReferences, nValueReferences, values, "fmi3GetFloat64"));
}

fmi3Status fmi3GetInt32(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                        size_t nValueReferences, fmi3Int32 values[], size_t nValues)
{
    int value;
    size_t i;
    if (scalars(instance, nValueReferences, nValues, "fmi3GetInt32") != 0) {
        return fmi3Error;
    }
    for (i = 0; i < nValueReferences; ++i) {
        if (vse_fmu_get_int32(shared(instance), &valueReferences[i], 1, &value, "fmi3GetInt32") != 0) {
            return fmi3Error;
        }
        values[i] = (fmi3Int32)value;
    }
    return fmi3OK;
}

fmi3Status fmi3SetFloat64(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                          size_t nValueReferences, const fmi3Float64 values[], size_t nValues)
{
    if (scalars(instance, nValueReferences, nValues, "fmi3SetFloat64") != 0) {
        return fmi3Error;
    }
    return status(vse_fmu_set_float64(shared(instance), valueReferences, nValueReferences, values, "fmi3SetFloat64"));
}

fmi3Status fmi3GetFloat32(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                          fmi3Float32 values[], size_t nValues) { NO_VARIABLE_OF_TYPE("fmi3GetFloat32"); }
fmi3Status fmi3GetInt8(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                       fmi3Int8 values[], size_t nValues) { NO_VARIABLE_OF_TYPE("fmi3GetInt8"); }
fmi3Status fmi3GetUInt8(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                        fmi3UInt8 values[], size_t nValues) { NO_VARIABLE_OF_TYPE("fmi3GetUInt8"); }
fmi3Status fmi3GetInt16(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                        fmi3Int16 values[], size_t nValues) { NO_VARIABLE_OF_TYPE("fmi3GetInt16"); }
fmi3Status fmi3GetUInt16(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                         fmi3UInt16 values[], size_t nValues) { NO_VARIABLE_OF_TYPE("fmi3GetUInt16"); }
fmi3Status fmi3GetUInt32(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                         fmi3UInt32 values[], size_t nValues) { NO_VARIABLE_OF_TYPE("fmi3GetUInt32"); }
fmi3Status fmi3GetInt64(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                        fmi3Int64 values[], size_t nValues) { NO_VARIABLE_OF_TYPE("fmi3GetInt64"); }
fmi3Status fmi3GetUInt64(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                         fmi3UInt64 values[], size_t nValues) { NO_VARIABLE_OF_TYPE("fmi3GetUInt64"); }
fmi3Status fmi3GetBoolean(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                          fmi3Boolean values[], size_t nValues) { NO_VARIABLE_OF_TYPE("fmi3GetBoolean"); }
fmi3Status fmi3GetString(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                         fmi3String values[], size_t nValues) { NO_VARIABLE_OF_TYPE("fmi3GetString"); }
fmi3Status fmi3SetFloat32(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                          const fmi3Float32 values[], size_t nValues) { NO_VARIABLE_OF_TYPE("fmi3SetFloat32"); }
fmi3Status fmi3SetInt8(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                       const fmi3Int8 values[], size_t nValues) { NO_VARIABLE_OF_TYPE("fmi3SetInt8"); }
fmi3Status fmi3SetUInt8(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                        const fmi3UInt8 values[], size_t nValues) { NO_VARIABLE_OF_TYPE("fmi3SetUInt8"); }
fmi3Status fmi3SetInt16(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                        const fmi3Int16 values[], size_t nValues) { NO_VARIABLE_OF_TYPE("fmi3SetInt16"); }
fmi3Status fmi3SetUInt16(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                         const fmi3UInt16 values[], size_t nValues) { NO_VARIABLE_OF_TYPE("fmi3SetUInt16"); }
fmi3Status fmi3SetInt32(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                        const fmi3Int32 values[], size_t nValues) { NO_VARIABLE_OF_TYPE("fmi3SetInt32"); }
fmi3Status fmi3SetUInt32(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                         const fmi3UInt32 values[], size_t nValues) { NO_VARIABLE_OF_TYPE("fmi3SetUInt32"); }
fmi3Status fmi3SetInt64(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                        const fmi3Int64 values[], size_t nValues) { NO_VARIABLE_OF_TYPE("fmi3SetInt64"); }
fmi3Status fmi3SetUInt64(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                         const fmi3UInt64 values[], size_t nValues) { NO_VARIABLE_OF_TYPE("fmi3SetUInt64"); }
fmi3Status fmi3SetBoolean(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                          const fmi3Boolean values[], size_t nValues) { NO_VARIABLE_OF_TYPE("fmi3SetBoolean"); }
fmi3Status fmi3SetString(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                         const fmi3String values[], size_t nValues) { NO_VARIABLE_OF_TYPE("fmi3SetString"); }

fmi3Status fmi3GetBinary(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                         size_t valueSizes[], fmi3Binary values[], size_t nValues)
{
    (void)valueSizes;
    NO_VARIABLE_OF_TYPE("fmi3GetBinary");
}

fmi3Status fmi3SetBinary(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                         const size_t valueSizes[], const fmi3Binary values[], size_t nValues)
{
    (void)valueSizes;
    NO_VARIABLE_OF_TYPE("fmi3SetBinary");
}

fmi3Status fmi3GetClock(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                        fmi3Clock values[])
{
    const size_t nValues = nValueReferences;
    NO_VARIABLE_OF_TYPE("fmi3GetClock");
}

fmi3Status fmi3SetClock(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                        const fmi3Clock values[])
{
    const size_t nValues = nValueReferences;
    NO_VARIABLE_OF_TYPE("fmi3SetClock");
}

fmi3Status fmi3GetNumberOfVariableDependencies(fmi3Instance instance, fmi3ValueReference valueReference,
                                               size_t *nDependencies)
{
    (void)valueReference; (void)nDependencies;
    NOT_OFFERED("fmi3GetNumberOfVariableDependencies", "the dependencies are in modelDescription.xml");
}

fmi3Status fmi3GetVariableDependencies(fmi3Instance instance, fmi3ValueReference dependent,
                                       size_t elementIndicesOfDependent[], fmi3ValueReference independents[],
                                       size_t elementIndicesOfIndependents[], fmi3DependencyKind dependencyKinds[],
                                       size_t nDependencies)
{
    (void)dependent; (void)elementIndicesOfDependent; (void)independents; (void)elementIndicesOfIndependents;
    (void)dependencyKinds; (void)nDependencies;
    NOT_OFFERED("fmi3GetVariableDependencies", "the dependencies are in modelDescription.xml");
}

fmi3Status fmi3GetFMUState(fmi3Instance instance, fmi3FMUState *FMUState)
{
    (void)FMUState;
    NOT_OFFERED("fmi3GetFMUState", "canGetAndSetFMUState is false");
}

fmi3Status fmi3SetFMUState(fmi3Instance instance, fmi3FMUState FMUState)
{
    (void)FMUState;
    NOT_OFFERED("fmi3SetFMUState", "canGetAndSetFMUState is false");
}

fmi3Status fmi3FreeFMUState(fmi3Instance instance, fmi3FMUState *FMUState)
{
    (void)FMUState;
    NOT_OFFERED("fmi3FreeFMUState", "canGetAndSetFMUState is false");
}

fmi3Status fmi3SerializedFMUStateSize(fmi3Instance instance, fmi3FMUState FMUState, size_t *size)
{
    (void)FMUState; (void)size;
    NOT_OFFERED("fmi3SerializedFMUStateSize", "canSerializeFMUState is false");
}

fmi3Status fmi3SerializeFMUState(fmi3Instance instance, fmi3FMUState FMUState, fmi3Byte serializedState[], size_t size)
{
    (void)FMUState; (void)serializedState; (void)size;
    NOT_OFFERED("fmi3SerializeFMUState", "canSerializeFMUState is false");
}

fmi3Status fmi3DeserializeFMUState(fmi3Instance instance, const fmi3Byte serializedState[], size_t size,
                                   fmi3FMUState *FMUState)
{
    (void)serializedState; (void)size; (void)FMUState;
    NOT_OFFERED("fmi3DeserializeFMUState", "canSerializeFMUState is false");
}

fmi3Status fmi3GetDirectionalDerivative(fmi3Instance instance, const fmi3ValueReference unknowns[], size_t nUnknowns,
                                        const fmi3ValueReference knowns[], size_t nKnowns, const fmi3Float64 seed[],
                                        size_t nSeed, fmi3Float64 sensitivity[], size_t nSensitivity)
{
    (void)unknowns; (void)nUnknowns; (void)knowns; (void)nKnowns; (void)seed; (void)nSeed; (void)sensitivity;
    (void)nSensitivity;
    NOT_OFFERED("fmi3GetDirectionalDerivative", "providesDirectionalDerivatives is false");
}

fmi3Status fmi3GetAdjointDerivative(fmi3Instance instance, const fmi3ValueReference unknowns[], size_t nUnknowns,
                                    const fmi3ValueReference knowns[], size_t nKnowns, const fmi3Float64 seed[],
                                    size_t nSeed, fmi3Float64 sensitivity[], size_t nSensitivity)
{
    (void)unknowns; (void)nUnknowns; (void)knowns; (void)nKnowns; (void)seed; (void)nSeed; (void)sensitivity;
    (void)nSensitivity;
    NOT_OFFERED("fmi3GetAdjointDerivative", "providesAdjointDerivatives is false");
}

fmi3Status fmi3EnterConfigurationMode(fmi3Instance instance)
{
    NOT_OFFERED("fmi3EnterConfigurationMode", "the FMU has no structural parameters");
}

fmi3Status fmi3ExitConfigurationMode(fmi3Instance instance)
{
    NOT_OFFERED("fmi3ExitConfigurationMode", "the FMU has no structural parameters");
}

fmi3Status fmi3GetIntervalDecimal(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                                  size_t nValueReferences, fmi3Float64 intervals[], fmi3IntervalQualifier qualifiers[])
{
    (void)valueReferences; (void)nValueReferences; (void)intervals; (void)qualifiers;
    NOT_OFFERED("fmi3GetIntervalDecimal", "the FMU has no clocks");
}

fmi3Status fmi3GetIntervalFraction(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                                   size_t nValueReferences, fmi3UInt64 counters[], fmi3UInt64 resolutions[],
                                   fmi3IntervalQualifier qualifiers[])
{
    (void)valueReferences; (void)nValueReferences; (void)counters; (void)resolutions; (void)qualifiers;
    NOT_OFFERED("fmi3GetIntervalFraction", "the FMU has no clocks");
}

fmi3Status fmi3GetShiftDecimal(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                               size_t nValueReferences, fmi3Float64 shifts[])
{
    (void)valueReferences; (void)nValueReferences; (void)shifts;
    NOT_OFFERED("fmi3GetShiftDecimal", "the FMU has no clocks");
}

fmi3Status fmi3GetShiftFraction(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                                size_t nValueReferences, fmi3UInt64 counters[], fmi3UInt64 resolutions[])
{
    (void)valueReferences; (void)nValueReferences; (void)counters; (void)resolutions;
    NOT_OFFERED("fmi3GetShiftFraction", "the FMU has no clocks");
}

fmi3Status fmi3SetIntervalDecimal(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                                  size_t nValueReferences, const fmi3Float64 intervals[])
{
    (void)valueReferences; (void)nValueReferences; (void)intervals;
    NOT_OFFERED("fmi3SetIntervalDecimal", "the FMU has no clocks");
}

fmi3Status fmi3SetIntervalFraction(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                                   size_t nValueReferences, const fmi3UInt64 counters[], const fmi3UInt64 resolutions[])
{
    (void)valueReferences; (void)nValueReferences; (void)counters; (void)resolutions;
    NOT_OFFERED("fmi3SetIntervalFraction", "the FMU has no clocks");
}

fmi3Status fmi3SetShiftDecimal(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                               size_t nValueReferences, const fmi3Float64 shifts[])
{
    (void)valueReferences; (void)nValueReferences; (void)shifts;
    NOT_OFFERED("fmi3SetShiftDecimal", "the FMU has no clocks");
}

fmi3Status fmi3SetShiftFraction(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                                size_t nValueReferences, const fmi3UInt64 counters[], const fmi3UInt64 resolutions[])
{
    (void)valueReferences; (void)nValueReferences; (void)counters; (void)resolutions;
    NOT_OFFERED("fmi3SetShiftFraction", "the FMU has no clocks");
}

fmi3Status fmi3EvaluateDiscreteStates(fmi3Instance instance)
{
    NOT_OFFERED("fmi3EvaluateDiscreteStates", "no event mode");
}

fmi3Status fmi3UpdateDiscreteStates(fmi3Instance instance, fmi3Boolean *discreteStatesNeedUpdate,
                                    fmi3Boolean *terminateSimulation, fmi3Boolean *nominalsOfContinuousStatesChanged,
                                    fmi3Boolean *valuesOfContinuousStatesChanged, fmi3Boolean *nextEventTimeDefined,
                                    fmi3Float64 *nextEventTime)
{
    (void)discreteStatesNeedUpdate; (void)terminateSimulation; (void)nominalsOfContinuousStatesChanged;
    (void)valuesOfContinuousStatesChanged; (void)nextEventTimeDefined; (void)nextEventTime;
    NOT_OFFERED("fmi3UpdateDiscreteStates", "no event mode");
}

fmi3Status fmi3EnterContinuousTimeMode(fmi3Instance instance)
{
    NOT_OFFERED("fmi3EnterContinuousTimeMode", "a co-simulation FMU only");
}

fmi3Status fmi3CompletedIntegratorStep(fmi3Instance instance, fmi3Boolean noSetFMUStatePriorToCurrentPoint,
                                       fmi3Boolean *enterEventMode, fmi3Boolean *terminateSimulation)
{
    (void)noSetFMUStatePriorToCurrentPoint; (void)enterEventMode; (void)terminateSimulation;
    NOT_OFFERED("fmi3CompletedIntegratorStep", "a co-simulation FMU only");
}

fmi3Status fmi3SetTime(fmi3Instance instance, fmi3Float64 time)
{
    (void)time;
    NOT_OFFERED("fmi3SetTime", "a co-simulation FMU only");
}

fmi3Status fmi3SetContinuousStates(fmi3Instance instance, const fmi3Float64 continuousStates[],
                                   size_t nContinuousStates)
{
    (void)continuousStates; (void)nContinuousStates;
    NOT_OFFERED("fmi3SetContinuousStates", "a co-simulation FMU only");
}

fmi3Status fmi3GetContinuousStateDerivatives(fmi3Instance instance, fmi3Float64 derivatives[],
                                             size_t nContinuousStates)
{
    (void)derivatives; (void)nContinuousStates;
    NOT_OFFERED("fmi3GetContinuousStateDerivatives", "a co-simulation FMU only");
}

fmi3Status fmi3GetEventIndicators(fmi3Instance instance, fmi3Float64 eventIndicators[], size_t nEventIndicators)
{
    (void)eventIndicators; (void)nEventIndicators;
    NOT_OFFERED("fmi3GetEventIndicators", "a co-simulation FMU only");
}

fmi3Status fmi3GetContinuousStates(fmi3Instance instance, fmi3Float64 continuousStates[], size_t nContinuousStates)
{
    (void)continuousStates; (void)nContinuousStates;
    NOT_OFFERED("fmi3GetContinuousStates", "a co-simulation FMU only");
}

fmi3Status fmi3GetNominalsOfContinuousStates(fmi3Instance instance, fmi3Float64 nominals[], size_t nContinuousStates)
{
    (void)nominals; (void)nContinuousStates;
    NOT_OFFERED("fmi3GetNominalsOfContinuousStates", "a co-simulation FMU only");
}

fmi3Status fmi3GetNumberOfEventIndicators(fmi3Instance instance, size_t *nEventIndicators)
{
    (void)instance;
    *nEventIndicators = 0;
    return fmi3OK;
}

fmi3Status fmi3GetNumberOfContinuousStates(fmi3Instance instance, size_t *nContinuousStates)
{
    (void)instance;
    *nContinuousStates = 0;
    return fmi3OK;
}

fmi3Status fmi3EnterStepMode(fmi3Instance instance)
{
    NOT_OFFERED("fmi3EnterStepMode", "no event mode: the instance is in step mode after initialization");
}

fmi3Status fmi3GetOutputDerivatives(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                                    size_t nValueReferences, const fmi3Int32 orders[], fmi3Float64 values[],
                                    size_t nValues)
{
    (void)valueReferences; (void)nValueReferences; (void)orders; (void)values; (void)nValues;
    NOT_OFFERED("fmi3GetOutputDerivatives", "the outputs are piecewise constant");
}

fmi3Status fmi3DoStep(fmi3Instance instance, fmi3Float64 currentCommunicationPoint, fmi3Float64 communicationStepSize,
                      fmi3Boolean noSetFMUStatePriorToCurrentPoint, fmi3Boolean *eventHandlingNeeded,
                      fmi3Boolean *terminateSimulation, fmi3Boolean *earlyReturn, fmi3Float64 *lastSuccessfulTime)
{
    int result;
    (void)noSetFMUStatePriorToCurrentPoint;
    result = vse_fmu_do_step(shared(instance), currentCommunicationPoint, communicationStepSize, "fmi3DoStep");
    *eventHandlingNeeded = fmi3False;
    *terminateSimulation = fmi3False;
    *earlyReturn = fmi3False;
    *lastSuccessfulTime = vse_fmu_model_time(shared(instance)->model);
    return status(result);
}

fmi3Status fmi3ActivateModelPartition(fmi3Instance instance, fmi3ValueReference clockReference,
                                      fmi3Float64 activationTime)
{
    (void)clockReference; (void)activationTime;
    NOT_OFFERED("fmi3ActivateModelPartition", "a co-simulation FMU only");
}
