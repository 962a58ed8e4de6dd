#include <math.h>

#include "kf2dof_hand.h"

void kf2dof_hand_setup(kf2dof_hand_params *p, const double raw[24])
{
    const double m = raw[0], iz = raw[1], a = raw[2], b = raw[3], cf = raw[4], cr = raw[5];
    const double T = raw[21];
    int i;
    p->k11 = -(cf + cr) / m;
    p->k12 = (b * cr - a * cf) / m;
    p->k21 = (b * cr - a * cf) / iz;
    p->k22 = -(a * a * cf + b * b * cr) / iz;
    p->b1 = cf / m;
    p->b2 = a * cf / iz;
    p->q11 = raw[6] * T; p->q12 = raw[7] * T; p->q22 = raw[8] * T;
    p->r11 = raw[9]; p->r12 = raw[10]; p->r22 = raw[11];
    p->p11 = raw[12]; p->p12 = raw[13]; p->p22 = raw[14];
    p->vx_min = raw[15]; p->vx_resume = raw[16]; p->vx_max = raw[17];
    p->delta_max = raw[18]; p->ay_max = raw[19]; p->r_max = raw[20];
    p->terms = (int)raw[22];
    p->squarings = (int)raw[23];
    p->h = T;
    for (i = 0; i < p->squarings; ++i) {
        p->h *= 0.5;
    }
    for (i = 1; i < KF2DOF_HAND_MAX_TERMS + 2; ++i) {
        p->inverse[i] = 1.0 / i;
    }
}

static double clamp_speed(const kf2dof_hand_params *p, double vx)
{
    return fmin(fmax(vx, p->vx_min), p->vx_max);
}

void kf2dof_hand_init(kf2dof_hand_state *s, const kf2dof_hand_params *p, const double u[4])
{
    const int ok_delta = fabs(u[0]) <= p->delta_max, ok_vx = fabs(u[1]) <= p->vx_max;
    const int ok_ay = fabs(u[2]) <= p->ay_max, ok_r = fabs(u[3]) <= p->r_max;
    const int active = ok_delta && ok_vx && ok_ay && ok_r && !(u[1] < p->vx_resume);
    s->vy = 0.0;
    s->r = ok_r ? u[3] : 0.0;
    s->p11 = p->p11; s->p12 = p->p12; s->p22 = p->p22;
    s->delta_prev = ok_delta ? u[0] : 0.0;
    s->vx_prev = ok_vx ? u[1] : p->vx_min;
    s->holding = active ? 0.0 : 1.0;
}

void kf2dof_hand_step(kf2dof_hand_state *s, const kf2dof_hand_params *p, const double u[4],
                      double y[4])
{
    const int ok_delta = fabs(u[0]) <= p->delta_max, ok_vx = fabs(u[1]) <= p->vx_max;
    const int ok_ay = fabs(u[2]) <= p->ay_max, ok_r = fabs(u[3]) <= p->r_max;
    const int all = ok_delta && ok_vx && ok_ay && ok_r;
    const int low = ok_vx && (u[1] < p->vx_min || (s->holding != 0.0 && u[1] < p->vx_resume));
    double status = (all ? 0.0 : 2.0) + (low ? 1.0 : 0.0);
    if (all && !low) {
        /* ZOH: psi = sum X^k/(k+1)! by Horner, X = A h; Phi = I + X psi; Gamma = h psi B */
        const double vp = clamp_speed(p, s->vx_prev), ivp = 1.0 / vp, h = p->h;
        const double x11 = p->k11 * ivp * h, x12 = (p->k12 * ivp - vp) * h;
        const double x21 = p->k21 * ivp * h, x22 = p->k22 * ivp * h;
        double s11 = 1.0, s12 = 0.0, s21 = 0.0, s22 = 1.0, f11, f12, f21, f22, g1, g2;
        double vy, r, p11, p12, p22, vx, iv, c11, c12, e1, e2, m11, m12, m21, m22;
        double S11, S12, S22, idet, i11, i12, i22, K11, K12, K21, K22, j11, j12, j21, j22;
        double t11, t12, t21, t22;
        int k;
        for (k = p->terms; k > 0; --k) {
            const double c = p->inverse[k + 1];
            const double n11 = x11 * s11 + x12 * s21, n12 = x11 * s12 + x12 * s22;
            const double n21 = x21 * s11 + x22 * s21, n22 = x21 * s12 + x22 * s22;
            s11 = 1.0 + n11 * c; s12 = n12 * c; s21 = n21 * c; s22 = 1.0 + n22 * c;
        }
        f11 = 1.0 + x11 * s11 + x12 * s21; f12 = x11 * s12 + x12 * s22;
        f21 = x21 * s11 + x22 * s21; f22 = 1.0 + x21 * s12 + x22 * s22;
        g1 = h * (s11 * p->b1 + s12 * p->b2);
        g2 = h * (s21 * p->b1 + s22 * p->b2);
        for (k = 0; k < p->squarings; ++k) {
            const double n1 = f11 * g1 + f12 * g2 + g1, n2 = f21 * g1 + f22 * g2 + g2;
            const double n11 = f11 * f11 + f12 * f21, n12 = f11 * f12 + f12 * f22;
            const double n21 = f21 * f11 + f22 * f21, n22 = f21 * f12 + f22 * f22;
            g1 = n1; g2 = n2; f11 = n11; f12 = n12; f21 = n21; f22 = n22;
        }
        /* predict */
        vy = f11 * s->vy + f12 * s->r + g1 * s->delta_prev;
        r = f21 * s->vy + f22 * s->r + g2 * s->delta_prev;
        t11 = f11 * s->p11 + f12 * s->p12; t12 = f11 * s->p12 + f12 * s->p22;
        t21 = f21 * s->p11 + f22 * s->p12; t22 = f21 * s->p12 + f22 * s->p22;
        p11 = t11 * f11 + t12 * f12 + p->q11;
        p12 = t11 * f21 + t12 * f22 + p->q12;
        p22 = t21 * f21 + t22 * f22 + p->q22;
        /* update with z = [ay, r]: C = [c11 c12; 0 1], D = [b1; 0] */
        vx = clamp_speed(p, u[1]);
        iv = 1.0 / vx;
        c11 = p->k11 * iv;
        c12 = p->k12 * iv;
        e1 = u[2] - (c11 * vy + c12 * r) - p->b1 * u[0];
        e2 = u[3] - r;
        m11 = p11 * c11 + p12 * c12; m12 = p12;     /* P C' */
        m21 = p12 * c11 + p22 * c12; m22 = p22;
        S11 = c11 * m11 + c12 * m21 + p->r11;
        S12 = c11 * m12 + c12 * m22 + p->r12;
        S22 = m22 + p->r22;
        idet = 1.0 / (S11 * S22 - S12 * S12);
        i11 = S22 * idet; i12 = -S12 * idet; i22 = S11 * idet;
        K11 = m11 * i11 + m12 * i12; K12 = m11 * i12 + m12 * i22;
        K21 = m21 * i11 + m22 * i12; K22 = m21 * i12 + m22 * i22;
        vy += K11 * e1 + K12 * e2;
        r += K21 * e1 + K22 * e2;
        /* Joseph: (I - K C) P (I - K C)' + K R K' */
        j11 = 1.0 - K11 * c11; j12 = -K11 * c12 - K12;
        j21 = -K21 * c11; j22 = 1.0 - K21 * c12 - K22;
        t11 = j11 * p11 + j12 * p12; t12 = j11 * p12 + j12 * p22;
        t21 = j21 * p11 + j22 * p12; t22 = j21 * p12 + j22 * p22;
        s->p11 = t11 * j11 + t12 * j12 + (K11 * p->r11 + K12 * p->r12) * K11
                 + (K11 * p->r12 + K12 * p->r22) * K12;
        s->p12 = t11 * j21 + t12 * j22 + (K11 * p->r11 + K12 * p->r12) * K21
                 + (K11 * p->r12 + K12 * p->r22) * K22;
        s->p22 = t21 * j21 + t22 * j22 + (K21 * p->r11 + K22 * p->r12) * K21
                 + (K21 * p->r12 + K22 * p->r22) * K22;
        s->vy = vy;
        s->r = r;
        s->holding = 0.0;
        y[0] = atan(vy * iv);          /* atan2(vy, vx) for vx >= vx_min > 0, at a third of the cost */
    } else {
        s->vy = 0.0;
        s->p11 = p->p11; s->p12 = p->p12; s->p22 = p->p22;
        s->holding = 1.0;
        y[0] = 0.0;
    }
    if (ok_delta) {
        s->delta_prev = u[0];
    }
    if (ok_vx) {
        s->vx_prev = u[1];
    }
    y[1] = s->vy;
    y[2] = s->r;
    y[3] = status;
}
