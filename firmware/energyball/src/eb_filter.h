/* The on-board quaternion complementary filter of Zhu & Shi ("Motion
 * Control in VR", sec. 3, steps 1-5), in float, with the same equations and
 * conventions as tracker/fusion/complementary.py (its docstring gives the
 * conversion from the paper's frames: q is q_WS, Hamilton product, world z up).
 */
#ifndef EB_FILTER_H
#define EB_FILTER_H

#include <stdbool.h>

#ifdef __cplusplus
extern "C" {
#endif

/* Weight of the gyroscope per sample (sec. 3, step 5); the host filter's default. */
#define EB_FILTER_ALPHA 0.999f

typedef struct {
    float q[4]; /* q_WS, scalar first */
    float alpha;
    bool levelled; /* whether an accelerometer sample has set the tilt yet */
} eb_filter_t;

void eb_filter_init(eb_filter_t *f, float alpha);
/* One sample: body rate (rad/s), specific force (any unit; all zero = unusable,
 * left out of the correction), sample interval dt (s). */
void eb_filter_update(eb_filter_t *f, const float gyr[3], const float acc[3], float dt);

#ifdef __cplusplus
}
#endif

#endif
