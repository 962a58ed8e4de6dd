/*
 * vse_fmu_instance.h: the part of an FMU instance both FMI versions share: the phase an instance
 * is in, the model and its rules for setting, reading and stepping, with a one-line message for
 * every refusal. The adapters (vse_fmi2.c, vse_fmi3.c) translate their version's calls and status
 * codes to these functions.
 *
 * Part of vsegen's FMU wrapper (not generated; the same for every estimator).
 */
#ifndef VSE_FMU_INSTANCE_H
#define VSE_FMU_INSTANCE_H

#include <stddef.h>

#include "vse_fmu_model.h"

/** Where an instance is in the FMI co-simulation life cycle. */
typedef enum {
    VSE_FMU_INSTANTIATED,   /**< after instantiate or reset: parameters and inputs may be set */
    VSE_FMU_INITIALIZING,   /**< initialization mode: parameters and inputs may be set */
    VSE_FMU_STEPPING,       /**< step mode: inputs and (tunable) parameters may be set, steps run */
    VSE_FMU_TERMINATED      /**< after terminate: values may be read */
} vse_fmu_phase;

/** Reports a refusal: the adapter logs `message` through its importer's callback. */
typedef void vse_fmu_logger(void *adapter, const char *message);

/** One instance: its model, a second model the setters restore from when a call is refused, and
 *  the adapter's logger. */
typedef struct {
    vse_fmu_model *model;
    vse_fmu_model *backup;
    vse_fmu_phase phase;
    vse_fmu_logger *log;
    void *adapter;
} vse_fmu_instance;

/** The instance over `model` and `backup` (vse_fmu_model_size() bytes each, allocated by the
 *  adapter), reset as instantiated. */
void vse_fmu_instance_init(vse_fmu_instance *instance, vse_fmu_model *model, vse_fmu_model *backup,
                           vse_fmu_logger *log, void *adapter);

/** Back to the state after instantiation (FMI reset). */
void vse_fmu_instance_reset(vse_fmu_instance *instance);

/** Every function below returns 0 on success, else -1 after logging the reason; a refused call
 *  changes nothing. `caller` names the FMI function in the message. */
int vse_fmu_enter_initialization(vse_fmu_instance *instance, double start_time, const char *caller);
int vse_fmu_exit_initialization(vse_fmu_instance *instance, const char *caller);
int vse_fmu_terminate(vse_fmu_instance *instance, const char *caller);
int vse_fmu_set_float64(vse_fmu_instance *instance, const unsigned int vr[], size_t n, const double values[],
                        const char *caller);
int vse_fmu_get_float64(vse_fmu_instance *instance, const unsigned int vr[], size_t n, double values[],
                        const char *caller);
int vse_fmu_get_int32(vse_fmu_instance *instance, const unsigned int vr[], size_t n, int values[],
                      const char *caller);
int vse_fmu_do_step(vse_fmu_instance *instance, double time, double step, const char *caller);

/** Logs that `caller` is not offered (`what`: why) and returns -1. */
int vse_fmu_unsupported(vse_fmu_instance *instance, const char *caller, const char *what);

#endif /* VSE_FMU_INSTANCE_H */
