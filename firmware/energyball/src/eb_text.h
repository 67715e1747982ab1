/* The paper's text stream (Zhu & Shi, sec. 4: quaternion and flex angle to the PC
 * at 9600 baud), in the line format of PROTOCOL.md sec. 10:
 *   printf("%.4f,%.4f,%.4f,%.4f,%.2f\r\n", w, x, y, z, flex_deg)
 * written without printf, whose float support costs about 1.5 KB of flash.
 */
#ifndef EB_TEXT_H
#define EB_TEXT_H

#include <stddef.h>

#ifdef __cplusplus
extern "C" {
#endif

#define EB_TEXT_LINE_MAX 64 /* 4 x "-1.0000," + "-32767.00\r\n" and a NUL fit */

/* Writes the line (NUL terminated) and returns its length without the NUL. */
size_t eb_format_text_line(char *out, const float q[4], float flex_deg);

#ifdef __cplusplus
}
#endif

#endif
