/* Zhu & Shi, sec. 3: gyroscope integration with a partial tilt correction.
 *
 *   q(t+dt) = q((1 - alpha) phi, v_tilt) q(t) q_delta          (step 5)
 *
 * q_delta is the gyroscope's rotation over dt; phi and v_tilt are the angle and
 * axis from the accelerometer's direction, seen in the world frame through
 * q(t) (step 1), to up (steps 2-4). The first accelerometer sample corrects the
 * tilt in full (fraction 1), as tracker/fusion/complementary.py does.
 *
 * Cost on the AVR (no FPU: a float multiply takes about 130 cycles, an add 110, a
 * division or square root 480, sinf or cosf 1700, atan2f 2800; measured in
 * firmware/sim/boardsim): where the angles are small, which at 200 Hz the gyroscope's
 * always is, the trigonometric functions are replaced by their Taylor series and the
 * normalisation's square root and divisions by one Newton step. Each series is cut
 * where its truncation error is below u = 2^-24 = 5.96e-8, the unit roundoff of float
 * (the rounding of every operation here), so the result is the exact formulas' to
 * float rounding (tests/firmware/test_firmware_host.py holds them against the Python
 * filter and scipy over the full gyroscope range). Larger angles take the exact path.
 */
#include "eb_filter.h"

#include <math.h>

/* Hamilton product r = p * q (r may alias neither). */
static void quat_mul(float r[4], const float p[4], const float q[4])
{
    r[0] = p[0] * q[0] - p[1] * q[1] - p[2] * q[2] - p[3] * q[3];
    r[1] = p[0] * q[1] + p[1] * q[0] + p[2] * q[3] - p[3] * q[2];
    r[2] = p[0] * q[2] - p[1] * q[3] + p[2] * q[0] + p[3] * q[1];
    r[3] = p[0] * q[3] + p[1] * q[2] - p[2] * q[1] + p[3] * q[0];
}

/* quat_mul(q, p, q) for p = (w, x, y, 0), a rotation about a horizontal axis: the
 * terms of p[3] = 0 left out (4 multiplications and 4 additions fewer). */
static void quat_mul_horizontal(float q[4], const float p[4])
{
    float r0 = p[0] * q[0] - p[1] * q[1] - p[2] * q[2];
    float r1 = p[0] * q[1] + p[1] * q[0] + p[2] * q[3];
    float r2 = p[0] * q[2] - p[1] * q[3] + p[2] * q[0];
    q[3] = p[0] * q[3] + p[1] * q[2] - p[2] * q[1];
    q[0] = r0;
    q[1] = r1;
    q[2] = r2;
}

/* Below these squared angles quat_from_rotvec uses its series: two terms up to 0.02 rad
 * (the tilt correction after levelling turns by at most (1 - alpha) pi = 0.0031 rad),
 * three up to 0.35 rad (the gyroscope at 200 Hz turns by at most sqrt(3) x 2000 deg/s x
 * 5 ms = 0.30 rad, all three axes at full scale, and so at any rate of 173 Hz or more). */
#define SERIES2_MAX_ANGLE_SQ 4e-4f
#define SERIES3_MAX_ANGLE_SQ 0.1225f

/* Unit quaternion of the rotation vector v (angle = |v|, radians); the paper's
 * q_delta = (cos(l dt / 2), w / l sin(l dt / 2)) for v = w dt.
 *
 * For small |v|, with h = |v| / 2 and h2 = h^2 (no square root):
 *   cos h        = 1 - h2 / 2 + h2^2 / 24 - h^6 / 720 ...
 *   sin h / |v|  = 1/2 - h2 / 12 + h2^2 / 240 - h^6 / 10080 ...
 * Both series alternate with falling terms, so the error is below the first term
 * left out: with three terms, |v| <= 0.35 rad, 0.175^6 / 720 = 4.0e-8 = 0.67 u and
 * 0.175^6 / 10080 = 2.9e-9 = 0.05 u; with two, |v| <= 0.02 rad, 0.01^4 / 24 = 4.2e-10
 * and 0.01^4 / 240 = 4.2e-11, below 0.01 u. */
static void quat_from_rotvec(float r[4], float x, float y, float z)
{
    float angle_sq = x * x + y * y + z * z;
    float s;
    if (angle_sq <= SERIES2_MAX_ANGLE_SQ) {
        float h2 = 0.25f * angle_sq;
        r[0] = 1.0f - 0.5f * h2;
        s = 0.5f - h2 * (1.0f / 12.0f);
    } else if (angle_sq <= SERIES3_MAX_ANGLE_SQ) {
        float h2 = 0.25f * angle_sq;
        r[0] = 1.0f - h2 * (0.5f - h2 * (1.0f / 24.0f));
        s = 0.5f - h2 * (1.0f / 12.0f - h2 * (1.0f / 240.0f));
    } else if (angle_sq > SERIES3_MAX_ANGLE_SQ) {
        float angle = sqrtf(angle_sq);
        s = sinf(0.5f * angle) / angle;
        r[0] = cosf(0.5f * angle);
    } else { /* not a number: no rotation */
        r[0] = 1.0f;
        s = 0.0f;
    }
    r[1] = x * s;
    r[2] = y * s;
    r[3] = z * s;
}

/* v' = q v q* for unit q: v + w t + q_vec x t with t = 2 q_vec x v. */
static void quat_rotate(float r[3], const float q[4], const float v[3])
{
    float tx = 2.0f * (q[2] * v[2] - q[3] * v[1]);
    float ty = 2.0f * (q[3] * v[0] - q[1] * v[2]);
    float tz = 2.0f * (q[1] * v[1] - q[2] * v[0]);
    r[0] = v[0] + q[0] * tx + q[2] * tz - q[3] * ty;
    r[1] = v[1] + q[0] * ty + q[3] * tx - q[1] * tz;
    r[2] = v[2] + q[0] * tz + q[1] * ty - q[2] * tx;
}

/* Within this of 1, a squared norm is corrected by one Newton step (2^-13). */
#define NEWTON_MAX_NORM_ERROR 1.220703125e-4f

/* q / |q|. Products of unit quaternions stay unit to a few u, so |q|^2 = 1 + e with
 * |e| <= 2^-13 and 1 / sqrt(1 + e) = 1 - e/2 + 3 e^2 / 8 - 5 e^3 / 16 ...: one Newton
 * step from 1, 1 - e/2, is off by 3 e^2 / 8 (1 + 2e-4 at most) = 5.6e-9 = 0.09 u.
 * e = |q|^2 - 1 is exact (Sterbenz: |q|^2 is within a factor 2 of 1). */
static void quat_normalize(float q[4])
{
    float e = q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3] - 1.0f;
    float k;
    if (fabsf(e) <= NEWTON_MAX_NORM_ERROR) {
        k = 1.0f - 0.5f * e;
    } else if (e > -1.0f && e < INFINITY) {
        k = 1.0f / sqrtf(1.0f + e);
    } else { /* zero or not finite: start again from the identity */
        q[0] = 1.0f;
        q[1] = q[2] = q[3] = 0.0f;
        return;
    }
    for (int i = 0; i < 4; i++)
        q[i] *= k;
}

/* Below this (tan phi)^2 (phi 11.3 degrees) tilt_correction uses its series. */
#define SERIES_MAX_TAN_SQ 0.04f

/* phi / |v x up| for v within 11.3 degrees of up (v_z > 0, t = |v x up| / v_z <= 0.2):
 *   atan(t) / (t v_z) = (1 - t^2/3 + t^4/5 - t^6/7 + t^8/9 - t^10/11 ...) / v_z,
 * alternating with falling terms, off by at most 0.2^10 / 11 = 9.3e-9 = 0.16 u of
 * itself: one division instead of a square root, atan2f and a division. */
static float tilt_angle_per_sine(float s_sq, float vz)
{
    float inv = 1.0f / vz;
    float t2 = s_sq * inv * inv;
    return inv * (1.0f - t2 * (1.0f / 3.0f - t2 * (0.2f - t2 * (1.0f / 7.0f - t2 * (1.0f / 9.0f)))));
}

/* Steps 2-5: the rotation by fraction * phi about v_tilt = v x up, taking the world
 * vector v toward up (+z). phi = atan2(|v x up|, v . up), the same angle as
 * arccos(v_z / |v|) but accurate near 0; a half-turn about east where v points
 * straight down (tracker/fusion/qmath.py tilt_to_up). */
static void tilt_correction(float r[4], const float v[3], float fraction)
{
    float s_sq = v[0] * v[0] + v[1] * v[1];
    float k; /* fraction * phi / |v x up| */
    if (v[2] > 0.0f && s_sq <= SERIES_MAX_TAN_SQ * v[2] * v[2]) {
        k = fraction * tilt_angle_per_sine(s_sq, v[2]);
    } else {
        float s = sqrtf(s_sq);
        float phi = atan2f(s, v[2]);
        if (s_sq <= 1e-24f * (s_sq + v[2] * v[2])) { /* |v x up| <= 1e-12 |v| */
            quat_from_rotvec(r, phi < 1.5707964f ? 0.0f : fraction * phi, 0.0f, 0.0f);
            return;
        }
        k = fraction * phi / s;
    }
    quat_from_rotvec(r, v[1] * k, -v[0] * k, 0.0f);
}

void eb_filter_init(eb_filter_t *f, float alpha)
{
    f->q[0] = 1.0f;
    f->q[1] = f->q[2] = f->q[3] = 0.0f;
    f->alpha = alpha;
    f->levelled = false;
}

void eb_filter_update(eb_filter_t *f, const float gyr[3], const float acc[3], float dt)
{
    float delta[4], q[4];
    quat_from_rotvec(delta, gyr[0] * dt, gyr[1] * dt, gyr[2] * dt);
    quat_mul(q, f->q, delta); /* the body rate post-multiplies */
    if (acc[0] != 0.0f || acc[1] != 0.0f || acc[2] != 0.0f) {
        float v[3], tilt[4];
        quat_rotate(v, f->q, acc); /* step 1, with q(t) before this sample's rotation */
        tilt_correction(tilt, v, f->levelled ? 1.0f - f->alpha : 1.0f);
        quat_mul_horizontal(q, tilt);
        f->levelled = true;
    }
    for (int i = 0; i < 4; i++)
        f->q[i] = q[i];
    quat_normalize(f->q);
}
