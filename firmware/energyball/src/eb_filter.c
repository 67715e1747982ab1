/* Zhu & Shi, sec. 3: gyroscope integration with a partial tilt correction.
 *
 *   q(t+dt) = q((1 - alpha) phi, v_tilt) q(t) q_delta          (step 5)
 *
 * q_delta is the gyroscope's rotation over dt; phi and v_tilt are the angle and
 * axis from the accelerometer's direction, seen in the world frame through
 * q(t) (step 1), to up (steps 2-4). The first accelerometer sample corrects the
 * tilt in full (fraction 1), as tracker/fusion/complementary.py does.
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

/* Unit quaternion of the rotation vector v (angle = |v|, radians); the paper's
 * q_delta = (cos(l dt / 2), w / l sin(l dt / 2)) for v = w dt. */
static void quat_from_rotvec(float r[4], float x, float y, float z)
{
    float angle = sqrtf(x * x + y * y + z * z);
    if (!(angle > 0.0f)) {
        r[0] = 1.0f;
        r[1] = r[2] = r[3] = 0.0f;
        return;
    }
    float s = sinf(0.5f * angle) / angle;
    r[0] = cosf(0.5f * angle);
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

static void quat_normalize(float q[4])
{
    float n = sqrtf(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
    if (n > 0.0f && n < INFINITY) {
        for (int i = 0; i < 4; i++)
            q[i] /= n;
    } else { /* zero or not finite: start again from the identity */
        q[0] = 1.0f;
        q[1] = q[2] = q[3] = 0.0f;
    }
}

/* Steps 2-5: the rotation by fraction * phi about v_tilt = v x up, taking the world
 * vector v toward up (+z). phi = atan2(|v x up|, v . up), the same angle as
 * arccos(v_z / |v|) but accurate near 0; a half-turn about east where v points
 * straight down (tracker/fusion/qmath.py tilt_to_up). */
static void tilt_correction(float r[4], const float v[3], float fraction)
{
    float s = sqrtf(v[0] * v[0] + v[1] * v[1]);
    float phi = atan2f(s, v[2]);
    if (s <= 1e-12f * sqrtf(v[0] * v[0] + v[1] * v[1] + v[2] * v[2])) {
        quat_from_rotvec(r, phi < 1.5707964f ? 0.0f : fraction * phi, 0.0f, 0.0f);
        return;
    }
    float k = fraction * phi / s;
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
        quat_mul(f->q, tilt, q);
        f->levelled = true;
    } else {
        for (int i = 0; i < 4; i++)
            f->q[i] = q[i];
    }
    quat_normalize(f->q);
}
