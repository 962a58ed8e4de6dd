/*
 * vse_fmi2.c: the FMI 2.0 co-simulation interface of a vsegen FMU, over vse_fmu_instance.
 *
 * Part of vsegen's FMU wrapper (not generated; the same for every estimator). Co-simulation
 * without FMU state, derivatives or asynchronous steps; every other function of fmi2Functions.h
 * is exported and answers fmi2Error with a logged reason. Memory comes from the importer's
 * allocateMemory, only in fmi2Instantiate, and goes back in fmi2FreeInstance.
 */
#include <string.h>

#include "fmi2Functions.h"
#include "vse_fmu_instance.h"

typedef struct {
    vse_fmu_instance shared;
    fmi2CallbackFunctions functions;
    char name[64];
} instance2;

/* The importer's logger, category logStatusError (declared in modelDescription.xml). The message
 * goes as the format itself, '%' doubled: importers that print it unformatted (e.g. FMPy) and
 * those that format it show the same line. */
static void log_error(void *adapter, const char *message)
{
    const instance2 *self = (const instance2 *)adapter;
    char format[2 * VSE_FMU_MESSAGE_SIZE + 192];
    size_t i = 0;
    for (; *message != '\0' && i + 2 < sizeof format; ++message) {
        if (*message == '%') {
            format[i++] = '%';
        }
        format[i++] = *message;
    }
    format[i] = '\0';
    if (self->functions.logger != NULL) {
        self->functions.logger(self->functions.componentEnvironment, self->name, fmi2Error, "logStatusError", format);
    }
}

static vse_fmu_instance *shared(fmi2Component c)
{
    return &((instance2 *)c)->shared;
}

static fmi2Status status(int result)
{
    return result == 0 ? fmi2OK : fmi2Error;
}

#define NOT_OFFERED(caller, what) return status(vse_fmu_unsupported(shared(c), caller, what))

const char *fmi2GetTypesPlatform(void)
{
    return fmi2TypesPlatform;
}

const char *fmi2GetVersion(void)
{
    return fmi2Version;
}

fmi2Status fmi2SetDebugLogging(fmi2Component c, fmi2Boolean loggingOn, size_t nCategories,
                               const fmi2String categories[])
{
    (void)c; (void)loggingOn; (void)nCategories; (void)categories;
    return fmi2OK;      /* errors are always logged; there is nothing else to log */
}

fmi2Component fmi2Instantiate(fmi2String instanceName, fmi2Type fmuType, fmi2String fmuGUID,
                              fmi2String fmuResourceLocation, const fmi2CallbackFunctions *functions,
                              fmi2Boolean visible, fmi2Boolean loggingOn)
{
    instance2 *self;
    const char *refusal = NULL;
    (void)fmuResourceLocation; (void)visible; (void)loggingOn;
    if (functions == NULL || functions->allocateMemory == NULL || functions->freeMemory == NULL) {
        return NULL;
    }
    if (fmuType != fmi2CoSimulation) {
        refusal = "fmi2Instantiate: model exchange is not supported (a co-simulation FMU only)";
    } else if (fmuGUID == NULL || strcmp(fmuGUID, vse_fmu_model_token()) != 0) {
        refusal = "fmi2Instantiate: the GUID is not this FMU's (another modelDescription.xml?)";
    }
    self = refusal == NULL ? (instance2 *)functions->allocateMemory(1, sizeof *self) : NULL;
    if (self != NULL) {
        self->shared.model = (vse_fmu_model *)functions->allocateMemory(2, vse_fmu_model_size());
        if (self->shared.model == NULL) {
            functions->freeMemory(self);
            self = NULL;
        }
    }
    if (self == NULL) {
        if (functions->logger != NULL) {
            functions->logger(functions->componentEnvironment, instanceName, fmi2Error, "logStatusError",
                              refusal != NULL ? refusal : "fmi2Instantiate: out of memory");
        }
        return NULL;
    }
    self->functions = *functions;
    (void)strncpy(self->name, instanceName != NULL ? instanceName : "", sizeof self->name - 1);
    vse_fmu_instance_init(&self->shared, self->shared.model,
                          (vse_fmu_model *)((char *)self->shared.model + vse_fmu_model_size()), log_error, self);
    return self;
}

void fmi2FreeInstance(fmi2Component c)
{
    if (c != NULL) {
        instance2 *self = (instance2 *)c;
        fmi2CallbackFreeMemory free_memory = self->functions.freeMemory;
        free_memory(self->shared.model);
        free_memory(self);
    }
}

fmi2Status fmi2SetupExperiment(fmi2Component c, fmi2Boolean toleranceDefined, fmi2Real tolerance,
                               fmi2Real startTime, fmi2Boolean stopTimeDefined, fmi2Real stopTime)
{
    (void)toleranceDefined; (void)tolerance; (void)stopTimeDefined; (void)stopTime;
    if (shared(c)->phase != VSE_FMU_INSTANTIATED) {
        NOT_OFFERED("fmi2SetupExperiment", "only before fmi2EnterInitializationMode");
    }
    vse_fmu_model_start(shared(c)->model, startTime);
    return fmi2OK;
}

fmi2Status fmi2EnterInitializationMode(fmi2Component c)
{
    return status(vse_fmu_enter_initialization(shared(c), vse_fmu_model_time(shared(c)->model),
                                               "fmi2EnterInitializationMode"));
}

fmi2Status fmi2ExitInitializationMode(fmi2Component c)
{
    return status(vse_fmu_exit_initialization(shared(c), "fmi2ExitInitializationMode"));
}

fmi2Status fmi2Terminate(fmi2Component c)
{
    return status(vse_fmu_terminate(shared(c), "fmi2Terminate"));
}

fmi2Status fmi2Reset(fmi2Component c)
{
    vse_fmu_instance_reset(shared(c));
    return fmi2OK;
}

fmi2Status fmi2GetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, fmi2Real value[])
{
    return status(vse_fmu_get_float64(shared(c), vr, nvr, value, "fmi2GetReal"));
}

fmi2Status fmi2GetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, fmi2Integer value[])
{
    return status(vse_fmu_get_int32(shared(c), vr, nvr, value, "fmi2GetInteger"));
}

fmi2Status fmi2SetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, const fmi2Real value[])
{
    return status(vse_fmu_set_float64(shared(c), vr, nvr, value, "fmi2SetReal"));
}

fmi2Status fmi2GetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, fmi2Boolean value[])
{
    (void)vr; (void)value;
    return nvr == 0 ? fmi2OK : status(vse_fmu_unsupported(shared(c), "fmi2GetBoolean", "the FMU has no Boolean variable"));
}

fmi2Status fmi2GetString(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, fmi2String value[])
{
    (void)vr; (void)value;
    return nvr == 0 ? fmi2OK : status(vse_fmu_unsupported(shared(c), "fmi2GetString", "the FMU has no String variable"));
}

fmi2Status fmi2SetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, const fmi2Integer value[])
{
    (void)vr; (void)value;
    return nvr == 0 ? fmi2OK
        : status(vse_fmu_unsupported(shared(c), "fmi2SetInteger", "the FMU's Integer variables are outputs"));
}

fmi2Status fmi2SetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, const fmi2Boolean value[])
{
    (void)vr; (void)value;
    return nvr == 0 ? fmi2OK : status(vse_fmu_unsupported(shared(c), "fmi2SetBoolean", "the FMU has no Boolean variable"));
}

fmi2Status fmi2SetString(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, const fmi2String value[])
{
    (void)vr; (void)value;
    return nvr == 0 ? fmi2OK : status(vse_fmu_unsupported(shared(c), "fmi2SetString", "the FMU has no String variable"));
}

fmi2Status fmi2GetFMUstate(fmi2Component c, fmi2FMUstate *FMUstate)
{
    (void)FMUstate;
    NOT_OFFERED("fmi2GetFMUstate", "canGetAndSetFMUstate is false");
}

fmi2Status fmi2SetFMUstate(fmi2Component c, fmi2FMUstate FMUstate)
{
    (void)FMUstate;
    NOT_OFFERED("fmi2SetFMUstate", "canGetAndSetFMUstate is false");
}

fmi2Status fmi2FreeFMUstate(fmi2Component c, fmi2FMUstate *FMUstate)
{
    (void)FMUstate;
    NOT_OFFERED("fmi2FreeFMUstate", "canGetAndSetFMUstate is false");
}

fmi2Status fmi2SerializedFMUstateSize(fmi2Component c, fmi2FMUstate FMUstate, size_t *size)
{
    (void)FMUstate; (void)size;
    NOT_OFFERED("fmi2SerializedFMUstateSize", "canSerializeFMUstate is false");
}

fmi2Status fmi2SerializeFMUstate(fmi2Component c, fmi2FMUstate FMUstate, fmi2Byte serializedState[], size_t size)
{
    (void)FMUstate; (void)serializedState; (void)size;
    NOT_OFFERED("fmi2SerializeFMUstate", "canSerializeFMUstate is false");
}

fmi2Status fmi2DeSerializeFMUstate(fmi2Component c, const fmi2Byte serializedState[], size_t size,
                                   fmi2FMUstate *FMUstate)
{
    (void)serializedState; (void)size; (void)FMUstate;
    NOT_OFFERED("fmi2DeSerializeFMUstate", "canSerializeFMUstate is false");
}

fmi2Status fmi2GetDirectionalDerivative(fmi2Component c, const fmi2ValueReference vUnknown_ref[], size_t nUnknown,
                                        const fmi2ValueReference vKnown_ref[], size_t nKnown,
                                        const fmi2Real dvKnown[], fmi2Real dvUnknown[])
{
    (void)vUnknown_ref; (void)nUnknown; (void)vKnown_ref; (void)nKnown; (void)dvKnown; (void)dvUnknown;
    NOT_OFFERED("fmi2GetDirectionalDerivative", "providesDirectionalDerivative is false");
}

fmi2Status fmi2SetRealInputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                                       const fmi2Integer order[], const fmi2Real value[])
{
    (void)vr; (void)nvr; (void)order; (void)value;
    NOT_OFFERED("fmi2SetRealInputDerivatives", "canInterpolateInputs is false");
}

fmi2Status fmi2GetRealOutputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                                        const fmi2Integer order[], fmi2Real value[])
{
    (void)vr; (void)nvr; (void)order; (void)value;
    NOT_OFFERED("fmi2GetRealOutputDerivatives", "maxOutputDerivativeOrder is 0");
}

fmi2Status fmi2DoStep(fmi2Component c, fmi2Real currentCommunicationPoint, fmi2Real communicationStepSize,
                      fmi2Boolean noSetFMUStatePriorToCurrentPoint)
{
    (void)noSetFMUStatePriorToCurrentPoint;
    return status(vse_fmu_do_step(shared(c), currentCommunicationPoint, communicationStepSize, "fmi2DoStep"));
}

fmi2Status fmi2CancelStep(fmi2Component c)
{
    NOT_OFFERED("fmi2CancelStep", "fmi2DoStep never returns fmi2Pending");
}

fmi2Status fmi2GetStatus(fmi2Component c, const fmi2StatusKind s, fmi2Status *value)
{
    (void)s; (void)value;
    NOT_OFFERED("fmi2GetStatus", "fmi2DoStep never returns fmi2Pending");
}

fmi2Status fmi2GetRealStatus(fmi2Component c, const fmi2StatusKind s, fmi2Real *value)
{
    if (s != fmi2LastSuccessfulTime) {
        NOT_OFFERED("fmi2GetRealStatus", "only fmi2LastSuccessfulTime");
    }
    *value = vse_fmu_model_time(shared(c)->model);
    return fmi2OK;
}

fmi2Status fmi2GetIntegerStatus(fmi2Component c, const fmi2StatusKind s, fmi2Integer *value)
{
    (void)s; (void)value;
    NOT_OFFERED("fmi2GetIntegerStatus", "no integer status");
}

fmi2Status fmi2GetBooleanStatus(fmi2Component c, const fmi2StatusKind s, fmi2Boolean *value)
{
    (void)s; (void)value;
    NOT_OFFERED("fmi2GetBooleanStatus", "fmi2DoStep never returns fmi2Discard");
}

fmi2Status fmi2GetStringStatus(fmi2Component c, const fmi2StatusKind s, fmi2String *value)
{
    (void)s; (void)value;
    NOT_OFFERED("fmi2GetStringStatus", "fmi2DoStep never returns fmi2Pending");
}
