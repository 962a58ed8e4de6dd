/* Hand-written 2-DOF Kalman-filter step: the same estimator as the generated kf2dof (same model,
 * ZOH series, Joseph update, hold rule), written the way an expert would write it by hand:
 * constants derived once in kf2dof_hand_setup, 1/vx computed once, P stored as three entries, the
 * 2x2 innovation covariance inverted in closed form with one division, no pointer checks.
 * It is the baseline of bench/ (instructions per step) and is tested against the reference. */
#ifndef KF2DOF_HAND_H
#define KF2DOF_HAND_H

#define KF2DOF_HAND_MAX_TERMS 30

typedef struct {
    double k11, k12, k21, k22;   /* A(vx) = [k11/vx, k12/vx - vx; k21/vx, k22/vx] */
    double b1, b2;               /* B = [b1; b2], D = [b1; 0] */
    double q11, q12, q22;        /* Q_d = Q_c T */
    double r11, r12, r22;        /* R */
    double p11, p12, p22;        /* P_0 */
    double vx_min, vx_resume, vx_max, delta_max, ay_max, r_max;
    double h;                    /* T / 2^squarings */
    double inverse[KF2DOF_HAND_MAX_TERMS + 2];  /* 1/k, so the series multiplies */
    int terms, squarings;        /* ZOH series plan */
} kf2dof_hand_params;

typedef struct {
    double vy, r, p11, p12, p22, delta_prev, vx_prev, holding;
} kf2dof_hand_state;

/* raw: mass, yaw_inertia, a, b, C_f, C_r, Q_c (3), R (3), P0 (3), vx_min, vx_resume, vx_max,
 * delta_max, ay_max, r_max, T, terms, squarings */
void kf2dof_hand_setup(kf2dof_hand_params *p, const double raw[24]);
void kf2dof_hand_init(kf2dof_hand_state *s, const kf2dof_hand_params *p, const double u[4]);
/* u = [delta, vx, ay, r]; y = [beta, vy, r, status] */
void kf2dof_hand_step(kf2dof_hand_state *s, const kf2dof_hand_params *p, const double u[4],
                      double y[4]);

#endif
