/*
 * vse_fmu_instance.c: the FMU instance's life cycle and value access, shared by both FMI versions.
 *
 * Part of vsegen's FMU wrapper (not generated; the same for every estimator).
 */
#include "vse_fmu_instance.h"

#include <stdio.h>
#include <string.h>

static const char *const PHASE_NAMES[] = {"instantiated", "initialization mode", "step mode", "terminated"};

static int refuse(vse_fmu_instance *instance, const char *caller, const char *why)
{
    char message[VSE_FMU_MESSAGE_SIZE + 96];
    (void)snprintf(message, sizeof message, "%s: %s", caller, why);
    instance->log(instance->adapter, message);
    return -1;
}

static int wrong_phase(vse_fmu_instance *instance, const char *caller)
{
    char why[96];
    (void)snprintf(why, sizeof why, "not allowed when the instance is %s", PHASE_NAMES[instance->phase]);
    return refuse(instance, caller, why);
}

void vse_fmu_instance_init(vse_fmu_instance *instance, vse_fmu_model *model, vse_fmu_model *backup,
                           vse_fmu_logger *log, void *adapter)
{
    instance->model = model;
    instance->backup = backup;
    instance->log = log;
    instance->adapter = adapter;
    vse_fmu_instance_reset(instance);
}

void vse_fmu_instance_reset(vse_fmu_instance *instance)
{
    vse_fmu_model_reset(instance->model);
    instance->phase = VSE_FMU_INSTANTIATED;
}

int vse_fmu_enter_initialization(vse_fmu_instance *instance, double start_time, const char *caller)
{
    if (instance->phase != VSE_FMU_INSTANTIATED) {
        return wrong_phase(instance, caller);
    }
    vse_fmu_model_start(instance->model, start_time);
    instance->phase = VSE_FMU_INITIALIZING;
    return 0;
}

int vse_fmu_exit_initialization(vse_fmu_instance *instance, const char *caller)
{
    char why[VSE_FMU_MESSAGE_SIZE];
    if (instance->phase != VSE_FMU_INITIALIZING) {
        return wrong_phase(instance, caller);
    }
    if (vse_fmu_model_check_calibration(instance->model, why) != 0) {
        return refuse(instance, caller, why);
    }
    instance->phase = VSE_FMU_STEPPING;
    return 0;
}

int vse_fmu_terminate(vse_fmu_instance *instance, const char *caller)
{
    if (instance->phase != VSE_FMU_STEPPING) {
        return wrong_phase(instance, caller);
    }
    instance->phase = VSE_FMU_TERMINATED;
    return 0;
}

/* Sets every value or none: a refused value, or in step mode a calibration the kit's checks
 * reject, restores the model as it was before the call. */
int vse_fmu_set_float64(vse_fmu_instance *instance, const unsigned int vr[], size_t n, const double values[],
                        const char *caller)
{
    char why[VSE_FMU_MESSAGE_SIZE];
    size_t i;
    if (instance->phase == VSE_FMU_TERMINATED) {
        return wrong_phase(instance, caller);
    }
    memcpy(instance->backup, instance->model, vse_fmu_model_size());
    for (i = 0; i < n; ++i) {
        if (vse_fmu_model_set_float64(instance->model, vr[i], values[i], why) != 0) {
            memcpy(instance->model, instance->backup, vse_fmu_model_size());
            return refuse(instance, caller, why);
        }
    }
    if (instance->phase == VSE_FMU_STEPPING && vse_fmu_model_check_calibration(instance->model, why) != 0) {
        memcpy(instance->model, instance->backup, vse_fmu_model_size());
        return refuse(instance, caller, why);
    }
    return 0;
}

int vse_fmu_get_float64(vse_fmu_instance *instance, const unsigned int vr[], size_t n, double values[],
                        const char *caller)
{
    char why[VSE_FMU_MESSAGE_SIZE];
    size_t i;
    for (i = 0; i < n; ++i) {
        if (vse_fmu_model_get_float64(instance->model, vr[i], &values[i], why) != 0) {
            return refuse(instance, caller, why);
        }
    }
    return 0;
}

int vse_fmu_get_int32(vse_fmu_instance *instance, const unsigned int vr[], size_t n, int values[],
                      const char *caller)
{
    char why[VSE_FMU_MESSAGE_SIZE];
    size_t i;
    for (i = 0; i < n; ++i) {
        if (vse_fmu_model_get_int32(instance->model, vr[i], &values[i], why) != 0) {
            return refuse(instance, caller, why);
        }
    }
    return 0;
}

int vse_fmu_do_step(vse_fmu_instance *instance, double time, double step, const char *caller)
{
    char why[VSE_FMU_MESSAGE_SIZE];
    if (instance->phase != VSE_FMU_STEPPING) {
        return wrong_phase(instance, caller);
    }
    if (vse_fmu_model_do_step(instance->model, time, step, why) != 0) {
        return refuse(instance, caller, why);
    }
    return 0;
}

int vse_fmu_unsupported(vse_fmu_instance *instance, const char *caller, const char *what)
{
    char why[VSE_FMU_MESSAGE_SIZE];
    (void)snprintf(why, sizeof why, "not supported (%s)", what);
    return refuse(instance, caller, why);
}
