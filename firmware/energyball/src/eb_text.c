#include "eb_text.h"

#include <math.h>
#include <stdint.h>

#define FIXED_LIMIT 99999.0f /* larger magnitudes are clamped (a flex angle is +-327 at most) */

/* x with `decimals` digits after the point, rounded to nearest (ties to even). */
static char *put_fixed(char *p, float x, uint8_t decimals)
{
    static const uint16_t scales[] = {1, 10, 100, 1000, 10000};
    if (!(x == x))
        x = 0.0f; /* NaN */
    if (signbit(x))
        *p++ = '-';
    float a = fabsf(x);
    uint32_t v = (uint32_t)lrintf((a < FIXED_LIMIT ? a : FIXED_LIMIT) * scales[decimals]);
    char digits[12];
    uint8_t n = 0;
    while (n <= decimals || v) { /* at least one digit before the point */
        digits[n++] = (char)('0' + v % 10);
        v /= 10;
    }
    while (n--) {
        *p++ = digits[n];
        if (n == decimals && decimals)
            *p++ = '.';
    }
    return p;
}

size_t eb_format_text_line(char *out, const float q[4], float flex_deg)
{
    char *p = out;
    for (uint8_t i = 0; i < 4; i++) {
        p = put_fixed(p, q[i], 4);
        *p++ = ',';
    }
    p = put_fixed(p, flex_deg, 2);
    *p++ = '\r';
    *p++ = '\n';
    *p = '\0';
    return (size_t)(p - out);
}
