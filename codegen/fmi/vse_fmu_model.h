/*
 * vse_fmu_model.h: what the FMI adapters (vse_fmi2.c, vse_fmi3.c) need of one generated
 * estimator, implemented by the generated vse_<estimator>_fmu_model.c.
 *
 * Part of vsegen's FMU wrapper (not generated; the same for every estimator). The adapters
 * translate the FMI calls of their version into these functions; every rule of the FMU (the
 * sample time, parameter bounds, the calibration checks) lives behind them, once.
 *
 * Value references: 0 the time, then the inputs, the outputs and the calibration entries in the
 * order of the kit's structs (see modelDescription.xml).
 */
#ifndef VSE_FMU_MODEL_H
#define VSE_FMU_MODEL_H

#include <stddef.h>

/** Bytes of the longest message a model function writes into its `why` buffer, with the NUL. */
#define VSE_FMU_MESSAGE_SIZE (320)

/** The estimator's state, inputs, outputs, calibration and time; opaque to the adapters, which
 *  allocate vse_fmu_model_size() bytes for it when they instantiate (and nowhere else). A model
 *  holds no pointer, so a copy of its bytes is a copy of the model. */
typedef struct vse_fmu_model vse_fmu_model;

/** Bytes the adapter allocates for one model. */
size_t vse_fmu_model_size(void);

/** The model as instantiated: inputs 0, calibration as generated, time 0 s, no sample processed
 *  yet (outputs 0, status LOW_SPEED: the estimator holds). */
void vse_fmu_model_reset(vse_fmu_model *model);

/** Start the model's time at `start_time` (s; the experiment's start time). */
void vse_fmu_model_start(vse_fmu_model *model, double start_time);

/** The instantiation token (FMI 3; the GUID of FMI 2) of the modelDescription.xml this model
 *  belongs to. */
const char *vse_fmu_model_token(void);

/** The sample time T the kit was generated for, s. */
double vse_fmu_model_sample_time(void);

/** Set the Float64 variable `vr` (an input or a calibration entry) to `value`: 0 on success,
 *  else -1 with the reason in `why` and nothing changed. A calibration entry must be finite and
 *  within its bounds; the checks that relate entries (e.g. vx_resume > vx_min) are
 *  vse_fmu_model_check_calibration's. */
int vse_fmu_model_set_float64(vse_fmu_model *model, unsigned int vr, double value,
                              char why[VSE_FMU_MESSAGE_SIZE]);

/** Read the Float64 variable `vr` (time, input, real output or calibration entry). */
int vse_fmu_model_get_float64(const vse_fmu_model *model, unsigned int vr, double *value,
                              char why[VSE_FMU_MESSAGE_SIZE]);

/** Read the Int32 variable `vr` (status, or another integer output). */
int vse_fmu_model_get_int32(const vse_fmu_model *model, unsigned int vr, int *value,
                            char why[VSE_FMU_MESSAGE_SIZE]);

/** 0 when the calibration passes every check of the kit (vse_<estimator>_calibration_check),
 *  else -1 with the broken check in `why` (a baked build: always 0). */
int vse_fmu_model_check_calibration(vse_fmu_model *model, char why[VSE_FMU_MESSAGE_SIZE]);

/** Advance from `time` (s, the model's own time) by `step` (s, a whole multiple of the sample
 *  time): the kit's step runs step / T times on the inputs as set, the first one after
 *  initialising the state from them. -1 with the reason in `why`, nothing changed, for another
 *  time or step size. */
int vse_fmu_model_do_step(vse_fmu_model *model, double time, double step, char why[VSE_FMU_MESSAGE_SIZE]);

/** The model's time, s. */
double vse_fmu_model_time(const vse_fmu_model *model);

#endif /* VSE_FMU_MODEL_H */
